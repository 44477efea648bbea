//! The bond loops. Written once, generic over the material; everything inside is
//! monomorphised, with no allocation, hashing or dynamic dispatch per bond.
//!
//! Parallelism is gather-style over node chunks: each node sums its own family in a fixed
//! order, so results are bitwise identical for any number of threads.

use crate::material::simd::{self, NodeBonds};
use crate::body::Body;
use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::{Bonds, PartialVolume, Quadrature};
use crate::material::{BondGeom, Material};
use crate::math::Vector;
use crate::state::{State, BROKEN, INTACT};
use rayon::prelude::*;
use std::ops::Range;

/// Nodes per parallel work unit.
const NODE_CHUNK: usize = 256;

/// Force evaluation for one material over one body: owns the material, the quadrature
/// weights and the per-node pre-pass buffer.
pub struct ForceEngine<const D: usize, M: Material<D>> {
    pub material: M,
    pub quad: Quadrature,
    /// Use the models' AVX2 kernels where they apply (3D, uniform grid, x86-64 with AVX2).
    pub vector_kernels: bool,
    /// Every neighbour index is a node of the body (checked once; the kernel relies on it).
    neighbors_in_bounds: bool,
    points: Vec<M::Point>,
    chunks: Vec<Range<usize>>,
}

/// Where the bond loop gets quadrature weights: per node in general, from constants on a
/// uniform grid (one monomorphised loop each, written once).
trait Weights: Sync {
    /// Geometry of bond i→j of reference length `ref_len` and current length `len`.
    fn geom(&self, b: usize, i: usize, j: usize, ref_len: f64, len: f64) -> BondGeom;
}

impl Weights for Quadrature {
    #[inline(always)]
    fn geom(&self, b: usize, i: usize, j: usize, ref_len: f64, len: f64) -> BondGeom {
        let (phi_ij, phi_ji) = self.phi_pair(b, i, j, ref_len);
        BondGeom {
            ref_len,
            len,
            phi_ij,
            phi_ji,
            vol_j: self.nodes[j].volume,
        }
    }
}

impl Weights for UniformWeights {
    #[inline(always)]
    fn geom(&self, _b: usize, _i: usize, _j: usize, ref_len: f64, len: f64) -> BondGeom {
        let phi = self.phi(ref_len);
        BondGeom {
            ref_len,
            len,
            phi_ij: phi,
            phi_ji: phi,
            vol_j: self.node.volume,
        }
    }
}

/// The family of one node, as the bond loops walk it.
struct Family<'a> {
    i: usize,
    /// Global index of the first bond of the family.
    first: usize,
    neighbors: &'a [u32],
    ref_lengths: &'a [f64],
}

impl Family<'_> {
    /// Calls `f(b, j, |ξ|, y_j − y_i, |y_j − y_i|)` for every intact bond b = i→j. With `failure =
    /// Some((s0, no_fail))` it first breaks, irreversibly, each bond whose stretch exceeds s0
    /// unless an end is in a no-fail set; the stretch is bitwise the same from either end, so
    /// breakage is symmetric. Returns the number of bonds broken.
    #[inline(always)]
    fn visit_intact<const D: usize>(
        &self,
        current: &[Vector<D>],
        status: &mut [u8],
        failure: Option<(f64, &[bool])>,
        mut f: impl FnMut(usize, usize, f64, Vector<D>, f64),
    ) -> u64 {
        let yi = current[self.i];
        let mut broke = 0;
        for (slot, ((&j, &ref_len), st)) in self
            .neighbors
            .iter()
            .zip(self.ref_lengths)
            .zip(status)
            .enumerate()
        {
            if *st != INTACT {
                continue;
            }
            let j = j as usize;
            let y = current[j] - yi;
            let len = y.norm();
            if let Some((s0, no_fail)) = failure {
                if len - ref_len > s0 * ref_len && !(no_fail[self.i] || no_fail[j]) {
                    *st = BROKEN;
                    broke += 1;
                    continue;
                }
            }
            f(self.first + slot, j, ref_len, y, len);
        }
        broke
    }
}

/// Splits `data` into consecutive mutable pieces ending at each of `ends`.
fn split_at_ends<T>(mut data: &mut [T], ends: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut out = Vec::new();
    let mut start = 0;
    for end in ends {
        let (head, tail) = std::mem::take(&mut data).split_at_mut(end - start);
        out.push(head);
        data = tail;
        start = end;
    }
    out
}

impl<const D: usize, M: Material<D>> ForceEngine<D, M> {
    pub fn new(mut material: M, body: &Body<D>, bonds: &Bonds, rule: PartialVolume) -> Self {
        let quad = Quadrature::for_body(rule, body, bonds);
        material.setup(body, bonds, &quad);
        let n = body.len();
        let chunks = (0..n)
            .step_by(NODE_CHUNK)
            .map(|s| s..(s + NODE_CHUNK).min(n))
            .collect();
        let neighbors_in_bounds = bonds.neighbors.iter().all(|&j| (j as usize) < n);
        ForceEngine {
            material,
            quad,
            vector_kernels: true,
            neighbors_in_bounds,
            points: vec![M::Point::default(); n],
            chunks,
        }
    }

