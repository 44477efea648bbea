//! Output of a distributed run: when rank 0's observers want a step, every rank sends its
//! owned nodes' fields to rank 0, which fills a state of the whole body and hands the
//! observers that — the same view, and so the same files, as one process writes. Bonds stay
//! on their ranks: an observer that reads the broken bonds (`[analysis.crack_surface]`) gets
//! each rank's broken halves, gathered in rank order (the one-process node order).

use crate::analysis::BrokenHalf;
use crate::body::Body;
use crate::bonds::{Bonds, PartialVolume, Quadrature};
use crate::checkpoint::DriverState;
use crate::math::Vector;
use crate::observe::{Observer, StepView};
use crate::run::{RunError, ViewSource};
use crate::solver::impactor::Impactor;
use crate::solver::ranks::Ranks;
use crate::solver::Fields;
use crate::state::State;
use std::sync::Arc;

/// Per node: u, v, current position, force and body force (D each), damage, energy density.
const fn words(d: usize) -> usize {
    5 * d + 2
}

/// Gathers the fields to rank 0 for its observers.
pub struct Gather<const D: usize> {
    ranks: Arc<dyn Ranks>,
    owned: usize,
    /// Rank 0's whole-body fields.
    root: Option<Root<D>>,
}

/// The whole body's fields on rank 0, as the observers read them.
struct Root<const D: usize> {
    body: Body<D>,
    densities: Vec<f64>,
    state: State<D>,
    bonds: Bonds,
    quad: Quadrature,
    damage: Vec<f64>,
    energy: Vec<f64>,
    dissipation: f64,
    /// What every rank holds alike: contact's and the impactors' (`Fields`).
    contact: Contact<D>,
    /// The broken halves of every rank's rows, in global order (gathered when an observer
    /// reads them).
    halves: Vec<BrokenHalf<D>>,
}

/// Contact's energy and the impactors, the same on every rank (their sums run over every
/// rank's nodes): rank 0 hands its own.
#[derive(Default)]
struct Contact<const D: usize> {
    on: bool,
    energy: f64,
    impactor_kinetic_energy: f64,
    impactors: Vec<Impactor<D>>,
}

impl<const D: usize> Gather<D> {
    /// `whole`: on rank 0, the whole body and every node's density; `owned`: this rank's
    /// owned nodes.
    pub fn new(ranks: Arc<dyn Ranks>, owned: usize, whole: Option<(Body<D>, Vec<f64>)>) -> Self {
        let root = whole.map(|(body, densities)| {
            let n = body.len();
            let bonds = Bonds {
                offsets: vec![0; n + 1],
                ..Default::default()
            };
            let mut state = State::new(&body, &bonds, 0);
            state.current = body.positions.clone();
            Root {
                quad: Quadrature::new(PartialVolume::None, &[], &[], &[]),
                bonds,
                state,
                densities,
                damage: vec![0.0; n],
                energy: vec![0.0; n],
                dissipation: 0.0,
                contact: Contact::default(),
                halves: Vec::new(),
                body,
            }
        });
        Gather { ranks, owned, root }
    }
}

impl<const D: usize> ViewSource<D> for Gather<D> {
    fn offer(
        &mut self,
        fields: &dyn Fields<D>,
        observers: &mut [Box<dyn Observer<D>>],
        last: bool,
        stage_end: bool,
    ) -> Result<(), RunError> {
        let state = fields.state();
        let step = state.step;
        let wanted = last || stage_end;
        let want = observers.iter().any(|o| o.wants(step, wanted));
        if !self.ranks.broadcast_bool(want) {
            return Ok(());
        }
        let reads_bonds = observers
            .iter()
            .any(|o| o.wants(step, wanted) && o.reads_broken_bonds());
        let halves = self
            .ranks
            .broadcast_bool(reads_bonds)
            .then(|| self.ranks.gather(&pack_halves(&fields.broken_halves())));
        let (damage, energy) = (fields.damage(), fields.energy_density());
        let dissipation = fields.damage_dissipation();
        let Some(all) = self.gather_nodes(state, &[&damage, &energy]) else {
            return Ok(());
        };
        let root = self.root.as_mut().expect("rank 0 keeps the whole body");
        for (i, w) in all.chunks_exact(words(D)).enumerate() {
            root.damage[i] = w[5 * D];
            root.energy[i] = w[5 * D + 1];
        }
        root.dissipation = dissipation;
        if let Some(words) = halves.flatten() {
            root.halves = unpack_halves(&words);
        }
        root.contact = Contact {
            on: fields.has_contact(),
            energy: fields.contact_energy(),
            impactor_kinetic_energy: fields.impactor_kinetic_energy(),
            impactors: fields.impactors().to_vec(),
        };
        let view = StepView::new(&*root as &dyn Fields<D>, last);
        for o in observers.iter_mut() {
            if o.wants(step, wanted) {
                o.observe(&view)?;
            }
        }
        Ok(())
    }

