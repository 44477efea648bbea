//! `peridyn study`: a parameter study of a deck. The study file (`deck::study`) names the deck,
//! the numbers of it to vary (factors), the design (Morris screening, `study::morris`, or a
//! sweep over every combination, `study::sweep`) and the outputs read back from each run's CSV
//! files (`study::table`). Every design point's deck is built and validated before the first
//! run; each run writes its own results folder (`runs/run_NNNN/`, with the `deck.toml` it ran),
//! and `runs.csv` is rewritten after every run, so a study that is stopped continues where it
//! stopped when started again with the same study file and folder: finished runs (those in
//! `runs.csv` with the same factor values) are not run again, and a run left midway continues
//! from its checkpoint (`run_folder`). A run that fails (an unstable
//! run stopped by the guard, say) is recorded as failed and its outputs left empty; the Morris
//! statistics skip the elementary effects that need it. At the end: `morris.csv` and one
//! μ*–σ plot per output (`plots/morris_<output>.png`), or, for a sweep of one factor, a plot of
//! each output against it (`plots/sweep_<output>.png`).

use crate::atomic_file::write_atomic;
use crate::deck::edit::{set_number, set_value};
use crate::deck::study::{LoadedStudy, OutputSpec, Reduce, StudyMethod};
use crate::deck::{DeckError, KeyPath, LoadedDeck};
use crate::distributed::study::{collect, rounds, Outcome};
use crate::plot::curve::write_named_curves_png;
use crate::plot::morris_plot::write_morris_png;
use crate::run::{check, run_with, RunControl, RunError, RunOptions};
use crate::solver::ranks::Ranks;
use crate::study::morris::{morris_statistics, Factor, FactorEffect, MorrisDesign, MorrisOptions};
use crate::study::sweep::sweep_points;
use crate::study::table::{Reduction, Table, Window};
use crate::study::toml_number::number_at;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

pub mod kept_runs;
mod over_ranks;
pub mod run_folder;
use run_folder::Start;

/// How a study's runs use the ranks `mpirun` started.
#[derive(Clone)]
pub enum Spread {
    /// One process runs every run.
    Alone,
    /// Each run in one process on one rank, in rounds of one run per rank (`peridyn study`).
    RunPerRank(Arc<dyn Ranks>),
    /// Each run one model over every rank, the runs one after another (`peridyn validate`: a
    /// case's finest grid needs them all; `over_ranks`).
    RunOverRanks(Arc<dyn Ranks>),
    /// One process runs `n` runs side by side, the threads shared out among them: many small
    /// runs (a screening's) use the cores better than each run over all the threads.
    AtOnce(usize),
}

impl Spread {
    fn ranks(&self) -> Option<&Arc<dyn Ranks>> {
        match self {
            Spread::Alone | Spread::AtOnce(_) => None,
            Spread::RunPerRank(r) | Spread::RunOverRanks(r) => Some(r),
        }
    }
}

/// Where and how a study runs.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    pub out_dir: PathBuf,
    /// Worker threads of each run (results are identical for any count).
    pub threads: Option<usize>,
    /// No progress lines.
    pub quiet: bool,
    /// Runs of the design before this index are left out: not run now (those finished in an
    /// earlier invocation's `runs.csv` are still read). 0: every run.
    pub from_run: usize,
    /// A copy of the finished runs kept outside `out_dir` (`kept_runs`): read at the start,
    /// rewritten after every run.
    pub kept_runs: Option<PathBuf>,
}

/// Why a study stopped.
#[derive(Debug, thiserror::Error)]
pub enum StudyRunError {
    #[error(transparent)]
    Deck(#[from] DeckError),
    #[error("{0}")]
    Design(String),
    #[error("run {run} ({values}) cannot run:\n{error}")]
    Point {
        run: usize,
        values: String,
        error: String,
    },
    #[error("{study}: outputs[{index}] (`{name}`): {message}")]
    Output {
        study: String,
        index: usize,
        name: String,
        message: String,
    },
    #[error("{0}")]
    Io(String),
}

/// One run of the design: its factor values and, once run, its outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRecord {
    pub values: Vec<f64>,
    /// Morris: the trajectory the run belongs to.
    pub trajectory: Option<usize>,
    /// "ok", "failed: …", or "" (not run yet).
    pub status: String,
    pub outputs: Vec<Option<f64>>,
}

