//! Boundary conditions, loads and initial conditions on named node sets.

pub mod time_function;

pub use time_function::TimeFunction;

use crate::body::Body;
use crate::math::Vector;
use crate::state::State;
use serde::{Deserialize, Serialize};

/// What a boundary condition prescribes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kinematic {
    Displacement,
    Velocity,
}

/// A prescribed displacement or velocity `value · f(t)` on one component of a node set; with
/// `offsets` (one per node), `(value + offsets[k]) · f(t)` at node `nodes[k]`.
#[derive(Debug, Clone)]
pub struct BoundaryCondition {
    pub set: String,
    pub nodes: Vec<u32>,
    pub kind: Kinematic,
    pub component: usize,
    pub value: f64,
    pub time: TimeFunction,
    /// Per-node additions to `value` (a gradient's term); empty: none.
    pub offsets: Vec<f64>,
}

impl BoundaryCondition {
    /// The prescribed value at the condition's k-th node, at f(t) = `factor`.
    fn at(&self, k: usize, factor: f64) -> f64 {
        match self.offsets.get(k) {
            Some(offset) => (self.value + offset) * factor,
            None => self.value * factor,
        }
    }

    /// The offsets of a gradient g (value per metre) about `origin`: g · (x − origin) at each
    /// node's reference position.
    pub fn gradient_offsets<const D: usize>(
        body: &Body<D>,
        nodes: &[u32],
        gradient: &Vector<D>,
        origin: &Vector<D>,
    ) -> Vec<f64> {
        nodes
            .iter()
            .map(|&i| gradient.dot(&(body.positions[i as usize] - origin)))
            .collect()
    }
}

/// A distributed load on a node set: a body force density `value · f(t)` (N/m³), or a total
/// force (e.g. traction × area) spread over the set's volume.
#[derive(Debug, Clone)]
pub struct Load<const D: usize> {
    pub set: String,
    pub nodes: Vec<u32>,
    /// Body force density (N/m³) at f = 1.
    pub density: Vector<D>,
    pub time: TimeFunction,
}

/// All boundary conditions and loads of a run.
#[derive(Debug, Clone, Default)]
pub struct Loading<const D: usize> {
    pub conditions: Vec<BoundaryCondition>,
    pub loads: Vec<Load<D>>,
    /// Viscous damping coefficient (1/s): adds −ρ·η·v to the force density.
    pub damping: f64,
}

impl<const D: usize> Loading<D> {
    /// Prescribes the half-step velocities (t = t_n + dt/2) of velocity conditions.
    pub fn apply_half_step_velocity(&self, state: &mut State<D>, t_half: f64) {
        for bc in self
            .conditions
            .iter()
            .filter(|c| c.kind == Kinematic::Velocity)
        {
            let f = bc.time.value(t_half);
            for (k, &i) in bc.nodes.iter().enumerate() {
                state.v[i as usize][bc.component] = bc.at(k, f);
            }
        }
    }

    /// After the drift to t: overwrites displacements of displacement conditions.
    pub fn apply_displacements(&self, body: &Body<D>, state: &mut State<D>, t: f64) {
        for bc in self
            .conditions
            .iter()
            .filter(|c| c.kind == Kinematic::Displacement)
        {
            let f = bc.time.value(t);
            for (k, &i) in bc.nodes.iter().enumerate() {
                let i = i as usize;
                let u = bc.at(k, f);
                state.u[i][bc.component] = u;
                state.current[i][bc.component] = body.positions[i][bc.component] + u;
            }
        }
    }

    /// At the end of a step (time t): sets the velocities of every constrained component.
    pub fn apply_end_velocities(&self, state: &mut State<D>, t: f64) {
        for bc in &self.conditions {
            let f = match bc.kind {
                Kinematic::Velocity => bc.time.value(t),
                Kinematic::Displacement => bc.time.rate(t),
            };
            for (k, &i) in bc.nodes.iter().enumerate() {
                state.v[i as usize][bc.component] = bc.at(k, f);
            }
        }
    }

    /// Fills `state.body_force` with the external body-force density at time t.
    pub fn body_forces(&self, state: &mut State<D>, t: f64) {
        for b in state.body_force.iter_mut() {
            *b = Vector::zeros();
        }
        for load in &self.loads {
            let f = load.density * load.time.value(t);
            for &i in &load.nodes {
                state.body_force[i as usize] += f;
            }
        }
    }

    /// A per-node, per-component mask of constrained degrees of freedom.
    pub fn constrained_mask(&self, n: usize) -> Vec<[bool; 3]> {
        let mut mask = vec![[false; 3]; n];
        for bc in &self.conditions {
            for &i in &bc.nodes {
                mask[i as usize][bc.component] = true;
            }
        }
        mask
    }
}

/// An initial velocity field on a node set: v(x) = value + gradient · (x − origin).
#[derive(Debug, Clone)]
pub struct InitialVelocity<const D: usize> {
    pub nodes: Vec<u32>,
    pub value: Vector<D>,
    pub gradient: nalgebra::SMatrix<f64, D, D>,
    pub origin: Vector<D>,
}

impl<const D: usize> InitialVelocity<D> {
    /// Sets the velocities of the set's nodes.
    pub fn apply(&self, body: &Body<D>, state: &mut State<D>) {
        for &i in &self.nodes {
            let i = i as usize;
            state.v[i] = self.value + self.gradient * (body.positions[i] - self.origin);
        }
    }
}
