//! The stage loops: a staged run's stages one after the other, and each stage's drive loop
//! (explicit with a fixed or adaptive time step, quasi-static load steps), offering every
//! committed step to the observers and writing the checkpoints that fall on it.

use super::{ModelReport, RunError};
use crate::checkpoint::{Checkpoints, DriverState};
use crate::deck::solver_settings::SolverSettings;
use crate::deck::stages::{StagePlan, StageReport};
use crate::material::Material;
use crate::math::Vector;
use crate::observe::{Observer, StageStart, StepView};
use crate::solver::quasi_static::Ticker;
use crate::solver::Fields;
use crate::solver::{AdaptiveDt, AdaptiveDtSettings, QuasiStatic, QuasiStaticSettings, Simulation};
use crate::state::State;
use std::time::Instant;

/// Drives the whole run: the deck's stages, or its one stage.
pub(crate) fn drive_stages<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    first: SolverSettings,
    report: &ModelReport,
    plans: Vec<StagePlan<D>>,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    if plans.is_empty() {
        run_stage(sim, first, report, watch)
    } else {
        run_stages(sim, first, report, plans, watch)
    }
}

/// Runs the deck's stages one after the other: each starts from the state the one before
/// left (the clock runs on), with its own boundary conditions, loads, no-fail sets, solver and
/// history interval; a quasi-static stage starts at rest. A run continued from a checkpoint
/// skips the stages finished before it and continues the one it was in.
fn run_stages<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    first: SolverSettings,
    report: &ModelReport,
    plans: Vec<StagePlan<D>>,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let count = plans.len() + 1;
    let resumed_stage = watch.resume.as_ref().map_or(0, |d| d.stage as usize);
    if resumed_stage == 0 {
        watch.final_stage = count == 1;
        run_stage(sim, first, &report.stages[0], watch)?;
    }
    for (k, plan) in plans.into_iter().enumerate() {
        let index = k + 1;
        if index < resumed_stage {
            continue;
        }
        let stage = &report.stages[index];
        sim.body.no_fail = plan.no_fail;
        sim.dt = stage.dt;
        if index == resumed_stage {
            // The checkpoint holds the state the stage's start made and what followed it.
            sim.replace_loading(plan.loading);
        } else {
            if plan.settings.quasi_static.is_some() {
                sim.state.v.iter_mut().for_each(|v| *v = Vector::zeros());
            }
            sim.set_loading(plan.loading)?;
            watch.stage_start = (sim.state.step, sim.state.time);
        }
        watch.stage = index as u64;
        let start = StageStart {
            index,
            history_interval: match plan.history_interval {
                0 => u64::MAX,
                k => k,
            },
        };
        for o in watch.observers.iter_mut() {
            o.begin_stage(&start);
        }
        watch.final_stage = index + 1 == count;
        run_stage(sim, plan.settings, stage, watch)?;
    }
    Ok(())
}

/// One stage with its solver, from `watch.stage_start` (a run continued from a checkpoint is
/// past it): `stage` gives its steps and duration (a `ModelReport` or `StageReport`). A
/// continued run's driver state serves this stage only.
fn run_stage<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: SolverSettings,
    stage: &impl StageLength,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let (step, time) = watch.stage_start;
    match (settings.quasi_static, settings.adaptive) {
        (Some(qs), _) => quasi_static_loop(sim, qs, (time, stage.steps()), watch),
        (None, Some(a)) => {
            let adaptive = a.settings(sim.dt);
            adaptive_loop(sim, adaptive, time + stage.duration(), watch)
        }
        (None, None) => explicit_loop(sim, step + stage.steps(), watch),
    }?;
    watch.resume = None;
    Ok(())
}

/// How long a stage runs.
trait StageLength {
    fn steps(&self) -> u64;
    fn duration(&self) -> f64;
}

impl StageLength for ModelReport {
    fn steps(&self) -> u64 {
        self.steps
    }
    fn duration(&self) -> f64 {
        self.end_time
    }
}

impl StageLength for StageReport {
    fn steps(&self) -> u64 {
        self.steps
    }
    fn duration(&self) -> f64 {
        self.duration
    }
}

/// What the explicit loops do with each committed step besides stepping: offer it to the
/// observers, write the checkpoint that falls on it, stop where asked.
pub(crate) struct Watch<'a, const D: usize> {
    observers: &'a mut [Box<dyn Observer<D>>],
    checkpoints: Option<Checkpoints>,
    stop_after: Option<u64>,
    /// Continuing from a checkpoint (whose step the observers saw before the interruption)
    /// with the driver state it kept.
    resume: Option<DriverState<D>>,
    /// The stage in progress is the run's last: its end is the end of the run.
    final_stage: bool,
    /// The stage in progress and the step and time it started at.
    stage: u64,
    stage_start: (u64, f64),
    /// Where the observers' view comes from when not from the simulation itself.
    source: Option<&'a mut dyn ViewSource<D>>,
    /// Progress lines inside long quasi-static load steps (`RunOptions::quiet` off).
    progress: bool,
}

