//! The PMB bond loop four bonds at a time (AVX2, 2D and 3D) on grids whose nodes differ:
//! dual-horizon and multi-grid PD (seed 003 §2.2–2.3: a horizon, a micromodulus and a
//! critical stretch per node) and non-uniform cells (NB-NUG, free meshes: a volume and a cell
//! size per node). Each lane gathers the other end's constants as it gathers its position, and
//! each half of a bond breaks on its own node's critical stretch. The laws are the generic
//! loop's: the pair weight ½(c_i φ_ij μ_ij + c_j φ_ji μ_ji) (`Pmb::pair_weight`, seed 003
//! Eq. 8), the HHB factor with the neighbour's cell (seed 000 Eqs. 12–14), the halves' failure
//! of `CriticalStretch`; only the order of the sums differs (four lanes, then the tail), and it
//! is fixed, so results stay bitwise identical for any thread count. `tests/suite/kernels.rs`
//! checks the kernel against the generic loop.

use super::simd::NodeBonds;
use crate::bonds::partial_volume::NodeWeight;
use crate::bonds::PartialVolume;
use crate::damage::break_halves;
use crate::per_node::PerNode;
use crate::state::BROKEN;

/// The critical stretch of a node.
#[derive(Debug, Clone, Copy)]
pub enum CriticalStretches<'a> {
    Uniform(f64),
    PerNode(&'a [f64]),
}

impl CriticalStretches<'_> {
    #[inline(always)]
    fn at(&self, k: usize) -> f64 {
        match *self {
            CriticalStretches::Uniform(s0) => s0,
            CriticalStretches::PerNode(s0) => s0[k],
        }
    }
}

/// What the kernel reads of the grid and the damage law besides the families.
#[derive(Debug, Clone, Copy)]
pub struct NodeConstants<'a> {
    /// `Hhb` or `None` (the exact rule's stored fractions take the generic loop).
    pub rule: PartialVolume,
    /// Every node's volume, cell and horizon (ghosts included).
    pub nodes: &'a [NodeWeight],
    pub s0: CriticalStretches<'a>,
}

/// The PMB constants of the nodes: c0 per unit volume² and the horizon of the conical
/// profile, per node or one for all (`horizon`: the reference one of a uniform c0).
#[derive(Debug, Clone, Copy)]
pub struct PmbNodes<'a> {
    pub c0: &'a PerNode,
    pub horizons: &'a PerNode,
    pub horizon: f64,
    pub conical: bool,
}

impl PmbNodes<'_> {
    /// c(ξ) of node k's half at |ξ| = l (`Pmb::c`).
    #[inline(always)]
    fn c(&self, k: usize, l: f64) -> f64 {
        match self.conical {
            true => self.c0.at(k) * (1.0 - l / self.horizons.at(k)).max(0.0),
            false => self.c0.at(k),
        }
    }

    /// The pair weight of a bond from its halves' φ μ (`Pmb::pair_weight`, dual coupling).
    #[inline(always)]
    fn pair_weight(&self, (i, j): (usize, usize), l: f64, pm_ij: f64, pm_ji: f64) -> f64 {
        match self.c0 {
            PerNode::Uniform(c0) => {
                let c = match self.conical {
                    true => c0 * (1.0 - l / self.horizon).max(0.0),
                    false => *c0,
                };
                c * 0.5 * (pm_ij + pm_ji)
            }
            PerNode::Varying(_) => 0.5 * (self.c(i, l) * pm_ij + self.c(j, l) * pm_ji),
        }
    }
}

