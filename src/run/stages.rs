//! The stage loops: a staged run's stages one after the other, and each stage's drive loop
//! (explicit with a fixed or adaptive time step, quasi-static load steps), offering every
//! committed step to the observers and writing the checkpoints that fall on it. A run is
//! taken one committed step at a time (`Course::advance`): `drive_stages` takes them all, a
//! session (`crate::session`) a few per call, through the same code.

use super::{ModelReport, RunError};
use crate::checkpoint::{Checkpoints, DriverState};
use crate::deck::solver_settings::SolverSettings;
use crate::deck::stages::StagePlan;
use crate::material::Material;
use crate::math::Vector;
use crate::observe::{Observer, StageStart, StepView};
use crate::solver::quasi_static::Ticker;
use crate::solver::Fields;
use crate::solver::{
    AdaptiveDt, AdaptiveDtSettings, Advanced, Pause, QuasiStatic, QuasiStaticSettings, Simulation,
};
use crate::state::State;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Drives the whole run: the deck's stages, or its one stage. Returns what the quasi-static
/// stages' solvers report for the summary.
pub(crate) fn drive_stages<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    first: SolverSettings,
    report: &ModelReport,
    plans: Vec<StagePlan<D>>,
    watch: &mut Watch<D>,
) -> Result<Vec<String>, RunError> {
    let mut course = Course::new(first, report, plans);
    while course.advance(sim, watch)? {}
    Ok(course.notes)
}

/// A run's stages and where it is in them: the deck's stages one after the other, each
/// starting from the state the one before left (the clock runs on), with its own boundary
/// conditions, loads, no-fail sets, solver and history interval; a quasi-static stage starts
/// at rest. A run continued from a checkpoint skips the stages finished before it and
/// continues the one it was in.
pub(crate) struct Course<const D: usize> {
    /// The deck's own stage's solver.
    first: SolverSettings,
    /// The further stages, in order; taken as they start.
    plans: std::vec::IntoIter<StagePlan<D>>,
    /// Each stage's steps, time step (or load increment) and duration.
    spans: Vec<Span>,
    /// Each stage's name (empty for a run of one stage).
    names: Vec<String>,
    /// What each quasi-static stage that ended in this process used and spent (the summary's
    /// notes).
    pub(crate) notes: Vec<String>,
    /// The next stage to start.
    next: usize,
    /// The loop of the stage in progress.
    current: Option<Loop<D>>,
}

/// How long a stage runs: a `ModelReport`'s numbers, or a `StageReport`'s.
#[derive(Debug, Clone, Copy)]
struct Span {
    steps: u64,
    dt: f64,
    duration: f64,
}

impl<const D: usize> Course<D> {
    pub(crate) fn new(
        first: SolverSettings,
        report: &ModelReport,
        plans: Vec<StagePlan<D>>,
    ) -> Self {
        let spans = if plans.is_empty() {
            vec![Span {
                steps: report.steps,
                dt: report.dt,
                duration: report.end_time,
            }]
        } else {
            report
                .stages
                .iter()
                .map(|s| Span {
                    steps: s.steps,
                    dt: s.dt,
                    duration: s.duration,
                })
                .collect()
        };
        Course {
            first,
            plans: plans.into_iter(),
            spans,
            names: report.stages.iter().map(|s| s.name.clone()).collect(),
            notes: Vec::new(),
            next: 0,
            current: None,
        }
    }

