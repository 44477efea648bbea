//! The `peridyn` command line: a thin layer over the library.

use clap::{Parser, Subcommand};
use peridyn::deck::study::LoadedStudy;
use peridyn::deck::LoadedDeck;
use peridyn::run::{check_timed, run_with, RunControl, RunOptions};
use peridyn::study_run::{plan_study, run_study, StudyOptions};
use peridyn::validation::{validate, Layout, ValidateOptions};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "peridyn",
    version,
    about = "Peridynamic fracture simulation in 2D and 3D"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a deck: fields (VTU/PVD), history (CSV), damage maps (PNG, 2D), resolved deck.
    Run {
        deck: PathBuf,
        /// Results folder (default: results/<deck name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Worker threads (default: all cores). Results are identical for any count.
        #[arg(long)]
        threads: Option<usize>,
        /// No progress output.
        #[arg(short, long)]
        quiet: bool,
        /// Continue a killed run from the checkpoint in its results folder (-o, or DIR if
        /// given), with the same deck; its files continue as if it had not stopped.
        #[arg(long, value_name = "DIR", num_args = 0..=1)]
        restart: Option<Option<PathBuf>>,
        /// Stop after this step as if killed (tests of restarts).
        #[arg(long, hide = true)]
        stop_after_step: Option<u64>,
    },
    /// Draw the PNG plots of a finished (or interrupted) run's history.csv into RUN_DIR/plots:
    /// energies, load–displacement per loaded node set, openings, broken bonds, time step.
    Plot { run_dir: PathBuf },
    /// Validate a deck and print the model it builds (nodes, bonds, δ/Δx, constants, dt, memory);
    /// given a study file, validate it and every run's deck (as `study --dry-run`).
    Check {
        deck: PathBuf,
        #[arg(long)]
        threads: Option<usize>,
        /// Also predict a distributed run on N ranks: each rank's nodes, ghosts, bonds, halo
        /// bytes per step and memory (docs/distributed.md).
        #[arg(long, value_name = "N")]
        ranks: Option<usize>,
        /// With --ranks: the memory one rank may use, in GB (default: this machine's
        /// available memory shared by the N ranks); a share larger than that is refused.
        #[arg(long, value_name = "GB", requires = "ranks")]
        rank_memory: Option<f64>,
    },
    /// Write a deck's grid without running it: nodes (VTU: volume, cell size, horizon, block)
    /// and, in 2D, a PNG of the nodes with the shape's outline.
    Grid {
        deck: PathBuf,
        /// Output folder (default: results/<deck name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Run a parameter study of a deck (study file: the deck, the numbers to vary, Morris
    /// screening or a sweep, the outputs to read): every run in DIR/runs/, runs.csv, and for
    /// Morris morris.csv and a μ*–σ plot per output. Started again, it continues where it
    /// stopped.
    Study {
        study: PathBuf,
        /// Results folder (default: results/<study name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Worker threads of each run (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress lines.
        #[arg(short, long)]
        quiet: bool,
        /// Validate the study and every run's deck, print the runs, run nothing.
        #[arg(long)]
        dry_run: bool,
    },
    /// Reproduce the papers' results: run validation cases (validation/seed*/*.toml; all of
    /// them when none is named), compare with the papers' numbers, and write
    /// docs/validation.md with its figures (full size). Started again, a case continues where
    /// it stopped.
    Validate {
        cases: Vec<PathBuf>,
        /// The reduced (CI) version of each case: minutes, not hours; the report is left as
        /// it is, and rows outside their reduced tolerance fail the command.
        #[arg(long)]
        reduced: bool,
        /// Only write docs/validation.md again from the committed measurements.
        #[arg(long, conflicts_with_all = ["cases", "reduced"])]
        report: bool,
        /// The validation folder (default: validation, or the one holding the named cases).
        #[arg(long)]
        root: Option<PathBuf>,
        /// Results folder of the runs (default: results/validation or results/validation-reduced).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Only the first N values of each case's series (coarsest first): a pass over every
        /// case before the long runs of the finest grids; a later run continues with the rest.
        #[arg(long, value_name = "N")]
        first: Option<usize>,
        #[arg(long)]
        threads: Option<usize>,
        #[arg(short, long)]
        quiet: bool,
    },
    /// Measure force-loop throughput (node-steps/s, bond evaluations/s, bytes per bond).
    Bench {
        /// Target number of directed bonds per case.
        #[arg(long, default_value_t = 4_000_000)]
        bonds: usize,
        /// Steps per measurement.
        #[arg(long, default_value_t = 20)]
        steps: u64,
        /// Thread counts to measure, comma separated (default: 1 and all cores).
        #[arg(long, value_delimiter = ',')]
        threads: Vec<usize>,
        /// Cases to measure, comma separated (default: all; `peridyn bench --cases list` names them).
        #[arg(long, value_delimiter = ',')]
        cases: Vec<String>,
    },
}

