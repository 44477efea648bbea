//! Running a deck. Dispatch-once: the deck's dimension and material pick `run_model::<D, M>()`;
//! everything below is monomorphised. A run is a sequence of named stages, each in its own
//! file, so that a distributed run can replace the pieces it must:
//!
//! 1. build the simulation (`prepare`),
//! 2. restore it from a checkpoint when continuing (`restart`),
//! 3. write the resolved deck (`resolved`) and attach the observers (`observers`),
//! 4. drive the stages (`stages`),
//! 5. finish the observers and write the summary (`finish`).
//!
//! `check` builds and reports without stepping; `report` holds what both print.

mod check;
pub(crate) mod finish;
pub(crate) mod observers;
mod prepare;
mod report;
pub(crate) mod resolved;
pub(crate) mod restart;
pub(crate) mod stages;

pub use check::{check, check_timed, QuasiStaticBasis, TimeEstimate};
pub use prepare::{prepare, prepare_shared, DamageAndReports};
pub use report::{ModelReport, RunSummary};
pub use stages::{drive, drive_adaptive, drive_quasi_static, ViewSource};

use crate::checkpoint::{CheckpointError, Origin};
use crate::deck::build::{build_constitution, build_model, MaterialChoice, Model};
use crate::deck::solver_settings::solver_settings;
use crate::deck::{DeckError, LoadedDeck};
use crate::material::Material;
use crate::solver::StepError;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Deck(#[from] DeckError),
    #[error("{0}")]
    Step(#[from] StepError),
    #[error("writing results: {0}")]
    Io(#[from] std::io::Error),
    #[error("{0}")]
    Threads(String),
    #[error("{0}")]
    Checkpoint(#[from] CheckpointError),
    /// A distributed run cannot go on: another rank refused a checkpoint or could not read
    /// its part, or could not write a snapshot piece or the checkpoint.
    #[error("{0}")]
    Distributed(String),
    /// The run stopped after this step as `RunControl::stop_after_step` asked.
    #[error("stopped after step {0} as asked (--stop-after-step)")]
    Stopped(u64),
    /// The run stopped after this step because `RunControl::interrupt` was set; its files
    /// hold every step up to it.
    #[error("interrupted after step {0}")]
    Interrupted(u64),
}

impl RunError {
    /// Whether every rank of a distributed run meets this error alike (the deck, a refused
    /// checkpoint, an unstable step), so each can stop with it; any other (a file rank 0
    /// cannot write) is one rank's, and the others may be waiting for it.
    pub fn on_every_rank(&self) -> bool {
        matches!(
            self,
            RunError::Deck(_)
                | RunError::Distributed(_)
                | RunError::Checkpoint(_)
                | RunError::Step(_)
                | RunError::Stopped(_)
        )
    }
}

/// Options of `peridyn run`.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub out_dir: PathBuf,
    pub threads: Option<usize>,
    /// No progress output.
    pub quiet: bool,
}

/// How a run continues or stops, besides `RunOptions`.
#[derive(Debug, Clone, Default)]
pub struct RunControl {
    /// Continue the run in `RunOptions::out_dir` from its checkpoint.
    pub restart: bool,
    /// Stop after this step as a killed run would (files not finished): for tests of restarts.
    pub stop_after_step: Option<u64>,
    /// Stop at this pause inside a quasi-static load step (each writes a checkpoint; they
    /// come with `checkpoint_every`), as a killed run would: for tests of restarts.
    pub stop_at_pause: Option<u64>,
    /// Once set (from another thread: Ctrl-C in Python), the run stops after the step in
    /// progress with `RunError::Interrupted`, its files finished up to that step.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// Also checkpoint at the first step after each stretch of this much wall time, whatever
    /// the deck says (the runs of studies and validation cases, which continue from it).
    pub checkpoint_every: Option<std::time::Duration>,
}

pub(crate) fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> Result<T, RunError> {
    match threads {
        None => Ok(f()),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| RunError::Threads(e.to_string()))?;
            Ok(pool.install(f))
        }
    }
}

/// Runs a deck, writing results into `opts.out_dir`.
pub fn run(ld: &LoadedDeck, opts: &RunOptions) -> Result<RunSummary, RunError> {
    run_with(ld, opts, &RunControl::default())
}

/// Runs a deck, or continues it from its checkpoint, as `control` says.
pub fn run_with(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
) -> Result<RunSummary, RunError> {
    with_threads(opts.threads, || match ld.deck.dimension {
        2 => run_dim::<2>(ld, opts, control),
        _ => run_dim::<3>(ld, opts, control),
    })?
}

fn run_dim<const D: usize>(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
) -> Result<RunSummary, RunError> {
    let model = build_model::<D>(ld)?;
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    match material {
        MaterialChoice::Pmb(m) => run_model(ld, model, m, rest, opts, control),
        MaterialChoice::Lps(m) => run_model(ld, model, m, rest, opts, control),
        MaterialChoice::Correspondence(m) => run_model(ld, model, m, rest, opts, control),
        // PMB and LPS blocks only: the scalar path.
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => run_model(ld, model, m, rest, opts, control),
            Err(m) => run_model(ld, model, m, rest, opts, control),
        },
    }
}

/// A run in its named stages: build → restore → write the resolved deck → attach observers
/// → drive the stages → finish.
fn run_model<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    mut model: Model<D>,
    material: M,
    rest: DamageAndReports,
    opts: &RunOptions,
    control: &RunControl,
) -> Result<RunSummary, RunError> {
    let out = &opts.out_dir;
    let pores = model.pores.clone();
    let plans = std::mem::take(&mut model.stages);
    let staged = !plans.is_empty();
    let (mut sim, report) = prepare(ld, model, material, rest)?;
    let resolved = resolved::resolved_deck(ld)?;
    let origin = Origin::new(&resolved, &ld.file);
    let resume = restart::restore(control, out, &origin, &mut sim)?;
    resolved::write_start(ld, &resolved, &report, pores.as_deref(), out)?;
    let attached = observers::attach(ld, opts, &sim, &report, staged, resume.is_some())?;
    let checkpoints = restart::checkpoints(
        &ld.deck,
        out,
        origin,
        attached.snapshot_every,
        control.checkpoint_every,
    );
    let latest_checkpoint = checkpoints
        .as_ref()
        .map(|c| (c.path.clone(), c.origin.clone()));
    let observers::Attached {
        mut observers,
        crack,
        path,
        surface,
        ..
    } = attached;
    let started = Instant::now();
    let result = {
        let stop_after = control.stop_after_step;
        let mut watch = stages::Watch::new(&mut observers, checkpoints, stop_after, resume, staged)
            .with_interrupt(control.interrupt.clone())
            .with_stop_at_pause(control.stop_at_pause)
            .with_progress(!opts.quiet);
        let settings = solver_settings(&ld.deck);
        stages::drive_stages(&mut sim, settings, &report, plans, &mut watch)
    };
    let finished = finish::Finished {
        result,
        started,
        latest_checkpoint,
        crack,
        path,
        surface,
        nodes: sim.body.len(),
        writes: true,
    };
    finish::finish(ld, &mut sim, observers, report, finished, out)
}