    /// Starts the run's first stage (the one a continued run was in), offering step 0 to a
    /// fresh run's observers, when no stage has started yet.
    pub(crate) fn start<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        watch: &mut Watch<D>,
    ) -> Result<(), RunError> {
        if self.next == 0 {
            self.begin(sim, watch)?;
        }
        Ok(())
    }

    /// Takes one committed step, starting the next stage when the one in progress is done;
    /// false when the run is over (no step taken).
    pub(crate) fn advance<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        watch: &mut Watch<D>,
    ) -> Result<bool, RunError> {
        loop {
            if let Some(stage) = self.current.as_mut() {
                if stage.step(sim, watch)? {
                    return Ok(true);
                }
                if let Loop::QuasiStatic { solver, .. } = stage {
                    let name = match self.names.get(self.next - 1) {
                        Some(name) => format!("stage {name}"),
                        None => "quasi-static".into(),
                    };
                    let mut note = format!("{name}: {}", solver.describe());
                    if solver.broken_through(sim) {
                        note += &format!(
                            "; stopped at load time {:e}: the body stores less than {} of the work done on it",
                            sim.state.time,
                            solver.settings.stop_when_stored_below.unwrap_or_default()
                        );
                    }
                    self.notes.push(note);
                }
                // A continued run's driver state served the stage it was in only.
                self.current = None;
                watch.at.resume = None;
            }
            if !self.begin(sim, watch)? {
                return Ok(false);
            }
        }
    }

    /// Whether the run's last stage is done.
    pub(crate) fn done<M: Material<D>>(&self, sim: &Simulation<D, M>) -> bool {
        self.next == self.spans.len() && self.current.as_ref().is_none_or(|l| l.finished(sim))
    }

    /// The energy given to the run is what the state holds now (after a state written by
    /// hand): blow-ups are measured against it from here on.
    pub(crate) fn rebase<M: Material<D>>(&mut self, sim: &Simulation<D, M>) {
        if let Some(l) = self.current.as_mut() {
            l.rebase(sim);
        }
    }

    /// The driver state a checkpoint of the current step records.
    pub(crate) fn driver_state<M: Material<D>>(
        &self,
        sim: &Simulation<D, M>,
        at: &Position<D>,
    ) -> DriverState<D> {
        let solver = match &self.current {
            Some(l) => l.driver(sim),
            None => DriverState {
                next_dt: sim.dt,
                ..DriverState::default()
            },
        };
        at.driver_state(sim, solver)
    }

    /// Starts the next stage (skipping those a continued run finished before its checkpoint):
    /// its loading and the loop of its solver. False when no stage is left.
    fn begin<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        watch: &mut Watch<D>,
    ) -> Result<bool, RunError> {
        let count = self.spans.len();
        let resumed_stage = watch.at.resume.as_ref().map_or(0, |d| d.stage as usize);
        let (index, settings) = loop {
            let index = self.next;
            if index >= count {
                return Ok(false);
            }
            self.next += 1;
            if index == 0 {
                if resumed_stage == 0 {
                    break (0, self.first.clone());
                }
                continue;
            }
            let plan = self.plans.next().expect("a plan for each further stage");
            if index < resumed_stage {
                continue;
            }
            sim.body.no_fail = plan.no_fail;
            sim.dt = self.spans[index].dt;
            if index == resumed_stage {
                // The checkpoint holds the state the stage's start made and what followed it.
                sim.replace_loading(plan.loading);
            } else {
                if plan.settings.quasi_static.is_some() {
                    sim.state.v.iter_mut().for_each(|v| *v = Vector::zeros());
                }
                sim.set_loading(plan.loading)?;
                watch.at.stage_start = (sim.state.step, sim.state.time);
            }
            watch.at.stage = index as u64;
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
            break (index, plan.settings);
        };
        watch.at.final_stage = index + 1 == count;
        let span = self.spans[index];
        let (step, time) = watch.at.stage_start;
        self.current = Some(match (settings.quasi_static, settings.adaptive) {
            (Some(qs), _) => Loop::quasi_static(sim, qs, (time, span.steps), watch)?,
            (None, Some(a)) => {
                let adaptive = a.settings(sim.dt);
                Loop::adaptive(sim, adaptive, time + span.duration, watch)?
            }
            (None, None) => Loop::explicit(sim, step + span.steps, watch)?,
        });
        Ok(true)
    }
}

