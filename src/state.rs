//! Everything a step mutates: displacements, velocities, forces and bond status.

use crate::body::Body;
use crate::bonds::Bonds;
use crate::math::Vector;

/// Bond status byte: intact.
pub const INTACT: u8 = 0;
/// Bond status byte: broken (irreversible).
pub const BROKEN: u8 = 1;

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
    /// Per directed bond: `INTACT` or `BROKEN`.
    pub status: Vec<u8>,
    /// Number of broken directed bonds.
    pub broken: u64,
    /// Work done by boundary conditions and loads since the start (J).
    pub external_work: f64,
    /// Energy removed by viscous damping since the start (J).
    pub dissipated_viscous: f64,
}

impl<const D: usize> State<D> {
    /// The reference state: at rest, every bond intact.
    pub fn new(body: &Body<D>, bonds: &Bonds) -> Self {
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
            broken: 0,
            external_work: 0.0,
            dissipated_viscous: 0.0,
        }
    }

    /// Sets u and keeps `current` consistent.
    pub fn set_displacement(&mut self, body: &Body<D>, i: usize, u: Vector<D>) {
        self.u[i] = u;
        self.current[i] = body.positions[i] + u;
    }

    /// Kinetic energy Σ ½ ρ V |v|² (J).
    pub fn kinetic_energy(&self, body: &Body<D>, rho: f64) -> f64 {
        self.v
            .iter()
            .zip(&body.volumes)
            .map(|(v, &vol)| 0.5 * rho * vol * v.norm_squared())
            .sum()
    }
}
