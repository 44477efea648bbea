//! Explicit dynamics with velocity Verlet, the simulation bundle it advances, and the energy
//! bookkeeping (kinetic, strain, external work, viscous dissipation).

use super::contact::NodeContact;
use super::damage_cache::DamageCache;
use super::impactor::{Impactor, Impactors};
use super::ranks::{agreed_uniform, ordered_fold, ordered_sum, Share};
use super::ForceEngine;
use crate::analysis::BrokenHalf;
use crate::body::Body;
use crate::bonds::{Bonds, PartialVolume, Quadrature};
use crate::counters::Counters;
use crate::damage::Damage;
use crate::loading::Loading;
use crate::material::{Material, PointError};
use crate::math::Vector;
use crate::observe::crack_surface::broken_halves;
use crate::state::State;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// A run that cannot continue, with the diagnosis.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    #[error("the material cannot be set up on these bonds: {0}")]
    Setup(#[from] PointError),
    #[error("the run went unstable at step {step} (t = {time:e} s): {quantity} of node {node} at x = {position:?} is {value:.4e}; lower the time step (safety_factor) or check the loads{hint}")]
    Unstable {
        step: u64,
        time: f64,
        node: usize,
        position: Vec<f64>,
        quantity: &'static str,
        value: f64,
        /// What else to look at for this material (empty for central models).
        hint: &'static str,
    },
    /// A distributed run stopped: the message of the rank that diagnosed it.
    #[error("{0}")]
    OnAnotherRank(String),
    #[error(
        "the quasi-static solver did not converge in load step {step} (load time {time:e}): {what}"
    )]
    NotConverged { step: u64, time: f64, what: String },
}

/// The instability hint of a model with non-central force states: a damaged correspondence
/// family stiffens past the intact body's stable step (docs/models.md).
const NON_CENTRAL_HINT: &str = "; a correspondence node that lost many bonds is stiffer than the intact body (docs/models.md, \"Time step and energy under heavy damage\"): a smaller safety_factor may be needed";

/// Everything a run needs, with public fields (the reference data is not to be changed once
/// the run has started).
pub struct Simulation<const D: usize, M: Material<D>> {
    pub body: Body<D>,
    pub bonds: Bonds,
    pub engine: ForceEngine<D, M>,
    pub loading: Loading<D>,
    pub state: State<D>,
    /// Time step in use (s).
    pub dt: f64,
    /// Silling–Askari stable time step estimate (s).
    pub dt_stable: f64,
    /// Mass density of each node (kg/m³).
    pub densities: Vec<f64>,
    pub counters: Counters,
    /// Node–node contact (`None`: off, at no cost).
    pub contact: Option<NodeContact<D>>,
    /// Rigid impactors (empty: none).
    pub impactors: Impactors<D>,
    /// Constrained (node, component) pairs, and the same as a per-node mask.
    constrained: Vec<(usize, usize)>,
    pub(super) constrained_mask: Vec<[bool; 3]>,
    /// This process's share of a distributed run (`None`: the whole body, one process).
    pub share: Option<Arc<Share>>,
    /// The damage observers last read, kept to compute again only where bonds broke.
    damage_seen: DamageCache,
}