/// The loop of one stage's solver, taken one committed step at a time.
enum Loop<const D: usize> {
    /// Fixed steps until step `end` (counted from the run's start); `given` is the energy
    /// given to the run, which `check_energy` measures blow-ups against.
    Explicit { end: u64, given: (f64, f64) },
    /// Adaptive steps until `end_time`, the last one shortened to land on it; times closer
    /// than `slack` to the end are the end.
    Adaptive {
        controller: Box<AdaptiveDt<D>>,
        end_time: f64,
        slack: f64,
        given: (f64, f64),
    },
    /// Load steps `k..=load_steps` of `increment` from the stage's start time `start`.
    QuasiStatic {
        solver: Box<QuasiStatic<D>>,
        start: f64,
        increment: f64,
        load_steps: u64,
        k: u64,
    },
}

impl<const D: usize> Loop<D> {
    fn explicit<M: Material<D>>(
        sim: &mut Simulation<D, M>,
        end: u64,
        watch: &mut Watch<D>,
    ) -> Result<Self, RunError> {
        let given = (0.0, 0.0);
        Loop::Explicit { end, given }.started(sim, end == 0, watch)
    }

    fn adaptive<M: Material<D>>(
        sim: &mut Simulation<D, M>,
        settings: AdaptiveDtSettings,
        end_time: f64,
        watch: &mut Watch<D>,
    ) -> Result<Self, RunError> {
        // From the initial dt, also when continuing.
        let slack = 1e-9 * sim.dt;
        let controller = match &watch.at.resume {
            None => AdaptiveDt::new(settings),
            Some(d) => {
                sim.dt = d.next_dt;
                AdaptiveDt::resumed(settings, d.since_change, d.rejected)
            }
        };
        let given = (0.0, 0.0);
        let l = Loop::Adaptive {
            controller: Box::new(controller),
            end_time,
            slack,
            given,
        };
        l.started(sim, end_time <= slack, watch)
    }

    /// A continued run skips the load steps whose targets it has passed and takes the
    /// solver's memory from the checkpoint.
    fn quasi_static<M: Material<D>>(
        sim: &mut Simulation<D, M>,
        settings: QuasiStaticSettings,
        (start, load_steps): (f64, u64),
        watch: &mut Watch<D>,
    ) -> Result<Self, RunError> {
        let increment = sim.dt;
        let mut solver = QuasiStatic::new(sim, settings, increment);
        if watch.progress {
            solver.ticker = Ticker::every(PROGRESS_SECONDS);
        }
        if let Some(memory) = watch.at.resume.as_mut().and_then(|d| d.quasi_static.take()) {
            solver.resume(memory);
        }
        // A run continued from the step that broke the body through has no step left.
        let k = match solver.broken_through(sim) {
            true => load_steps + 1,
            false => 1,
        };
        let l = Loop::QuasiStatic {
            solver: Box::new(solver),
            start,
            increment,
            load_steps,
            k,
        };
        l.started(sim, load_steps == 0, watch)
    }

    /// Offers step 0 of a fresh run (`empty`: the stage has no steps, so it is also the
    /// stage's end), then takes the energy given to the run.
    fn started<M: Material<D>>(
        mut self,
        sim: &mut Simulation<D, M>,
        empty: bool,
        watch: &mut Watch<D>,
    ) -> Result<Self, RunError> {
        if watch.at.resume.is_none() && sim.state.step == 0 {
            watch.commit(sim, empty, |sim| self.driver(sim))?;
        }
        self.rebase(sim);
        Ok(self)
    }

    fn rebase<M: Material<D>>(&mut self, sim: &Simulation<D, M>) {
        match self {
            Loop::Explicit { given, .. } | Loop::Adaptive { given, .. } => {
                *given = energy_given(sim)
            }
            Loop::QuasiStatic { .. } => {}
        }
    }

