//! AVX2 + FMA bond loops of the correspondence model (3D, uniform grid, one horizon), four
//! bonds at a time: the pre-pass sums N = Σ ω η⊗ξ w and, when the caller cannot reuse it
//! (`Sums::kept`), K = Σ ω ξ⊗ξ w (seed 004, Eqs. 6–7);
//! the force pass under one critical stretch sums the other halves ω φ V (B_j ξ + C1_j η) and
//! the own-half sums Σ s ξ, Σ s η (see `Correspondence` and `Material::FACTORED_OWN_HALF`);
//! the force pass under one critical energy evaluates both halves of each bond,
//! T = ω φ (B_i ξ + C1_i η) + ω φ (B_j ξ + C1_j η) (Eq. 8 with Eq. 14 through B = A − C1 H),
//! records its work w += ½ (T_prev + T)·Δη in the bond's vector work record [w, T] (Foster,
//! Silling & Chen 2011; seed 002 Eq. 6; seed 004 Eqs. 16–18, `damage::critical_energy`) and
//! breaks the bonds with w ≥ w_c φ̄.
//!
//! Same terms, failure rules and partial-volume factor as the generic loops; the sums of
//! products are fused multiply–adds (one rounding instead of two), and the order of a node's
//! bond terms is four lanes, then the tail. Both are fixed, so results stay bitwise identical
//! for any thread count; they differ from the generic loop by round-off (10⁻¹⁴ of the forces),
//! and the quantities that decide failure (|y|, the stretch, the work update from the pair
//! force) are computed in the generic loop's order. The kernels run only where the CPU has
//! both AVX2 and FMA (`simd::fma_available`). `tests/suite/kernels.rs` compares them with the
//! generic loop.
//!
//! Loads: a neighbour's (x, y, z), B and C1 are read as 128-bit pairs, two bonds per 256-bit
//! register, and interleaved with in-lane unpacks (no lane-crossing shuffle, never a byte past
//! a node's record).

use super::simd::NodeBonds;
use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::PartialVolume;
use crate::damage::critical_energy::UniformCriticalEnergy;

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

/// Where the force kernels find a node's entries in its point record (3D, in f64 words; the
/// layout of `CorrespondencePoint`, checked against these at compile time): B column-major
/// from 0, C1 from `RECORD_C1`, the current position from `RECORD_Y`, the reference position
/// from `RECORD_X`. The kernels read up to word `RECORD_READ` (exclusive) of a record.
pub const RECORD_C1: usize = 9;
pub const RECORD_Y: usize = 18;
pub const RECORD_X: usize = 21;
pub const RECORD_READ: usize = 24;

/// Families of up to this many bonds get `Sums::kept`.
pub const KEPT_BITS: usize = 256;

/// What the pre-pass of a node sums.
#[derive(Debug, Clone, Copy)]
pub struct Sums {
    /// K = Σ ω ξ⊗ξ w, column-major, and Σ s ξ (s = ω φ V; both zero unless asked for).
    pub k: [f64; 9],
    pub sum_xi: [f64; 3],
    /// N = Σ ω η⊗ξ w, column-major.
    pub n: [f64; 9],
    /// Bonds broken by this pass.
    pub broke: u64,
    /// Bit b set when bond b carried force (intact after this pass, of non-zero length):
    /// the exact set K is summed over, for families of up to `KEPT_BITS` bonds.
    pub kept: Option<[u64; 4]>,
}

