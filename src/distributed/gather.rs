//! Output of a distributed run: when rank 0's observers want a step, every rank sends its
//! owned nodes' fields to rank 0, which fills a state of the whole body and hands the
//! observers that — the same view, and so the same files, as one process writes. Bonds stay
//! on their ranks: an observer that reads the broken bonds (`[analysis.crack_surface]`) gets
//! each rank's broken halves, gathered in rank order (the one-process node order). With
//! `[output] pieces = "per_rank"` each rank writes its owned nodes' snapshot piece itself, and
//! a step whose observers read no field (the `.pvtu` and `fields.pvd` only) gathers none.

use crate::analysis::BrokenHalf;
use crate::body::Body;
use crate::bonds::{Bonds, PartialVolume, Quadrature};
use crate::checkpoint::{write_section, Checkpoints, DriverState, Section, Sizes};
use crate::math::Vector;
use crate::observe::observer::Every;
use crate::observe::snapshots::{piece_name, NodeFields};
use crate::observe::{Observer, StepView};
use crate::run::{RunError, ViewSource};
use crate::solver::impactor::Impactor;
use crate::solver::ranks::{bytes_from_words, bytes_to_words, Ranks};
use crate::solver::Fields;
use crate::state::State;
use std::io::Write;
use std::path::PathBuf;
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
    /// With `[output] pieces = "per_rank"`: this rank's snapshot pieces.
    pieces: Option<PieceWriter>,
}

/// Writes a rank's piece of each snapshot, on the snapshots' schedule (`Snapshots::wants`).
pub struct PieceWriter {
    /// The results' `fields/` folder.
    pub dir: PathBuf,
    pub every: Every,
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
        Self::writing(ranks, owned, whole, None)
    }

    /// `new`, each rank writing its own snapshot pieces with `pieces`.
    pub fn writing(
        ranks: Arc<dyn Ranks>,
        owned: usize,
        whole: Option<(Body<D>, Vec<f64>)>,
        pieces: Option<PieceWriter>,
    ) -> Self {
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
        Gather {
            ranks,
            owned,
            root,
            pieces,
        }
    }

    /// Writes this rank's piece of the snapshot of `fields`' step, if one is due; every rank
    /// learns whether every piece was written (and so they all are before rank 0 writes the
    /// `.pvtu` that names them).
    fn write_piece(&self, fields: &dyn Fields<D>, wanted: bool) -> Result<(), RunError> {
        let Some(p) = &self.pieces else {
            return Ok(());
        };
        let step = fields.state().step;
        if !p.every.hits(step, wanted) {
            return Ok(());
        }
        let (body, state) = (fields.body(), fields.state());
        let (damage, energy) = (fields.damage(), fields.energy_density());
        let written = NodeFields::of(
            (&body.positions, &body.blocks),
            (&state.u, &state.v),
            (&damage, &energy),
            self.owned,
        )
        .write(&p.dir.join(piece_name(step, self.ranks.rank())));
        let failed = self.ranks.sum_u64(written.is_err() as u64);
        match written {
            Err(e) => Err(e.into()),
            Ok(()) if failed > 0 => Err(RunError::Distributed(format!(
                "{failed} rank(s) could not write their piece of the snapshot of step {step}"
            ))),
            Ok(()) => Ok(()),
        }
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
        self.write_piece(fields, wanted)?;
        let wanting = |read: fn(&dyn Observer<D>) -> bool| {
            observers
                .iter()
                .any(|o| o.wants(step, wanted) && read(o.as_ref()))
        };
        let (reads_bonds, reads_fields) = (
            wanting(|o| o.reads_broken_bonds()),
            wanting(|o| o.reads_fields()),
        );
        let halves = self
            .ranks
            .broadcast_bool(reads_bonds)
            .then(|| self.ranks.gather(&pack_halves(&fields.broken_halves())));
        let dissipation = fields.damage_dissipation();
        if self.ranks.broadcast_bool(reads_fields) {
            let (damage, energy) = (fields.damage(), fields.energy_density());
            let Some(all) = self.gather_nodes(state, &[&damage, &energy]) else {
                return Ok(());
            };
            let root = self.root.as_mut().expect("rank 0 keeps the whole body");
            for (i, w) in all.chunks_exact(words(D)).enumerate() {
                root.damage[i] = w[5 * D];
                root.energy[i] = w[5 * D + 1];
            }
        }
        // The observers that read no field read the step and time.
        let Some(root) = self.root.as_mut() else {
            return Ok(());
        };
        root.state.step_scalars_from(state);
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

    fn write_checkpoint(
        &mut self,
        checkpoints: &Checkpoints,
        state: &State<D>,
        driver: &DriverState<D>,
    ) -> Result<(), RunError> {
        let ranks = &*self.ranks;
        let sizes = self.whole_sizes(state, driver);
        let mut written = false;
        let result = match self.root {
            Some(_) => crate::checkpoint::write_with(
                &checkpoints.path,
                &checkpoints.origin,
                &sizes,
                state,
                driver,
                |w| {
                    written = true;
                    stream_sections(ranks, state, driver, self.owned, Some(w))
                },
            ),
            None => Ok(()),
        };
        // The other ranks' parts are taken even when rank 0 could not write them (no rank
        // waits for ever), and every rank learns the outcome.
        if !written {
            let _ = stream_sections::<D, std::io::Sink>(ranks, state, driver, self.owned, None);
        }
        let failed = result.as_ref().err().map(ToString::to_string);
        match (result, ranks.first_message(failed)) {
            (Err(e), _) => Err(e.into()),
            (Ok(()), Some(message)) => Err(RunError::Distributed(message)),
            (Ok(()), None) => Ok(()),
        }
    }
}