    /// The solver's part of a checkpoint.
    fn driver<M: Material<D>>(&self, sim: &Simulation<D, M>) -> DriverState<D> {
        match self {
            Loop::Explicit { .. } => DriverState {
                next_dt: sim.dt,
                ..DriverState::default()
            },
            Loop::Adaptive { controller, .. } => DriverState {
                next_dt: sim.dt,
                since_change: controller.since_change(),
                rejected: controller.rejected,
                ..DriverState::default()
            },
            Loop::QuasiStatic { solver, .. } => DriverState {
                quasi_static: Some(solver.memory()),
                ..DriverState::default()
            },
        }
    }

    /// Whether the stage's last step is done.
    fn finished<M: Material<D>>(&self, sim: &Simulation<D, M>) -> bool {
        match *self {
            Loop::Explicit { end, .. } => sim.state.step >= end,
            Loop::Adaptive {
                end_time, slack, ..
            } => end_time - sim.state.time <= slack,
            Loop::QuasiStatic {
                start,
                increment,
                load_steps,
                k,
                ..
            } => k > load_steps || sim.state.time >= start + load_steps as f64 * increment,
        }
    }

    /// Takes the stage's steps to its end.
    fn run<M: Material<D>>(
        mut self,
        sim: &mut Simulation<D, M>,
        watch: &mut Watch<D>,
    ) -> Result<(), RunError> {
        while self.step(sim, watch)? {}
        Ok(())
    }

    /// Takes one committed step of the stage: steps it, checks it for blow-up and offers it
    /// to the observers. False when the stage is done (no step taken).
    fn step<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        watch: &mut Watch<D>,
    ) -> Result<bool, RunError> {
        match self {
            Loop::Explicit { end, given } => {
                let (end, given) = (*end, *given);
                let k = sim.state.step + 1;
                if k > end {
                    return Ok(false);
                }
                sim.step()?;
                if k.is_multiple_of(100) || k == end {
                    sim.check_finite()?;
                }
                // Every 10 steps: an O(nodes) sum that sees an instability before it overflows.
                if k.is_multiple_of(10) || k == end {
                    sim.check_energy(given)?;
                }
                watch.commit(sim, k == end, |sim| self.driver(sim))?;
            }
            Loop::Adaptive {
                controller,
                end_time,
                slack,
                given,
            } => {
                let (end_time, slack, given) = (*end_time, *slack, *given);
                if end_time - sim.state.time <= slack {
                    return Ok(false);
                }
                sim.dt = sim.dt.min(end_time - sim.state.time);
                controller.step(sim)?;
                let k = sim.state.step;
                let last = end_time - sim.state.time <= slack;
                if k.is_multiple_of(100) || last {
                    sim.check_finite()?;
                }
                if k.is_multiple_of(10) || last {
                    sim.check_energy(given)?;
                }
                watch.commit(sim, last, |sim| self.driver(sim))?;
            }
            Loop::QuasiStatic {
                solver,
                start,
                increment,
                load_steps,
                k,
            } => loop {
                if *k > *load_steps {
                    return Ok(false);
                }
                // The target from k, not by summing increments: no drift over many steps.
                let target = *start + *k as f64 * *increment;
                if sim.state.time >= target {
                    *k += 1;
                    continue;
                }
                // One committed piece: the whole load step, or a part of a split one; or a
                // pause inside it when a checkpoint falls due.
                solver.pause = watch.pause_at().map(Pause::At);
                if solver.advance_or_pause(sim, target)? == Advanced::Paused {
                    watch.checkpoint_inside_step(sim, solver)?;
                    continue;
                }
                sim.check_finite()?;
                // Once broken through (`stop_when_stored_below`), no load step is left.
                let broken = solver.broken_through(sim);
                let stage_end = broken || (*k == *load_steps && sim.state.time >= target);
                if broken {
                    *k = *load_steps + 1;
                }
                watch.commit(sim, stage_end, |sim| self.driver(sim))?;
                break;
            },
        }
        Ok(true)
    }
}

