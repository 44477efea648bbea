//! The `peridyn` command line, a thin layer over the library. Both programs run it: `peridyn`
//! in one process, and `peridyn-mpi` (the `mpi/` package) on the ranks `mpirun` starts, which
//! hands it their `Ranks`.

mod args;
mod distributed;

use crate::deck::case::LoadedCase;
use crate::deck::study::LoadedStudy;
use crate::deck::LoadedDeck;
use crate::run::{check_timed, run_with, RunControl, RunOptions};
use crate::solver::ranks::Ranks;
use crate::study_run::{plan_study, run_study, StudyOptions};
use crate::validation::{validate, Layout, ValidateOptions};
use args::{Cli, Command, ValidateArgs};
use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

/// The deck's file name without extension ("run" if it has none).
fn deck_name(deck: &std::path::Path) -> String {
    deck.file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "run".into())
}

/// `--checkpoint-minutes M` as a wall-clock interval: M must be a positive number of minutes.
fn wall_interval(minutes: f64) -> Result<std::time::Duration, String> {
    if !(minutes.is_finite() && minutes > 0.0) {
        return Err(format!(
            "--checkpoint-minutes {minutes}: expected a positive number of minutes (e.g. 10)"
        ));
    }
    Ok(std::time::Duration::from_secs_f64(minutes * 60.0))
}

/// A run's results folder: `-o`, or the folder `--restart DIR` continues (the same one when
/// both are given), or results/<deck name>.
fn run_folder(
    deck: &std::path::Path,
    output: Option<PathBuf>,
    restart: &Option<Option<PathBuf>>,
) -> Result<PathBuf, String> {
    match (output, restart.clone().flatten()) {
        (Some(o), Some(r)) if o != r => Err(format!("--restart {} and -o {} name different folders: a run continues in its own results folder; give one of them", r.display(), o.display())),
        (o, r) => Ok(o.or(r).unwrap_or_else(|| PathBuf::from("results").join(deck_name(deck)))),
    }
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

/// `peridyn check` of a validation case: the case and, for its full and reduced versions,
/// every run's deck (a case runs as a sweep over its series).
fn check_case(file: &std::path::Path, threads: Option<usize>) -> Result<(), String> {
    let case = LoadedCase::from_file(file).map_err(|e| e.to_string())?;
    for (reduced, size) in [(false, "full"), (true, "reduced")] {
        let Some(study) = case.study(reduced) else {
            println!(
                "{}: case is valid; it runs nothing (no deck)",
                file.display()
            );
            return Ok(());
        };
        let runs = plan_study(&study, threads).map_err(|e| e.to_string())?;
        let n = runs.len();
        let noun = if n == 1 { "run" } else { "runs" };
        println!(
            "{}: case is valid; {size}: {n} {noun}, every run's deck is valid and builds",
            file.display()
        );
    }
    Ok(())
}

/// Runs the command line of this process's arguments. `world`: the ranks of a process started
/// by `mpirun` (the `peridyn-mpi` program); with more than one, `run` and `study` are
/// distributed over them.
pub fn main(world: Option<Arc<dyn Ranks>>) -> ExitCode {
    let cli = Cli::parse();
    if let Some(ranks) = world.filter(|r| r.size() > 1) {
        return distributed::run_command(cli.command, ranks);
    }
    let result: Result<(), String> = match cli.command {
        Command::Run {
            deck,
            output,
            threads,
            quiet,
            restart,
            stop_after_step,
            checkpoint_minutes,
        } => (|| {
            let ld = LoadedDeck::from_file(&deck).map_err(|e| e.to_string())?;
            let out_dir = run_folder(&deck, output, &restart)?;
            let checkpoint_every = checkpoint_minutes.map(wall_interval).transpose()?;
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
                    checkpoint_every,
                    ..RunControl::default()
                },
            )
            .map_err(|e| e.to_string())?;
            println!("{summary}");
            Ok(())
        })(),
        Command::Plot { run_dir } => (|| {
            let files = crate::plot::history_plots::write_history_plots(&run_dir)
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
            let src = std::fs::read_to_string(&deck).unwrap_or_default();
            if LoadedCase::is_case(&src) {
                return check_case(&deck, threads);
            }
            if LoadedStudy::is_study(&src) {
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
                2 => crate::distributed::plan::plan::<2>(&ld, n),
                _ => crate::distributed::plan::plan::<3>(&ld, n),
            }
            .map_err(|e| e.to_string())?;
            println!("{}: deck is valid; {n} ranks would own", deck.display());
            for (r, p) in plans.iter().enumerate() {
                println!("rank {r:<11} {p}");
            }
            let per_rank = rank_memory
                .map(|gb| (gb * 1e9) as u64)
                .or_else(|| crate::memory::available_bytes().map(|b| b / n as u64));
            match per_rank {
                Some(bytes) => crate::distributed::plan::refuse_unfit(&plans, bytes),
                None => Ok(()),
            }
        })(),
        Command::Grid { deck, output } => (|| {
            let ld = LoadedDeck::from_file(&deck).map_err(|e| e.to_string())?;
            let out_dir = output.unwrap_or_else(|| PathBuf::from("results").join(deck_name(&deck)));
            let report = crate::grid::write_grid(&ld, &out_dir).map_err(|e| e.to_string())?;
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
                    from_run: 0,
                    kept_runs: None,
                },
            )
            .map_err(|e| e.to_string())?;
            println!("{report}");
            Ok(())
        })(),
        Command::Validate(args) => validate_cases(args, None),
        Command::Bench {
            bonds,
            steps,
            threads,
            cases,
        } => crate::bench::run_benchmarks(bonds, steps, &threads, &cases).map(|_| ()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}

/// `peridyn validate`: in one process, or with `over`, each run one model over the ranks
/// (rank 0 prints and writes the measurements and the report).
fn validate_cases(args: ValidateArgs, over: Option<Arc<dyn Ranks>>) -> Result<(), String> {
    let root = args
        .root
        .or_else(|| {
            let paper_dir = args.cases.first()?.parent()?;
            Some(paper_dir.parent()?.to_path_buf())
        })
        .unwrap_or_else(|| PathBuf::from("validation"));
    let layout = Layout::new(root);
    let default_out = if args.reduced {
        "validation-reduced"
    } else {
        "validation"
    };
    let opts = ValidateOptions {
        out_dir: args
            .output
            .unwrap_or_else(|| PathBuf::from("results").join(default_out)),
        reduced: args.reduced,
        first: args.first,
        last: args.last,
        threads: args.threads,
        quiet: args.quiet,
    };
    let root_rank = over.as_ref().is_none_or(|r| r.rank() == 0);
    let done = validate(&args.cases, &layout, &opts, !args.report, over)?;
    if root_rank {
        println!("{done}");
    }
    match done.differing() {
        n if args.reduced && n > 0 => Err(format!("{n} result(s) outside their reduced tolerance")),
        _ => Ok(()),
    }
}