/// How the observers see a committed step when the simulation is not the whole body: a
/// distributed run gathers the fields its observers read to rank 0.
pub trait ViewSource<const D: usize> {
    /// Offers the step of `fields` (this rank's share) to `observers` (rank 0's; none on the
    /// other ranks) as `offer` does; every rank calls it after every committed step.
    fn offer(
        &mut self,
        fields: &dyn Fields<D>,
        observers: &mut [Box<dyn Observer<D>>],
        last: bool,
        stage_end: bool,
    ) -> Result<(), RunError>;

    /// The whole body's state for a checkpoint, on the process that writes it (`None` on
    /// the others); every rank calls it when a checkpoint falls due.
    fn whole_state(&mut self, state: &State<D>) -> Option<&State<D>>;
}

impl<'a, const D: usize> Watch<'a, D> {
    /// A run's watch: its observers and checkpoints, where to stop, and the driver state of
    /// the checkpoint it continues from (which names the stage in progress).
    pub(crate) fn new(
        observers: &'a mut [Box<dyn Observer<D>>],
        checkpoints: Option<Checkpoints>,
        stop_after: Option<u64>,
        resume: Option<DriverState<D>>,
        staged: bool,
    ) -> Self {
        Watch {
            observers,
            checkpoints,
            stop_after,
            stage: resume.as_ref().map_or(0, |d| d.stage),
            stage_start: resume.as_ref().map_or((0, 0.0), |d| d.stage_start),
            resume,
            final_stage: !staged,
            source: None,
            progress: false,
        }
    }

    /// Prints progress inside long quasi-static load steps when `on`.
    pub(crate) fn with_progress(mut self, on: bool) -> Self {
        self.progress = on;
        self
    }

    /// The observers see the steps through `source`.
    pub(crate) fn with_source(mut self, source: &'a mut dyn ViewSource<D>) -> Self {
        self.source = Some(source);
        self
    }

    /// Only observers.
    fn observers(observers: &'a mut [Box<dyn Observer<D>>]) -> Self {
        Watch {
            observers,
            checkpoints: None,
            stop_after: None,
            resume: None,
            final_stage: true,
            stage: 0,
            stage_start: (0, 0.0),
            source: None,
            progress: false,
        }
    }

    /// Offers a committed step; `stage_end`: it ends the stage (and the run, in the last).
    /// `driver` gives the solver's part of a checkpoint, when one is written.
    fn commit<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        stage_end: bool,
        driver: impl FnOnce(&Simulation<D, M>) -> DriverState<D>,
    ) -> Result<(), RunError> {
        let last = stage_end && self.final_stage;
        match self.source.as_deref_mut() {
            None => offer(sim, self.observers, last, stage_end)?,
            Some(source) => {
                let started = Instant::now();
                source.offer(&*sim, self.observers, last, stage_end)?;
                sim.counters.observe += started.elapsed();
            }
        }
        let step = sim.state.step;
        if let Some(c) = self.checkpoints.as_ref().filter(|c| c.wants(step, last)) {
            let started = Instant::now();
            // The files first: a restart keeps what they hold up to the checkpoint's step.
            for o in self.observers.iter_mut() {
                o.flush()?;
            }
            let driver = DriverState {
                stage: self.stage,
                stage_start: self.stage_start,
                impactors: sim.impactors.states(),
                ..driver(sim)
            };
            match self.source.as_deref_mut() {
                None => c.write(&sim.state, &driver)?,
                Some(source) => {
                    if let Some(whole) = source.whole_state(&sim.state) {
                        c.write(whole, &driver)?;
                    }
                }
            }
            sim.counters.observe += started.elapsed();
        }
        match self.stop_after {
            Some(n) if step >= n && !last => Err(RunError::Stopped(step)),
            _ => Ok(()),
        }
    }
}

/// The step loop: step, check for blow-up, offer the committed step to observers.
pub fn drive<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    steps: u64,
    observers: &mut [Box<dyn Observer<D>>],
) -> Result<(), RunError> {
    explicit_loop(sim, steps, &mut Watch::observers(observers))
}

/// Fixed steps until step `steps` (counted from the run's start).
fn explicit_loop<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    steps: u64,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let driver = |sim: &Simulation<D, M>| DriverState {
        next_dt: sim.dt,
        ..DriverState::default()
    };
    if watch.resume.is_none() && sim.state.step == 0 {
        watch.commit(sim, steps == 0, driver)?;
    }
    let given = energy_given(sim);
    for k in sim.state.step + 1..=steps {
        sim.step()?;
        if k % 100 == 0 || k == steps {
            sim.check_finite()?;
        }
        // Every 10 steps: an O(nodes) sum that sees an instability before it overflows.
        if k % 10 == 0 || k == steps {
            sim.check_energy(given)?;
        }
        watch.commit(sim, k == steps, driver)?;
    }
    Ok(())
}

