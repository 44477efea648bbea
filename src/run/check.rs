//! `peridyn check`: build the model and report it without running, optionally timing a few
//! steps of the built model.

use super::prepare::prepare;
use super::{with_threads, ModelReport, RunError};
use crate::deck::build::{build_constitution, build_model, MaterialChoice};
use crate::deck::LoadedDeck;
use crate::material::Material;
use crate::solver::Simulation;
use std::time::Instant;

/// Builds the model and reports it, without stepping.
pub fn check(ld: &LoadedDeck, threads: Option<usize>) -> Result<ModelReport, RunError> {
    Ok(checked(ld, threads, false)?.0)
}

/// `check`, and for a single-stage explicit run the time its steps will take, from a few
/// steps of the built model timed on the same threads (`peridyn check`).
pub fn check_timed(
    ld: &LoadedDeck,
    threads: Option<usize>,
) -> Result<(ModelReport, Option<TimeEstimate>), RunError> {
    checked(ld, threads, true)
}

/// What `check_timed` predicts: the stepping alone (the force passes and the integration),
/// without the output, at the deck's time step.
#[derive(Debug, Clone, Copy)]
pub struct TimeEstimate {
    pub seconds_per_step: f64,
    pub steps: u64,
    /// Steps timed, after one untimed (whose one-off work, such as a first contact list,
    /// later steps do not repeat).
    pub timed_steps: u64,
}

impl std::fmt::Display for TimeEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "time estimate    {:.1} s stepping {} steps at {:.3e} s per step ({} steps timed; \
             output and breaking bonds add to it)",
            self.seconds_per_step * self.steps as f64,
            self.steps,
            self.seconds_per_step,
            self.timed_steps
        )
    }
}

/// Steps `check_timed` times after the untimed one.
const TIMED_STEPS: u64 = 3;

fn checked(
    ld: &LoadedDeck,
    threads: Option<usize>,
    time: bool,
) -> Result<(ModelReport, Option<TimeEstimate>), RunError> {
    with_threads(threads, || match ld.deck.dimension {
        2 => check_dim::<2>(ld, time),
        _ => check_dim::<3>(ld, time),
    })?
}

fn check_dim<const D: usize>(
    ld: &LoadedDeck,
    time: bool,
) -> Result<(ModelReport, Option<TimeEstimate>), RunError> {
    let model = build_model::<D>(ld)?;
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    fn timed<const D: usize, M: Material<D>>(
        (mut sim, report): (Simulation<D, M>, ModelReport),
        time: bool,
    ) -> (ModelReport, Option<TimeEstimate>) {
        let estimate = (time && report.solver == "explicit" && report.stages.is_empty())
            .then(|| time_steps(&mut sim, report.steps))
            .flatten();
        (report, estimate)
    }
    Ok(match material {
        MaterialChoice::Pmb(m) => timed(prepare(ld, model, m, rest)?, time),
        MaterialChoice::Lps(m) => timed(prepare(ld, model, m, rest)?, time),
        MaterialChoice::Correspondence(m) => timed(prepare(ld, model, m, rest)?, time),
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => timed(prepare(ld, model, m, rest)?, time),
            Err(m) => timed(prepare(ld, model, m, rest)?, time),
        },
    })
}

/// One untimed step, then `TIMED_STEPS` timed (of a model `check` throws away); `None` for a
/// run of no steps or when a step fails (the run itself will say why).
fn time_steps<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    steps: u64,
) -> Option<TimeEstimate> {
    if steps == 0 || sim.step().is_err() {
        return None;
    }
    let started = Instant::now();
    for _ in 0..TIMED_STEPS {
        sim.step().ok()?;
    }
    Some(TimeEstimate {
        seconds_per_step: started.elapsed().as_secs_f64() / TIMED_STEPS as f64,
        steps,
        timed_steps: TIMED_STEPS,
    })
}
