//! Everything a step mutates: displacements, velocities, forces and bond status.

use crate::body::Body;
use crate::bonds::Bonds;
use crate::math::Vector;

/// Status of a directed bond entry i→j, two bits for its two halves (see `damage`): both
/// intact.
pub const INTACT: u8 = 0;
/// The half owned by the entry's node (its force state T_i⟨ξ⟩) is broken.
pub const OWN_BROKEN: u8 = 1;
/// The half owned by the neighbour (T_j⟨−ξ⟩) is broken.
pub const OTHER_BROKEN: u8 = 2;
/// Both halves broken: the bond carries no force. Breakage is irreversible.
pub const BROKEN: u8 = OWN_BROKEN | OTHER_BROKEN;

/// The evolving state of a run.
#[derive(Debug)]
pub struct State<const D: usize> {
    pub time: f64,
    pub step: u64,
    /// Displacement u (m).
    pub u: Vec<Vector<D>>,
    /// Velocity v (m/s).
    pub v: Vec<Vector<D>>,
    /// Current positions y = x + u, kept so the bond loop reads one array per neighbour.
    pub current: Vec<Vector<D>>,
    /// Internal force density of the last force evaluation (N/m³).
    pub force: Vec<Vector<D>>,
    /// External body-force density of the last evaluation (N/m³).
    pub body_force: Vec<Vector<D>>,
    /// Per directed bond entry: the broken bits of its two halves.
    pub status: Vec<u8>,
    /// Per directed bond entry: the damage law's history words (empty when it keeps none).
    pub history: Vec<f64>,
    /// Current positions at the previous force evaluation, kept only for damage laws that
    /// integrate the work done on bonds (empty otherwise).
    pub previous: Vec<Vector<D>>,
    /// Per node, the matrices of its own half at the previous force evaluation (B and C1,
    /// `Material::NODE_MATRIX_WORDS` each), kept only when a critical energy integrates each
    /// half's work apart (`DamageLaw::SPLITS_WORK`; empty otherwise).
    pub previous_matrices: Vec<f64>,
    /// Number of broken directed bond halves (a bond whose ends share a law counts twice).
    pub broken: u64,
    /// Work done by boundary conditions and loads since the start (J).
    pub external_work: f64,
    /// Energy removed by viscous damping since the start (J).
    pub dissipated_viscous: f64,
    /// Strain energy released by breaking bonds since the start (J): at every evaluation that
    /// breaks bonds, the strain energy of the current configuration before the breaks minus
    /// after them (`solver::dissipation`; softening adds its share from the history, see
    /// `ForceEngine::dissipated_energy`).
    pub dissipated_damage: f64,
    /// The last step's time step (s), or its load increment in a quasi-static run.
    pub dt: f64,
    /// Force evaluations of the last step: 1 for an explicit step, the relaxation
    /// iterations of a quasi-static load step.
    pub iterations: u64,
}

/// `clone_from` copies into the arrays already there: the adaptive time step saves the
/// state before every step, and a derived `Clone` would allocate (and the kernel zero) fresh
/// arrays each time, tens of MB per step.
impl<const D: usize> Clone for State<D> {
    fn clone(&self) -> Self {
        let mut copy = State::empty();
        copy.clone_from(self);
        copy
    }

    fn clone_from(&mut self, source: &Self) {
        // Destructured without `..`: a new field fails to compile until it is copied.
        let State {
            time,
            step,
            u,
            v,
            current,
            force,
            body_force,
            status,
            history,
            previous,
            previous_matrices,
            broken,
            external_work,
            dissipated_viscous,
            dissipated_damage,
            dt,
            iterations,
        } = self;
        *time = source.time;
        *step = source.step;
        u.clone_from(&source.u);
        v.clone_from(&source.v);
        current.clone_from(&source.current);
        force.clone_from(&source.force);
        body_force.clone_from(&source.body_force);
        status.clone_from(&source.status);
        history.clone_from(&source.history);
        previous.clone_from(&source.previous);
        previous_matrices.clone_from(&source.previous_matrices);
        *broken = source.broken;
        *external_work = source.external_work;
        *dissipated_viscous = source.dissipated_viscous;
        *dissipated_damage = source.dissipated_damage;
        *dt = source.dt;
        *iterations = source.iterations;
    }
}

