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
#[derive(Debug, Clone)]
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
            broken: 0,
            external_work: 0.0,
            dissipated_viscous: 0.0,
            dissipated_damage: 0.0,
            dt: 0.0,
            iterations: 0,
        }
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