/// Each section of a checkpoint's arrays ([`Section::ALL`]) from every rank in rank order
/// into `w` on rank 0 (`None` on the others, and on rank 0 when its file could not be
/// opened): one rank's part at a time, so rank 0 holds one part, not the whole body's
/// arrays. The ranks' parts follow each other in the global order (a rank's rows and nodes
/// come after the ranks' before it). After a failed write the parts are still taken.
fn stream_sections<const D: usize, W: Write>(
    ranks: &dyn Ranks,
    state: &State<D>,
    driver: &DriverState<D>,
    owned: usize,
    mut w: Option<&mut W>,
) -> std::io::Result<()> {
    let mut failed = None;
    for section in Section::ALL {
        let mut part = Vec::new();
        write_section(section, state, driver, owned, &mut part)?;
        let words = bytes_to_words(&part);
        drop(part);
        ranks.gather_each(&words, &mut |words| {
            if let (Some(w), None) = (w.as_deref_mut(), &failed) {
                let (bytes, _) = bytes_from_words(words);
                if let Err(e) = w.write_all(&bytes) {
                    failed = Some(e);
                }
            }
        });
    }
    failed.map_or(Ok(()), Err)
}

impl<const D: usize> Gather<D> {
    /// The whole body's array sizes of a checkpoint from every rank's (every rank calls it):
    /// a rank's node arrays hold its ghosts too, its bond arrays only its rows.
    fn whole_sizes(&self, state: &State<D>, driver: &DriverState<D>) -> Sizes {
        let ranks = &*self.ranks;
        let local = Sizes::of(state, driver);
        let nodes = ranks.sum_u64(self.owned as u64) as usize;
        // Every rank keeps the previous evaluation and the predictor or none.
        let all_or_none = |n: usize| if n > 0 { nodes } else { 0 };
        Sizes {
            nodes,
            entries: ranks.sum_u64(local.entries as u64) as usize,
            history: ranks.sum_u64(local.history as u64) as usize,
            previous: all_or_none(local.previous),
            matrices: local.matrices / local.nodes.max(1) * nodes,
            predictor: all_or_none(local.predictor),
        }
    }

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
        s.step_scalars_from(state);
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