    #[inline(always)]
    fn geom(&self, b: usize, i: usize, j: usize, ref_len: f64, len: f64) -> BondGeom {
        self.quad.geom(b, i, j, ref_len, len)
    }

    /// Evaluates failure and internal force densities into `state.force`; returns the number
    /// of directed bonds broken by this evaluation.
    ///
    /// Failure is decided in the first sweep over the bonds of a step, from the bond stretch
    /// alone, which is bitwise the same seen from either end: breakage is symmetric.
    pub fn compute(&mut self, body: &Body<D>, bonds: &Bonds, state: &mut State<D>) -> u64 {
        // Dispatch once on the weight source: on uniform grids φ depends on |ξ| only and no
        // per-neighbour node data is read.
        match self.quad.uniform() {
            Some(uniform) => self.compute_with(&uniform, body, bonds, state),
            None => {
                let quad = self.quad.clone();
                self.compute_with(&quad, body, bonds, state)
            }
        }
    }

    fn compute_with<W: Weights>(
        &mut self,
        weights: &W,
        body: &Body<D>,
        bonds: &Bonds,
        state: &mut State<D>,
    ) -> u64 {
        let s0 = self.material.critical_stretch();
        let no_fail: &[bool] = &body.no_fail;
        let mut newly_broken = 0u64;
        // The AVX2 kernels, where the model has them: 3D, uniform grid, x86-64 with AVX2, and
        // neighbour indices known to be in bounds (the kernels' gathers rely on it).
        let vector =
            if D == 3 && self.vector_kernels && self.neighbors_in_bounds && simd::available() {
                self.quad.uniform()
            } else {
                None
            };
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

        if M::NEEDS_PREPASS {
            let (material, chunks) = (&self.material, &self.chunks);
            let status_chunks = split_at_ends(
                &mut state.status,
                chunks.iter().map(|c| bonds.offsets[c.end]),
            );
            let point_chunks = split_at_ends(&mut self.points, chunks.iter().map(|c| c.end));
            let current = &state.current;
            newly_broken += chunks
                .par_iter()
                .zip(status_chunks)
                .zip(point_chunks)
                .map(|((nodes, status), points)| {
                    let base = bonds.offsets[nodes.start];
                    let mut broke = 0u64;
                    for (k, i) in nodes.clone().enumerate() {
                        let r = bonds.family(i);
                        let status = &mut status[r.start - base..r.end - base];
                        if let Some(w) = &vector {
                            let mut nb = NodeBonds::of(i, flat, bonds, status, no_fail, Some(s0));
                            // SAFETY: AVX2 is available and neighbour indices are in bounds.
                            if let Some((p, nb_broken)) =
                                unsafe { material.vector_prepass(&mut nb, w) }
                            {
                                points[k] = p;
                                broke += nb_broken;
                                continue;
                            }
                        }
                        let mut acc = M::Point::default();
                        let family = Family {
                            i,
                            first: r.start,
                            neighbors: &bonds.neighbors[r.clone()],
                            ref_lengths: &bonds.ref_lengths[r.clone()],
                        };
                        broke += family.visit_intact(
                            current,
                            status,
                            Some((s0, no_fail)),
                            |b, j, ref_len, _, len| {
                                material.accumulate(&mut acc, &weights.geom(b, i, j, ref_len, len));
                            },
                        );
                        points[k] = material.finish_point(i, acc);
                    }
                    broke
                })
                .sum::<u64>();
        }

        let status_chunks = split_at_ends(
            &mut state.status,
            self.chunks.iter().map(|c| bonds.offsets[c.end]),
        );
        let force_chunks = split_at_ends(&mut state.force, self.chunks.iter().map(|c| c.end));
        let (material, points) = (&self.material, &self.points);
        let current = &state.current;
        // A two-pass model decided failure in its pre-pass.
        let failure = (!M::NEEDS_PREPASS).then_some((s0, no_fail));
        newly_broken += self
            .chunks
            .par_iter()
            .zip(status_chunks)
            .zip(force_chunks)
            .map(|((nodes, status), forces)| {
                let base = bonds.offsets[nodes.start];
                let mut broke = 0u64;
                for (k, i) in nodes.clone().enumerate() {
                    let r = bonds.family(i);
                    let status = &mut status[r.start - base..r.end - base];
                    if let Some(w) = &vector {
                        let mut nb =
                            NodeBonds::of(i, flat, bonds, status, no_fail, failure.map(|f| f.0));
                        // SAFETY: AVX2 is available and neighbour indices are in bounds.
                        if let Some((f, nb_broken)) =
                            unsafe { material.vector_force(&mut nb, w, points) }
                        {
                            forces[k] = Vector::<D>::from_fn(|a, _| f[a]);
                            broke += nb_broken;
                            continue;
                        }
                    }
                    let pi = &points[i];
                    let mut f = Vector::<D>::zeros();
                    let family = Family {
                        i,
                        first: r.start,
                        neighbors: &bonds.neighbors[r.clone()],
                        ref_lengths: &bonds.ref_lengths[r.clone()],
                    };
                    broke +=
                        family.visit_intact(current, status, failure, |b, j, ref_len, y, len| {
                            if len > 0.0 {
                                let g = weights.geom(b, i, j, ref_len, len);
                                f += y
                                    * (material.pair_force_per_length(i, j, &g, pi, &points[j])
                                        * g.vol_j);
                            }
                        });
                    forces[k] = f;
                }
                broke
            })
            .sum::<u64>();

        state.broken += newly_broken;
        newly_broken
    }