/// PMB force density on node i and the bond halves it broke, on a grid of per-node constants.
///
/// # Safety
/// `simd::available()` must be true, every neighbour index below `current.len() / nb.dim`
/// and below the lengths of `w.nodes` and of the per-node arrays of `pmb` and `w.s0`.
pub unsafe fn pmb_force(nb: &mut NodeBonds, pmb: &PmbNodes, w: &NodeConstants) -> ([f64; 3], u64) {
    debug_assert!(nb.softening.is_none() && nb.work.is_none());
    debug_assert!(w.rule != PartialVolume::Exact);
    #[cfg(target_arch = "x86_64")]
    {
        if nb.dim == 2 {
            avx::pmb_force::<2>(nb, pmb, w)
        } else {
            avx::pmb_force::<3>(nb, pmb, w)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("simd::available() is false off x86-64")
}

/// The generic loop's decision and force for bonds `from..` of the family (the lanes' tail).
fn tail(
    nb: &mut NodeBonds,
    from: usize,
    pmb: &PmbNodes,
    w: &NodeConstants,
    f: &mut [f64; 3],
) -> u64 {
    let i = nb.i;
    let own = nb.position(i);
    let (cell_i, s0_i) = (&w.nodes[i], w.s0.at(i));
    let mut broke = 0;
    for b in from..nb.neighbors.len() {
        if nb.status[b] == BROKEN {
            continue;
        }
        let j = nb.neighbors[b] as usize;
        let y = nb.position(j);
        let d = [y[0] - own[0], y[1] - own[1], y[2] - own[2]];
        let len = super::simd::length(&d);
        let l = nb.ref_lengths[b];
        let (over_i, over_j) = (len - l > s0_i * l, len - l > w.s0.at(j) * l);
        if (over_i || over_j) && !(nb.no_fail[i] || nb.no_fail[j]) {
            broke += break_halves(&mut nb.status[b], over_i, over_j);
        }
        let st = nb.status[b];
        if st == BROKEN || len <= 0.0 {
            continue;
        }
        let cell_j = &w.nodes[j];
        let mu = |bit: u8| if st & bit == 0 { 1.0 } else { 0.0 };
        let pm_ij = cell_j.phi(w.rule, l, cell_i.horizon) * mu(crate::state::OWN_BROKEN);
        let pm_ji = cell_i.phi(w.rule, l, cell_j.horizon) * mu(crate::state::OTHER_BROKEN);
        let per_length = pmb.pair_weight((i, j), l, pm_ij, pm_ji) * (len - l) / (l * len);
        let coef = per_length * cell_j.volume;
        for a in 0..3 {
            f[a] += coef * d[a];
        }
    }
    broke
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::*;
    use crate::material::simd::avx::{
        add_force, bond_vectors_in, conical, gather, neighbours, own_position, prefetch,
        status_lanes, sum,
    };
    use std::arch::x86_64::*;

    /// The neighbours' cells, transposed: volume, half cell, inverse cell, horizon per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cells(nodes: &[NodeWeight], js: &[usize; 4]) -> [__m256d; 4] {
        // `NodeWeight` is four f64 in its declared order (checked in `pmb_force`).
        let row = |k: usize| _mm256_loadu_pd(&nodes[js[k]] as *const NodeWeight as *const f64);
        let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
        let (t0, t1) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
        let (t2, t3) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
        [
            _mm256_permute2f128_pd::<0x20>(t0, t2),
            _mm256_permute2f128_pd::<0x20>(t1, t3),
            _mm256_permute2f128_pd::<0x31>(t0, t2),
            _mm256_permute2f128_pd::<0x31>(t1, t3),
        ]
    }

    /// `phi` on four lanes: a horizon and a cell (half size, inverse size) per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn phi4(
        rule: PartialVolume,
        l: __m256d,
        horizon: __m256d,
        half_cell: __m256d,
        inv_cell: __m256d,
    ) -> __m256d {
        match rule {
            PartialVolume::Hhb => _mm256_min_pd(
                _mm256_max_pd(
                    _mm256_mul_pd(
                        _mm256_sub_pd(_mm256_add_pd(horizon, half_cell), l),
                        inv_cell,
                    ),
                    _mm256_setzero_pd(),
                ),
                _mm256_set1_pd(1.0),
            ),
            PartialVolume::None | PartialVolume::Exact => {
                _mm256_and_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(l, horizon), _mm256_set1_pd(1.0))
            }
        }
    }

    /// c0 g(l) on four lanes (`PmbNodes::c`): g = max(1 − l/h, 0) when conical.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn c4(is_conical: bool, c0: __m256d, l: __m256d, horizon: __m256d) -> __m256d {
        match is_conical {
            true => _mm256_mul_pd(c0, conical(l, horizon)),
            false => c0,
        }
    }

    /// Lanes where `st & bit == 0`, as 1.0 (else 0.0).
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn intact_half(st: __m256i, bit: u8) -> __m256d {
        let clear = _mm256_cmpeq_epi64(
            _mm256_and_si256(st, _mm256_set1_epi64x(bit as i64)),
            _mm256_setzero_si256(),
        );
        _mm256_and_pd(_mm256_castsi256_pd(clear), _mm256_set1_pd(1.0))
    }

    /// Breaks the halves of lanes b..b+4 set in `own` (node i's) and `other` (the neighbour's)
    /// unless an end is no-fail. Rare: out of line.
    #[cold]
    #[inline(never)]
    fn break_lanes(nb: &mut NodeBonds, b: usize, (own, other): (i32, i32), broke: &mut u64) {
        for lane in 0..4 {
            let (o, t) = (own & (1 << lane) != 0, other & (1 << lane) != 0);
            let j = nb.neighbors[b + lane] as usize;
            if (o || t) && !(nb.no_fail[nb.i] || nb.no_fail[j]) {
                *broke += break_halves(&mut nb.status[b + lane], o, t);
            }
        }
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn pmb_force<const D: usize>(
        nb: &mut NodeBonds,
        pmb: &PmbNodes,
        w: &NodeConstants,
    ) -> ([f64; 3], u64) {
        const {
            assert!(std::mem::size_of::<NodeWeight>() == 4 * std::mem::size_of::<f64>());
        }
        debug_assert_eq!(nb.dim, D);
        let i = nb.i;
        let yi = own_position(nb);
        let cell_i = w.nodes[i];
        let (h_i, half_i, inv_i) = (
            _mm256_set1_pd(cell_i.horizon),
            _mm256_set1_pd(cell_i.half_cell),
            _mm256_set1_pd(cell_i.inv_cell),
        );
        let s0_i = _mm256_set1_pd(w.s0.at(i));
        let (c0_i, hc_i) = (
            _mm256_set1_pd(pmb.c0.at(i)),
            _mm256_set1_pd(pmb.horizons.at(i)),
        );
        let all_broken = _mm256_set1_epi64x(BROKEN as i64);
        let half = _mm256_set1_pd(0.5);
        let mut acc = [_mm256_setzero_pd(); 3];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let [dx, dy, dz, len] = bond_vectors_in::<D>(nb, b, yi);
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let js = neighbours(nb, b);
            // Each half breaks on its own node's s0 (`CriticalStretch`, seed 003).
            let ext = _mm256_sub_pd(len, l);
            let s0_j = match w.s0 {
                CriticalStretches::Uniform(s0) => _mm256_set1_pd(s0),
                CriticalStretches::PerNode(s0) => gather(s0, &js),
            };
            let broken =
                _mm256_castsi256_pd(_mm256_cmpeq_epi64(status_lanes(nb.status, b), all_broken));
            let over = |s0: __m256d| {
                _mm256_movemask_pd(_mm256_andnot_pd(
                    broken,
                    _mm256_cmp_pd::<_CMP_GT_OQ>(ext, _mm256_mul_pd(s0, l)),
                ))
            };
            let (own, other) = (over(s0_i), over(s0_j));
            if own | other != 0 {
                break_lanes(nb, b, (own, other), &mut broke);
            }
            let st = status_lanes(nb.status, b);
            let keep = _mm256_andnot_pd(
                _mm256_castsi256_pd(_mm256_cmpeq_epi64(st, all_broken)),
                _mm256_cmp_pd::<_CMP_GT_OQ>(len, _mm256_setzero_pd()),
            );
            let [vol_j, half_j, inv_j, h_j] = cells(w.nodes, &js);
            let pm_ij = _mm256_mul_pd(
                phi4(w.rule, l, h_i, half_j, inv_j),
                intact_half(st, crate::state::OWN_BROKEN),
            );
            let pm_ji = _mm256_mul_pd(
                phi4(w.rule, l, h_j, half_i, inv_i),
                intact_half(st, crate::state::OTHER_BROKEN),
            );
            // `PmbNodes::pair_weight`'s arithmetic.
            let weight = match pmb.c0 {
                PerNode::Uniform(c0) => {
                    let c = c4(
                        pmb.conical,
                        _mm256_set1_pd(*c0),
                        l,
                        _mm256_set1_pd(pmb.horizon),
                    );
                    _mm256_mul_pd(_mm256_mul_pd(c, half), _mm256_add_pd(pm_ij, pm_ji))
                }
                PerNode::Varying(c0) => {
                    let hc_j = match pmb.horizons {
                        PerNode::Uniform(h) => _mm256_set1_pd(*h),
                        PerNode::Varying(h) => gather(h, &js),
                    };
                    let c_i = c4(pmb.conical, c0_i, l, hc_i);
                    let c_j = c4(pmb.conical, gather(c0, &js), l, hc_j);
                    _mm256_mul_pd(
                        half,
                        _mm256_add_pd(_mm256_mul_pd(c_i, pm_ij), _mm256_mul_pd(c_j, pm_ji)),
                    )
                }
            };
            let per_length = _mm256_div_pd(_mm256_mul_pd(weight, ext), _mm256_mul_pd(l, len));
            add_force(
                &mut acc,
                _mm256_mul_pd(per_length, vol_j),
                keep,
                [dx, dy, dz],
            );
            b += 4;
        }
        let mut f = [sum(acc[0]), sum(acc[1]), sum(acc[2])];
        broke += tail(nb, b, pmb, w, &mut f);
        (f, broke)
    }
}