/// What a study did.
#[derive(Debug, Clone)]
pub struct StudyReport {
    pub method: StudyMethod,
    pub factors: Vec<String>,
    pub runs: Vec<RunRecord>,
    /// Runs taken from an earlier invocation (its `runs.csv`, or the kept runs).
    pub reused: usize,
    /// Each run's wall minutes, where known (a run finished, its folder or the kept runs).
    pub minutes: Vec<Option<f64>>,
    /// Morris: each output's name and its factors' statistics.
    pub effects: Vec<(String, Vec<FactorEffect>)>,
    pub out_dir: PathBuf,
}

impl StudyReport {
    pub fn failed(&self) -> usize {
        self.runs.iter().filter(|r| r.status != "ok").count()
    }
}

impl fmt::Display for StudyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "study            {} runs ({} from an earlier invocation, {} failed) in {}",
            self.runs.len(),
            self.reused,
            self.failed(),
            self.out_dir.display()
        )?;
        for (output, effects) in &self.effects {
            writeln!(
                f,
                "Morris, {output}: factors by μ* (unit-range elementary effects)"
            )?;
            let mut ranked: Vec<&FactorEffect> = effects.iter().collect();
            ranked.sort_by(|a, b| {
                b.mu_star
                    .unwrap_or(f64::NEG_INFINITY)
                    .total_cmp(&a.mu_star.unwrap_or(f64::NEG_INFINITY))
            });
            for e in ranked {
                let show = |v: Option<f64>| v.map_or("—".into(), |v| format!("{v:.4e}"));
                writeln!(
                    f,
                    "  {:<40} μ* {}  μ {}  σ {}  ({} effects)",
                    e.name,
                    show(e.mu_star),
                    show(e.mu),
                    show(e.sigma),
                    e.effects
                )?;
            }
        }
        Ok(())
    }
}

/// The design: each run's factor values (physical units) and, for Morris, its trajectory.
enum Design {
    Morris(MorrisDesign),
    Sweep(Vec<Vec<f64>>),
}

impl Design {
    fn of(ls: &LoadedStudy) -> Result<Design, StudyRunError> {
        let factors = &ls.study.factors;
        Ok(match ls.study.method {
            StudyMethod::Morris => {
                let m = ls.morris();
                let factors = factors
                    .iter()
                    .map(|f| Factor::new(&f.key, f.min.unwrap_or(0.0), f.max.unwrap_or(1.0)))
                    .collect();
                let options = MorrisOptions {
                    trajectories: m.trajectories,
                    pool: m.pool,
                    levels: m.levels,
                    seed: m.seed,
                };
                Design::Morris(
                    MorrisDesign::new(factors, &options)
                        .map_err(|e| StudyRunError::Design(e.to_string()))?,
                )
            }
            StudyMethod::Sweep => Design::Sweep(sweep_points(
                &factors
                    .iter()
                    .map(|f| f.values.clone().unwrap_or_default())
                    .collect::<Vec<_>>(),
            )),
        })
    }

    fn records(&self) -> Vec<RunRecord> {
        let blank = |values: Vec<f64>, trajectory| RunRecord {
            values,
            trajectory,
            status: String::new(),
            outputs: Vec::new(),
        };
        match self {
            Design::Morris(d) => {
                let per = d.factors().len() + 1;
                d.points()
                    .enumerate()
                    .map(|(k, v)| blank(v, Some(k / per)))
                    .collect()
            }
            Design::Sweep(points) => points.iter().map(|v| blank(v.clone(), None)).collect(),
        }
    }
}

/// The deck of one design point: the base deck with the fixed numbers, then the factors'
/// numbers and those set with them, replaced.
fn point_deck(ls: &LoadedStudy, values: &[f64]) -> Result<String, String> {
    let mut text = ls.base.src.clone();
    for f in &ls.study.fixed {
        text = set_value(&text, &KeyPath::parse(&f.key), &f.value)?;
    }
    for (key, &v) in ls.keys.iter().zip(values) {
        text = set_number(&text, key, v)?;
    }
    for (key, v) in linked_numbers(ls, values) {
        text = set_number(&text, &KeyPath::parse(key), v)?;
    }
    Ok(text)
}

/// The numbers set with the factors at a design point: each `also` key with its factor's
/// value, each `with` key with its value at the position of its factor's value.
fn linked_numbers<'a>(ls: &'a LoadedStudy, values: &[f64]) -> Vec<(&'a str, f64)> {
    let mut numbers = Vec::new();
    for (f, v) in ls.study.factors.iter().zip(values) {
        numbers.extend(f.also.iter().map(|key| (key.as_str(), *v)));
        let Some(p) = f
            .values
            .as_ref()
            .and_then(|vs| vs.iter().position(|x| x == v))
        else {
            continue;
        };
        numbers.extend(f.with.iter().map(|l| (l.key.as_str(), l.values[p])));
    }
    numbers
}

