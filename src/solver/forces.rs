//! The bond loops. Written once, generic over the material and the damage law; everything
//! inside is monomorphised, with no allocation, hashing or dynamic dispatch per bond.
//!
//! Parallelism is gather-style over node chunks: each node sums its own family in a fixed
//! order, so results are bitwise identical for any number of threads. A bond's two entries
//! (i→j in i's row, j→i in j's) are updated by their own rows from the same numbers, so they
//! always agree.

use super::cross_bonds::{CrossBonds, RemoteWords};
use super::dissipation::DissipationTracker;
use super::ranks::{ordered_sum, Share};
use crate::body::Body;
use crate::bonds::partial_volume::{NodeWeight, UniformWeights};
use crate::bonds::{Bonds, PartialVolume, Quadrature};
use crate::damage::critical_stretch::UniformCriticalStretch;
use crate::damage::mixed::MixedLaws;
use crate::damage::{
    BondForce, Damage, DamageLaw, MixedDamage, PerNode, Stretch, Work, BROKEN, INTACT,
    OTHER_BROKEN, OWN_BROKEN,
};
use crate::material::simd::{self, NodeBonds};
use crate::material::simd_nodes::{CriticalStretches, NodeConstants};
use crate::material::{BondGeom, Material, PointError};
use crate::math::{to3, Vector};
use crate::state::State;
use rayon::prelude::*;
use std::ops::Range;

/// Nodes per parallel work unit.
pub const NODE_CHUNK: usize = 256;

/// Force evaluation for one material and damage law over one body: owns the material, the
/// damage law, the quadrature weights and the per-node pre-pass buffer.
pub struct ForceEngine<const D: usize, M: Material<D>> {
    pub material: M,
    pub damage: Damage,
    pub quad: Quadrature,
    /// Use the models' AVX2 kernels where they apply (uniform grid, one uniform damage law
    /// a kernel implements, x86-64 with AVX2).
    pub vector_kernels: bool,
    /// Every neighbour index is a node of the body (checked once; the kernel relies on it).
    neighbors_in_bounds: bool,
    points: Vec<M::Point>,
    chunks: Vec<Range<usize>>,
    /// Books the strain energy each evaluation's damage releases (`state.dissipated_damage`).
    dissipation: DissipationTracker,
    /// Own halves the last evaluation broke in each node chunk.
    broke_in_chunk: Vec<u64>,
    /// Mid-step positions of the booking (reused buffer).
    mid_step: Vec<Vector<D>>,
    /// This process's share of a distributed run (`solver::ranks`): the ghosts' point states
    /// come from their owners, the halves broken and the energy released are summed over
    /// every rank.
    pub share: Option<std::sync::Arc<Share>>,
    /// A distributed run's bonds across ranks, paired when a law first reads both entries.
    cross_bonds: std::sync::OnceLock<CrossBonds>,
    /// Every node is no-fail on every rank (a quasi-static relaxation): nothing breaks, and
    /// the ranks skip summing the halves broken.
    pub all_protected: bool,
}

/// Where the bond loop gets quadrature weights: per node in general, from constants on a
/// uniform grid (one monomorphised loop each, written once).
trait Weights: Sync {
    /// (φ_ij, φ_ji, V_j) of bond b = i→j of reference length `ref_len`.
    fn weights(&self, b: usize, i: usize, j: usize, ref_len: f64) -> (f64, f64, f64);

    /// The rule and every node's cell, when the weights come from them alone (not from a
    /// constant, not from stored fractions): what the per-node kernels gather.
    fn node_weights(&self) -> Option<(PartialVolume, &[NodeWeight])> {
        None
    }
}

impl Weights for Quadrature {
    #[inline(always)]
    fn weights(&self, b: usize, i: usize, j: usize, ref_len: f64) -> (f64, f64, f64) {
        let (phi_ij, phi_ji) = self.phi_pair(b, i, j, ref_len);
        (phi_ij, phi_ji, self.nodes[j].volume)
    }

    fn node_weights(&self) -> Option<(PartialVolume, &[NodeWeight])> {
        (self.rule != PartialVolume::Exact).then_some((self.rule, &self.nodes[..]))
    }
}

impl Weights for UniformWeights {
    #[inline(always)]
    fn weights(&self, _b: usize, _i: usize, _j: usize, ref_len: f64) -> (f64, f64, f64) {
        let phi = self.phi(ref_len);
        (phi, phi, self.node.volume)
    }
}

/// What a bond loop reads besides the families.
struct Sweep<'a, const D: usize, W: Weights, Dm: DamageLaw> {
    current: &'a [Vector<D>],
    positions: &'a [Vector<D>],
    no_fail: &'a [bool],
    weights: &'a W,
    damage: &'a Dm,
    bonds: &'a Bonds,
}

/// One bond entry handed to a sweep's body: its geometry and its mutable damage record.
struct Visit<'a, const D: usize> {
    j: usize,
    geom: BondGeom<D>,
    status: &'a mut u8,
    history: &'a mut [f64],
    /// An end is in a no-fail set (evaluated only for laws that decide on work).
    protected: bool,
}