    /// Strain energy density W_i (J/m³) of every node at the state of the last `compute`.
    pub fn energy_density(&self, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> Vec<f64> {
        (0..body.len())
            .into_par_iter()
            .map(|i| {
                let pi = &self.points[i];
                let mut sum = 0.0;
                for b in bonds.family(i) {
                    if state.status[b] != INTACT {
                        continue;
                    }
                    let j = bonds.neighbors[b] as usize;
                    let len = (state.current[j] - state.current[i]).norm();
                    sum += self.material.bond_energy(
                        i,
                        &self.geom(b, i, j, bonds.ref_lengths[b], len),
                        pi,
                    );
                }
                self.material.point_energy(i, pi, sum)
            })
            .collect()
    }

    /// Peridynamic stress of node i, σ_i = Σ_j t_i⟨ξ⟩ (M ⊗ ξ) φ_ij V_j (Silling et al. 2007:
    /// the stress of a homogeneous deformation is ∫ T⟨ξ⟩ ⊗ ξ dV). Row a, column b: M_a ξ_b.
    pub fn stress(
        &self,
        body: &Body<D>,
        bonds: &Bonds,
        state: &State<D>,
        i: usize,
    ) -> [[f64; D]; D] {
        let mut sigma = [[0.0; D]; D];
        let pi = &self.points[i];
        for b in bonds.family(i) {
            if state.status[b] != INTACT {
                continue;
            }
            let j = bonds.neighbors[b] as usize;
            let y = state.current[j] - state.current[i];
            let xi = body.positions[j] - body.positions[i];
            let g = self.geom(b, i, j, bonds.ref_lengths[b], y.norm());
            let t = self.material.force_state(i, &g, pi) * g.weight();
            for a in 0..D {
                for c in 0..D {
                    sigma[a][c] += t * y[a] / g.len * xi[c];
                }
            }
        }
        sigma
    }

    /// Total strain energy Σ W_i V_i (J).
    pub fn strain_energy(&self, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> f64 {
        self.energy_density(body, bonds, state)
            .iter()
            .zip(&body.volumes)
            .map(|(w, v)| w * v)
            .sum()
    }

    /// Damage index per node: broken over initial bond volume, d = 1 − Σ μ φ V_j / Σ φ V_j
    /// (seed 000, Eq. 10).
    pub fn damage(&self, body: &Body<D>, bonds: &Bonds, state: &State<D>) -> Vec<f64> {
        (0..body.len())
            .into_par_iter()
            .map(|i| {
                let (mut broken, mut total) = (0.0, 0.0);
                for b in bonds.family(i) {
                    let j = bonds.neighbors[b] as usize;
                    let w = self.quad.phi_pair(b, i, j, bonds.ref_lengths[b]).0 * body.volumes[j];
                    total += w;
                    if state.status[b] != INTACT {
                        broken += w;
                    }
                }
                if total > 0.0 {
                    broken / total
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// Stable time step of Silling & Askari (2005): Δt < sqrt(2ρ / Σ_j C_ij w_ij) at every node,
    /// with C = c/|ξ| the linearised bond stiffness.
    pub fn stable_time_step(&self, body: &Body<D>, bonds: &Bonds) -> f64 {
        let rho = self.material.density();
        (0..body.len())
            .into_par_iter()
            .map(|i| {
                let k: f64 = bonds
                    .family(i)
                    .map(|b| {
                        let j = bonds.neighbors[b] as usize;
                        let l = bonds.ref_lengths[b];
                        self.material.bond_stiffness(l)
                            * self.quad.phi_pair(b, i, j, l).0
                            * body.volumes[j]
                    })
                    .sum();
                if k > 0.0 {
                    (2.0 * rho / k).sqrt()
                } else {
                    f64::INFINITY
                }
            })
            .reduce(|| f64::INFINITY, f64::min)
    }
}
