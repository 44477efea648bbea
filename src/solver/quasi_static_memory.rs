//! What the quasi-static solver keeps besides the state, between load steps and inside one:
//! a checkpoint saves it, so that a continued run relaxes from the same start and, inside a
//! paused load step, takes the same iterations as the run that did not stop.
//!
//! A load step can run for hours (the elastic preload of a million-node plate relaxes from
//! rest through some ten thousand ADR iterations; a crack crossing a 200 000-node plate in one
//! load step takes some hundred thousand conjugate-gradient evaluations), longer than a
//! session or a job's wall time. So a relaxation, ADR or NCG, may pause between two
//! iterations (`Pause`): the solver returns with the step in progress kept
//! (`StepInProgress`), the run writes a checkpoint, and the next call continues the iteration
//! where it stopped. A pause changes no number: the iteration reads only the state and what
//! `StepInProgress` keeps (ADR's velocities, NCG's search direction).

use crate::math::Vector;
use crate::state::State;
use std::time::Instant;

use super::quasi_static::LoadStepReport;

/// What a quasi-static solver carries from one committed load step to the next (besides the
/// state), and the load step in progress when it paused inside one.
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiStaticMemory<const D: usize> {
    pub increment: f64,
    pub largest_load: f64,
    pub previous: Option<(f64, Vec<Vector<D>>)>,
    pub iterations: u64,
    /// A relaxation with the spectral masses failed earlier in the run: Gershgorin's masses
    /// stay in use (a continued run must not measure the spectrum again).
    pub gershgorin: bool,
    /// The spectral radius the masses were scaled by and the force evaluations it took, once
    /// measured: a continued run scales them alike instead of measuring again (which needs a
    /// fresh copy of the bonds' state beside the paused step's records). `None` before, and
    /// from a checkpoint of format 5 or earlier (measured again then: the same number).
    pub spectrum: Option<(f64, u64)>,
    /// The load step in progress, when the solver paused inside it.
    pub in_step: Option<Box<StepInProgress<D>>>,
}

/// When a relaxation pauses, between two iterations, for a checkpoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pause {
    /// At the first iteration that ends after this instant (the checkpoints' wall clock).
    At(Instant),
    /// After every this many iterations of a relaxation (for tests).
    Every(u64),
}

impl Pause {
    /// Whether a relaxation that has taken `since` iterations since it started or last
    /// continued pauses now.
    pub fn due(&self, since: u64) -> bool {
        match *self {
            Pause::At(at) => Instant::now() >= at,
            Pause::Every(n) => since >= n,
        }
    }
}

/// A load step paused inside a relaxation: what its continuation reads besides the state
/// (the step's start, what it took so far, the work record of its last decision) and the
/// relaxation's own (its iterations; for ADR its first residual, velocities and last
/// accelerations, and its start when a failure would take it again with other masses; for
/// NCG its search direction and the iterations since its last restart).
#[derive(Debug, Clone, PartialEq)]
pub struct StepInProgress<const D: usize> {
    /// The load parameter at the step's start (the last committed one) and at its end.
    pub t0: f64,
    pub t1: f64,
    /// Displacements and applied forces at the step's start: the predictor's next point and
    /// the trapezoid of the step's external work.
    pub u0: Vec<Vector<D>>,
    pub load0: Vec<Vector<D>>,
    /// What the step took before the relaxation in progress (its equilibria counted).
    pub report: LoadStepReport,
    /// The bonds' work record as the step's last decision left it.
    pub record: WorkRecord<D>,
    /// The relaxation in progress.
    pub relaxation: RelaxationPaused<D>,
    /// ADR's v^{n−½} and F^{n−1}/λ per node (empty in the solver's own copy, which keeps them
    /// in its working arrays; filled in a checkpoint's).
    pub velocity: Vec<Vector<D>>,
    pub previous_acceleration: Vec<Vector<D>>,
    /// NCG's search direction per node (empty for ADR, and in the solver's own copy).
    pub direction: Vec<Vector<D>>,
}

/// A relaxation paused between two iterations (its ADR velocities and accelerations, or its
/// NCG search direction, are kept beside it: in the solver's working arrays, or in
/// `StepInProgress`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RelaxationPaused<const D: usize> {
    /// Its iterations so far (NCG: force evaluations), and its residual at its start (ADR).
    pub iterations: u64,
    pub start_residual: f64,
    /// NCG: its iterations since the direction was last restarted (0 for ADR).
    pub since_restart: u64,
    /// Its start, with the spectral masses: a relaxation that fails with them is taken again
    /// from there with Gershgorin's.
    pub fallback_start: Option<RelaxationStart<D>>,
}

/// The bonds' work record as the last decision left it (see `quasi_static`'s module doc):
/// their history words and the positions and correspondence matrices of the evaluation that
/// recorded them.
#[derive(Debug, Clone, PartialEq)]
pub struct WorkRecord<const D: usize> {
    pub history: Vec<f64>,
    pub previous: Vec<Vector<D>>,
    pub previous_matrices: Vec<f64>,
}

impl<const D: usize> WorkRecord<D> {
    pub fn of(state: &State<D>) -> Self {
        WorkRecord {
            history: state.history.clone(),
            previous: state.previous.clone(),
            previous_matrices: state.previous_matrices.clone(),
        }
    }

    pub fn keep(&mut self, state: &State<D>) {
        self.history.clone_from(&state.history);
        self.previous.clone_from(&state.previous);
        self.previous_matrices.clone_from(&state.previous_matrices);
    }

    pub fn restore(&self, state: &mut State<D>) {
        state.history.clone_from(&self.history);
        state.previous.clone_from(&self.previous);
        state.previous_matrices.clone_from(&self.previous_matrices);
    }
}

/// The arrays of the state a relaxation changes, as they were at its start: the
/// displacements, positions and forces, and the work record its force evaluations add to.
/// The rest (velocities, bond status, the scalars) no relaxation touches: every bond is
/// protected while it runs.
#[derive(Debug, Clone, PartialEq)]
pub struct RelaxationStart<const D: usize> {
    pub u: Vec<Vector<D>>,
    pub current: Vec<Vector<D>>,
    pub force: Vec<Vector<D>>,
    pub body_force: Vec<Vector<D>>,
    pub record: WorkRecord<D>,
}

impl<const D: usize> RelaxationStart<D> {
    pub fn of(state: &State<D>) -> Self {
        RelaxationStart {
            u: state.u.clone(),
            current: state.current.clone(),
            force: state.force.clone(),
            body_force: state.body_force.clone(),
            record: WorkRecord::of(state),
        }
    }

    pub fn restore(&self, state: &mut State<D>) {
        state.u.clone_from(&self.u);
        state.current.clone_from(&self.current);
        state.force.clone_from(&self.force);
        state.body_force.clone_from(&self.body_force);
        self.record.restore(state);
    }
}