/// Pre-pass of node i: N (and K and Σ s ξ if `with_k`; column-major 3×3) over its
/// intact bonds, deciding failure like the generic loop, and which bonds carried force.
///
/// # Safety
/// `simd::fma_available()`; every neighbour index below `nb.current.len() / 3` and
/// `law.reference.len() / 3`.
pub unsafe fn correspondence_sums(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
    with_k: bool,
) -> Sums {
    #[cfg(target_arch = "x86_64")]
    {
        let hhb = w.rule == PartialVolume::Hhb;
        match (nb.s0.is_some(), with_k) {
            (true, true) => avx::with_weights!(avx::sums, [true, true], hhb, law, (nb, law, w)),
            (true, false) => avx::with_weights!(avx::sums, [true, false], hhb, law, (nb, law, w)),
            (false, true) => avx::with_weights!(avx::sums, [false, true], hhb, law, (nb, law, w)),
            (false, false) => {
                avx::with_weights!(avx::sums, [false, false], hhb, law, (nb, law, w))
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("fma_available() is false off x86-64")
}

/// Force pass of node i: the sum of the other halves ω φ V (B_j ξ + C1_j η) over its intact
/// bonds; `points` holds each node's point state as `stride` f64 laid out as the `RECORD_*`
/// offsets say, from this evaluation's pre-pass (C1 symmetric: the kernels read its lower
/// triangle).
///
/// # Safety
/// As for `correspondence_sums`; `points.len() >= stride * nodes` and
/// `stride >= RECORD_READ`.
pub unsafe fn correspondence_force(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
    points: &[f64],
    stride: usize,
) -> ([f64; 3], [f64; 3]) {
    #[cfg(target_arch = "x86_64")]
    {
        let hhb = w.rule == PartialVolume::Hhb;
        if law.control {
            avx::with_weights!(avx::force, [true], hhb, law, (nb, law, w, points, stride))
        } else {
            avx::with_weights!(avx::force, [false], hhb, law, (nb, law, w, points, stride))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("fma_available() is false off x86-64")
}

/// Force pass of node i under a uniform critical-energy law: the force density of the bonds
/// that hold and the bonds broken, each bond's work recorded in `nb.history` (four words per
/// bond: w, T) from the previous positions `nb.previous`.
///
/// # Safety
/// As for `correspondence_force`; `nb.history.len() == 4 * nb.neighbors.len()` and
/// `nb.previous.len() == nb.current.len()`.
pub unsafe fn correspondence_force_work(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
    energy: &UniformCriticalEnergy,
    points: &[f64],
    stride: usize,
) -> ([f64; 3], u64) {
    debug_assert_eq!(nb.history.len(), 4 * nb.neighbors.len());
    debug_assert_eq!(nb.previous.len(), nb.current.len());
    #[cfg(target_arch = "x86_64")]
    {
        let hhb = w.rule == PartialVolume::Hhb;
        if law.control {
            avx::with_weights!(
                avx::force_work,
                [true],
                hhb,
                law,
                (nb, law, w, energy, points, stride)
            )
        } else {
            avx::with_weights!(
                avx::force_work,
                [false],
                hhb,
                law,
                (nb, law, w, energy, points, stride)
            )
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("fma_available() is false off x86-64")
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::*;
    use crate::damage::{DamageLaw, Work};
    use crate::material::simd::avx::{intact, phi_of, prefetch, sum};
    use crate::material::simd::{length, tail};
    use crate::state::{BROKEN, INTACT};
    use std::arch::x86_64::*;

    /// Calls `kernel::<FLAGS.., HHB, INVERSE>(args..)` with the partial-volume rule (`HHB`)
    /// and the influence function (`INVERSE`: ω = δ/|ξ|) as compile-time flags: tested inside
    /// the bond loop, they were not hoisted out of it.
    macro_rules! with_weights {
        ($($kernel:ident)::+, [$($flag:expr),*], $hhb:expr, $law:expr, ($($arg:expr),*)) => {
            match ($hhb, $law.inverse_influence) {
                (true, true) => $($kernel)::+::<$($flag,)* true, true>($($arg),*),
                (true, false) => $($kernel)::+::<$($flag,)* true, false>($($arg),*),
                (false, true) => $($kernel)::+::<$($flag,)* false, true>($($arg),*),
                (false, false) => $($kernel)::+::<$($flag,)* false, false>($($arg),*),
            }
        };
    }
    pub(super) use with_weights;

    /// The neighbours of bonds b..b+4.
    #[inline(always)]
    unsafe fn neighbours(nb: &NodeBonds, b: usize) -> [usize; 4] {
        let p = nb.neighbors.as_ptr().add(b);
        [
            *p as usize,
            *p.add(1) as usize,
            *p.add(2) as usize,
            *p.add(3) as usize,
        ]
    }

    /// Entries k and k + 1 of the records at p[0..4], one lane per record: 128-bit loads of
    /// records 0 and 2 into one register, 1 and 3 into another, then in-lane unpacks.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn pair(p: &[*const f64; 4], k: usize) -> (__m256d, __m256d) {
        let even = _mm256_loadu2_m128d(p[2].add(k), p[0].add(k));
        let odd = _mm256_loadu2_m128d(p[3].add(k), p[1].add(k));
        (_mm256_unpacklo_pd(even, odd), _mm256_unpackhi_pd(even, odd))
    }

    /// The neighbours' current and reference positions (y, x) from their records, one lane
    /// per neighbour, and with zero-energy control C1's entry (2, 2), which shares a 128-bit
    /// pair with y₀.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn positions<const CONTROL: bool>(
        p: &[*const f64; 4],
    ) -> ([__m256d; 3], [__m256d; 3], __m256d) {
        if CONTROL {
            let (c22, y0) = pair(p, RECORD_Y - 1);
            let (y1, y2) = pair(p, RECORD_Y + 1);
            let (x0, _) = pair(p, RECORD_X);
            let (x1, x2) = pair(p, RECORD_X + 1);
            ([y0, y1, y2], [x0, x1, x2], c22)
        } else {
            let (y0, y1) = pair(p, RECORD_Y);
            let (y2, x0) = pair(p, RECORD_Y + 2);
            let (x1, x2) = pair(p, RECORD_X + 1);
            ([y0, y1, y2], [x0, x1, x2], _mm256_setzero_pd())
        }
    }

    /// acc += B u + C1 v with the neighbours' B and C1 (`c22` from `positions`), one lane per
    /// neighbour. C1 is symmetric (λ tr(K⁻¹) I + 2μ K⁻¹ of a symmetric K, or c_s I), so only
    /// its lower triangle is read: 11 pairs of entries instead of 13 with the positions.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn add_matrices<const CONTROL: bool>(
        p: &[*const f64; 4],
        u: &[__m256d; 3],
        v: &[__m256d; 3],
        c22: __m256d,
        acc: &mut [__m256d; 3],
    ) {
        // B column-major: entry m is (m % 3, m / 3).
        for q in 0..4 {
            let (e0, e1) = pair(p, 2 * q);
            for (m, e) in [(2 * q, e0), (2 * q + 1, e1)] {
                acc[m % 3] = _mm256_fmadd_pd(e, u[m / 3], acc[m % 3]);
            }
        }
        let (b22, c00) = pair(p, 8);
        acc[2] = _mm256_fmadd_pd(b22, u[2], acc[2]);
        if CONTROL {
            let (c10, c20) = pair(p, RECORD_C1 + 1);
            let (c11, c21) = pair(p, RECORD_C1 + 4);
            add_symmetric(&[c00, c10, c20, c11, c21, c22], v, acc);
        }
    }

    /// Words of C1's lower triangle (0,0), (1,0), (2,0), (1,1), (2,1), (2,2) in a record,
    /// from `RECORD_C1` (column-major).
    const C1_LOWER: [usize; 6] = [0, 1, 2, 4, 5, 8];

    /// acc += C v for a symmetric C given by its lower triangle (the order of `C1_LOWER`),
    /// each row in column order.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn add_symmetric(c: &[__m256d; 6], v: &[__m256d; 3], acc: &mut [__m256d; 3]) {
        let rows = [[c[0], c[1], c[2]], [c[1], c[3], c[4]], [c[2], c[4], c[5]]];
        for (r, row) in rows.iter().enumerate() {
            for (e, v) in row.iter().zip(v) {
                acc[r] = _mm256_fmadd_pd(*e, *v, acc[r]);
            }
        }
    }

    /// Prefetches the three cache lines of each record the force kernels read (words
    /// 0..`RECORD_READ` of a 64-byte-aligned record).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn prefetch_records(points: *const f64, stride: usize, n: [usize; 4]) {
        for k in n {
            let record = points.add(k * stride) as *const i8;
            _mm_prefetch::<_MM_HINT_T0>(record);
            _mm_prefetch::<_MM_HINT_T0>(record.add(64));
            _mm_prefetch::<_MM_HINT_T0>(record.add(128));
        }
    }

    /// (x, y, z) of the nodes `n` in the flat positions `base`, less `origin`, one lane per
    /// node: (x, y) and (y, z) pairs, so that no load reads past a node.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn rows(base: *const f64, n: [usize; 4], origin: &[__m256d; 3]) -> [__m256d; 3] {
        let p = n.map(|k| base.add(3 * k));
        let (x, _) = pair(&p, 0);
        let (y, z) = pair(&p, 1);
        [
            _mm256_sub_pd(x, origin[0]),
            _mm256_sub_pd(y, origin[1]),
            _mm256_sub_pd(z, origin[2]),
        ]
    }

    /// Node i's (x, y, z) in the flat positions `base`, broadcast.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn own(base: *const f64, i: usize) -> [__m256d; 3] {
        [
            _mm256_set1_pd(*base.add(3 * i)),
            _mm256_set1_pd(*base.add(3 * i + 1)),
            _mm256_set1_pd(*base.add(3 * i + 2)),
        ]
    }

    /// |y|² in the generic loop's order, (x² + y²) + z².
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn square(d: &[__m256d; 3]) -> __m256d {
        _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(d[0], d[0]), _mm256_mul_pd(d[1], d[1])),
            _mm256_mul_pd(d[2], d[2]),
        )
    }

    /// ω(|ξ|) x on four lanes (ω = δ/|ξ| when `INVERSE`, else 1).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn times_omega<const INVERSE: bool>(
        law: &CorrespondenceLaw,
        l: __m256d,
        x: __m256d,
    ) -> __m256d {
        if INVERSE {
            _mm256_mul_pd(_mm256_div_pd(_mm256_set1_pd(law.horizon), l), x)
        } else {
            x
        }
    }

    /// ω(|ξ|) φ(|ξ|) on four lanes: the generic ω · (φ μ) with μ = 1.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn omega_phi<const HHB: bool, const INVERSE: bool>(
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        l: __m256d,
    ) -> __m256d {
        times_omega::<INVERSE>(law, l, phi_of::<HHB>(w, l))
    }

    /// ω(|ξ|) φ(|ξ|) V on four lanes, zero outside `keep`: the generic ω · (φ μ V).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn weight<const HHB: bool, const INVERSE: bool>(
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        l: __m256d,
        keep: __m256d,
    ) -> __m256d {
        let pv = _mm256_mul_pd(phi_of::<HHB>(w, l), _mm256_set1_pd(w.node.volume));
        _mm256_and_pd(times_omega::<INVERSE>(law, l, pv), keep)
    }

    /// Breaks the bonds of the lanes in `bits` unless an end is no-fail; returns how many.
    #[cold]
    #[inline(never)]
    fn break_lanes(nb: &mut NodeBonds, b: usize, bits: i32) -> u64 {
        let mut broke = 0;
        for lane in 0..4 {
            let j = nb.neighbors[b + lane] as usize;
            if bits & (1 << lane) != 0 && !(nb.no_fail[nb.i] || nb.no_fail[j]) {
                nb.status[b + lane] = BROKEN;
                broke += 1;
            }
        }
        broke
    }

    /// The lanes of bonds b..b+4 that carry force: intact after the critical stretch (if
    /// this pass decides it, `$decide`: |y| − |ξ| > s0 |ξ|, as the generic loop) and of
    /// non-zero length. A macro, so that it is always inlined into the kernels (as a function
    /// it was not).
    ///
    /// `$near` is ((1 + s0)² (1 − 10⁻¹²)): lanes with |y|² at most that times |ξ|² cannot
    /// exceed s0 whatever the rounding of the exact test (its errors are ~10⁻¹⁶ relative), so
    /// the square root and the exact test run only for groups with a lane nearer the
    /// threshold (or NaN): the same decisions as the generic loop, without a square root per
    /// bond (whose latency the pre-pass was waiting on, by its samples).
    macro_rules! keep_lanes {
        ($decide:expr, $nb:expr, $b:expr, $d:expr, $l:expr, $s0:expr, $near:expr, $broke:expr) => {{
            let sq = square($d);
            let mut live = intact($nb.status, $b);
            // (Dead code when `$decide` is a false constant.)
            let far = _mm256_mul_pd(_mm256_mul_pd($l, $l), $near);
            if $decide && _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NLE_UQ>(sq, far)) != 0 {
                let len = _mm256_sqrt_pd(sq);
                let over = _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_GT_OQ>(_mm256_sub_pd(len, $l), _mm256_mul_pd($s0, $l)),
                    live,
                );
                let bits = _mm256_movemask_pd(over);
                if bits != 0 {
                    $broke += break_lanes($nb, $b, bits);
                    live = intact($nb.status, $b);
                }
            }
            // |y| > 0 exactly when |y|² > 0.
            _mm256_and_pd(live, _mm256_cmp_pd::<_CMP_GT_OQ>(sq, _mm256_setzero_pd()))
        }};
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn sums<
        const DECIDE: bool,
        const WITH_K: bool,
        const HHB: bool,
        const INVERSE: bool,
    >(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
    ) -> Sums {
        let i = nb.i;
        let (current, reference) = (nb.current.as_ptr(), law.reference.as_ptr());
        let yi = own(current, i);
        let xi_i = own(reference, i);
        let zero = _mm256_setzero_pd();
        // K's lower triangle (K is symmetric): (0,0), (1,0), (2,0), (1,1), (2,1), (2,2).
        let mut k = [zero; 6];
        // N column-major: entry (r, c) at 3c + r, as `SMatrix`.
        let mut n = [zero; 9];
        let mut sxi = [zero; 3];
        let s0 = nb.s0.unwrap_or(f64::INFINITY);
        let near = _mm256_set1_pd((1.0 + s0) * (1.0 + s0) * (1.0 - 1e-12));
        let s0 = _mm256_set1_pd(s0);
        // Bit b: bond b carries force (meaningful for families of up to `KEPT_BITS` bonds).
        let mut kept = [0u64; 4];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let j = neighbours(nb, b);
            let d = rows(current, j, &yi);
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = keep_lanes!(DECIDE, nb, b, &d, l, s0, near, broke);
            kept[(b / 64) & 3] |= (_mm256_movemask_pd(keep) as u64) << (b % 64);
            let s = weight::<HHB, INVERSE>(law, w, l, keep);
            let xi = rows(reference, j, &xi_i);
            // K += (ξ s) ξᵀ, N += (η s) ξᵀ (the generic `accumulate`, fused).
            if WITH_K {
                let xs = [
                    _mm256_mul_pd(xi[0], s),
                    _mm256_mul_pd(xi[1], s),
                    _mm256_mul_pd(xi[2], s),
                ];
                k[0] = _mm256_fmadd_pd(xs[0], xi[0], k[0]);
                k[1] = _mm256_fmadd_pd(xs[1], xi[0], k[1]);
                k[2] = _mm256_fmadd_pd(xs[2], xi[0], k[2]);
                k[3] = _mm256_fmadd_pd(xs[1], xi[1], k[3]);
                k[4] = _mm256_fmadd_pd(xs[2], xi[1], k[4]);
                k[5] = _mm256_fmadd_pd(xs[2], xi[2], k[5]);
                for a in 0..3 {
                    sxi[a] = _mm256_add_pd(sxi[a], xs[a]);
                }
            }
            for r in 0..3 {
                let es = _mm256_mul_pd(_mm256_sub_pd(d[r], xi[r]), s);
                for c in 0..3 {
                    n[3 * c + r] = _mm256_fmadd_pd(es, xi[c], n[3 * c + r]);
                }
            }
            b += 4;
        }
        let (k00, k10, k20, k11, k21, k22) = (
            sum(k[0]),
            sum(k[1]),
            sum(k[2]),
            sum(k[3]),
            sum(k[4]),
            sum(k[5]),
        );
        let mut ks = [k00, k10, k20, k10, k11, k21, k20, k21, k22];
        let mut ns = [0.0; 9];
        for e in 0..9 {
            ns[e] = sum(n[e]);
        }
        let mut sx = sxi.map(|v| sum(v));
        broke += tail(nb, b, |b, j, l, d, _| {
            kept[(b / 64) & 3] |= 1 << (b % 64);
            let s = law.omega(l) * (w.phi(l) * w.node.volume);
            let xi = law.xi(i, j);
            for r in 0..3 {
                let (xs, es) = (xi[r] * s, (d[r] - xi[r]) * s);
                if WITH_K {
                    sx[r] += xs;
                }
                for c in 0..3 {
                    if WITH_K {
                        ks[3 * c + r] += xs * xi[c];
                    }
                    ns[3 * c + r] += es * xi[c];
                }
            }
        });
        Sums {
            k: ks,
            sum_xi: sx,
            n: ns,
            broke,
            kept: (nb.neighbors.len() <= KEPT_BITS).then_some(kept),
        }
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn force<const CONTROL: bool, const HHB: bool, const INVERSE: bool>(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        points: &[f64],
        stride: usize,
    ) -> ([f64; 3], [f64; 3]) {
        debug_assert!(
            nb.s0.is_none(),
            "the correspondence force pass does not decide failure"
        );
        let i = nb.i;
        let yi = own(nb.current.as_ptr(), i);
        let xi_i = own(law.reference.as_ptr(), i);
        let zero = _mm256_setzero_pd();
        // One sum per row for both the B and the C1 terms: fewer live registers (the sums
        // spilled to the stack when the B and C1 terms had their own).
        let (mut other, mut seta) = ([zero; 3], [zero; 3]);
        let mut b = 0;
        let base = points.as_ptr();
        while b + 4 <= nb.neighbors.len() {
            let p = neighbours(nb, b).map(|k| base.add(k * stride));
            let (y, x, c22) = positions::<CONTROL>(&p);
            let d: [__m256d; 3] = std::array::from_fn(|a| _mm256_sub_pd(y[a], yi[a]));
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = _mm256_and_pd(
                intact(nb.status, b),
                _mm256_cmp_pd::<_CMP_GT_OQ>(square(&d), zero),
            );
            let s = weight::<HHB, INVERSE>(law, w, l, keep);
            let xi: [__m256d; 3] = std::array::from_fn(|a| _mm256_sub_pd(x[a], xi_i[a]));
            let xs = xi.map(|v| _mm256_mul_pd(v, s));
            let es: [__m256d; 3] =
                std::array::from_fn(|a| _mm256_mul_pd(_mm256_sub_pd(d[a], xi[a]), s));
            for a in 0..3 {
                seta[a] = _mm256_add_pd(seta[a], es[a]);
            }
            // Σ s (B_j ξ + C1_j η) = Σ B_j (s ξ) + C1_j (s η).
            add_matrices::<CONTROL>(&p, &xs, &es, c22, &mut other);
            b += 4;
        }
        let mut f = other.map(|v| sum(v));
        let mut se = seta.map(|v| sum(v));
        tail(nb, b, |_, j, l, d, _| {
            let s = law.omega(l) * (w.phi(l) * w.node.volume);
            let xi = law.xi(i, j);
            let eta = [d[0] - xi[0], d[1] - xi[1], d[2] - xi[2]];
            let v = linear_half::<CONTROL>(&points[j * stride..j * stride + 18], &xi, &eta);
            for r in 0..3 {
                se[r] += eta[r] * s;
                f[r] += v[r] * s;
            }
        });
        (f, se)
    }

    /// B ξ + C1 η of one bond from the 18 entries `m` (B then C1, column-major), in the
    /// generic `linear_half`'s order: (B ξ) + (C1 η), each row ((m₀ξ₀ + m₁ξ₁) + m₂ξ₂).
    #[inline(always)]
    fn linear_half<const CONTROL: bool>(m: &[f64], xi: &[f64; 3], eta: &[f64; 3]) -> [f64; 3] {
        let mut v = [0.0; 3];
        for r in 0..3 {
            v[r] = m[r] * xi[0] + m[3 + r] * xi[1] + m[6 + r] * xi[2];
            if CONTROL {
                v[r] += m[9 + r] * eta[0] + m[12 + r] * eta[1] + m[15 + r] * eta[2];
            }
        }
        v
    }

    /// Lane k of v.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn lanes(v: __m256d) -> [f64; 4] {
        let mut a = [0.0; 4];
        _mm256_storeu_pd(a.as_mut_ptr(), v);
        a
    }

    /// The lanes of `bits` whose bond is in tension (|y| > |ξ|, |y| in the generic order).
    #[cold]
    #[inline(never)]
    fn in_tension(bits: i32, d: [[f64; 4]; 3], l: [f64; 4]) -> i32 {
        let mut out = 0;
        for lane in 0..4 {
            let y = [d[0][lane], d[1][lane], d[2][lane]];
            if bits & (1 << lane) != 0 && length(&y) - l[lane] > 0.0 {
                out |= 1 << lane;
            }
        }
        out
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn force_work<const CONTROL: bool, const HHB: bool, const INVERSE: bool>(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        energy: &UniformCriticalEnergy,
        points: &[f64],
        stride: usize,
    ) -> ([f64; 3], u64) {
        let i = nb.i;
        let previous = nb.previous.as_ptr();
        let (yi, xi_i, pi) = (
            own(nb.current.as_ptr(), i),
            own(law.reference.as_ptr(), i),
            own(previous, i),
        );
        let base = points.as_ptr();
        // Node i's B and C1's lower triangle (C1 is symmetric, see `add_matrices`), broadcast.
        let entry = |m: usize| _mm256_set1_pd(*base.add(i * stride + m));
        let mine_b: [__m256d; 9] = std::array::from_fn(entry);
        let mine_c1 = C1_LOWER.map(|m| entry(RECORD_C1 + m));
        let zero = _mm256_setzero_pd();
        let (half, wc, volume) = (
            _mm256_set1_pd(0.5),
            _mm256_set1_pd(energy.wc),
            _mm256_set1_pd(w.node.volume),
        );
        let mut acc = [zero; 3];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let j = neighbours(nb, b);
            let p = j.map(|k| base.add(k * stride));
            // The work records stream through the cache and evict the neighbours' records,
            // whose loads the loop then waited on: fetch those of two groups on.
            if b + 12 <= nb.neighbors.len() {
                prefetch_records(base, stride, neighbours(nb, b + 8));
            }
            let (y, x, c22) = positions::<CONTROL>(&p);
            let d: [__m256d; 3] = std::array::from_fn(|a| _mm256_sub_pd(y[a], yi[a]));
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            // Intact and of non-zero length: the bonds the generic loop records work for.
            let mut keep = _mm256_and_pd(
                intact(nb.status, b),
                _mm256_cmp_pd::<_CMP_GT_OQ>(square(&d), zero),
            );
            let xi: [__m256d; 3] = std::array::from_fn(|a| _mm256_sub_pd(x[a], xi_i[a]));
            let eta: [__m256d; 3] = std::array::from_fn(|a| _mm256_sub_pd(d[a], xi[a]));
            // Both halves' B ξ + C1 η: node i's from its broadcast entries, then the
            // neighbours'.
            let mut t: [__m256d; 3] = std::array::from_fn(|r| {
                let v = _mm256_mul_pd(mine_b[r], xi[0]);
                let v = _mm256_fmadd_pd(mine_b[3 + r], xi[1], v);
                _mm256_fmadd_pd(mine_b[6 + r], xi[2], v)
            });
            if CONTROL {
                add_symmetric(&mine_c1, &eta, &mut t);
            }
            add_matrices::<CONTROL>(&p, &xi, &eta, c22, &mut t);
            // The pair force T = ω φ (both halves), the generic `pair_force` without V.
            let wp = omega_phi::<HHB, INVERSE>(law, w, l);
            let force = [
                _mm256_mul_pd(t[0], wp),
                _mm256_mul_pd(t[1], wp),
                _mm256_mul_pd(t[2], wp),
            ];
            // Δη = y − (y_j − y_i at the previous evaluation).
            let dp = rows(previous, j, &pi);
            let step = [
                _mm256_sub_pd(d[0], dp[0]),
                _mm256_sub_pd(d[1], dp[1]),
                _mm256_sub_pd(d[2], dp[2]),
            ];
            // The records [w, T] of the four bonds, as lanes; the records four groups on are
            // prefetched (the stream of 64 bytes per bond read and written each evaluation
            // otherwise stalls the loop on memory; a prefetch past the end is harmless).
            let hp = nb.history.as_mut_ptr().add(4 * b);
            prefetch::<512, _>(hp);
            prefetch::<576, _>(hp);
            let rec = [hp as *const f64, hp.add(4), hp.add(8), hp.add(12)];
            let (w_old, f0) = pair(&rec, 0);
            let (f1, f2) = pair(&rec, 2);
            // `accumulate_work`: w += ½ ((T_prev + T)·Δη), in its order.
            let dot = _mm256_add_pd(
                _mm256_add_pd(
                    _mm256_mul_pd(_mm256_add_pd(f0, force[0]), step[0]),
                    _mm256_mul_pd(_mm256_add_pd(f1, force[1]), step[1]),
                ),
                _mm256_mul_pd(_mm256_add_pd(f2, force[2]), step[2]),
            );
            let w_new = _mm256_add_pd(w_old, _mm256_mul_pd(half, dot));
            // Lanes outside `keep` keep their record.
            let ws = _mm256_blendv_pd(w_old, w_new, keep);
            let fs = [
                _mm256_blendv_pd(f0, force[0], keep),
                _mm256_blendv_pd(f1, force[1], keep),
                _mm256_blendv_pd(f2, force[2], keep),
            ];
            let (lo_a, hi_a) = (_mm256_unpacklo_pd(ws, fs[0]), _mm256_unpackhi_pd(ws, fs[0]));
            let (lo_b, hi_b) = (
                _mm256_unpacklo_pd(fs[1], fs[2]),
                _mm256_unpackhi_pd(fs[1], fs[2]),
            );
            _mm256_storeu_pd(hp, _mm256_permute2f128_pd::<0x20>(lo_a, lo_b));
            _mm256_storeu_pd(hp.add(4), _mm256_permute2f128_pd::<0x20>(hi_a, hi_b));
            _mm256_storeu_pd(hp.add(8), _mm256_permute2f128_pd::<0x31>(lo_a, lo_b));
            _mm256_storeu_pd(hp.add(12), _mm256_permute2f128_pd::<0x31>(hi_a, hi_b));
            // `fails_on_work`: w ≥ w_c φ̄, φ̄ = ½(φ + φ), and in tension if `tension_only`.
            let p = phi_of::<HHB>(w, l);
            let over = _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_GE_OQ>(
                    w_new,
                    _mm256_mul_pd(wc, _mm256_mul_pd(half, _mm256_add_pd(p, p))),
                ),
                keep,
            );
            let mut bits = _mm256_movemask_pd(over);
            if bits != 0 {
                if energy.tension_only {
                    bits = in_tension(bits, d.map(|v| lanes(v)), lanes(l));
                }
                if bits != 0 {
                    broke += break_lanes(nb, b, bits);
                    keep = _mm256_and_pd(keep, intact(nb.status, b));
                }
            }
            // The generic loop's T V over the bonds that hold.
            for a in 0..3 {
                acc[a] = _mm256_fmadd_pd(_mm256_and_pd(force[a], keep), volume, acc[a]);
            }
            b += 4;
        }
        let mut f = [sum(acc[0]), sum(acc[1]), sum(acc[2])];
        let pts = |k: usize| &points[k * stride..k * stride + 18];
        for b in b..nb.neighbors.len() {
            if nb.status[b] != INTACT {
                continue;
            }
            let j = nb.neighbors[b] as usize;
            let at = |v: &[f64], k: usize| [v[3 * k], v[3 * k + 1], v[3 * k + 2]];
            let (yj, yi, pj, pi) = (
                at(nb.current, j),
                at(nb.current, i),
                at(nb.previous, j),
                at(nb.previous, i),
            );
            let d = [yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]];
            let len = length(&d);
            if len <= 0.0 {
                continue;
            }
            // The generic loop's steps for one bond: T = ω φ (B_i ξ + C1_i η) + ω φ (B_j ξ +
            // C1_j η), its work, failure, T V.
            let l = nb.ref_lengths[b];
            let (om, p) = (law.omega(l), w.phi(l));
            let xi = law.xi(i, j);
            let eta = [d[0] - xi[0], d[1] - xi[1], d[2] - xi[2]];
            let (own_half, other) = (
                linear_half::<CONTROL>(pts(i), &xi, &eta),
                linear_half::<CONTROL>(pts(j), &xi, &eta),
            );
            let force: [f64; 3] = std::array::from_fn(|a| own_half[a] * om * p + other[a] * om * p);
            let step: [f64; 3] = std::array::from_fn(|a| d[a] - (pj[a] - pi[a]));
            broke += energy.on_work(
                i,
                j,
                Work::Vector { force, step },
                len - l,
                0.5 * (p + p),
                nb.no_fail[i] || nb.no_fail[j],
                &mut nb.history[4 * b..4 * b + 4],
                &mut nb.status[b],
            );
            if nb.status[b] == BROKEN {
                continue;
            }
            for a in 0..3 {
                f[a] += force[a] * w.node.volume;
            }
        }
        (f, broke)
    }
}