impl<const D: usize, W: Weights, Dm: DamageLaw> Sweep<'_, D, W, Dm> {
    /// Walks node i's family (entries `r`, with their status bytes and history words):
    /// skips fully broken bonds, lets the damage law decide from the stretch when `decide`,
    /// and calls `f` for every bond that still carries force. Returns the own halves broken.
    #[inline(always)]
    fn walk<M: Material<D>>(
        &self,
        i: usize,
        r: Range<usize>,
        status: &mut [u8],
        history: &mut [f64],
        decide: bool,
        mut f: impl FnMut(Visit<D>) -> u64,
    ) -> u64 {
        // Everything the loop reads, in locals (the compiler keeps them in registers).
        let (current, positions, no_fail, weights, damage) = (
            self.current,
            self.positions,
            self.no_fail,
            self.weights,
            self.damage,
        );
        let yi = current[i];
        let hw = history_words::<D, M, Dm>();
        let neighbors = &self.bonds.neighbors[r.clone()];
        let ref_lengths = &self.bonds.ref_lengths[r.clone()];
        let mut broke = 0;
        for (slot, ((&j, &ref_len), st)) in neighbors
            .iter()
            .zip(ref_lengths)
            .zip(status.iter_mut())
            .enumerate()
        {
            if *st == BROKEN || (Dm::HALVES_TOGETHER && *st != INTACT) {
                continue;
            }
            let j = j as usize;
            let y = current[j] - yi;
            let len = y.norm();
            let history = &mut history[slot * hw..(slot + 1) * hw];
            let protected = || no_fail[i] || no_fail[j];
            if decide && Dm::ON_STRETCH {
                broke += damage.on_stretch(i, j, Stretch { len, ref_len }, protected, history, st);
                if *st == BROKEN {
                    continue;
                }
            }
            if len <= 0.0 {
                continue;
            }
            // Both halves intact (the common case) needs no call into the law.
            let (mu_ij, mu_ji) = if !Dm::PARTIAL && (Dm::HALVES_TOGETHER || *st == INTACT) {
                (1.0, 1.0)
            } else {
                damage.factors(i, j, history, *st)
            };
            let (phi_ij, phi_ji, vol_j) = weights.weights(r.start + slot, i, j, ref_len);
            let xi = if M::NEEDS_XI {
                positions[j] - positions[i]
            } else {
                Vector::zeros()
            };
            broke += f(Visit {
                j,
                geom: BondGeom {
                    ref_len,
                    len,
                    phi_ij,
                    phi_ji,
                    vol_j,
                    mu_ij,
                    mu_ji,
                    y,
                    xi,
                },
                status: st,
                history,
                protected: Dm::ON_WORK && protected(),
            });
        }
        broke
    }
}

/// What the damage laws are told of material `M`'s pair force.
pub const fn bond_force<const D: usize, M: Material<D>>() -> BondForce {
    match (M::CENTRAL, M::LINEAR_BOND) {
        (true, true) => BondForce::Linear,
        (true, false) => BondForce::Central,
        (false, _) if M::NODE_MATRIX_WORDS > 0 => BondForce::NodeLinear,
        (false, _) => BondForce::Vector,
    }
}

/// Split work: whether an entry whose own half has done `half_work` may belong to a bond
/// that fails, i.e. whether twice it (with a margin for rounding) reaches node i's threshold:
/// w_i + w_j ≥ w_c φ̄ needs one of the two at least ½ w_c φ̄.
#[inline(always)]
fn may_fail<Dm: DamageLaw>(damage: &Dm, i: usize, half_work: f64, weight: f64) -> bool {
    damage.fails_on_work(i, 1.0, weight, 2.0 * half_work * (1.0 + 1e-6))
}

/// History words per bond entry of law `Dm` with material `M`.
const fn history_words<const D: usize, M: Material<D>, Dm: DamageLaw>() -> usize {
    crate::damage::history_words::<Dm>(bond_force::<D, M>())
}

/// Splits `data` into consecutive mutable pieces ending at `scale` × each of `ends` (non-generic
/// over the caller: one copy per element type).
fn split_at_ends<'a, T>(mut data: &'a mut [T], ends: &[usize], scale: usize) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(ends.len());
    let mut start = 0;
    for &end in ends {
        let (head, tail) = std::mem::take(&mut data).split_at_mut(end * scale - start);
        out.push(head);
        data = tail;
        start = end * scale;
    }
    out
}

/// One node chunk's share of the bond and node arrays: its nodes, their bonds' status bytes and
/// history words, and one per-node slot each (the pre-pass's point states or the forces).
type ChunkItem<'a, P> = (Range<usize>, &'a mut [u8], &'a mut [f64], &'a mut [P]);

/// Cuts the bond arrays (`hw` history words per bond) and a per-node array at the chunks'
/// ends.
fn chunk_items<'a, P>(
    chunks: &[Range<usize>],
    bond_ends: &[usize],
    hw: usize,
    (status, history, per_node): (&'a mut [u8], &'a mut [f64], &'a mut [P]),
) -> Vec<ChunkItem<'a, P>> {
    let node_ends: Vec<usize> = chunks.iter().map(|c| c.end).collect();
    (chunks.iter().cloned())
        .zip(split_at_ends(status, bond_ends, 1))
        .zip(split_at_ends(history, bond_ends, hw))
        .zip(split_at_ends(per_node, &node_ends, 1))
        .map(|(((nodes, status), history), per_node)| (nodes, status, history, per_node))
        .collect()
}

/// Node i's bonds (of the chunk `nodes`): their range in `bonds` and their entries in the
/// chunk's status bytes and history words (`hw` per bond), which start at the chunk's first
/// bond. (Inlined: once per node in both passes.)
#[inline(always)]
fn family_arrays<'a>(
    bonds: &Bonds,
    nodes: &Range<usize>,
    i: usize,
    hw: usize,
    status: &'a mut [u8],
    history: &'a mut [f64],
) -> (Range<usize>, &'a mut [u8], &'a mut [f64]) {
    let r = bonds.family(i);
    let (start, end) = (
        r.start - bonds.offsets[nodes.start],
        r.end - bonds.offsets[nodes.start],
    );
    (
        r,
        &mut status[start..end],
        &mut history[start * hw..end * hw],
    )
}

/// Runs `job` on every item in parallel and returns its results in item order. The job is a
/// trait object (one indirect call per node chunk) so that rayon's machinery is compiled once
/// per item type instead of once per model, weight rule and damage law: `compute_with` has
/// some twenty instances per model, and their parallel iterators were half the crate's code
/// handed to the compiler.
fn map_chunks<J: Send>(items: Vec<J>, job: &(dyn Fn(J) -> u64 + Sync)) -> Vec<u64> {
    items.into_par_iter().map(job).collect()
}