/// The deck's file name without extension ("run" if it has none).
fn deck_name(deck: &std::path::Path) -> String {
    deck.file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "run".into())
}

/// Validates a study file and every run's deck, and prints the runs (`study --dry-run`,
/// `check STUDY`).
fn check_study(study: &std::path::Path, threads: Option<usize>) -> Result<(), String> {
    let ls = LoadedStudy::from_file(study).map_err(|e| e.to_string())?;
    let runs = plan_study(&ls, threads).map_err(|e| e.to_string())?;
    println!(
        "{}: study is valid, {} runs; every run's deck is valid and builds",
        study.display(),
        runs.len()
    );
    let keys: Vec<&str> = ls.study.factors.iter().map(|f| f.key.as_str()).collect();
    println!("run,{}", keys.join(","));
    for (k, r) in runs.iter().enumerate() {
        let v: Vec<String> = r.values.iter().map(|v| v.to_string()).collect();
        println!("{k},{}", v.join(","));
    }
    Ok(())
}

/// The ranks of a run started by `mpirun -np N` (N > 1) with the `mpi` feature; `None`
/// otherwise (one process, as without the feature).
#[cfg(feature = "mpi")]
fn ranks() -> Option<(
    mpi::environment::Universe,
    peridyn::distributed::mpi_ranks::MpiRanks,
)> {
    let (universe, _) = mpi::initialize_with_threading(mpi::Threading::Serialized)?;
    let ranks = peridyn::distributed::mpi_ranks::MpiRanks::world();
    use peridyn::solver::ranks::Ranks;
    if ranks.size() > 1 {
        Some((universe, ranks))
    } else {
        None
    }
}

/// `peridyn run` over ranks: rank 0 prints; an error every rank meets (the deck, too few
/// nodes for the ranks, a refused checkpoint, an unstable step) ends every rank, any other (a
/// file rank 0 cannot write) aborts the others, which may be waiting for it.
#[cfg(feature = "mpi")]
fn run_distributed(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
    ranks: peridyn::distributed::mpi_ranks::MpiRanks,
) -> ExitCode {
    use peridyn::run::RunError;
    use peridyn::solver::ranks::Ranks;
    let root = ranks.rank() == 0;
    match peridyn::distributed::run_with(ld, opts, control, std::sync::Arc::new(ranks)) {
        Ok(summary) => {
            if root {
                println!("{summary}");
            }
            ExitCode::SUCCESS
        }
        Err(
            e @ (RunError::Deck(_)
            | RunError::Distributed(_)
            | RunError::Checkpoint(_)
            | RunError::Step(_)
            | RunError::Stopped(_)),
        ) => {
            if root {
                eprintln!("error: {e}");
            }
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("error (rank {}): {e}", ranks.rank());
            ranks.abort(1)
        }
    }
}

