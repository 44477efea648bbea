//! AVX2 bond loops of the correspondence model (3D, uniform grid, one critical stretch, one
//! horizon), four bonds at a time: the pre-pass sums K = Σ ω ξ⊗ξ w and N = Σ ω η⊗ξ w
//! (seed 004, Eqs. 6–7) and the force pass sums the other halves ω φ V (B_j ξ + C1_j η) and
//! the own-half sums Σ s ξ, Σ s η (see `Correspondence` and `Material::FACTORED_OWN_HALF`).
//! Same terms, failure rule and partial-volume factor as the generic loops (`super::simd`'s
//! helpers); only the summation order differs (four lanes, then the tail), and it is fixed,
//! so results stay bitwise identical for any thread count. `tests/suite/kernels.rs` compares them
//! with the generic loop.

use super::simd::NodeBonds;
use crate::bonds::partial_volume::UniformWeights;

/// What the kernels need of the model.
#[derive(Debug, Clone, Copy)]
pub struct CorrespondenceLaw<'a> {
    /// Reference positions, flat x, y, z.
    pub reference: &'a [f64],
    /// The (uniform) horizon δ.
    pub horizon: f64,
    /// ω = δ/|ξ| instead of 1.
    pub inverse_influence: bool,
    /// Zero-energy control: the C1 η terms (C1 is zero without it).
    pub control: bool,
}

impl CorrespondenceLaw<'_> {
    #[inline(always)]
    fn omega(&self, l: f64) -> f64 {
        if self.inverse_influence {
            self.horizon / l
        } else {
            1.0
        }
    }

    /// Reference bond vector ξ = x_j − x_i.
    #[inline(always)]
    fn xi(&self, i: usize, j: usize) -> [f64; 3] {
        let r = self.reference;
        [
            r[3 * j] - r[3 * i],
            r[3 * j + 1] - r[3 * i + 1],
            r[3 * j + 2] - r[3 * i + 2],
        ]
    }
}