impl<const D: usize, M: Material<D>> Simulation<D, M> {
    /// Builds the force engine, evaluates the initial forces and the stable time step.
    /// `dt = None` uses `safety_factor × dt_stable`. Fails when the material cannot be set up
    /// on these families (e.g. a correspondence node without enough bonds).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        body: Body<D>,
        bonds: Bonds,
        material: M,
        damage: impl Into<Damage>,
        rule: PartialVolume,
        loading: Loading<D>,
        dt: Option<f64>,
        safety_factor: f64,
    ) -> Result<Self, StepError> {
        Self::new_shared(
            body,
            bonds,
            material,
            damage,
            rule,
            loading,
            (dt, safety_factor),
            None,
        )
    }

    /// `new` for one rank's `share` of a distributed run (`body` and `bonds` its owned nodes
    /// and ghosts, `solver::ranks`): the stable time step is the smallest over every rank.
    #[allow(clippy::too_many_arguments)]
    pub fn new_shared(
        body: Body<D>,
        bonds: Bonds,
        material: M,
        damage: impl Into<Damage>,
        rule: PartialVolume,
        loading: Loading<D>,
        (dt, safety_factor): (Option<f64>, f64),
        share: Option<Share>,
    ) -> Result<Self, StepError> {
        let damage = damage.into();
        let history_words = damage.history_words(crate::solver::bond_force::<D, M>());
        let keep_previous = damage.records_work() && !M::CENTRAL;
        let splits_work = damage.splits_work(crate::solver::bond_force::<D, M>());
        let share = share.map(Arc::new);
        let quad = Quadrature::for_body_agreed(rule, &body, &bonds, |uniform| match &share {
            None => uniform,
            Some(s) => agreed_uniform(&*s.ranks, uniform),
        });
        let owned = share.as_ref().map_or(body.len(), |s| s.owned);
        let mut engine =
            ForceEngine::with_quadrature(material, damage, &body, &bonds, quad, owned)?;
        if let Some(s) = &share {
            // Before anything reads them (the stable step reads a ghost's micromodulus).
            engine.material.share_constants(s);
        }
        let mut dt_stable = engine.stable_time_step(&body, &bonds);
        if let Some(s) = &share {
            // A ghost has no family here (infinite step): the owners' count.
            dt_stable = s.ranks.min_f64(dt_stable);
            engine.share = Some(s.clone());
        }
        let densities = (0..body.len())
            .map(|i| engine.material.density(i))
            .collect();
        let (constrained, mask) = constraints(&loading, body.len(), owned);
        let mut state = State::new(&body, &bonds, history_words);
        if keep_previous {
            state.previous = state.current.clone();
        }
        if splits_work {
            // As the vector work record: the first evaluation's work starts from the
            // unloaded bond, T_prev = 0 (zero matrices; η' = 0 at the reference positions).
            state.previous_matrices = vec![0.0; body.len() * M::NODE_MATRIX_WORDS];
        }
        let mut sim = Simulation {
            body,
            bonds,
            engine,
            loading,
            state,
            dt: dt.unwrap_or(safety_factor * dt_stable),
            dt_stable,
            densities,
            counters: Counters::default(),
            contact: None,
            impactors: Impactors::default(),
            constrained,
            constrained_mask: mask,
            share,
            damage_seen: DamageCache::default(),
        };
        sim.loading
            .apply_displacements(&sim.body, &mut sim.state, 0.0);
        sim.loading.apply_end_velocities(&mut sim.state, 0.0);
        sim.refresh_forces()?;
        Ok(sim)
    }

    /// Takes `loading` without applying it: for a state that already has it applied (one
    /// restored from a checkpoint).
    pub fn replace_loading(&mut self, loading: Loading<D>) {
        (self.constrained, self.constrained_mask) =
            constraints(&loading, self.body.len(), self.owned());
        self.loading = loading;
    }

    /// Switches to another set of boundary conditions and loads (a new stage): the
    /// constrained components are those of `loading`, its displacements and velocities are
    /// applied at the current time, and the forces are evaluated again (bonds past their limit
    /// break here, e.g. when a stage lifts a no-fail set). Returns the bond halves broken.
    pub fn set_loading(&mut self, loading: Loading<D>) -> Result<u64, StepError> {
        self.replace_loading(loading);
        let t = self.state.time;
        self.loading
            .apply_displacements(&self.body, &mut self.state, t);
        self.loading.apply_end_velocities(&mut self.state, t);
        self.refresh_forces()
    }

    /// The nodes this process owns: local 0..owned (all, in one process).
    pub fn owned(&self) -> usize {
        self.share.as_deref().map_or(self.body.len(), |s| s.owned)
    }

    /// A distributed run's ghosts take their owners' displacements, velocities and
    /// positions (before a force evaluation reads them).
    fn exchange_ghosts(&mut self) {
        if let Some(s) = &self.share {
            s.halo.exchange(&*s.ranks, &mut self.state);
        }
    }

    /// v += dt/2 · a with a = (f + b)/ρ − η v, in parallel (each node on its own).
    fn half_kick(&mut self) {
        let (half, eta) = (0.5 * self.dt, self.loading.damping);
        let s = &mut self.state;
        (&mut s.v, &s.force, &s.body_force, &self.densities)
            .into_par_iter()
            .with_min_len(4096)
            .for_each(|(v, f, b, &rho)| {
                let a = (f + b) / rho - *v * eta;
                *v += a * half;
            });
    }

    /// Viscous power Σ ρ V η |v|², summed in a fixed order (deterministic for any thread count).
    fn viscous_power(&self) -> f64 {
        let owned = self.owned();
        let terms = self.state.v[..owned]
            .iter()
            .zip(&self.body.volumes)
            .zip(&self.densities)
            .map(|((v, vol), rho)| rho * vol * self.loading.damping * v.norm_squared());
        ordered_sum(self.share.as_deref(), terms)
    }

    /// Re-evaluates forces (and body forces) at the current state; call it after changing
    /// `state.u` by hand (an initial displacement field) so the next step starts consistent.
    /// Returns the bond halves broken.
    pub fn refresh_forces(&mut self) -> Result<u64, StepError> {
        self.exchange_ghosts();
        let broken = self
            .engine
            .compute(&self.body, &self.bonds, &mut self.state);
        let t = self.state.time;
        self.loading.body_forces(&mut self.state, t);
        self.add_contact_forces();
        Ok(broken)
    }

    /// Adds the node–node contact and impactor forces to the internal force densities.
    fn add_contact_forces(&mut self) {
        if let Some(c) = &mut self.contact {
            c.add_forces(
                &self.body,
                &self.bonds,
                &mut self.state,
                self.share.as_deref(),
            );
        }
        if !self.impactors.is_empty() {
            self.impactors
                .add_forces(&self.body, &mut self.state, self.share.as_deref());
        }
    }

    /// One velocity-Verlet step: half-kick → prescribed velocities → drift → prescribed
    /// displacements → forces → half-kick → end-of-step velocities.
    pub fn step(&mut self) -> Result<u64, StepError> {
        let dt = self.dt;
        let t0 = self.state.time;
        let t1 = t0 + dt;
        let started = Instant::now();

        // Constrained degrees of freedom: remember (u, v, V(f+b)) to book the work the
        // constraints do over the step (trapezoidal rule).
        let before: Vec<(f64, f64, f64)> = self
            .constrained
            .iter()
            .map(|&(i, k)| {
                (
                    self.state.u[i][k],
                    self.state.v[i][k],
                    self.body.volumes[i] * (self.state.force[i][k] + self.state.body_force[i][k]),
                )
            })
            .collect();
        let u_old_free_work = self.body_force_power_start();

        self.half_kick();
        self.impactors.begin_step(dt);
        self.loading
            .apply_half_step_velocity(&mut self.state, t0 + 0.5 * dt);
        let dissipated = if self.loading.damping > 0.0 {
            self.viscous_power() * dt
        } else {
            0.0
        };
        let positions = &self.body.positions;
        (&mut self.state.u, &mut self.state.current, &self.state.v)
            .into_par_iter()
            .zip(positions.par_iter())
            .with_min_len(4096)
            .for_each(|((u, y, v), x)| {
                *u += v * dt;
                *y = x + *u;
            });
        self.loading
            .apply_displacements(&self.body, &mut self.state, t1);
        self.exchange_ghosts();
        self.counters.integrate += started.elapsed();

        let started = Instant::now();
        let broken =
            self.engine
                .compute_in_step(&self.body, &self.bonds, &mut self.state, 0.5 * dt);
        self.loading.body_forces(&mut self.state, t1);
        self.add_contact_forces();
        self.counters.force += started.elapsed();

        let started = Instant::now();
        self.half_kick();
        self.loading.apply_end_velocities(&mut self.state, t1);

        // Work of the constraints: ΔKE of the dof minus the work of the other forces on it.
        let work = self.body_force_work(&u_old_free_work) + self.impactors.end_step(dt);
        let terms = self
            .constrained
            .iter()
            .zip(&before)
            .map(|(&(i, k), &(u0, v0, f0))| {
                let (u1, v1) = (self.state.u[i][k], self.state.v[i][k]);
                let f1 =
                    self.body.volumes[i] * (self.state.force[i][k] + self.state.body_force[i][k]);
                0.5 * self.densities[i] * self.body.volumes[i] * (v1 * v1 - v0 * v0)
                    - 0.5 * (f0 + f1) * (u1 - u0)
            });
        let work = ordered_fold(self.share.as_deref(), work, terms);
        self.state.external_work += work;
        self.state.dissipated_viscous += dissipated;
        self.state.time = t1;
        self.state.step += 1;
        self.state.dt = dt;
        self.state.iterations = 1;
        self.counters.integrate += started.elapsed();
        self.counters.steps += 1;
        self.counters.bonds_broken += broken;
        Ok(broken)
    }

    /// Body-force densities and displacements of loaded free nodes at the start of a step.
    fn body_force_power_start(&self) -> Vec<(Vector<D>, Vector<D>)> {
        if self.loading.loads.is_empty() {
            return Vec::new();
        }
        (0..self.body.len())
            .map(|i| (self.state.body_force[i], self.state.u[i]))
            .collect()
    }

    /// Work of body forces over the step on unconstrained components (trapezoidal rule).
    fn body_force_work(&self, start: &[(Vector<D>, Vector<D>)]) -> f64 {
        if start.is_empty() {
            return 0.0;
        }
        let mask = &self.constrained_mask;
        let terms = start[..self.owned()]
            .iter()
            .enumerate()
            .flat_map(|(i, (b0, u0))| {
                (0..D).filter(move |&k| !mask[i][k]).map(move |k| {
                    self.body.volumes[i]
                        * 0.5
                        * (b0[k] + self.state.body_force[i][k])
                        * (self.state.u[i][k] - u0[k])
                })
            });
        ordered_fold(self.share.as_deref(), 0.0, terms)
    }

    /// Checks every node for a non-finite displacement, velocity or force; names the first.
    pub fn check_finite(&self) -> Result<(), StepError> {
        let found = self.first_non_finite();
        match &self.share {
            None => found,
            // Every rank stops, with the first node of the lowest rank that found one.
            Some(s) => match s.ranks.first_message(found.err().map(|e| e.to_string())) {
                None => Ok(()),
                Some(message) => Err(StepError::OnAnotherRank(message)),
            },
        }
    }

    fn first_non_finite(&self) -> Result<(), StepError> {
        let first = self.share.as_deref().map_or(0, |s| s.first);
        for i in 0..self.owned() {
            for (quantity, v) in [
                ("displacement", &self.state.u[i]),
                ("velocity", &self.state.v[i]),
                ("force density", &self.state.force[i]),
            ] {
                if let Some(&value) = v.iter().find(|x| !x.is_finite()) {
                    return Err(StepError::Unstable {
                        step: self.state.step,
                        time: self.state.time,
                        node: first + i,
                        position: self.body.positions[i].iter().cloned().collect(),
                        quantity,
                        value,
                        hint: Self::instability_hint(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Stops a run whose kinetic energy has grown past ten times the energy it was given:
    /// `start` = (kinetic + strain energy, external work) when the loop started, so the energy
    /// given is the first plus the work done since. Energy from nowhere is an instability,
    /// caught long before it overflows into NaN. Names the node with the largest kinetic
    /// energy. A body given no energy is not checked.
    pub fn check_energy(&self, start: (f64, f64)) -> Result<(), StepError> {
        let given = start.0 + (self.state.external_work - start.1).abs();
        if given <= 0.0 {
            return Ok(());
        }
        let kinetic = self.kinetic_energy();
        if kinetic <= 10.0 * given {
            return Ok(());
        }
        let node_energy =
            |i: usize| self.densities[i] * self.body.volumes[i] * self.state.v[i].norm_squared();
        let node = (0..self.owned())
            .max_by(|&a, &b| node_energy(a).total_cmp(&node_energy(b)))
            .unwrap_or(0);
        if let Some(s) = &self.share {
            // The node of the rank with the largest (the last such rank on a tie, as
            // `max_by` picks the last).
            let top = s.ranks.max_f64(node_energy(node));
            let mine = (node_energy(node) == top).then_some(s.ranks.rank());
            let last = s.ranks.max_f64(mine.map_or(-1.0, |r| r as f64));
            let message = (mine == Some(last as usize))
                .then(|| self.unstable_speed(s.first + node, node).to_string());
            let message = s.ranks.first_message(message).unwrap_or_default();
            return Err(StepError::OnAnotherRank(message));
        }
        Err(self.unstable_speed(node, node))
    }

    /// The instability of a node (global index `node`, local `i`) faster than the energy put
    /// in allows.
    fn unstable_speed(&self, node: usize, i: usize) -> StepError {
        StepError::Unstable {
            step: self.state.step,
            time: self.state.time,
            node,
            position: self.body.positions[i].iter().cloned().collect(),
            quantity:
                "speed (m/s; the body's kinetic energy is more than ten times the energy put in)",
            value: self.state.v[i].norm(),
            hint: Self::instability_hint(),
        }
    }

    fn instability_hint() -> &'static str {
        if M::CENTRAL {
            ""
        } else {
            NON_CENTRAL_HINT
        }
    }

    /// Kinetic energy (J).
    pub fn kinetic_energy(&self) -> f64 {
        match &self.share {
            None => self.state.kinetic_energy(&self.body, &self.densities),
            Some(s) => {
                let terms = (0..s.owned).map(|i| {
                    0.5 * self.densities[i] * self.body.volumes[i] * self.state.v[i].norm_squared()
                });
                ordered_sum(Some(s), terms)
            }
        }
    }

    /// Strain energy (J).
    pub fn strain_energy(&self) -> f64 {
        match &self.share {
            None => self
                .engine
                .strain_energy(&self.body, &self.bonds, &self.state),
            Some(s) => {
                let w = self
                    .engine
                    .energy_density(&self.body, &self.bonds, &self.state);
                let terms = (0..s.owned).map(|i| w[i] * self.body.volumes[i]);
                ordered_sum(Some(s), terms)
            }
        }
    }

    /// External force (N) that holds a node set: −Σ_i V_i f_int,i over the set.
    pub fn reaction(&self, nodes: &[u32]) -> Vector<D> {
        -nodes
            .iter()
            .map(|&i| self.state.force[i as usize] * self.body.volumes[i as usize])
            .fold(Vector::zeros(), |a, b| a + b)
    }
}

/// The constrained (node, component) pairs of a loading, and the same as a per-node mask.
fn constraints<const D: usize>(
    loading: &Loading<D>,
    n: usize,
    owned: usize,
) -> (Vec<(usize, usize)>, Vec<[bool; 3]>) {
    let mask = loading.constrained_mask(n);
    // A ghost's constraint is its owner's to book.
    let pairs = (0..owned)
        .flat_map(|i| (0..D).map(move |k| (i, k)))
        .filter(|&(i, k)| mask[i][k])
        .collect();
    (pairs, mask)
}

/// What observers may read of a simulation, whatever its material.
pub trait Fields<const D: usize> {
    fn body(&self) -> &Body<D>;
    fn state(&self) -> &State<D>;
    /// The bond families (topology and reference lengths).
    fn bonds(&self) -> &Bonds;
    /// The partial-volume weights of the bonds.
    fn quadrature(&self) -> &Quadrature;
    /// Damage index per node.
    fn damage(&self) -> Vec<f64>;
    /// Strain energy density per node (J/m³).
    fn energy_density(&self) -> Vec<f64>;
    /// Kinetic energy (J).
    fn kinetic_energy(&self) -> f64;
    /// Energy dissipated by damage since the start (J).
    fn damage_dissipation(&self) -> f64;
    /// External force (N) that holds a node set.
    fn reaction(&self, nodes: &[u32]) -> Vector<D>;
    /// Whether the run has node–node contact or impactors (their history columns).
    fn has_contact(&self) -> bool {
        false
    }
    /// Contact potential energy (J): node–node pairs plus the impactors' penalty.
    fn contact_energy(&self) -> f64 {
        0.0
    }
    /// Kinetic energy of the free impactors (J).
    fn impactor_kinetic_energy(&self) -> f64 {
        0.0
    }
    /// The impactors and their state.
    fn impactors(&self) -> &[Impactor<D>] {
        &[]
    }
    /// The broken halves of the bonds, in node then bond order
    /// (`observe::crack_surface::broken_halves`).
    fn broken_halves(&self) -> Vec<BrokenHalf<D>> {
        let bonds = self.bonds();
        broken_halves(
            self.body(),
            &bonds.offsets,
            &bonds.neighbors,
            self.quadrature(),
            &self.state().status,
        )
    }
}

impl<const D: usize, M: Material<D>> Fields<D> for Simulation<D, M> {
    fn body(&self) -> &Body<D> {
        &self.body
    }
    fn state(&self) -> &State<D> {
        &self.state
    }
    fn bonds(&self) -> &Bonds {
        &self.bonds
    }
    fn quadrature(&self) -> &Quadrature {
        &self.engine.quad
    }
    fn damage(&self) -> Vec<f64> {
        self.damage_seen
            .damage(&self.engine, &self.body, &self.bonds, &self.state)
    }
    fn energy_density(&self) -> Vec<f64> {
        self.engine
            .energy_density(&self.body, &self.bonds, &self.state)
    }
    fn damage_dissipation(&self) -> f64 {
        self.engine
            .dissipated_energy(&self.body, &self.bonds, &self.state)
    }
    fn kinetic_energy(&self) -> f64 {
        Simulation::kinetic_energy(self)
    }
    fn reaction(&self, nodes: &[u32]) -> Vector<D> {
        Simulation::reaction(self, nodes)
    }
    fn has_contact(&self) -> bool {
        self.contact.is_some() || !self.impactors.is_empty()
    }
    fn contact_energy(&self) -> f64 {
        self.contact.as_ref().map_or(0.0, |c| c.energy) + self.impactors.energy()
    }
    fn impactor_kinetic_energy(&self) -> f64 {
        self.impactors.kinetic_energy()
    }
    fn impactors(&self) -> &[Impactor<D>] {
        &self.impactors.list
    }
}