impl<const D: usize, M: Material<D>> ForceEngine<D, M> {
    /// Sets up the material (per-node constants from the intact families) and the damage law.
    pub fn new(
        material: M,
        damage: Damage,
        body: &Body<D>,
        bonds: &Bonds,
        rule: PartialVolume,
    ) -> Result<Self, PointError> {
        let quad = Quadrature::for_body(rule, body, bonds);
        Self::with_quadrature(material, damage, body, bonds, quad, body.len())
    }

    /// `new` with the bonds' quadrature given; nodes from `owned` on are a distributed run's
    /// ghosts (no rows).
    pub fn with_quadrature(
        mut material: M,
        damage: Damage,
        body: &Body<D>,
        bonds: &Bonds,
        quad: Quadrature,
        owned: usize,
    ) -> Result<Self, PointError> {
        material.setup(body, bonds, &quad, owned)?;
        let n = body.len();
        let chunks = (0..n)
            .step_by(NODE_CHUNK)
            .map(|s| s..(s + NODE_CHUNK).min(n))
            .collect();
        let neighbors_in_bounds = bonds.neighbors.iter().all(|&j| (j as usize) < n);
        Ok(ForceEngine {
            material,
            damage,
            quad,
            vector_kernels: true,
            neighbors_in_bounds,
            points: vec![M::Point::default(); n],
            chunks,
            dissipation: DissipationTracker::default(),
            broke_in_chunk: Vec::new(),
            mid_step: Vec::new(),
            share: None,
            cross_bonds: Default::default(),
            all_protected: false,
        })
    }

    /// The point states of the last evaluation (θ for LPS, F and the stress for
    /// correspondence).
    pub fn points(&self) -> &[M::Point] {
        &self.points
    }

    /// Evaluates damage and internal force densities into `state.force`, and books the strain
    /// energy the damage released into `state.dissipated_damage`; returns the number of
    /// directed bond halves broken by this evaluation (each bond of a law shared by both ends
    /// counts twice, once per entry).
    pub fn compute(&mut self, body: &Body<D>, bonds: &Bonds, state: &mut State<D>) -> u64 {
        self.compute_in_step(body, bonds, state, 0.0)
    }

    /// `compute` inside a time step whose drift moved the nodes by dt·v: the release is booked
    /// at the mid-step positions y − `half_dt`·v. A bond breaks at a stretch past its limit,
    /// and the velocity-Verlet kick gives back only the mean of its force before (intact) and
    /// after (broken) over the step; the energy at mid-step is what the step's balance loses
    /// (to second order in the step's stretch increment), the energy at the end would count
    /// the overshoot past the limit, which no kick delivered.
    pub fn compute_in_step(
        &mut self,
        body: &Body<D>,
        bonds: &Bonds,
        state: &mut State<D>,
        half_dt: f64,
    ) -> u64 {
        let mut tracker = std::mem::take(&mut self.dissipation);
        tracker.remember(state);
        let mut broke = self.evaluate(body, bonds, state);
        debug_assert!(!self.all_protected || broke == 0, "a protected bond broke");
        if let Some(share) = self.share.as_ref().filter(|_| !self.all_protected) {
            // Every rank books the release when any rank broke a half (the sum continues
            // through ranks that broke none).
            let local = broke;
            broke = share.ranks.sum_u64(local);
            state.broken += broke - local;
        }
        if broke > 0 {
            // The mid-step positions, in a buffer kept between evaluations.
            let mut mid_step = std::mem::take(&mut self.mid_step);
            if half_dt != 0.0 {
                mid_step.clear();
                mid_step.par_extend(
                    state
                        .current
                        .par_iter()
                        .zip(&state.v)
                        .map(|(y, v)| y - v * half_dt),
                );
            }
            let at = if half_dt == 0.0 {
                &state.current
            } else {
                &mid_step
            };
            let per_chunk = tracker.released(
                &self.chunks,
                &self.broke_in_chunk,
                bonds,
                &body.volumes,
                state,
                |i, status| {
                    let record = (status, &state.history[..]);
                    self.node_energy_with(body, bonds, at, record, i)
                },
            );
            state.dissipated_damage += ordered_sum(self.share.as_deref(), per_chunk.into_iter());
            self.mid_step = mid_step;
        }
        self.dissipation = tracker;
        broke
    }

    /// `compute` without the dissipation booking.
    fn evaluate(&mut self, body: &Body<D>, bonds: &Bonds, state: &mut State<D>) -> u64 {
        // Dispatch once on the damage law and the weight source: on uniform grids φ depends
        // on |ξ| only and no per-neighbour node data is read.
        let damage = std::mem::replace(&mut self.damage, Damage::none());
        let uniform = self.quad.uniform();
        let quad = self.quad.clone();
        let broke = match (&damage, &uniform) {
            (Damage::CriticalStretch(d), Some(u)) => match d.s0 {
                PerNode::Uniform(s0) => {
                    self.compute_with(u, &UniformCriticalStretch { s0 }, body, bonds, state)
                }
                PerNode::Varying(_) => self.compute_with(u, d, body, bonds, state),
            },
            (Damage::CriticalStretch(d), None) => match d.s0 {
                PerNode::Uniform(s0) => {
                    self.compute_with(&quad, &UniformCriticalStretch { s0 }, body, bonds, state)
                }
                PerNode::Varying(_) => self.compute_with(&quad, d, body, bonds, state),
            },
            (Damage::CriticalEnergy(d), Some(u)) => match d.uniform_form() {
                Some(law) => self.compute_with(u, &law, body, bonds, state),
                None => self.compute_with(u, d, body, bonds, state),
            },
            (Damage::CriticalEnergy(d), None) => match d.uniform_form() {
                Some(law) => self.compute_with(&quad, &law, body, bonds, state),
                None => self.compute_with(&quad, d, body, bonds, state),
            },
            (Damage::Softening(d), Some(u)) => match d.uniform_form() {
                Some(law) => self.compute_with(u, &law, body, bonds, state),
                None => self.compute_with(u, d, body, bonds, state),
            },
            (Damage::Softening(d), None) => match d.uniform_form() {
                Some(law) => self.compute_with(&quad, &law, body, bonds, state),
                None => self.compute_with(&quad, d, body, bonds, state),
            },
            (Damage::Mixed(d), Some(u)) => self.compute_mixed(u, d, body, bonds, state),
            (Damage::Mixed(d), None) => self.compute_mixed(&quad, d, body, bonds, state),
        };
        self.damage = damage;
        broke
    }

