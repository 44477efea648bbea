//! `peridyn check`: build the model and report it without running, optionally timing a few
//! steps of the built model.

use super::prepare::prepare;
use super::{with_threads, ModelReport, RunError};
use crate::deck::build::{build_constitution, build_model, solver_settings, MaterialChoice};
use crate::deck::LoadedDeck;
use crate::material::Material;
use crate::solver::{QuasiStatic, QuasiStaticSettings, Simulation};
use std::time::Instant;

/// Builds the model and reports it, without stepping.
pub fn check(ld: &LoadedDeck, threads: Option<usize>) -> Result<ModelReport, RunError> {
    Ok(checked(ld, threads, false)?.0)
}

/// `check`, and for a single-stage run the time its steps will take, timed on the built model
/// on the same threads (`peridyn check`): a few explicit steps, or a quasi-static run's first
/// two load steps (see `QuasiStaticBasis`).
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
    /// For a quasi-static run: what the estimate stands on (`seconds_per_step` is then the
    /// mean over the load steps of the intact body).
    pub quasi_static: Option<QuasiStaticBasis>,
}

/// A quasi-static run's estimate: its first load step relaxes from rest, every later one
/// from the predictor's extrapolation, and each costs its iterations × the time of one
/// iteration (one force evaluation and the vector updates). Both steps are taken on the
/// built model with at most `PROBE_ITERATIONS` iterations (and `PROBE_BOND_EVALUATIONS`)
/// each; a relaxation that did not converge in them is extrapolated at its mean rate of
/// decrease (linear convergence). The estimate is that of a body that does not break: a load
/// step in which bonds break relaxes again after every decision, and one in which a crack
/// runs through takes many relaxations (`CRACK_STEP_RATIO`).
#[derive(Debug, Clone, Copy)]
pub struct QuasiStaticBasis {
    pub seconds_per_iteration: f64,
    /// Iterations of the first load step and of the second (measured or extrapolated).
    pub first: f64,
    pub later: f64,
    /// Both measured to convergence.
    pub measured: bool,
}

/// A load step in which a crack runs through the body took this many times the iterations of
/// the first load step in the measured cases (docs/performance.md, quasi-static crack growth:
/// 49 and 52 on seed 001's PMB plate with ADR, 75 on seed 000's NB-NUG plate with NCG).
pub const CRACK_STEP_RATIO: [f64; 2] = [50.0, 75.0];

/// Iterations allowed to each of the two load steps `check` takes …
const PROBE_ITERATIONS: u64 = 400;
/// … and at most about this many directed-bond evaluations each (about 2 s here: on a large
/// body 400 iterations take minutes), but never fewer than `PROBE_ITERATIONS_MIN` iterations:
/// the extrapolation needs a rate of decrease. A count, not a time, so that `check` gives the
/// same estimate of iterations on a busy machine as on a quiet one.
const PROBE_BOND_EVALUATIONS: f64 = 2e8;
const PROBE_ITERATIONS_MIN: u64 = 20;

impl std::fmt::Display for TimeEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(q) = &self.quasi_static {
            return write!(
                f,
                "time estimate    {:.1} s relaxing {} load steps of the intact body: {:.3e} s per \
                 iteration, {:.0} iterations in the first load step and {:.0} in each later one \
                 ({}); every load step that breaks bonds relaxes again after each decision, and \
                 one in which a crack runs through takes about {:.0}–{:.0} × the first step's \
                 iterations ({:.0}–{:.0} s more each)",
                self.seconds_per_step * self.steps as f64,
                self.steps,
                q.seconds_per_iteration,
                q.first,
                q.later,
                if q.measured {
                    "both measured"
                } else {
                    "extrapolated from the first iterations"
                },
                CRACK_STEP_RATIO[0],
                CRACK_STEP_RATIO[1],
                CRACK_STEP_RATIO[0] * q.first * q.seconds_per_iteration,
                CRACK_STEP_RATIO[1] * q.first * q.seconds_per_iteration
            );
        }
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
    let qs = solver_settings(&ld.deck).quasi_static;
    let qs = qs.as_ref();
    fn timed<const D: usize, M: Material<D>>(
        (mut sim, report): (Simulation<D, M>, ModelReport),
        time: bool,
        quasi_static: Option<&QuasiStaticSettings>,
    ) -> (ModelReport, Option<TimeEstimate>) {
        let estimate = match (quasi_static, time && report.stages.is_empty()) {
            (_, false) => None,
            (None, true) => time_steps(&mut sim, report.steps),
            (Some(qs), true) => time_load_steps(&mut sim, qs.clone(), report.steps, report.bonds),
        };
        (report, estimate)
    }
    Ok(match material {
        MaterialChoice::Pmb(m) => timed(prepare(ld, model, m, rest)?, time, qs),
        MaterialChoice::Lps(m) => timed(prepare(ld, model, m, rest)?, time, qs),
        MaterialChoice::Correspondence(m) => timed(prepare(ld, model, m, rest)?, time, qs),
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => timed(prepare(ld, model, m, rest)?, time, qs),
            Err(m) => timed(prepare(ld, model, m, rest)?, time, qs),
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
        quasi_static: None,
    })
}

/// A quasi-static run's first two load steps, each with at most `PROBE_ITERATIONS`
/// iterations and about `PROBE_BOND_EVALUATIONS` (see `QuasiStaticBasis`; `bonds` counts
/// each pair once); `None` for a run of no load steps or when a relaxation fails or does not
/// decrease the residual (the run itself will say why).
fn time_load_steps<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: QuasiStaticSettings,
    steps: u64,
    bonds: usize,
) -> Option<TimeEstimate> {
    if steps == 0 {
        return None;
    }
    let tolerance = settings.tolerance;
    // An iteration costs about one force evaluation: one per directed bond.
    let per_iteration = (2 * bonds).max(1) as f64;
    let budget = ((PROBE_BOND_EVALUATIONS / per_iteration) as u64)
        .clamp(PROBE_ITERATIONS_MIN, PROBE_ITERATIONS);
    let mut solver = QuasiStatic::new(sim, settings, sim.dt);
    let first = solver.probe(sim, budget).ok()?;
    let later = if steps > 1 {
        Some(solver.probe(sim, budget).ok()?)
    } else {
        None
    };
    // The spectral masses' measurement is part of the first probe's time.
    let (taken, seconds) = match later {
        Some(l) => (first.iterations + l.iterations, first.seconds + l.seconds),
        None => (first.iterations, first.seconds),
    };
    let taken = taken + solver.setup_evaluations;
    let seconds_per_iteration = seconds / taken.max(1) as f64;
    let first_needed = first.iterations_to(tolerance)?;
    let later_needed = match later {
        Some(l) => l.iterations_to(tolerance)?,
        None => 0.0,
    };
    let total = first_needed + later_needed * (steps - 1) as f64;
    Some(TimeEstimate {
        seconds_per_step: total * seconds_per_iteration / steps as f64,
        steps,
        timed_steps: steps.min(2),
        quasi_static: Some(QuasiStaticBasis {
            seconds_per_iteration,
            first: first_needed,
            later: later_needed,
            measured: first.converged && later.is_none_or(|l| l.converged),
        }),
    })
}