    fn whole_state(&mut self, state: &State<D>) -> Option<&State<D>> {
        // The bond entries of the owned rows are all of this rank's (a ghost has none), and
        // the ranks' rows follow each other in the global order.
        let status: Vec<f64> = state.status.iter().map(|&b| b as f64).collect();
        let status = self.ranks.gather(&status);
        let history = self.ranks.gather(&state.history);
        // A non-central model under a critical energy: each owned node's position and
        // own-half matrices at the previous evaluation (every rank keeps them or none).
        let nodes = state.u.len();
        let previous: Vec<f64> = state.previous[..self.owned.min(state.previous.len())]
            .iter()
            .flat_map(|v| v.iter().copied())
            .collect();
        let previous = (!state.previous.is_empty()).then(|| self.ranks.gather(&previous));
        let words = state.previous_matrices.len() / nodes.max(1);
        let matrices = (words > 0).then(|| {
            self.ranks
                .gather(&state.previous_matrices[..self.owned * words])
        });
        self.gather_nodes(state, &[])?;
        let root = self.root.as_mut()?;
        root.state.status = status?.into_iter().map(|b| b as u8).collect();
        root.state.history = history?;
        if let Some(previous) = previous.flatten() {
            root.state.previous = previous
                .chunks_exact(D)
                .map(Vector::<D>::from_column_slice)
                .collect();
        }
        if let Some(matrices) = matrices.flatten() {
            root.state.previous_matrices = matrices;
        }
        Some(&root.state)
    }

    fn whole_driver(&mut self, mut driver: DriverState<D>) -> DriverState<D> {
        // The displacements at the start of the quasi-static solver's last committed step
        // (its predictor's), of every node in the global order.
        let previous = driver
            .quasi_static
            .as_mut()
            .and_then(|m| m.previous.as_mut());
        if let Some((_, u)) = previous {
            let local: Vec<f64> = u[..self.owned]
                .iter()
                .flat_map(|v| v.iter().copied())
                .collect();
            if let Some(all) = self.ranks.gather(&local) {
                *u = all
                    .chunks_exact(D)
                    .map(Vector::<D>::from_column_slice)
                    .collect();
            }
        }
        driver
    }
}

impl<const D: usize> Gather<D> {
    /// Every rank's owned nodes' u, v, y, f, b (and `extra` words) into rank 0's whole
    /// state; the gathered words on rank 0.
    fn gather_nodes(&mut self, state: &State<D>, extra: &[&[f64]]) -> Option<Vec<f64>> {
        let per_node = 5 * D + extra.len();
        let mut buf = Vec::with_capacity(self.owned * per_node);
        for i in 0..self.owned {
            for v in [
                &state.u[i],
                &state.v[i],
                &state.current[i],
                &state.force[i],
                &state.body_force[i],
            ] {
                buf.extend_from_slice(v.as_slice());
            }
            buf.extend(extra.iter().map(|e| e[i]));
        }
        let all = self.ranks.gather(&buf)?;
        let root = self.root.as_mut().expect("rank 0 keeps the whole body");
        let s = &mut root.state;
        for (i, w) in all.chunks_exact(per_node).enumerate() {
            let v = |k: usize| Vector::<D>::from_column_slice(&w[k * D..(k + 1) * D]);
            (s.u[i], s.v[i], s.current[i], s.force[i], s.body_force[i]) =
                (v(0), v(1), v(2), v(3), v(4));
        }
        s.time = state.time;
        s.step = state.step;
        s.broken = state.broken;
        s.external_work = state.external_work;
        s.dissipated_viscous = state.dissipated_viscous;
        s.dissipated_damage = state.dissipated_damage;
        s.dt = state.dt;
        s.iterations = state.iterations;
        Some(all)
    }
}

/// Broken halves as words: x_i, x_j (D each), the weight, the horizon.
fn pack_halves<const D: usize>(halves: &[BrokenHalf<D>]) -> Vec<f64> {
    let mut buf = Vec::with_capacity(halves.len() * (2 * D + 2));
    for h in halves {
        buf.extend_from_slice(h.owner.as_slice());
        buf.extend_from_slice(h.neighbour.as_slice());
        buf.extend([h.weight, h.horizon]);
    }
    buf
}

fn unpack_halves<const D: usize>(words: &[f64]) -> Vec<BrokenHalf<D>> {
    words
        .chunks_exact(2 * D + 2)
        .map(|w| BrokenHalf {
            owner: Vector::<D>::from_column_slice(&w[..D]),
            neighbour: Vector::<D>::from_column_slice(&w[D..2 * D]),
            weight: w[2 * D],
            horizon: w[2 * D + 1],
        })
        .collect()
}

impl<const D: usize> Fields<D> for Root<D> {
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
        &self.quad
    }
    fn damage(&self) -> Vec<f64> {
        self.damage.clone()
    }
    fn energy_density(&self) -> Vec<f64> {
        self.energy.clone()
    }
    fn kinetic_energy(&self) -> f64 {
        self.state.kinetic_energy(&self.body, &self.densities)
    }
    fn damage_dissipation(&self) -> f64 {
        self.dissipation
    }
    /// As `Simulation::reaction`, over the gathered forces.
    fn reaction(&self, nodes: &[u32]) -> Vector<D> {
        -nodes
            .iter()
            .map(|&i| self.state.force[i as usize] * self.body.volumes[i as usize])
            .fold(Vector::zeros(), |a, b| a + b)
    }
    fn has_contact(&self) -> bool {
        self.contact.on
    }
    fn contact_energy(&self) -> f64 {
        self.contact.energy
    }
    fn impactor_kinetic_energy(&self) -> f64 {
        self.contact.impactor_kinetic_energy
    }
    fn impactors(&self) -> &[Impactor<D>] {
        &self.contact.impactors
    }
    fn broken_halves(&self) -> Vec<BrokenHalf<D>> {
        self.halves.clone()
    }
}