    /// `compute_with` for the mixed law, in the form its blocks need.
    fn compute_mixed<W: Weights>(
        &mut self,
        weights: &W,
        d: &MixedDamage,
        body: &Body<D>,
        bonds: &Bonds,
        state: &mut State<D>,
    ) -> u64 {
        match (d.softens(), d.records_work()) {
            (false, false) => {
                self.compute_with(weights, &MixedLaws::<false, false>(d), body, bonds, state)
            }
            (false, true) => {
                self.compute_with(weights, &MixedLaws::<false, true>(d), body, bonds, state)
            }
            (true, false) => {
                self.compute_with(weights, &MixedLaws::<true, false>(d), body, bonds, state)
            }
            (true, true) => {
                self.compute_with(weights, &MixedLaws::<true, true>(d), body, bonds, state)
            }
        }
    }

    fn compute_with<W: Weights, Dm: DamageLaw>(
        &mut self,
        weights: &W,
        damage: &Dm,
        body: &Body<D>,
        bonds: &Bonds,
        state: &mut State<D>,
    ) -> u64 {
        let no_fail: &[bool] = &body.no_fail;
        let hw = history_words::<D, M, Dm>();
        debug_assert_eq!(state.history.len(), bonds.len() * hw);
        // Own halves broken per node chunk (the dissipation booking skips quiet chunks).
        let mut per_chunk = vec![0u64; self.chunks.len()];
        let mut add = |counts: Vec<u64>| {
            per_chunk.iter_mut().zip(counts).for_each(|(a, c)| *a += c);
        };
        // The AVX2 kernels, where the model has them (2D and 3D): uniform grid, one critical
        // stretch, one softening law (PMB), or one critical energy (with a linear bond's
        // closed form, a central model's two-word work record, or a non-central model's
        // four-word one); x86-64 with AVX2, and neighbour indices known
        // to be in bounds (the kernels' gathers rely on it). A model without the kernel for
        // the case returns `None` and the generic loop runs.
        let s0 = damage.uniform_critical_stretch();
        let softening = damage.uniform_softening().filter(|_| hw == 1);
        let work = damage
            .uniform_critical_energy()
            .filter(|_| match bond_force::<D, M>() {
                BondForce::Linear => hw == 0,
                BondForce::Central => hw == 2,
                BondForce::Vector => hw == 4,
                BondForce::NodeLinear => hw == 1,
            });
        let vector = if (s0.is_some() || softening.is_some() || work.is_some())
            && self.vector_kernels
            && self.neighbors_in_bounds
            && simd::available()
        {
            self.quad.uniform()
        } else {
            None
        };
        // On a grid whose nodes differ, PMB's per-node kernel (`simd_nodes`) under a critical
        // stretch, one or per node; a model with a pre-pass keeps the generic loop.
        let nodes_kernel = weights
            .node_weights()
            .filter(|_| {
                vector.is_none()
                    && !M::NEEDS_PREPASS
                    && hw == 0
                    && self.vector_kernels
                    && self.neighbors_in_bounds
                    && simd::available()
            })
            .and_then(|(rule, nodes)| {
                let s0 = match (s0, damage.critical_stretch_per_node()) {
                    (Some(s0), _) => CriticalStretches::Uniform(s0),
                    (None, Some(s0)) => CriticalStretches::PerNode(s0),
                    (None, None) => return None,
                };
                Some(NodeConstants { rule, nodes, s0 })
            });
        let s0 = s0.unwrap_or(f64::INFINITY);
        // The current positions as one flat x, y, z array.
        assert_eq!(
            std::mem::size_of::<Vector<D>>(),
            D * std::mem::size_of::<f64>()
        );
        // SAFETY: `Vector<D>` is a `[f64; D]` in memory (size checked above), so the slice of
        // vectors is `D * len` contiguous f64 values.
        let flat: &[f64] = unsafe {
            std::slice::from_raw_parts(
                state.current.as_ptr() as *const f64,
                state.current.len() * D,
            )
        };
        let bond_ends: Vec<usize> = self.chunks.iter().map(|c| bonds.offsets[c.end]).collect();
        let sweep = Sweep {
            current: &state.current,
            positions: &body.positions,
            no_fail,
            weights,
            damage,
            bonds,
        };

        // Split work (`DamageLaw::SPLITS_WORK`): the pre-pass, once node i's matrices are
        // known, adds each entry's own half of the work and flags the nodes with an entry
        // that may reach w_c with its bond's other half; after the force pass
        // `resolve_split_work` decides those bonds from both entries. (The pre-pass has just
        // read the family's positions; the force pass reads the neighbours' moment records.)
        let split = Dm::SPLITS_WORK && bond_force::<D, M>() == BondForce::NodeLinear;
        debug_assert!(!split || (M::NEEDS_PREPASS && M::FACTORED_OWN_HALF));
        let words = M::NODE_MATRIX_WORDS;
        let flagged: Vec<std::sync::Mutex<Vec<usize>>> = match split {
            true => self.chunks.iter().map(|_| Default::default()).collect(),
            false => Vec::new(),
        };
        // Node i's matrices of the previous evaluation, which its pre-pass reads and then
        // replaces with this evaluation's (no other node reads them): per chunk.
        let mut previous_matrices = std::mem::take(&mut state.previous_matrices);
        let matrices_of_chunks = match split {
            true => {
                previous_matrices.resize(body.len() * words, 0.0);
                let ends: Vec<usize> = self.chunks.iter().map(|c| c.end).collect();
                split_at_ends(&mut previous_matrices, &ends, words)
            }
            false => self.chunks.iter().map(|_| Default::default()).collect(),
        };
        let previous = &state.previous;
        // SAFETY: as for `flat` (empty unless a non-central model records work).
        let previous_flat: &[f64] = unsafe {
            std::slice::from_raw_parts(previous.as_ptr() as *const f64, previous.len() * D)
        };

        if M::NEEDS_PREPASS {
            let (material, chunks) = (&self.material, &self.chunks);
            let arrays = (
                &mut state.status[..],
                &mut state.history[..],
                &mut self.points[..],
            );
            let items = chunk_items(chunks, &bond_ends, hw, arrays);
            let items: Vec<_> = items.into_iter().zip(matrices_of_chunks).collect();
            add(map_chunks(items, &|(
                (nodes, status, history, points),
                matrices,
            )| {
                let mut broke = 0u64;
                let mut flag = Vec::new();
                // What a kernel hands on to the next on the same node (split work).
                let mut scratch = Vec::new();
                for (k, i) in nodes.clone().enumerate() {
                    let (r, status, history) =
                        family_arrays(bonds, &nodes, i, hw, &mut *status, &mut *history);
                    let mine = matrices
                        .get_mut(k * words..(k + 1) * words)
                        .unwrap_or_default();
                    // The bonds broken, or with split work the entries that may fail.
                    let vector_count = vector.as_ref().and_then(|w| {
                        // Under a critical energy the pre-pass reads only the status.
                        let mut nb = NodeBonds::of(i, flat, bonds, &mut *status, no_fail, Some(s0))
                            .under(D, softening, work, &mut *history)
                            .with_previous(previous_flat, mine);
                        if split {
                            nb = nb.with_scratch(&mut scratch);
                        }
                        // SAFETY: AVX2 is available and neighbour indices are in bounds.
                        unsafe { material.vector_prepass(&mut nb, w, &mut points[k]) }
                    });
                    let count = vector_count.unwrap_or_else(|| {
                        let mut acc = M::Point::default();
                        let broke = sweep.walk::<M>(i, r.clone(), status, history, true, |v| {
                            material.accumulate(i, &mut acc, &v.geom);
                            0
                        });
                        points[k] = material.finish_point(i, acc);
                        if !split {
                            return broke;
                        }
                        debug_assert_eq!(broke, 0, "a critical energy breaks nothing here");
                        let pi = &points[k];
                        sweep.walk::<M>(i, r, status, history, false, |v| {
                            let g = &v.geom;
                            let step = g.y - (previous[v.j] - previous[i]);
                            v.history[0] += material.own_half_work(i, g, pi, mine, &step);
                            may_fail(damage, i, v.history[0], 0.5 * (g.phi_ij + g.phi_ji)) as u64
                        })
                    });
                    if !split {
                        broke += count;
                        continue;
                    }
                    if count > 0 {
                        flag.push(i);
                    }
                    material.node_matrices(&points[k], mine);
                }
                if !flag.is_empty() {
                    *flagged[nodes.start / NODE_CHUNK]
                        .lock()
                        .expect("not poisoned") = flag;
                }
                broke
            }));
        }
        state.previous_matrices = previous_matrices;
        if M::NEEDS_PREPASS {
            self.exchange_points();
        }

        let (material, points) = (&self.material, &self.points);
        // A two-pass model decided stretch-based failure in its pre-pass.
        let decide = !M::NEEDS_PREPASS;
        let arrays = (
            &mut state.status[..],
            &mut state.history[..],
            &mut state.force[..],
        );
        let items = chunk_items(&self.chunks, &bond_ends, hw, arrays);
        // With split work the pre-pass did the work: this pass only sums the forces.
        let work = work.filter(|_| !split);
        let counts = map_chunks(items, &|(nodes, status, history, forces)| {
            let mut broke = 0u64;
            for (k, i) in nodes.clone().enumerate() {
                let (r, status, history) =
                    family_arrays(bonds, &nodes, i, hw, &mut *status, &mut *history);
                if let Some(w) = &vector {
                    // The previous positions are empty unless a non-central model records
                    // work.
                    let s0 = decide.then_some(s0);
                    let mut nb = NodeBonds::of(i, flat, bonds, status, no_fail, s0)
                        .under(D, softening, work, history)
                        .with_previous(previous_flat, &[]);
                    // SAFETY: AVX2 is available and neighbour indices are in bounds.
                    if let Some((f, nb_broken)) =
                        unsafe { material.vector_force(&mut nb, w, points) }
                    {
                        forces[k] = Vector::<D>::from_fn(|a, _| f[a]);
                        broke += nb_broken;
                        continue;
                    }
                }
                if let Some(g) = &nodes_kernel {
                    let mut nb = NodeBonds::of(i, flat, bonds, status, no_fail, None)
                        .under(D, None, None, history);
                    // SAFETY: AVX2 is available and neighbour indices are in bounds.
                    if let Some((f, nb_broken)) = unsafe { material.vector_force_nodes(&mut nb, g) }
                    {
                        forces[k] = Vector::<D>::from_fn(|a, _| f[a]);
                        broke += nb_broken;
                        continue;
                    }
                }
                let pi = &points[i];
                let mut f = Vector::<D>::zeros();
                if M::FACTORED_OWN_HALF && (!Dm::ON_WORK || split) {
                    // The own halves through node i's matrices once: sum s ξ and s η
                    // over the family, evaluate only the other half per bond.
                    let (mut sum_xi, mut sum_eta) = (Vector::<D>::zeros(), Vector::<D>::zeros());
                    broke += sweep.walk::<M>(i, r, status, history, decide, |v| {
                        let g = &v.geom;
                        let s = material.own_half_weight(i, g);
                        sum_xi += g.xi * s;
                        sum_eta += (g.y - g.xi) * s;
                        f += material.other_half(i, v.j, g, &points[v.j]);
                        0
                    });
                    forces[k] = f + material.own_half_force(i, pi, &sum_xi, &sum_eta);
                    continue;
                }
                broke += sweep.walk::<M>(i, r, status, history, decide, |v| {
                    let Visit {
                        j,
                        mut geom,
                        status,
                        history,
                        protected,
                    } = v;
                    let pj = &points[j];
                    if !Dm::ON_WORK {
                        f += pair_force(material, i, j, &geom, pi, pj);
                        return 0;
                    }
                    // Energy-based failure needs the pair force first: record its work since
                    // the previous evaluation, then drop the halves that broke.
                    let extension = geom.len - geom.ref_len;
                    let (force, work) = if M::CENTRAL {
                        let per_length = material.pair_force_per_length(i, j, &geom, pi, pj);
                        let along = per_length * geom.len;
                        let work = if M::LINEAR_BOND && Dm::CLOSED_FORM_WORK {
                            Work::Stored {
                                energy: 0.5 * along * extension,
                            }
                        } else {
                            Work::Along {
                                force: along,
                                extension,
                            }
                        };
                        (geom.y * per_length, work)
                    } else {
                        let force = material.pair_force(i, j, &geom, pi, pj);
                        let step = geom.y - (previous[j] - previous[i]);
                        (
                            force,
                            Work::Vector {
                                force: to3(&force),
                                step: to3(&step),
                            },
                        )
                    };
                    let before = *status;
                    let broke = damage.on_work(
                        i,
                        j,
                        work,
                        extension,
                        0.5 * (geom.phi_ij + geom.phi_ji),
                        protected,
                        history,
                        status,
                    );
                    if *status == BROKEN {
                        return broke;
                    }
                    if *status != before {
                        (geom.mu_ij, geom.mu_ji) = damage.factors(i, j, history, *status);
                        f += pair_force(material, i, j, &geom, pi, pj);
                    } else {
                        f += force * geom.vol_j;
                    }
                    broke
                });
                forces[k] = f;
            }
            broke
        });
        add(counts);
        if split {
            let flagged = flagged
                .into_iter()
                .map(|m| m.into_inner().expect("not poisoned"));
            let resolved = self.resolve_split_work(weights, damage, body, bonds, state, flagged);
            add(resolved);
        }

        if Dm::ON_WORK && !M::CENTRAL {
            state.previous.clone_from(&state.current);
        }
        let newly_broken = per_chunk.iter().sum::<u64>();
        self.broke_in_chunk = per_chunk;
        state.broken += newly_broken;
        newly_broken
    }