/// Where a run is in its stages: what its checkpoints record besides the solver's part.
#[derive(Default)]
pub(crate) struct Position<const D: usize> {
    /// Continuing from a checkpoint (whose step the observers saw before the interruption)
    /// with the driver state it kept, until the stage it was in ends.
    resume: Option<DriverState<D>>,
    /// The stage in progress is the run's last: its end is the end of the run.
    final_stage: bool,
    /// The stage in progress and the step and time it started at.
    stage: u64,
    stage_start: (u64, f64),
}

impl<const D: usize> Position<D> {
    /// The start of a run, or of a run continued with a checkpoint's driver state (which
    /// names the stage in progress).
    pub(crate) fn new(resume: Option<DriverState<D>>, staged: bool) -> Self {
        Position {
            stage: resume.as_ref().map_or(0, |d| d.stage),
            stage_start: resume.as_ref().map_or((0, 0.0), |d| d.stage_start),
            resume,
            final_stage: !staged,
        }
    }

    /// The stage in progress (0: the deck's own).
    pub(crate) fn stage(&self) -> usize {
        self.stage as usize
    }

    /// A checkpoint's driver state: the solver's part, the stage and the impactors.
    fn driver_state<M: Material<D>>(
        &self,
        sim: &Simulation<D, M>,
        solver: DriverState<D>,
    ) -> DriverState<D> {
        DriverState {
            stage: self.stage,
            stage_start: self.stage_start,
            impactors: sim.impactors.states(),
            ..solver
        }
    }
}