/// `peridyn study` over ranks, each run on one rank: rank 0 prints and writes the study's
/// files; an error every rank meets (the study or a run's deck, a run's files) ends every
/// rank, any other (a file rank 0 cannot write) aborts the others.
#[cfg(feature = "mpi")]
fn study_distributed(
    study: &std::path::Path,
    opts: &StudyOptions,
    ranks: peridyn::distributed::mpi_ranks::MpiRanks,
) -> ExitCode {
    use peridyn::solver::ranks::Ranks;
    use peridyn::study_run::StudyRunError;
    let root = ranks.rank() == 0;
    let ls = match LoadedStudy::from_file(study) {
        Ok(ls) => ls,
        Err(e) => {
            if root {
                eprintln!("error: {e}");
            }
            return ExitCode::FAILURE;
        }
    };
    let rank = ranks.rank();
    let shared: std::sync::Arc<dyn Ranks> = std::sync::Arc::new(ranks);
    match peridyn::study_run::run_study_over(&ls, opts, Some(shared.clone())) {
        Ok(report) => {
            if root {
                println!("{report}");
            }
            ExitCode::SUCCESS
        }
        Err(
            e @ (StudyRunError::Deck(_)
            | StudyRunError::Design(_)
            | StudyRunError::Point { .. }
            | StudyRunError::Output { .. }),
        ) => {
            if root {
                eprintln!("error: {e}");
            }
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("error (rank {rank}): {e}");
            drop(shared);
            peridyn::distributed::mpi_ranks::MpiRanks::world().abort(1)
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    #[cfg(feature = "mpi")]
    if let Some((universe, ranks)) = ranks() {
        {
            use peridyn::solver::ranks::Ranks;
            if let Command::Study {
                study,
                output,
                threads,
                quiet,
                dry_run: false,
            } = &cli.command
            {
                let out_dir = output
                    .clone()
                    .unwrap_or_else(|| PathBuf::from("results").join(deck_name(study)));
                let opts = StudyOptions {
                    out_dir,
                    threads: *threads,
                    quiet: *quiet,
                };
                let code = study_distributed(study, &opts, ranks);
                drop(universe);
                return code;
            }
            let Command::Run {
                deck,
                output,
                threads,
                quiet,
                restart,
                stop_after_step,
            } = cli.command
            else {
                if ranks.rank() == 0 {
                    eprintln!("error: only `peridyn run` and `peridyn study` (not --dry-run) are distributed: start other commands without mpirun (or with -np 1)");
                }
                return ExitCode::FAILURE;
            };
            let ld = match LoadedDeck::from_file(&deck) {
                Ok(ld) => ld,
                Err(e) => {
                    if ranks.rank() == 0 {
                        eprintln!("error: {e}");
                    }
                    return ExitCode::FAILURE;
                }
            };
            if let (Some(o), Some(Some(r))) = (&output, &restart) {
                if o != r {
                    if ranks.rank() == 0 {
                        eprintln!("error: --restart {} and -o {} name different folders: a run continues in its own results folder; give one of them", r.display(), o.display());
                    }
                    return ExitCode::FAILURE;
                }
            }
            let out_dir = output
                .or(restart.clone().flatten())
                .unwrap_or_else(|| PathBuf::from("results").join(deck_name(&deck)));
            let opts = RunOptions {
                out_dir,
                threads,
                quiet,
            };
            let control = RunControl {
                restart: restart.is_some(),
                stop_after_step,
                ..RunControl::default()
            };
            let code = run_distributed(&ld, &opts, &control, ranks);
            drop(universe);
            return code;
        }
    }
    let result: Result<(), String> = match cli.command {
        Command::Run {
            deck,
            output,
            threads,
            quiet,
            restart,
            stop_after_step,
        } => (|| {
            let ld = LoadedDeck::from_file(&deck).map_err(|e| e.to_string())?;
            let output = match (output, restart.clone().flatten()) {
                (Some(o), Some(r)) if o != r => {
                    return Err(format!("--restart {} and -o {} name different folders: a run continues in its own results folder; give one of them", r.display(), o.display()));
                }
                (o, r) => o.or(r),
            };
            let out_dir = output.unwrap_or_else(|| PathBuf::from("results").join(deck_name(&deck)));
            let summary = run_with(
                &ld,
                &RunOptions {
                    out_dir,
                    threads,
                    quiet,
                },
                &RunControl {
                    restart: restart.is_some(),
                    stop_after_step,
                    ..RunControl::default()
                },
            )
            .map_err(|e| e.to_string())?;
            println!("{summary}");
            Ok(())
        })(),
        Command::Plot { run_dir } => (|| {
            let files = peridyn::plot::history_plots::write_history_plots(&run_dir)
                .map_err(|e| e.to_string())?;
            for f in files {
                println!("{}", f.display());
            }
            Ok(())
        })(),
        Command::Check {
            deck,
            threads,
            ranks,
            rank_memory,
        } => (|| {
            if std::fs::read_to_string(&deck).is_ok_and(|src| LoadedStudy::is_study(&src)) {
                return check_study(&deck, threads);
            }
            let ld = LoadedDeck::from_file(&deck).map_err(|e| e.to_string())?;
            let Some(n) = ranks.filter(|&n| n > 1) else {
                let (report, time) = check_timed(&ld, threads).map_err(|e| e.to_string())?;
                println!("{}: deck is valid\n{report}", deck.display());
                if let Some(time) = time {
                    println!("{time}");
                }
                return Ok(());
            };
            // Rank by rank only: a model meant for many ranks need not fit in this process.
            let plans = match ld.deck.dimension {
                2 => peridyn::distributed::plan::plan::<2>(&ld, n),
                _ => peridyn::distributed::plan::plan::<3>(&ld, n),
            }
            .map_err(|e| e.to_string())?;
            println!("{}: deck is valid; {n} ranks would own", deck.display());
            for (r, p) in plans.iter().enumerate() {
                println!("rank {r:<11} {p}");
            }
            let per_rank = rank_memory
                .map(|gb| (gb * 1e9) as u64)
                .or_else(|| peridyn::memory::available_bytes().map(|b| b / n as u64));
            match per_rank {
                Some(bytes) => peridyn::distributed::plan::refuse_unfit(&plans, bytes),
                None => Ok(()),
            }
        })(),
        Command::Grid { deck, output } => (|| {
            let ld = LoadedDeck::from_file(&deck).map_err(|e| e.to_string())?;
            let out_dir = output.unwrap_or_else(|| PathBuf::from("results").join(deck_name(&deck)));
            let report = peridyn::grid::write_grid(&ld, &out_dir).map_err(|e| e.to_string())?;
            println!(
                "{report}
grid written to {}",
                out_dir.display()
            );
            Ok(())
        })(),
        Command::Study {
            study,
            output,
            threads,
            quiet,
            dry_run,
        } => (|| {
            if dry_run {
                return check_study(&study, threads);
            }
            let ls = LoadedStudy::from_file(&study).map_err(|e| e.to_string())?;
            let out_dir =
                output.unwrap_or_else(|| PathBuf::from("results").join(deck_name(&study)));
            let report = run_study(
                &ls,
                &StudyOptions {
                    out_dir,
                    threads,
                    quiet,
                },
            )
            .map_err(|e| e.to_string())?;
            println!("{report}");
            Ok(())
        })(),
        Command::Validate {
            cases,
            reduced,
            report,
            root,
            output,
            first,
            threads,
            quiet,
        } => (|| {
            let root = root
                .or_else(|| {
                    let paper_dir = cases.first()?.parent()?;
                    Some(paper_dir.parent()?.to_path_buf())
                })
                .unwrap_or_else(|| PathBuf::from("validation"));
            let layout = Layout::new(root);
            let default_out = if reduced {
                "validation-reduced"
            } else {
                "validation"
            };
            let opts = ValidateOptions {
                out_dir: output.unwrap_or_else(|| PathBuf::from("results").join(default_out)),
                reduced,
                first,
                threads,
                quiet,
            };
            let done = validate(&cases, &layout, &opts, !report)?;
            println!("{done}");
            match done.differing() {
                n if reduced && n > 0 => {
                    Err(format!("{n} result(s) outside their reduced tolerance"))
                }
                _ => Ok(()),
            }
        })(),
        Command::Bench {
            bonds,
            steps,
            threads,
            cases,
        } => peridyn::bench::run_benchmarks(bonds, steps, &threads, &cases).map(|_| ()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}