impl<const D: usize> State<D> {
    /// The reference state: at rest, every bond intact, `history_words` of zeros per bond.
    pub fn new(body: &Body<D>, bonds: &Bonds, history_words: usize) -> Self {
        let n = body.len();
        State {
            time: 0.0,
            step: 0,
            u: vec![Vector::zeros(); n],
            v: vec![Vector::zeros(); n],
            current: body.positions.clone(),
            force: vec![Vector::zeros(); n],
            body_force: vec![Vector::zeros(); n],
            status: vec![INTACT; bonds.len()],
            history: vec![0.0; bonds.len() * history_words],
            previous: Vec::new(),
            previous_matrices: Vec::new(),
            broken: 0,
            external_work: 0.0,
            dissipated_viscous: 0.0,
            dissipated_damage: 0.0,
            dt: 0.0,
            iterations: 0,
        }
    }

    /// A state of no nodes and no bonds: the scalars of a checkpoint before its arrays.
    pub fn empty() -> Self {
        State {
            time: 0.0,
            step: 0,
            u: Vec::new(),
            v: Vec::new(),
            current: Vec::new(),
            force: Vec::new(),
            body_force: Vec::new(),
            status: Vec::new(),
            history: Vec::new(),
            previous: Vec::new(),
            previous_matrices: Vec::new(),
            broken: 0,
            external_work: 0.0,
            dissipated_viscous: 0.0,
            dissipated_damage: 0.0,
            dt: 0.0,
            iterations: 0,
        }
    }

    /// Takes `other`'s scalars: the time, step, counts and energies booked so far.
    pub fn step_scalars_from(&mut self, other: &State<D>) {
        self.time = other.time;
        self.step = other.step;
        self.broken = other.broken;
        self.external_work = other.external_work;
        self.dissipated_viscous = other.dissipated_viscous;
        self.dissipated_damage = other.dissipated_damage;
        self.dt = other.dt;
        self.iterations = other.iterations;
    }

    /// Sets u and keeps `current` consistent.
    pub fn set_displacement(&mut self, body: &Body<D>, i: usize, u: Vector<D>) {
        self.u[i] = u;
        self.current[i] = body.positions[i] + u;
    }

    /// Kinetic energy Σ ½ ρ V |v|² (J), with ρ per node.
    pub fn kinetic_energy(&self, body: &Body<D>, densities: &[f64]) -> f64 {
        self.v
            .iter()
            .zip(&body.volumes)
            .zip(densities)
            .map(|((v, &vol), &rho)| 0.5 * rho * vol * v.norm_squared())
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Saving the state again reuses the saved copy's arrays, and copies every value.
    #[test]
    fn clone_from_copies_into_the_arrays_already_there() {
        let mut state = State::<2> {
            time: 1.5,
            step: 7,
            u: vec![Vector::<2>::new(1.0, 2.0); 1000],
            v: vec![Vector::<2>::new(3.0, 4.0); 1000],
            current: vec![Vector::zeros(); 1000],
            force: vec![Vector::zeros(); 1000],
            body_force: vec![Vector::zeros(); 1000],
            status: vec![INTACT; 30_000],
            history: vec![0.5; 30_000],
            previous: Vec::new(),
            previous_matrices: Vec::new(),
            broken: 3,
            external_work: 2.0,
            dissipated_viscous: 0.25,
            dissipated_damage: 0.125,
            dt: 1e-7,
            iterations: 1,
        };
        let mut saved = state.clone();
        let (u, status, history) = (
            saved.u.as_ptr(),
            saved.status.as_ptr(),
            saved.history.as_ptr(),
        );
        state.u[999] = Vector::<2>::new(-1.0, -2.0);
        state.status[5] = BROKEN;
        state.history[7] = 9.0;
        state.time = 2.0;
        state.dissipated_damage = 1.0;
        saved.clone_from(&state);
        assert_eq!(saved.u.as_ptr(), u);
        assert_eq!(saved.status.as_ptr(), status);
        assert_eq!(saved.history.as_ptr(), history);
        assert_eq!(saved.u, state.u);
        assert_eq!(saved.status, state.status);
        assert_eq!(saved.history, state.history);
        assert_eq!((saved.time, saved.dissipated_damage), (2.0, 1.0));
    }
}