/// Pre-pass of node i: K and N (column-major 3×3) over its intact bonds, deciding failure like
/// the generic loop; returns (K, N, bonds broken).
///
/// # Safety
/// `simd::available()`; every neighbour index below `nb.current.len() / 3` and
/// `law.reference.len() / 3`.
pub unsafe fn correspondence_sums(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
) -> ([f64; 9], [f64; 9], u64) {
    #[cfg(target_arch = "x86_64")]
    {
        avx::sums(nb, law, w)
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("available() is false off x86-64")
}

/// Force pass of node i: (Σ other halves, Σ s ξ, Σ s η) with s = ω φ V over its intact bonds;
/// `points` holds each node's point state as `stride` f64 starting with B then C1 (column-major
/// 3×3 each).
///
/// # Safety
/// As for `correspondence_sums`; `points.len() >= stride * nodes` and `stride >= 18`.
pub unsafe fn correspondence_force(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
    points: &[f64],
    stride: usize,
) -> ([f64; 3], [f64; 3], [f64; 3]) {
    #[cfg(target_arch = "x86_64")]
    {
        avx::force(nb, law, w, points, stride)
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("available() is false off x86-64")
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::*;
    use crate::material::simd::avx::{bond_vectors, fail_and_keep, intact, own_position, phi, sum};
    use crate::material::simd::tail;
    use std::arch::x86_64::*;

    /// Bond vectors of bonds b..b+4 in the flat positions `base` (reference or current),
    /// less the node's own position `origin` (masked loads: never past a node).
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn rows(
        nb: &NodeBonds,
        base: *const f64,
        b: usize,
        origin: [__m256d; 3],
    ) -> [__m256d; 3] {
        let mask = _mm256_set_epi64x(0, -1, -1, -1);
        let row =
            |lane: usize| _mm256_maskload_pd(base.add(3 * nb.neighbors[b + lane] as usize), mask);
        let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
        let (t0, t1) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
        let (t2, t3) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
        [
            _mm256_sub_pd(_mm256_permute2f128_pd::<0x20>(t0, t2), origin[0]),
            _mm256_sub_pd(_mm256_permute2f128_pd::<0x20>(t1, t3), origin[1]),
            _mm256_sub_pd(_mm256_permute2f128_pd::<0x31>(t0, t2), origin[2]),
        ]
    }

    /// Reference bond vectors ξ of bonds b..b+4.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn reference_vectors(
        nb: &NodeBonds,
        law: &CorrespondenceLaw,
        b: usize,
        xi: [__m256d; 3],
    ) -> [__m256d; 3] {
        rows(nb, law.reference.as_ptr(), b, xi)
    }

    /// ω(|ξ|) φ(|ξ|) V on four lanes, zero outside `keep`: the generic ω · (φ μ V) with μ = 1.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn weight(
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        l: __m256d,
        keep: __m256d,
    ) -> __m256d {
        let pv = _mm256_mul_pd(phi(w, l), _mm256_set1_pd(w.node.volume));
        let s = if law.inverse_influence {
            _mm256_mul_pd(_mm256_div_pd(_mm256_set1_pd(law.horizon), l), pv)
        } else {
            pv
        };
        _mm256_and_pd(s, keep)
    }

    /// The node's own reference position, broadcast.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn own_reference(law: &CorrespondenceLaw, i: usize) -> [__m256d; 3] {
        [
            _mm256_set1_pd(law.reference[3 * i]),
            _mm256_set1_pd(law.reference[3 * i + 1]),
            _mm256_set1_pd(law.reference[3 * i + 2]),
        ]
    }

    /// Entries 0..18 (B then C1) of the point states of the neighbours of bonds b..b+4, one
    /// lane per bond: contiguous loads per neighbour, transposed four by four (cheaper than
    /// gathers).
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn neighbour_entries(
        nb: &NodeBonds,
        b: usize,
        base: *const f64,
        stride: usize,
    ) -> [__m256d; 18] {
        let p = [
            base.add(nb.neighbors[b] as usize * stride),
            base.add(nb.neighbors[b + 1] as usize * stride),
            base.add(nb.neighbors[b + 2] as usize * stride),
            base.add(nb.neighbors[b + 3] as usize * stride),
        ];
        let mut e = [_mm256_setzero_pd(); 18];
        for q in 0..4 {
            let (r0, r1) = (
                _mm256_loadu_pd(p[0].add(4 * q)),
                _mm256_loadu_pd(p[1].add(4 * q)),
            );
            let (r2, r3) = (
                _mm256_loadu_pd(p[2].add(4 * q)),
                _mm256_loadu_pd(p[3].add(4 * q)),
            );
            let (t0, t1) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
            let (t2, t3) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
            e[4 * q] = _mm256_permute2f128_pd::<0x20>(t0, t2);
            e[4 * q + 1] = _mm256_permute2f128_pd::<0x20>(t1, t3);
            e[4 * q + 2] = _mm256_permute2f128_pd::<0x31>(t0, t2);
            e[4 * q + 3] = _mm256_permute2f128_pd::<0x31>(t1, t3);
        }
        let last = |k: usize| _mm_loadu_pd(p[k].add(16));
        let (a, c) = (
            _mm256_set_m128d(last(2), last(0)),
            _mm256_set_m128d(last(3), last(1)),
        );
        e[16] = _mm256_unpacklo_pd(a, c);
        e[17] = _mm256_unpackhi_pd(a, c);
        e
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn sums(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
    ) -> ([f64; 9], [f64; 9], u64) {
        let i = nb.i;
        let yi = own_position(nb);
        let xi_i = own_reference(law, i);
        let zero = _mm256_setzero_pd();
        // Column-major: entry (r, c) at 3c + r, as `SMatrix`.
        let mut k = [zero; 9];
        let mut n = [zero; 9];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let [dx, dy, dz, len] = bond_vectors(nb, b, yi);
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = fail_and_keep(nb, b, len, l, &mut broke);
            let s = weight(law, w, l, keep);
            let xi = reference_vectors(nb, law, b, xi_i);
            let y = [dx, dy, dz];
            // K += (ξ s) ξᵀ, N += (η s) ξᵀ, as the generic `accumulate`.
            for r in 0..3 {
                let xs = _mm256_mul_pd(xi[r], s);
                let es = _mm256_mul_pd(_mm256_sub_pd(y[r], xi[r]), s);
                for c in 0..3 {
                    k[3 * c + r] = _mm256_add_pd(k[3 * c + r], _mm256_mul_pd(xs, xi[c]));
                    n[3 * c + r] = _mm256_add_pd(n[3 * c + r], _mm256_mul_pd(es, xi[c]));
                }
            }
            b += 4;
        }
        let mut ks = [0.0; 9];
        let mut ns = [0.0; 9];
        for e in 0..9 {
            ks[e] = sum(k[e]);
            ns[e] = sum(n[e]);
        }
        broke += tail(nb, b, |j, l, d, _| {
            let s = law.omega(l) * (w.phi(l) * w.node.volume);
            let xi = law.xi(i, j);
            for r in 0..3 {
                let (xs, es) = (xi[r] * s, (d[r] - xi[r]) * s);
                for c in 0..3 {
                    ks[3 * c + r] += xs * xi[c];
                    ns[3 * c + r] += es * xi[c];
                }
            }
        });
        (ks, ns, broke)
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn force(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        points: &[f64],
        stride: usize,
    ) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let i = nb.i;
        let yi = own_position(nb);
        let xi_i = own_reference(law, i);
        let zero = _mm256_setzero_pd();
        let (mut other, mut sxi, mut seta) = ([zero; 3], [zero; 3], [zero; 3]);
        let mut broke = 0;
        let mut b = 0;
        let base = points.as_ptr();
        while b + 4 <= nb.neighbors.len() {
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            // This pass decides no failure: only |y| > 0 matters, and |y|² > 0 says the same
            // without a square root.
            // (`fail_and_keep` without a critical stretch: intact and of non-zero length.)
            let [dx, dy, dz] = rows(nb, nb.current.as_ptr(), b, yi);
            let keep = if nb.s0.is_none() {
                let square = _mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                    _mm256_mul_pd(dz, dz),
                );
                _mm256_and_pd(
                    intact(nb.status, b),
                    _mm256_cmp_pd::<_CMP_GT_OQ>(square, _mm256_setzero_pd()),
                )
            } else {
                fail_and_keep(nb, b, bond_vectors(nb, b, yi)[3], l, &mut broke)
            };
            let s = weight(law, w, l, keep);
            let xi = reference_vectors(nb, law, b, xi_i);
            let eta = [
                _mm256_sub_pd(dx, xi[0]),
                _mm256_sub_pd(dy, xi[1]),
                _mm256_sub_pd(dz, xi[2]),
            ];
            for a in 0..3 {
                sxi[a] = _mm256_add_pd(sxi[a], _mm256_mul_pd(xi[a], s));
                seta[a] = _mm256_add_pd(seta[a], _mm256_mul_pd(eta[a], s));
            }
            // The neighbours' B and C1 (entries 0..18 of their point states), lane-wise.
            let e = neighbour_entries(nb, b, base, stride);
            // B_j ξ (+ C1_j η), row by row, in the generic matrix–vector order.
            let mut t = [zero; 3];
            for (r, t) in t.iter_mut().enumerate() {
                let mut v = _mm256_mul_pd(e[r], xi[0]);
                v = _mm256_add_pd(v, _mm256_mul_pd(e[3 + r], xi[1]));
                v = _mm256_add_pd(v, _mm256_mul_pd(e[6 + r], xi[2]));
                if law.control {
                    let mut u = _mm256_mul_pd(e[9 + r], eta[0]);
                    u = _mm256_add_pd(u, _mm256_mul_pd(e[12 + r], eta[1]));
                    u = _mm256_add_pd(u, _mm256_mul_pd(e[15 + r], eta[2]));
                    v = _mm256_add_pd(v, u);
                }
                *t = v;
            }
            for a in 0..3 {
                other[a] = _mm256_add_pd(other[a], _mm256_mul_pd(t[a], s));
            }
            b += 4;
        }
        let mut f = [sum(other[0]), sum(other[1]), sum(other[2])];
        let mut sx = [sum(sxi[0]), sum(sxi[1]), sum(sxi[2])];
        let mut se = [sum(seta[0]), sum(seta[1]), sum(seta[2])];
        broke += tail(nb, b, |j, l, d, _| {
            let s = law.omega(l) * (w.phi(l) * w.node.volume);
            let xi = law.xi(i, j);
            let eta = [d[0] - xi[0], d[1] - xi[1], d[2] - xi[2]];
            let p = &points[j * stride..j * stride + 18];
            for r in 0..3 {
                sx[r] += xi[r] * s;
                se[r] += eta[r] * s;
                let mut v = p[r] * xi[0] + p[3 + r] * xi[1] + p[6 + r] * xi[2];
                if law.control {
                    v += p[9 + r] * eta[0] + p[12 + r] * eta[1] + p[15 + r] * eta[2];
                }
                f[r] += v * s;
            }
        });
        debug_assert_eq!(
            broke, 0,
            "the correspondence force pass does not decide failure"
        );
        (f, sx, se)
    }
}