    /// A distributed run: the ghosts take their owners' point states (θ for LPS), which
    /// the force pass reads for the neighbour's half of a bond.
    fn exchange_points(&mut self) {
        if let Some(s) = &self.share {
            debug_assert!(M::HALO_WORDS > 0, "a pre-pass model without halo words");
            s.halo.exchange_items(
                &*s.ranks,
                M::HALO_WORDS,
                &mut self.points,
                M::point_words,
                M::point_from_words,
            );
        }
    }

    /// Split work: decides the bonds of the flagged nodes (per chunk, in node order) from
    /// the sum of their two entries' words, w = w_i + w_j (the same sum from either end),
    /// breaking both entries where `fails_on_work` says so unless an end is no-fail, and
    /// taking the bond's pair force back from both ends' force densities: as with the
    /// record of the whole pair's work, a bond does no work past the evaluation at which it
    /// reaches w_c (kept for one more evaluation, the separation work of
    /// `tests/suite/separation_work.rs` rose from 1.03 to 1.05 G0 in 3D). Returns the
    /// entries broken per chunk.
    ///
    /// A distributed run decides the bonds of its owned nodes in the same order, the turns
    /// of the ghosts included: a bond to a ghost k takes the word of k's entry from k's
    /// owner (`CrossBonds`), at k's turn if k's entry may fail and k comes first, and only
    /// the owned end's entry, count and force density change on this rank.
    fn resolve_split_work<W: Weights, Dm: DamageLaw>(
        &self,
        weights: &W,
        damage: &Dm,
        body: &Body<D>,
        bonds: &Bonds,
        state: &mut State<D>,
        flagged: impl Iterator<Item = Vec<usize>>,
    ) -> Vec<u64> {
        let mut broke = vec![0u64; self.chunks.len()];
        let owned = self.share.as_ref().map_or(body.len(), |s| s.owned);
        // In node order (chunks in order, nodes in order in each).
        let flagged: Vec<usize> = flagged.flatten().collect();
        let remote = match &self.share {
            Some(s) => self
                .cross_bonds
                .get_or_init(|| CrossBonds::new(bonds, s))
                .exchange(
                    &*s.ranks,
                    &s.halo.peers,
                    bonds,
                    (&state.history, 1),
                    &flagged,
                ),
            None => RemoteWords::default(),
        };
        let mut resolve = |i: usize, e: usize, other: Option<f64>, ghost_turn: bool| {
            let (j, ref_len) = (bonds.neighbors[e] as usize, bonds.ref_lengths[e]);
            let (phi_ij, phi_ji, vol_j) = weights.weights(e, i, j, ref_len);
            let weight = 0.5 * (phi_ij + phi_ji);
            // Whose turn it is: the one-process test reads that node's entry (a ghost's word
            // comes with its turn).
            let (turn, turn_word) = match (ghost_turn, other) {
                (true, Some(word)) => (j, word),
                _ => (i, state.history[e]),
            };
            if state.status[e] != INTACT
                || !may_fail(damage, turn, turn_word, weight)
                || body.no_fail[i]
                || body.no_fail[j]
            {
                return;
            }
            // The reverse entry only for a bond that may break (it is a search in j's row).
            let reverse = (j < owned).then(|| {
                bonds
                    .reverse(i, e)
                    .expect("every bond is stored at both ends")
            });
            let other = other.unwrap_or_else(|| state.history[reverse.expect("an owned end")]);
            // w_i + w_j (either order: the same sum).
            let work = state.history[e] + other;
            let y = state.current[j] - state.current[i];
            let len = y.norm();
            if !damage.fails_on_work(turn, len - ref_len, weight, work) {
                return;
            }
            let geom = BondGeom {
                ref_len,
                len,
                phi_ij,
                phi_ji,
                vol_j,
                mu_ij: 1.0,
                mu_ji: 1.0,
                y,
                xi: body.positions[j] - body.positions[i],
            };
            // From j's side the pair force is the exact negation of this one.
            let pair = self
                .material
                .pair_force(i, j, &geom, &self.points[i], &self.points[j]);
            state.status[e] = BROKEN;
            broke[i / NODE_CHUNK] += 1;
            state.force[i] -= pair * vol_j;
            if let Some(reverse) = reverse {
                let (_, _, vol_i) = weights.weights(reverse, j, i, ref_len);
                state.status[reverse] = BROKEN;
                broke[j / NODE_CHUNK] += 1;
                state.force[j] += pair * vol_i;
            }
        };
        for t in &remote.earlier {
            resolve(t.node, t.entry, Some(t.word), true);
        }
        for &i in &flagged {
            for e in bonds.family(i) {
                let j = bonds.neighbors[e] as usize;
                let other = (j >= owned).then(|| remote.word(e));
                resolve(i, e, other, false);
            }
        }
        for t in &remote.later {
            resolve(t.node, t.entry, Some(t.word), true);
        }
        broke
    }