/// The energy a loop starts with (kinetic and strain energy, and contact's: penalty energy
/// and the impactors' kinetic energy), and the external work done until then: what
/// `Simulation::check_energy` measures the energy given against.
pub(crate) fn energy_given<const D: usize, M: Material<D>>(sim: &Simulation<D, M>) -> (f64, f64) {
    (
        sim.kinetic_energy()
            + sim.strain_energy()
            + Fields::contact_energy(sim)
            + Fields::impactor_kinetic_energy(sim),
        sim.state.external_work,
    )
}

/// The explicit loop with an adaptive time step: committed steps until `end_time` (the last
/// one shortened to land on it), each offered to observers; rejected attempts are not seen.
pub fn drive_adaptive<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: AdaptiveDtSettings,
    end_time: f64,
    observers: &mut [Box<dyn Observer<D>>],
) -> Result<(), RunError> {
    adaptive_loop(sim, settings, end_time, &mut Watch::observers(observers))
}

fn adaptive_loop<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: AdaptiveDtSettings,
    end_time: f64,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    // Times closer than this to the end are the end (rounding of accumulated steps); from
    // the initial dt, also when continuing.
    let slack = 1e-9 * sim.dt;
    let mut controller = match &watch.resume {
        None => AdaptiveDt::new(settings),
        Some(d) => {
            sim.dt = d.next_dt;
            AdaptiveDt::resumed(settings, d.since_change, d.rejected)
        }
    };
    let driver = |sim: &Simulation<D, M>, c: &AdaptiveDt<D>| DriverState {
        next_dt: sim.dt,
        since_change: c.since_change(),
        rejected: c.rejected,
        ..DriverState::default()
    };
    if watch.resume.is_none() && sim.state.step == 0 {
        watch.commit(sim, end_time <= slack, |sim| driver(sim, &controller))?;
    }
    let mut k = sim.state.step;
    let given = energy_given(sim);
    while end_time - sim.state.time > slack {
        sim.dt = sim.dt.min(end_time - sim.state.time);
        controller.step(sim)?;
        k += 1;
        let last = end_time - sim.state.time <= slack;
        if k.is_multiple_of(100) || last {
            sim.check_finite()?;
        }
        if k.is_multiple_of(10) || last {
            sim.check_energy(given)?;
        }
        watch.commit(sim, last, |sim| driver(sim, &controller))?;
    }
    Ok(())
}

/// The quasi-static loop: `load_steps` equal load steps of pseudo-time `sim.dt`, each
/// committed in one piece or, when it breaks too many bonds, in several (every committed piece
/// is offered to observers).
pub fn drive_quasi_static<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: QuasiStaticSettings,
    load_steps: u64,
    observers: &mut [Box<dyn Observer<D>>],
) -> Result<(), RunError> {
    let start = sim.state.time;
    let watch = &mut Watch::observers(observers);
    quasi_static_loop(sim, settings, (start, load_steps), watch)
}

/// At most this often a progress line inside a quasi-static load step.
const PROGRESS_SECONDS: f64 = 5.0;

/// Load steps from the stage's start time `start`; a continued run skips the load steps whose
/// targets it has passed and takes the solver's memory from the checkpoint.
fn quasi_static_loop<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: QuasiStaticSettings,
    (start, load_steps): (f64, u64),
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let increment = sim.dt;
    let mut solver = QuasiStatic::new(sim, settings, increment);
    if watch.progress {
        solver.ticker = Ticker::every(PROGRESS_SECONDS);
    }
    let driver = |solver: &QuasiStatic<D>| DriverState {
        quasi_static: Some(solver.memory()),
        ..DriverState::default()
    };
    match watch.resume.as_mut().and_then(|d| d.quasi_static.take()) {
        Some(memory) => solver.resume(memory),
        None if watch.resume.is_none() && sim.state.step == 0 => {
            watch.commit(sim, load_steps == 0, |_| driver(&solver))?;
        }
        None => {}
    }
    for k in 1..=load_steps {
        // The target from k, not by summing increments: no drift over many steps.
        let target = start + k as f64 * increment;
        while sim.state.time < target {
            solver.advance(sim, target)?;
            sim.check_finite()?;
            let stage_end = k == load_steps && sim.state.time >= target;
            watch.commit(sim, stage_end, |_| driver(&solver))?;
        }
    }
    Ok(())
}

/// Offers a committed step to the observers that want it; every observer's schedule
/// includes the last step of each stage (`stage_end`) as it does the run's (`last`).
fn offer<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    observers: &mut [Box<dyn Observer<D>>],
    last: bool,
    stage_end: bool,
) -> Result<(), RunError> {
    let step = sim.state.step;
    let wanted = last || stage_end;
    if !observers.iter().any(|o| o.wants(step, wanted)) {
        return Ok(());
    }
    let started = Instant::now();
    {
        let view = StepView::new(&*sim as &dyn Fields<D>, last);
        for o in observers.iter_mut() {
            if o.wants(step, wanted) {
                o.observe(&view)?;
            }
        }
    }
    sim.counters.observe += started.elapsed();
    Ok(())
}