/// What the loops do with each committed step besides stepping: offer it to the observers,
/// write the checkpoint that falls on it, stop where asked.
pub(crate) struct Watch<'a, const D: usize> {
    observers: &'a mut [Box<dyn Observer<D>>],
    checkpoints: Option<Checkpoints>,
    stop_after: Option<u64>,
    /// Set from elsewhere (Ctrl-C in Python) to stop after the step in progress.
    interrupt: Option<Arc<AtomicBool>>,
    at: Position<D>,
    /// Where the observers' view comes from when not from the simulation itself.
    source: Option<&'a mut dyn ViewSource<D>>,
    /// Progress lines inside long quasi-static load steps (`RunOptions::quiet` off).
    progress: bool,
    /// Stop at this pause inside a load step, as a killed run would (tests); and the pauses
    /// so far.
    stop_at_pause: Option<u64>,
    pauses: u64,
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

    /// Writes the checkpoint of the whole body from this rank's `state` and `driver` and
    /// the other ranks' (the quasi-static solver's memory holds per-node displacements);
    /// every rank calls it when a checkpoint falls due.
    fn write_checkpoint(
        &mut self,
        checkpoints: &Checkpoints,
        state: &State<D>,
        driver: &DriverState<D>,
    ) -> Result<(), RunError>;
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
            interrupt: None,
            at: Position::new(resume, staged),
            source: None,
            progress: false,
            stop_at_pause: None,
            pauses: 0,
        }
    }

    /// Only observers, at `at`: a session's watch, made for each call from the position
    /// the last one left (`position`).
    pub(crate) fn at(observers: &'a mut [Box<dyn Observer<D>>], at: Position<D>) -> Self {
        Watch {
            observers,
            checkpoints: None,
            stop_after: None,
            interrupt: None,
            at,
            source: None,
            progress: false,
            stop_at_pause: None,
            pauses: 0,
        }
    }

    /// Where the run is: for the next call's watch.
    pub(crate) fn position(self) -> Position<D> {
        self.at
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

    /// The run stops at the `n`-th pause inside a load step, after its checkpoint (tests).
    pub(crate) fn with_stop_at_pause(mut self, n: Option<u64>) -> Self {
        self.stop_at_pause = n;
        self
    }

    /// When a quasi-static relaxation should pause for the checkpoint the wall clock asks
    /// for: none without one, and none in a distributed run (whose ranks' clocks would not
    /// agree on the iteration).
    fn pause_at(&self) -> Option<Instant> {
        let wall = self.checkpoints.as_ref()?.wall.as_ref()?;
        self.source.is_none().then(|| wall.last + wall.every)
    }

    /// Writes the checkpoint of the load step `solver` paused inside, after the observers'
    /// files: they end at the last committed step, where a continued run's observers
    /// continue. The paused step is lent to the checkpoint, not copied, and taken back
    /// whatever the writing gives.
    fn checkpoint_inside_step<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        solver: &mut QuasiStatic<D>,
    ) -> Result<(), RunError> {
        let lent = DriverState {
            quasi_static: Some(solver.lend_memory()),
            ..DriverState::default()
        };
        let driver = self.at.driver_state(sim, lent);
        let written = self.write_inside_step(sim, &driver);
        solver.take_back(driver.quasi_static.and_then(|m| m.in_step));
        written
    }

    /// `checkpoint_inside_step`'s writing.
    fn write_inside_step<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        driver: &DriverState<D>,
    ) -> Result<(), RunError> {
        let Some(c) = self.checkpoints.as_mut() else {
            return Ok(());
        };
        let started = Instant::now();
        for o in self.observers.iter_mut() {
            o.flush()?;
        }
        c.write(&sim.state, driver)?;
        if let Some(w) = c.wall.as_mut() {
            w.last = Instant::now();
        }
        sim.counters.observe += started.elapsed();
        self.pauses += 1;
        match self.stop_at_pause {
            Some(n) if self.pauses >= n => Err(RunError::Stopped(sim.state.step)),
            _ => Ok(()),
        }
    }

    /// The run stops after the step in progress once `flag` is set.
    pub(crate) fn with_interrupt(mut self, flag: Option<Arc<AtomicBool>>) -> Self {
        self.interrupt = flag;
        self
    }

    /// Only observers.
    fn observers(observers: &'a mut [Box<dyn Observer<D>>]) -> Self {
        Watch::at(observers, Position::new(None, false))
    }

    /// Offers a committed step; `stage_end`: it ends the stage (and the run, in the last).
    /// `driver` gives the solver's part of a checkpoint, when one is written.
    fn commit<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        stage_end: bool,
        driver: impl FnOnce(&Simulation<D, M>) -> DriverState<D>,
    ) -> Result<(), RunError> {
        let last = stage_end && self.at.final_stage;
        match self.source.as_deref_mut() {
            None => offer(sim, self.observers, last, stage_end)?,
            Some(source) => {
                let started = Instant::now();
                source.offer(&*sim, self.observers, last, stage_end)?;
                sim.counters.observe += started.elapsed();
            }
        }
        let step = sim.state.step;
        let due = self
            .checkpoints
            .as_mut()
            .is_some_and(|c| c.wants(step, last));
        if let Some(c) = self.checkpoints.as_ref().filter(|_| due) {
            let started = Instant::now();
            // The files first: a restart keeps what they hold up to the checkpoint's step.
            for o in self.observers.iter_mut() {
                o.flush()?;
            }
            let driver = self.at.driver_state(sim, driver(sim));
            match self.source.as_deref_mut() {
                None => c.write(&sim.state, &driver)?,
                Some(source) => source.write_checkpoint(c, &sim.state, &driver)?,
            }
            sim.counters.observe += started.elapsed();
        }
        match self.stop_after {
            Some(n) if step >= n && !last => return Err(RunError::Stopped(step)),
            _ => {}
        }
        match &self.interrupt {
            Some(flag) if !last && flag.load(Ordering::Relaxed) => Err(RunError::Interrupted(step)),
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
    let watch = &mut Watch::observers(observers);
    Loop::explicit(sim, steps, watch)?.run(sim, watch)
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
    let watch = &mut Watch::observers(observers);
    Loop::adaptive(sim, settings, end_time, watch)?.run(sim, watch)
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
    Loop::quasi_static(sim, settings, (start, load_steps), watch)?.run(sim, watch)
}

/// At most this often a progress line inside a quasi-static load step.
const PROGRESS_SECONDS: f64 = 5.0;

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