    /// Strain energy density W_i (J/m³) of every node at the state of the last `compute`.
    pub fn energy_density(&self, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> Vec<f64> {
        (0..body.len())
            .into_par_iter()
            .map(|i| {
                let pi = &self.points[i];
                let halves = self.intact_own_halves(body, bonds, state, i);
                self.energy_from(i, pi, halves)
            })
            .collect()
    }

    /// W_i from node i's point state and its intact own halves.
    fn energy_from(
        &self,
        i: usize,
        pi: &M::Point,
        halves: impl Iterator<Item = BondGeom<D>>,
    ) -> f64 {
        // A fold from +0.0 (`sum` would start from −0.0).
        let sum = halves.fold(0.0, |acc, g| acc + self.material.bond_energy(i, &g, pi));
        self.material.point_energy(i, pi, sum)
    }

    /// W_i of node i at the current positions with the given bond status and history
    /// (whole-body arrays), its point state recomputed from them: the dissipation tracker
    /// compares a node's energy before and after an evaluation damaged its bonds.
    pub(crate) fn node_energy_with(
        &self,
        body: &Body<D>,
        bonds: &Bonds,
        current: &[Vector<D>],
        damage_record: (&[u8], &[f64]),
        i: usize,
    ) -> f64 {
        let point = if M::NEEDS_PREPASS {
            // As the pre-pass: every bond that still carries force, with its factors.
            let mut acc = M::Point::default();
            for g in self.halves(body, bonds, current, damage_record, i, BROKEN) {
                if g.len > 0.0 {
                    self.material.accumulate(i, &mut acc, &g);
                }
            }
            self.material.finish_point(i, acc)
        } else {
            M::Point::default()
        };
        let own = self.halves(body, bonds, current, damage_record, i, OWN_BROKEN);
        self.energy_from(i, &point, own)
    }

    /// The bonds of node i whose own half is not broken, with their geometry now.
    fn intact_own_halves<'a>(
        &'a self,
        body: &'a Body<D>,
        bonds: &'a Bonds,
        state: &'a State<D>,
        i: usize,
    ) -> impl Iterator<Item = BondGeom<D>> + 'a {
        let record = (&state.status[..], &state.history[..]);
        self.halves(body, bonds, &state.current, record, i, OWN_BROKEN)
    }

    /// The bond entries of node i without any of the status bits `skip`, with their geometry
    /// at `current` and their factors from `status` and `history`.
    fn halves<'a>(
        &'a self,
        body: &'a Body<D>,
        bonds: &'a Bonds,
        current: &'a [Vector<D>],
        (status, history): (&'a [u8], &'a [f64]),
        i: usize,
        skip: u8,
    ) -> impl Iterator<Item = BondGeom<D>> + 'a {
        let hw = self.damage.history_words(bond_force::<D, M>());
        bonds
            .family(i)
            .filter(move |&b| status[b] & skip == 0)
            .map(move |b| {
                let j = bonds.neighbors[b] as usize;
                let y = current[j] - current[i];
                let l = bonds.ref_lengths[b];
                let (phi_ij, phi_ji) = self.quad.phi_pair(b, i, j, l);
                let (mu_ij, mu_ji) = if status[b] == INTACT && hw == 0 {
                    (1.0, 1.0)
                } else {
                    self.damage
                        .factors(i, j, &history[b * hw..(b + 1) * hw], status[b])
                };
                BondGeom {
                    ref_len: l,
                    len: y.norm(),
                    phi_ij,
                    phi_ji,
                    vol_j: body.volumes[j],
                    mu_ij,
                    mu_ji,
                    y,
                    xi: body.positions[j] - body.positions[i],
                }
            })
    }

    /// Peridynamic stress of node i, σ_i = Σ_j T_i⟨ξ⟩ ⊗ ξ φ_ij μ_ij V_j (Silling et al. 2007:
    /// the stress of a homogeneous deformation is ∫ T⟨ξ⟩ ⊗ ξ dV). Row a, column b: T_a ξ_b.
    pub fn stress(
        &self,
        body: &Body<D>,
        bonds: &Bonds,
        state: &State<D>,
        i: usize,
    ) -> [[f64; D]; D] {
        let mut sigma = [[0.0; D]; D];
        let pi = &self.points[i];
        for g in self.intact_own_halves(body, bonds, state, i) {
            if g.len <= 0.0 {
                continue;
            }
            let t = self.material.force_state_vector(i, &g, pi) * g.weight();
            for (a, row) in sigma.iter_mut().enumerate() {
                for (c, s) in row.iter_mut().enumerate() {
                    *s += t[a] * g.xi[c];
                }
            }
        }
        sigma
    }

    /// The energy damage has dissipated since the start (J): what the evaluations booked
    /// (`state.dissipated_damage`) plus, for softening halves, c·(G(s) − ½ g(s) s) at their
    /// largest stretch s (`UniformSoftening::dissipated_fraction` of the intact bond energy
    /// there), summed per node chunk in a fixed order.
    pub fn dissipated_energy(&self, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> f64 {
        if !self.damage.partial() {
            return state.dissipated_damage;
        }
        let hw = self.damage.history_words(bond_force::<D, M>());
        let point = M::Point::default();
        // The chunks of the owned nodes (a distributed run's ghosts follow them).
        let owned = self.share.as_ref().map_or(body.len(), |s| s.owned);
        let chunks = &self.chunks[..owned.div_ceil(NODE_CHUNK)];
        let per_chunk: Vec<f64> = chunks
            .par_iter()
            .map(|nodes| {
                nodes.clone().fold(0.0, |acc, i| {
                    let Some(law) = self.damage.softening_at(i) else {
                        return acc;
                    };
                    let own: f64 = bonds
                        .family(i)
                        .filter(|&b| state.history[b * hw] > law.s1)
                        .map(|b| {
                            let s = state.history[b * hw].min(law.sc);
                            let j = bonds.neighbors[b] as usize;
                            let l = bonds.ref_lengths[b];
                            let phi = self.quad.phi_pair(b, i, j, l).0;
                            let g = BondGeom::<D>::intact(l, l * (1.0 + s), phi, body.volumes[j]);
                            self.material.bond_energy(i, &g, &point) * law.dissipated_fraction(s)
                        })
                        .sum();
                    acc + own * body.volumes[i]
                })
            })
            .collect();
        state.dissipated_damage + ordered_sum(self.share.as_deref(), per_chunk.into_iter())
    }

    /// Total strain energy Σ W_i V_i (J).
    pub fn strain_energy(&self, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> f64 {
        self.energy_density(body, bonds, state)
            .iter()
            .zip(&body.volumes)
            .map(|(w, v)| w * v)
            .sum()
    }

    /// Damage index per node: the broken fraction of its own bond volume,
    /// d = 1 − Σ μ φ V_j / Σ φ V_j (seed 000, Eq. 10), a half counting as broken once it has
    /// failed completely.
    pub fn damage(&self, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> Vec<f64> {
        (0..body.len())
            .into_par_iter()
            .map(|i| self.node_damage(i, body, bonds, state))
            .collect()
    }

    /// Node i's damage index (as `damage`).
    pub fn node_damage(&self, i: usize, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> f64 {
        let (mut broken, mut total) = (0.0, 0.0);
        for b in bonds.family(i) {
            let j = bonds.neighbors[b] as usize;
            let w = self.quad.phi_pair(b, i, j, bonds.ref_lengths[b]).0 * body.volumes[j];
            total += w;
            if state.status[b] & OWN_BROKEN != 0 {
                broken += w;
            }
        }
        if total > 0.0 {
            broken / total
        } else {
            0.0
        }
    }

    /// Stable time step of Silling & Askari (2005): Δt < sqrt(2ρ_i / k_i) at every node, with
    /// k_i from `node_stiffness`.
    pub fn stable_time_step(&self, body: &Body<D>, bonds: &Bonds) -> f64 {
        self.node_stiffness(body, bonds)
            .par_iter()
            .enumerate()
            .map(|(i, &k)| {
                if k > 0.0 {
                    (2.0 * self.material.density(i) / k).sqrt()
                } else {
                    f64::INFINITY
                }
            })
            .reduce(|| f64::INFINITY, f64::min)
    }

    /// k_i = Σ_j C_ij φ̄ V_j (N/m⁴), the linearised bond stiffness C averaged over the bond's
    /// two halves and summed over the family (Silling & Askari 2005): the stable time step's
    /// and the quasi-static solver's fictitious mass's bound on the node's stiffness.
    pub fn node_stiffness(&self, body: &Body<D>, bonds: &Bonds) -> Vec<f64> {
        (0..body.len())
            .into_par_iter()
            .map(|i| {
                bonds
                    .family(i)
                    .map(|b| {
                        let j = bonds.neighbors[b] as usize;
                        self.pair_stiffness(bonds, b, i, j, INTACT) * body.volumes[j]
                    })
                    .sum()
            })
            .collect()
    }

    /// C̄ = ½ (C_i φ_ij + C_j φ_ji) of bond b = i→j (N/m⁷), each half's term only while that
    /// half (`status`'s bits) is intact.
    pub fn pair_stiffness(&self, bonds: &Bonds, b: usize, i: usize, j: usize, status: u8) -> f64 {
        let l = bonds.ref_lengths[b];
        let (phi_ij, phi_ji) = self.quad.phi_pair(b, i, j, l);
        let own = if status & OWN_BROKEN == 0 {
            self.material.bond_stiffness(i, l) * phi_ij
        } else {
            0.0
        };
        let other = if status & OTHER_BROKEN == 0 {
            self.material.bond_stiffness(j, l) * phi_ji
        } else {
            0.0
        };
        0.5 * (own + other)
    }
}

/// The pair force density vector of bond i→j on node i (per unit V_j is not applied yet).
#[inline(always)]
fn pair_force<const D: usize, M: Material<D>>(
    material: &M,
    i: usize,
    j: usize,
    g: &BondGeom<D>,
    pi: &M::Point,
    pj: &M::Point,
) -> Vector<D> {
    if M::CENTRAL {
        g.y * (material.pair_force_per_length(i, j, g, pi, pj) * g.vol_j)
    } else {
        material.pair_force(i, j, g, pi, pj) * g.vol_j
    }
}