fn describe(ls: &LoadedStudy, values: &[f64]) -> String {
    let factors = ls
        .study
        .factors
        .iter()
        .zip(values)
        .map(|(f, v)| (f.key.as_str(), *v));
    factors
        .chain(linked_numbers(ls, values))
        .map(|(key, v)| format!("{key} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The design's runs, every point's deck validated and its model built (as `peridyn check`
/// does: the time step against the stable one, memory), so that no run fails on its deck
/// after others have run; nothing is stepped.
fn plan(
    ls: &LoadedStudy,
    threads: Option<usize>,
) -> Result<(Design, Vec<RunRecord>, Vec<LoadedDeck>, usize), StudyRunError> {
    let design = Design::of(ls)?;
    let runs = design.records();
    let mut decks = Vec::with_capacity(runs.len());
    // The largest run's predicted memory (bytes): how many fit side by side.
    let mut largest = 0;
    for (k, run) in runs.iter().enumerate() {
        let point = |error: String| StudyRunError::Point {
            run: k,
            values: describe(ls, &run.values),
            error,
        };
        let text = point_deck(ls, &run.values).map_err(StudyRunError::Design)?;
        let deck = LoadedDeck::from_str(&text, &ls.base.file).map_err(|e| point(e.to_string()))?;
        let model = check(&deck, threads).map_err(|e| point(e.to_string()))?;
        largest = largest.max(model.memory_bytes);
        decks.push(deck);
    }
    Ok((design, runs, decks, largest))
}

/// The runs a study would make, each point's deck validated: `peridyn study --dry-run`.
pub fn plan_study(
    ls: &LoadedStudy,
    threads: Option<usize>,
) -> Result<Vec<RunRecord>, StudyRunError> {
    Ok(plan(ls, threads)?.1)
}

/// Runs the study (or continues it) in `opts.out_dir`.
pub fn run_study(ls: &LoadedStudy, opts: &StudyOptions) -> Result<StudyReport, StudyRunError> {
    run_study_over(ls, opts, &Spread::Alone)
}

/// `run_study` over the ranks of `spread`: each run on one rank in one process, in rounds of
/// one run per rank (`distributed::study`), or each run over every rank (`over_ranks`). Rank 0
/// rewrites `runs.csv` after each round and writes every file of the study itself, so they
/// are the serial study's byte for byte. The other ranks' reports hold no runs' outcomes.
pub fn run_study_over(
    ls: &LoadedStudy,
    opts: &StudyOptions,
    spread: &Spread,
) -> Result<StudyReport, StudyRunError> {
    let (design, mut runs, decks, largest) = plan(ls, opts.threads)?;
    // This rank's place in each round of runs, and the runs in a round.
    let (slot, size) = match spread {
        Spread::Alone | Spread::RunOverRanks(_) => (0, 1),
        Spread::AtOnce(n) => (0, fitting_side_by_side(*n, largest)),
        Spread::RunPerRank(r) => (r.rank(), r.size()),
    };
    let root = spread.ranks().is_none_or(|r| r.rank() == 0);
    let runs_dir = opts.out_dir.join("runs");
    std::fs::create_dir_all(&runs_dir).map_err(|e| io("create", &runs_dir, e))?;
    if root {
        write_atomic(&opts.out_dir.join("study.toml"), ls.src.as_bytes())
            .map_err(|e| io("write", &opts.out_dir.join("study.toml"), e))?;
    }
    let table_path = opts.out_dir.join("runs.csv");
    let header = runs_header(ls);
    let mut reused = resume(
        &table_path,
        &header,
        ls.study.outputs.len(),
        &mut runs,
        |k| {
            std::fs::read_to_string(run_folder::of_run(&runs_dir, k).join("deck.toml")).ok()
                == Some(decks[k].src.clone())
        },
    );
    // A finished run's outputs are read again from its folder, the record: the study file's
    // outputs may have been redefined since (another reduction under the same name). A folder
    // that no longer gives them runs again.
    for (k, run) in runs.iter_mut().enumerate() {
        if run.status == "ok" {
            match read_outputs(ls, &run_folder::of_run(&runs_dir, k)) {
                Ok(outputs) => run.outputs = outputs,
                Err(_) => {
                    run.status.clear();
                    reused -= 1;
                }
            }
        }
    }
    // Runs finished on another machine (no folder here) are taken from the kept runs.
    let fingerprints: Vec<String> = decks
        .iter()
        .map(|d| kept_runs::fingerprint(&d.src, &ls.study.outputs))
        .collect();
    let mut minutes: Vec<Option<f64>> = (0..runs.len())
        .map(|k| run_folder::wall_minutes(&run_folder::of_run(&runs_dir, k)))
        .collect();
    let kept = opts.kept_runs.as_deref();
    if let Some(path) = kept {
        let found = kept_runs::read(path, &header, &runs, &fingerprints);
        for ((run, found), minutes) in runs.iter_mut().zip(found).zip(&mut minutes) {
            if let (true, Some(found)) = (run.status.is_empty(), found) {
                (run.status, run.outputs, *minutes) = (found.status, found.outputs, found.minutes);
                reused += 1;
            }
        }
    }
    let keep = |runs: &[RunRecord], minutes: &[Option<f64>]| match kept {
        Some(path) if root => kept_runs::write(path, &header, runs, minutes, &fingerprints)
            .map_err(|e| io("write", path, e)),
        _ => Ok(()),
    };
    keep(&runs, &minutes)?;
    let total = runs.len();
    let mut pending: Vec<usize> = (opts.from_run..total)
        .filter(|&k| runs[k].status.is_empty())
        .collect();
    if let Spread::RunOverRanks(r) = spread {
        pending = over_ranks::agreed_pending(&**r, opts.from_run..total, &pending);
    }
    // A run's progress lines (a long run, or a long quasi-static load step, that printed
    // nothing would look hung); not when the ranks take several runs at once.
    let progress = !opts.quiet && matches!(spread, Spread::Alone | Spread::RunOverRanks(_));
    for round in rounds(&pending, size) {
        let point = |k: usize| {
            let dir = run_folder::of_run(&runs_dir, k);
            run_point(ls, opts, &decks[k], &dir, progress)
        };
        let outcomes = match spread {
            Spread::Alone => Some(vec![point(round[0])?]),
            Spread::AtOnce(_) => Some(run_at_once(ls, opts, &decks, &runs_dir, round)?),
            Spread::RunOverRanks(r) => {
                let (k, dir) = (round[0], run_folder::of_run(&runs_dir, round[0]));
                let mine = over_ranks::run_point_over_ranks(ls, opts, &decks[k], &dir, r)?;
                root.then(|| vec![mine])
            }
            Spread::RunPerRank(r) => {
                let mine = round
                    .get(slot)
                    .map(|&k| point(k).map_err(|e| e.to_string()));
                collect(&**r, round.len(), mine).map_err(StudyRunError::Io)?
            }
        };
        let Some(outcomes) = outcomes else {
            continue;
        };
        for (&k, outcome) in round.iter().zip(outcomes) {
            runs[k].status = outcome.status;
            runs[k].outputs = outcome.outputs;
            minutes[k] = run_folder::wall_minutes(&run_folder::of_run(&runs_dir, k))
                .or(Some(outcome.seconds / 60.0));
            write_runs(&table_path, &header, &runs).map_err(|e| io("write", &table_path, e))?;
            keep(&runs, &minutes)?;
            if !opts.quiet {
                print_run(ls, &runs[k], (k, total), outcome.seconds);
            }
        }
    }
    let effects = match (&design, root) {
        (_, false) => Vec::new(),
        (Design::Morris(d), true) => morris_results(ls, d, &runs, &opts.out_dir)?,
        (Design::Sweep(_), true) => {
            sweep_plots(ls, &runs, &opts.out_dir)?;
            Vec::new()
        }
    };
    Ok(StudyReport {
        method: ls.study.method,
        factors: ls.study.factors.iter().map(|f| f.key.clone()).collect(),
        runs,
        reused,
        minutes,
        effects,
        out_dir: opts.out_dir.clone(),
    })
}

fn io(what: &str, path: &Path, e: std::io::Error) -> StudyRunError {
    StudyRunError::Io(format!("cannot {what} {}: {e}", path.display()))
}

/// How many of `n` runs of at most `bytes` each fit in this machine's memory together (at
/// least one: a single run that does not fit was refused when it was planned).
fn fitting_side_by_side(n: usize, bytes: usize) -> usize {
    let fit = crate::memory::available_bytes().map_or(n, |a| (a / bytes.max(1) as u64) as usize);
    n.min(fit).max(1)
}

/// The runs of `round` side by side, each on its own threads (`opts.threads` shared out, at
/// least one each), without progress lines (theirs would interleave); their outcomes in the
/// round's order. Each run is the run it would be alone, bit for bit.
fn run_at_once(
    ls: &LoadedStudy,
    opts: &StudyOptions,
    decks: &[LoadedDeck],
    runs_dir: &Path,
    round: &[usize],
) -> Result<Vec<Outcome>, StudyRunError> {
    let threads = opts
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let each = StudyOptions {
        threads: Some((threads / round.len()).max(1)),
        ..opts.clone()
    };
    std::thread::scope(|scope| {
        let running: Vec<_> = round
            .iter()
            .map(|&k| {
                let (each, dir) = (&each, run_folder::of_run(runs_dir, k));
                scope.spawn(move || run_point(ls, each, &decks[k], &dir, false))
            })
            .collect();
        running
            .into_iter()
            .map(|r| {
                r.join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            })
            .collect()
    })
}

/// Runs one design point's `deck` in `dir`, or continues it from the checkpoint a stopped
/// invocation left there (`run_folder`), and reads its outputs; with `progress`, the run
/// prints its progress lines.
fn run_point(
    ls: &LoadedStudy,
    opts: &StudyOptions,
    deck: &LoadedDeck,
    dir: &Path,
    progress: bool,
) -> Result<Outcome, StudyRunError> {
    let started = Instant::now();
    let run_opts = RunOptions {
        out_dir: dir.to_path_buf(),
        threads: opts.threads,
        quiet: !progress,
    };
    let control = RunControl {
        checkpoint_every: Some(run_folder::CHECKPOINT_EVERY),
        ..RunControl::default()
    };
    let start = run_folder::prepare(dir, &deck.src).map_err(StudyRunError::Io)?;
    let mut result = match start {
        Start::Afresh => run_with(deck, &run_opts, &control),
        Start::FromCheckpoint => {
            if !opts.quiet {
                println!("{}: continued from its checkpoint", dir.display());
            }
            let restart = RunControl {
                restart: true,
                ..control.clone()
            };
            run_with(deck, &run_opts, &restart)
        }
    };
    // A folder that cannot be continued (a checkpoint of another version or deck, files that
    // do not reach the checkpoint's step): the run starts again. A run that fails on its own
    // (a blow-up) is not run twice.
    let unusable = matches!(result, Err(RunError::Checkpoint(_) | RunError::Io(_)));
    if start == Start::FromCheckpoint && unusable {
        if let (false, Err(e)) = (opts.quiet, &result) {
            println!("{}: {e}; started again", dir.display());
        }
        run_folder::start_afresh(dir, &deck.src).map_err(StudyRunError::Io)?;
        result = run_with(deck, &run_opts, &control);
    }
    let (status, outputs) = match result {
        Ok(_) => ("ok".into(), read_outputs(ls, dir)?),
        Err(e) => failed(ls, &e),
    };
    Ok(Outcome {
        status,
        outputs,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The status and outputs of a run that failed: one line, no commas (the status is a CSV
/// cell).
fn failed(ls: &LoadedStudy, e: &RunError) -> (String, Vec<Option<f64>>) {
    let message = e.to_string().replace(['\n', ','], " ");
    (
        format!("failed: {message}"),
        vec![None; ls.study.outputs.len()],
    )
}

/// The progress line of run `k` of `total`.
fn print_run(ls: &LoadedStudy, run: &RunRecord, (k, total): (usize, usize), seconds: f64) {
    let outputs = ls
        .study
        .outputs
        .iter()
        .zip(&run.outputs)
        .map(|(o, v)| {
            format!(
                "{} = {}",
                o.name,
                v.map_or("—".into(), |v| format!("{v:.5e}"))
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    let status = if run.status == "ok" { "" } else { " FAILED" };
    println!(
        "run {}/{total}{status} ({seconds:.1} s): {} → {outputs}",
        k + 1,
        describe(ls, &run.values),
    );
}

/// The outputs of a finished run, read from its folder. A missing file or column is the study
/// file's mistake (every run would miss it), not the run's: it stops the study.
fn read_outputs(ls: &LoadedStudy, dir: &Path) -> Result<Vec<Option<f64>>, StudyRunError> {
    ls.study
        .outputs
        .iter()
        .enumerate()
        .map(|(index, o)| {
            read_output_in(dir, o).map_err(|message| StudyRunError::Output {
                study: ls.file.display().to_string(),
                index,
                name: o.name.clone(),
                message,
            })
        })
        .collect()
}

/// One output of the run in `dir`: a number of `resolved.toml` by key, or a column of a CSV
/// file reduced (with `at_first_above`, at the time another column first passes its level).
pub fn read_output_in(dir: &Path, o: &OutputSpec) -> Result<Option<f64>, String> {
    let read = |file: &str| {
        std::fs::read_to_string(dir.join(file))
            .map_err(|e| format!("the run wrote no {file} ({e}); does the deck ask for it?"))
    };
    if o.is_toml() {
        let key = o.key.as_deref().unwrap_or("");
        return number_at(&read(&o.file)?, key)
            .map(Some)
            .map_err(|e| format!("{}, key `{key}`: {e}", o.file));
    }
    let table = |file: &str| {
        Table::parse(&read(file)?).map_err(|e| format!("{}: {e}", dir.join(file).display()))
    };
    let main = table(&o.file)?;
    if o.reduce == Some(Reduce::AtFirstAbove) {
        let when_file = o.when_file.as_deref().unwrap_or(&o.file);
        let when_column = o.when_column.as_deref().unwrap_or("");
        let when = if when_file == o.file {
            main.clone()
        } else {
            table(when_file)?
        };
        let level = o.threshold.unwrap_or(0.0);
        let passed = when
            .reduce(when_column, Reduction::FirstTimeAbove(level), window(o))
            .map_err(|e| format!("{when_file}: {e}"))?;
        let Some(time) = passed else {
            return Ok(None);
        };
        return main
            .value_at(o.column.as_deref().unwrap_or(""), time)
            .map_err(|e| format!("{}: {e}", o.file));
    }
    read_output(&main, o).map_err(|e| format!("{}: {e}", o.file))
}

fn window(o: &OutputSpec) -> Window {
    Window {
        from: o.from,
        until: o.until,
    }
}

/// One output of a run from one CSV table: its column reduced as the spec says (not
/// `at_first_above`, which reads a second table: `read_output_in`).
pub fn read_output(table: &Table, o: &OutputSpec) -> Result<Option<f64>, String> {
    let column = |name: Option<&str>| table.column(name.unwrap_or(""));
    let how = match o.reduce {
        None | Some(Reduce::AtFirstAbove) => {
            return Err(format!(
                "output `{}` is not one reduction of one column",
                o.name
            ))
        }
        Some(Reduce::Final) => Reduction::Final,
        Some(Reduce::Max) => Reduction::Max,
        Some(Reduce::Peak) => Reduction::Peak,
        Some(Reduce::LargestDrop) => Reduction::LargestDrop,
        Some(Reduce::Min) => Reduction::Min,
        Some(Reduce::MaxAbs) => Reduction::MaxAbs,
        Some(Reduce::FirstTimeAbove) => Reduction::FirstTimeAbove(o.threshold.unwrap_or(0.0)),
        Some(Reduce::TimeOfMax) => Reduction::TimeOfMax(o.within.unwrap_or(0.0)),
        Some(Reduce::Mean) => Reduction::Mean,
        Some(Reduce::Count) => Reduction::Count,
        Some(Reduce::Present) => Reduction::Present,
        Some(Reduce::Pearson) => Reduction::Pearson(column(o.against.as_deref())?),
        Some(Reduce::MaxDistance) => Reduction::MaxDistance(column(o.against.as_deref())?),
        Some(Reduce::Slope) => Reduction::Slope {
            against: column(o.against.as_deref())?,
            between: o.between,
        },
        Some(Reduce::Angle) => Reduction::Angle {
            against: column(o.against.as_deref())?,
            first: o.first.unwrap_or(0.0),
            between: o.between,
        },
        Some(Reduce::ForkOpening) => Reduction::ForkOpening(column(o.against.as_deref())?),
    };
    table.reduce(o.column.as_deref().unwrap_or(""), how, window(o))
}

fn runs_header(ls: &LoadedStudy) -> Vec<String> {
    let mut h = vec!["run".to_string()];
    if ls.study.method == StudyMethod::Morris {
        h.push("trajectory".into());
    }
    h.extend(ls.study.factors.iter().map(|f| f.key.clone()));
    h.extend(ls.study.outputs.iter().map(|o| o.name.clone()));
    h.push("status".into());
    h
}

/// `runs.csv`: one row per run of the design, values written so that they read back exactly
/// (Rust's shortest round-trip form); outputs of runs not (yet) run or failed left empty.
fn write_runs(path: &Path, header: &[String], runs: &[RunRecord]) -> std::io::Result<()> {
    let mut text = header.join(",") + "\n";
    for (k, r) in runs.iter().enumerate() {
        let mut cells = vec![k.to_string()];
        if let Some(t) = r.trajectory {
            cells.push(t.to_string());
        }
        cells.extend(r.values.iter().map(|v| v.to_string()));
        for k in 0..header.len() - cells.len() - 1 {
            cells.push(
                r.outputs
                    .get(k)
                    .copied()
                    .flatten()
                    .map_or(String::new(), |v| v.to_string()),
            );
        }
        cells.push(r.status.clone());
        text += &(cells.join(",") + "\n");
    }
    write_atomic(path, text.as_bytes())
}

/// Takes the finished runs of an earlier invocation's `runs.csv` (the same design columns,
/// the same factor values, a status, and a run folder whose deck is the one this run would
/// run: a changed base deck or `fixed` number runs everything again): returns how many. The
/// outputs may have changed since (one added to a validation case): they are read again
/// from each finished run's folder, not from the table, so hours of runs are not repeated.
fn resume(
    path: &Path,
    header: &[String],
    outputs: usize,
    runs: &mut [RunRecord],
    same_deck: impl Fn(usize) -> bool,
) -> usize {
    let Ok(text) = std::fs::read_to_string(path) else {
        return 0;
    };
    let mut lines = text.lines();
    let found: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    // run, trajectory (Morris), the factors; then the outputs and the status.
    let design = header.len() - outputs - 1;
    if found.len() < design + 1
        || found[..design] != header[..design]
        || found.last() != Some(&"status")
    {
        return 0;
    }
    let mut reused = 0;
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != found.len() {
            continue;
        }
        let Some((k, _)) = row_of_design(&cells, runs) else {
            continue;
        };
        let status = cells[cells.len() - 1];
        if status.is_empty() || !same_deck(k) {
            continue;
        }
        runs[k].outputs = vec![None; outputs];
        runs[k].status = status.to_string();
        reused += 1;
    }
    reused
}

/// The design's run a row of `runs.csv` (or of the kept runs) records, if its index and
/// factor values are that run's: the index and the column after the factors.
fn row_of_design(cells: &[&str], runs: &[RunRecord]) -> Option<(usize, usize)> {
    let k = cells
        .first()?
        .parse::<usize>()
        .ok()
        .filter(|&k| k < runs.len())?;
    let run = &runs[k];
    let first = if run.trajectory.is_some() { 2 } else { 1 };
    let end = first + run.values.len();
    let same = cells
        .get(first..end)?
        .iter()
        .zip(&run.values)
        .all(|(c, v)| c.parse::<f64>().ok() == Some(*v));
    same.then_some((k, end))
}

/// Morris statistics of every output, `morris.csv` and the μ*–σ plots.
fn morris_results(
    ls: &LoadedStudy,
    design: &MorrisDesign,
    runs: &[RunRecord],
    out: &Path,
) -> Result<Vec<(String, Vec<FactorEffect>)>, StudyRunError> {
    let mut results = Vec::new();
    let mut text = String::from("output,factor,mu_star,mu,sigma,effects,range\n");
    let plots = out.join("plots");
    std::fs::create_dir_all(&plots)
        .map_err(|e| StudyRunError::Io(format!("cannot create {}: {e}", plots.display())))?;
    for (k, o) in ls.study.outputs.iter().enumerate() {
        let ys: Vec<Option<f64>> = runs
            .iter()
            .map(|r| r.outputs.get(k).copied().flatten())
            .collect();
        let effects =
            morris_statistics(design, &ys).map_err(|e| StudyRunError::Design(e.to_string()))?;
        let cell = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
        for (e, f) in effects.iter().zip(&ls.study.factors) {
            text += &format!(
                "{},{},{},{},{},{},{}\n",
                o.name,
                e.name,
                cell(e.mu_star),
                cell(e.mu),
                cell(e.sigma),
                e.effects,
                f.max.unwrap_or(0.0) - f.min.unwrap_or(0.0)
            );
        }
        let points: Vec<_> = effects
            .iter()
            .map(|e| (e.name.clone(), e.mu_star, e.sigma))
            .collect();
        let path = plots.join(format!("morris_{}.png", o.name));
        write_morris_png(&path, &format!("Morris screening: {}", o.name), &points)
            .map_err(|e| StudyRunError::Io(e.to_string()))?;
        results.push((o.name.clone(), effects));
    }
    let path = out.join("morris.csv");
    write_atomic(&path, text.as_bytes())
        .map_err(|e| StudyRunError::Io(format!("cannot write {}: {e}", path.display())))?;
    Ok(results)
}

/// A sweep of one factor: each output against it.
fn sweep_plots(ls: &LoadedStudy, runs: &[RunRecord], out: &Path) -> Result<(), StudyRunError> {
    let [factor] = &ls.study.factors[..] else {
        return Ok(());
    };
    let plots = out.join("plots");
    std::fs::create_dir_all(&plots)
        .map_err(|e| StudyRunError::Io(format!("cannot create {}: {e}", plots.display())))?;
    for (k, o) in ls.study.outputs.iter().enumerate() {
        let points: Vec<(f64, f64)> = runs
            .iter()
            .map(|r| {
                (
                    r.values[0],
                    r.outputs.get(k).copied().flatten().unwrap_or(f64::NAN),
                )
            })
            .collect();
        let path = plots.join(format!("sweep_{}.png", o.name));
        write_named_curves_png(
            &path,
            &format!("{} against {}", o.name, factor.key),
            &factor.key,
            &o.name,
            &[(o.name.clone(), points)],
        )
        .map_err(|e| StudyRunError::Io(e.to_string()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn output(toml: &str) -> OutputSpec {
        toml::from_str(&format!("name = \"o\"\n{toml}")).unwrap()
    }

    /// A run's folder with a tip first beyond x = 4.8 mm at t = 3 µs, its speed, and a
    /// resolved deck.
    fn run_dir(tag: &str) -> std::path::PathBuf {
        let dir =
            std::env::temp_dir().join(format!("peridyn-outputs-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let write = |f: &str, text: &str| std::fs::write(dir.join(f), text).unwrap();
        write(
            "crack_tip.csv",
            "time,step,crack_x,crack_y\n1e-6,10,,\n2e-6,20,0.004,0\n3e-6,30,0.006,0\n",
        );
        write(
            "crack_speed.csv",
            "branch,time,speed,speed_over_rayleigh\ncrack,2e-6,1000,0.5\ncrack,4e-6,2000,1.0\n",
        );
        write(
            "resolved.toml",
            "[derived]\nhorizon = 0.003\n[[derived.materials]]\nkey = \"material\"\npeak_stretch = 0.005\n",
        );
        dir
    }

    #[test]
    fn outputs_read_across_files_and_from_the_resolved_deck() {
        let dir = run_dir("read");
        // x is first above 4.8 mm in the row at t = 3 µs (first_time_above reads the row's
        // time); the speed there is interpolated between 1000 at 2 µs and 2000 at 4 µs: 1500.
        let speed = output(
            "file = \"crack_speed.csv\"\ncolumn = \"speed\"\nreduce = \"at_first_above\"\n\
             when_file = \"crack_tip.csv\"\nwhen_column = \"crack_x\"\nthreshold = 0.0048",
        );
        assert_eq!(read_output_in(&dir, &speed), Ok(Some(1500.0)));
        // A level never passed: no value.
        let never = output(
            "file = \"crack_speed.csv\"\ncolumn = \"speed\"\nreduce = \"at_first_above\"\n\
             when_file = \"crack_tip.csv\"\nwhen_column = \"crack_x\"\nthreshold = 0.01",
        );
        assert_eq!(read_output_in(&dir, &never), Ok(None));
        let s1 = output("file = \"resolved.toml\"\nkey = \"derived.materials[0].peak_stretch\"");
        assert_eq!(read_output_in(&dir, &s1), Ok(Some(0.005)));
        let h = output("file = \"resolved.toml\"\nkey = \"derived.horizon\"");
        assert_eq!(read_output_in(&dir, &h), Ok(Some(0.003)));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_missing_file_key_or_column_is_named() {
        let dir = run_dir("missing");
        let e = read_output_in(
            &dir,
            &output("file = \"resolved.toml\"\nkey = \"derived.materials[0].sc\""),
        )
        .unwrap_err();
        assert!(
            e.contains(
                "resolved.toml, key `derived.materials[0].sc`: no `sc` at `derived.materials[0]`"
            ),
            "{e}"
        );
        let e = read_output_in(
            &dir,
            &output(
                "file = \"crack_speed.csv\"\ncolumn = \"speed\"\nreduce = \"at_first_above\"\n\
                 when_file = \"crack_tip.csv\"\nwhen_column = \"tip_x\"\nthreshold = 0.0",
            ),
        )
        .unwrap_err();
        assert!(e.contains("crack_tip.csv: no column `tip_x`"), "{e}");
        let e = read_output_in(
            &dir,
            &output("file = \"branching.csv\"\ncolumn = \"fork\"\nreduce = \"count\""),
        )
        .unwrap_err();
        assert!(e.contains("the run wrote no branching.csv"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
