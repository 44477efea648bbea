//! AVX2 + FMA bond loops of the correspondence model (2D and 3D, uniform grid, one horizon),
//! four bonds at a time: the pre-pass sums N = Σ ω η⊗ξ w and, when the caller cannot reuse it
//! (`Sums::kept`), K = Σ ω ξ⊗ξ w (seed 004, Eqs. 6–7);
//! the force pass under one critical stretch sums the neighbours' moment records s m_j
//! (`moment_*`: B, g, u and C1's version), from which the model forms the other halves
//! ω φ V (B_j ξ + C1_j η) and the own-half sum Σ s η without a product per bond (see
//! `Correspondence::vector_force` and `Material::FACTORED_OWN_HALF`);
//! the force pass under one critical energy evaluates both halves of each bond,
//! T = ω φ (B_i ξ + C1_i η) + ω φ (B_j ξ + C1_j η) (Eq. 8 with Eq. 14 through B = A − C1 H),
//! records its work w += ½ (T_prev + T)·Δη in the bond's vector work record [w, T] (Foster,
//! Silling & Chen 2011; seed 002 Eq. 6; seed 004 Eqs. 16–18, `damage::critical_energy`) and
//! breaks the bonds with w ≥ w_c φ̄.
//!
//! Same terms, failure rules and partial-volume factor as the generic loops; the sums of
//! products are fused multiply–adds (one rounding instead of two), and the order of a node's
//! bond terms is four lanes (two sets of sums, even and odd lanes, in the moment pass), then
//! the tail. Both are fixed, so results stay bitwise identical for any thread count; they
//! differ from the generic loop by round-off (10⁻¹⁴ of the forces; the moment form's grows
//! with the body's size over the horizon, see `Correspondence::moment_force`), and the
//! quantities that decide failure (|y|, the stretch, the work update from the pair force) are
//! computed in the generic loop's order. The critical-energy pass forms a bond's two halves
//! apart, in one order, and adds them scaled (in its lanes and its tail alike), so that the
//! entries i→j and j→i get exactly opposite pair forces and record the same work: both ends
//! decide the bond alike, as in the generic loop. The kernels run only where the CPU has both
//! AVX2 and FMA (`simd::fma_available`). `tests/suite/kernels.rs` compares them with the
//! generic loop and checks that the two entries of every bond agree.
//!
//! Loads: the moment pass reads each neighbour's record as whole 256-bit rows (two cache
//! lines in 3D); the pre-pass and the critical-energy pass read positions, B and C1 as
//! 128-bit pairs, two bonds per 256-bit register, interleaved with in-lane unpacks (no
//! lane-crossing shuffle, never a byte past a node's record). The kernels are generic over
//! the dimension D (`NodeBonds::dim`): vectors are D lanes, matrices D×D column-major; in 2D
//! the sums returned and the scalar tails pad the third component with zero.

use super::simd::{flat_position, NodeBonds};
use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::PartialVolume;
use crate::damage::critical_energy::UniformCriticalEnergy;

/// What the kernels need of the model.
#[derive(Debug, Clone, Copy)]
pub struct CorrespondenceLaw<'a> {
    /// Reference positions, flat (x, y, z in 3D, x, y in 2D).
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
    pub fn omega(&self, l: f64) -> f64 {
        if self.inverse_influence {
            self.horizon / l
        } else {
            1.0
        }
    }

    /// Reference bond vector ξ = x_j − x_i in dimension D, z = 0 in 2D.
    #[inline(always)]
    fn xi<const D: usize>(&self, i: usize, j: usize) -> [f64; 3] {
        let (xj, xi) = (
            flat_position(self.reference, D, j),
            flat_position(self.reference, D, i),
        );
        std::array::from_fn(|a| xj[a] - xi[a])
    }
}

/// Where the force kernels find a node's entries in its point record of dimension `d` (in f64
/// words; the layout of `CorrespondencePoint`, checked against these at compile time).
///
/// The critical-energy force kernel reads a block from word `record_block` on: B
/// column-major from its start, C1 from `record_c1`, the current position from `record_y`,
/// the reference position from `record_x`, up to `record_read` (exclusive; all four relative
/// to the block).
pub const fn record_block(_d: usize) -> usize {
    MOMENT_WORDS + 8
}
pub const fn record_c1(d: usize) -> usize {
    d * d
}
pub const fn record_y(d: usize) -> usize {
    2 * d * d
}
pub const fn record_x(d: usize) -> usize {
    2 * d * d + d
}
pub const fn record_read(d: usize) -> usize {
    2 * d * d + 2 * d
}

/// The force kernel under a critical stretch reads a neighbour's moment record, from word
/// `record_moments(d)` of its point record (64-byte aligned): B (d² words, column-major) from
/// 0, g = B (x − o) + C1 u from `moment_g`, u = y − x from `moment_u`, the version of the
/// node's C1 at `moment_version`, zero up to `moment_words`; o is the model's `origin`.
/// Σ s m_j over a family and Σ of the versions give the other halves (see
/// `correspondence_moments`). Two cache lines in 3D, one and a half in 2D: C1 itself, which
/// changes only with K, is not in it.
pub const fn record_moments(_d: usize) -> usize {
    0
}
pub const fn moment_g(d: usize) -> usize {
    d * d
}
pub const fn moment_u(d: usize) -> usize {
    d * d + d
}
pub const fn moment_version(d: usize) -> usize {
    d * d + 2 * d
}
/// Whole 256-bit rows: 16 words in 3D, 12 in 2D.
pub const fn moment_words(d: usize) -> usize {
    (moment_version(d) + 1).next_multiple_of(4)
}
/// The moment record's room in a point record, for either dimension.
pub const MOMENT_WORDS: usize = moment_words(3);

/// The (row, column) entries of a symmetric D×D matrix's lower triangle, column by column:
/// (0,0), (1,0), (2,0), (1,1), (2,1), (2,2) in 3D; (0,0), (1,0), (1,1) in 2D.
#[inline(always)]
pub fn lower<const D: usize>() -> impl Iterator<Item = (usize, usize)> {
    (0..D).flat_map(|c| (c..D).map(move |r| (r, c)))
}

/// Families of up to this many bonds get `Sums::kept`.
pub const KEPT_BITS: usize = 256;

/// What the pre-pass of a node sums; the matrices D×D column-major in their first D² words,
/// the vector in its first D.
#[derive(Debug, Clone, Copy)]
pub struct Sums {
    /// K = Σ ω ξ⊗ξ w and Σ s ξ (s = ω φ V; both zero unless asked for).
    pub k: [f64; 9],
    pub sum_xi: [f64; 3],
    /// N = Σ ω η⊗ξ w.
    pub n: [f64; 9],
    /// Bonds broken by this pass.
    pub broke: u64,
    /// Bit b set when bond b carried force (intact after this pass, of non-zero length):
    /// the exact set K is summed over, for families of up to `KEPT_BITS` bonds.
    pub kept: Option<[u64; 4]>,
}

/// Pre-pass of node i: N (and K and Σ s ξ if `with_k`) over its intact bonds, deciding
/// failure like the generic loop, and which bonds carried force.
///
/// # Safety
/// `simd::fma_available()`; every neighbour index below `nb.current.len() / nb.dim` and
/// `law.reference.len() / nb.dim`.
pub unsafe fn correspondence_sums(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
    with_k: bool,
) -> Sums {
    #[cfg(target_arch = "x86_64")]
    {
        let (dim, hhb) = (nb.dim, w.rule == PartialVolume::Hhb);
        match (nb.s0.is_some(), with_k) {
            (true, true) => avx::with_flags!(avx::sums, dim, [true, true], hhb, law, (nb, law, w)),
            (true, false) => {
                avx::with_flags!(avx::sums, dim, [true, false], hhb, law, (nb, law, w))
            }
            (false, true) => {
                avx::with_flags!(avx::sums, dim, [false, true], hhb, law, (nb, law, w))
            }
            (false, false) => {
                avx::with_flags!(avx::sums, dim, [false, false], hhb, law, (nb, law, w))
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("fma_available() is false off x86-64")
}

/// Force pass of node i: the moment sums Σ s m_j over the bonds that carry force, m_j node
/// j's moment record (`moment_*`) and s = ω φ V the bond's weight, and the sum of the
/// neighbours' versions (every bond of the groups of four, the tail's that carry force; exact:
/// whole numbers below 2⁵³). From them the model forms the other halves
/// Σ s (B_j ξ + C1_j η) without a product per bond (see `Correspondence::vector_force`).
/// `points` holds each node's point state as `stride` f64, the records from this evaluation's
/// pre-pass; `kept`, when given, is node i's set of bonds that carry force from that pre-pass
/// (`Sums::kept`), which spares reading the neighbours' positions.
///
/// # Safety
/// As for `correspondence_sums`; `points.len() >= stride * nodes` and
/// `stride >= record_moments(nb.dim) + moment_words(nb.dim)`.
pub unsafe fn correspondence_moments(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
    points: &[f64],
    stride: usize,
    kept: Option<&[u64; 4]>,
) -> ([f64; MOMENT_WORDS], f64) {
    #[cfg(target_arch = "x86_64")]
    {
        let (dim, hhb) = (nb.dim, w.rule == PartialVolume::Hhb);
        let known = kept.copied().unwrap_or_default();
        if kept.is_some() {
            avx::with_flags!(
                avx::moments,
                dim,
                [true],
                hhb,
                law,
                (nb, law, w, points, stride, &known)
            )
        } else {
            avx::with_flags!(
                avx::moments,
                dim,
                [false],
                hhb,
                law,
                (nb, law, w, points, stride, &known)
            )
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
/// As for `correspondence_sums`; `points.len() >= stride * nodes`,
/// `stride >= record_block(nb.dim) + record_read(nb.dim)`,
/// `nb.history.len() == 4 * nb.neighbors.len()` and `nb.previous.len() == nb.current.len()`.
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
    // The records' blocks from B on: the kernel's offsets are relative to them.
    let points = &points[record_block(nb.dim)..];
    #[cfg(target_arch = "x86_64")]
    {
        let (dim, hhb) = (nb.dim, w.rule == PartialVolume::Hhb);
        if law.control {
            avx::with_flags!(
                avx::force_work,
                dim,
                [true],
                hhb,
                law,
                (nb, law, w, energy, points, stride)
            )
        } else {
            avx::with_flags!(
                avx::force_work,
                dim,
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

    /// Calls `kernel::<D, FLAGS.., HHB, INVERSE>` with the dimension `D` (2 or 3), the
    /// partial-volume rule (`HHB`) and the influence function (`INVERSE`: ω = δ/|ξ|) as
    /// compile-time flags (tested inside the bond loop, they were not hoisted out of it).
    macro_rules! with_flags {
        ($($kernel:ident)::+, $dim:expr, [$($flag:expr),*], $hhb:expr, $law:expr, ($($arg:expr),*)) => {
            match ($dim == 2, $hhb, $law.inverse_influence) {
                (true, true, true) => $($kernel)::+::<2, $($flag,)* true, true>($($arg),*),
                (true, true, false) => $($kernel)::+::<2, $($flag,)* true, false>($($arg),*),
                (true, false, true) => $($kernel)::+::<2, $($flag,)* false, true>($($arg),*),
                (true, false, false) => $($kernel)::+::<2, $($flag,)* false, false>($($arg),*),
                (false, true, true) => $($kernel)::+::<3, $($flag,)* true, true>($($arg),*),
                (false, true, false) => $($kernel)::+::<3, $($flag,)* true, false>($($arg),*),
                (false, false, true) => $($kernel)::+::<3, $($flag,)* false, true>($($arg),*),
                (false, false, false) => $($kernel)::+::<3, $($flag,)* false, false>($($arg),*),
            }
        };
    }
    pub(super) use with_flags;

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

    /// The first D of three registers.
    #[inline(always)]
    fn first<const D: usize>(v: [__m256d; 3]) -> [__m256d; D] {
        std::array::from_fn(|a| v[a])
    }

    /// The neighbours' current and reference positions (y, x) from their records, one lane
    /// per neighbour, and in 3D with zero-energy control C1's entry (2, 2), which shares a
    /// 128-bit pair with y₀ (zero otherwise).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn positions<const D: usize, const CONTROL: bool>(
        p: &[*const f64; 4],
    ) -> ([__m256d; D], [__m256d; D], __m256d) {
        let (ry, rx) = (record_y(D), record_x(D));
        let zero = _mm256_setzero_pd();
        if D == 2 {
            let (y0, y1) = pair(p, ry);
            let (x0, x1) = pair(p, rx);
            (first([y0, y1, zero]), first([x0, x1, zero]), zero)
        } else if CONTROL {
            let (c22, y0) = pair(p, ry - 1);
            let (y1, y2) = pair(p, ry + 1);
            let (x0, _) = pair(p, rx);
            let (x1, x2) = pair(p, rx + 1);
            (first([y0, y1, y2]), first([x0, x1, x2]), c22)
        } else {
            let (y0, y1) = pair(p, ry);
            let (y2, x0) = pair(p, ry + 2);
            let (x1, x2) = pair(p, rx + 1);
            (first([y0, y1, y2]), first([x0, x1, x2]), zero)
        }
    }

    /// The index of entry (r, c) of a symmetric D×D matrix in the order of `lower`: columns
    /// 0..c hold D, D − 1, … entries.
    #[inline(always)]
    const fn lower_index<const D: usize>(r: usize, c: usize) -> usize {
        let (r, c) = if r >= c { (r, c) } else { (c, r) };
        c * (2 * D - c + 1) / 2 + (r - c)
    }

    /// acc += B u + C1 v with the neighbours' B and C1 (`c22` from `positions`), one lane per
    /// neighbour. C1 is symmetric (λ tr(K⁻¹) I + 2μ K⁻¹ of a symmetric K, or c_s I), so only
    /// its lower triangle is read: in 3D 11 pairs of entries instead of 13 with the positions.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn add_matrices<const D: usize, const CONTROL: bool>(
        p: &[*const f64; 4],
        u: &[__m256d; D],
        v: &[__m256d; D],
        c22: __m256d,
        acc: &mut [__m256d; D],
    ) {
        // B column-major: entry m is (m % D, m / D).
        for q in 0..D * D / 2 {
            let (e0, e1) = pair(p, 2 * q);
            for (m, e) in [(2 * q, e0), (2 * q + 1, e1)] {
                acc[m % D] = _mm256_fmadd_pd(e, u[m / D], acc[m % D]);
            }
        }
        let c1 = record_c1(D);
        if D == 2 {
            if CONTROL {
                let (c00, c10) = pair(p, c1);
                let (_, c11) = pair(p, c1 + 2);
                add_symmetric::<D>(&[c00, c10, c11, c11, c11, c11], v, acc);
            }
        } else {
            let (b22, c00) = pair(p, 8);
            acc[2] = _mm256_fmadd_pd(b22, u[2], acc[2]);
            if CONTROL {
                let (c10, c20) = pair(p, c1 + 1);
                let (c11, c21) = pair(p, c1 + 4);
                add_symmetric::<D>(&[c00, c10, c20, c11, c21, c22], v, acc);
            }
        }
    }

    /// acc += C v for a symmetric C given by its lower triangle (the order of `lower`; words
    /// past D(D + 1)/2 unused), each row in column order.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn add_symmetric<const D: usize>(
        c: &[__m256d; 6],
        v: &[__m256d; D],
        acc: &mut [__m256d; D],
    ) {
        for r in 0..D {
            for (col, v) in v.iter().enumerate() {
                acc[r] = _mm256_fmadd_pd(c[lower_index::<D>(r, col)], *v, acc[r]);
            }
        }
    }

    /// Prefetches the cache lines of each record the critical-energy force kernel reads
    /// (words 0..`record_read(D)` of the block, which starts a cache line: three lines in 3D,
    /// two in 2D).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn prefetch_records<const D: usize>(points: *const f64, stride: usize, n: [usize; 4]) {
        for k in n {
            let record = points.add(k * stride) as *const i8;
            for line in 0..(8 * record_read(D)).div_ceil(64) {
                _mm_prefetch::<_MM_HINT_T0>(record.add(64 * line));
            }
        }
    }

    /// The positions of the nodes `n` in the flat positions `base` (D per node), less
    /// `origin`, one lane per node: (x, y) and in 3D (y, z) pairs, so that no load reads past
    /// a node.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn rows<const D: usize>(
        base: *const f64,
        n: [usize; 4],
        origin: &[__m256d; D],
    ) -> [__m256d; D] {
        let p = n.map(|k| base.add(D * k));
        let (x, y) = pair(&p, 0);
        let z = if D == 3 { pair(&p, 1).1 } else { x };
        let v = first::<D>([x, y, z]);
        std::array::from_fn(|a| _mm256_sub_pd(v[a], origin[a]))
    }

    /// Node i's position in the flat positions `base` (D per node), broadcast.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn own<const D: usize>(base: *const f64, i: usize) -> [__m256d; D] {
        std::array::from_fn(|a| _mm256_set1_pd(*base.add(D * i + a)))
    }

    /// |y|² in the generic loop's order, (x² + y²) + z².
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn square<const D: usize>(d: &[__m256d; D]) -> __m256d {
        let mut s = _mm256_mul_pd(d[0], d[0]);
        for v in &d[1..] {
            s = _mm256_add_pd(s, _mm256_mul_pd(*v, *v));
        }
        s
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
        const D: usize,
        const DECIDE: bool,
        const WITH_K: bool,
        const HHB: bool,
        const INVERSE: bool,
    >(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
    ) -> Sums {
        debug_assert_eq!(nb.dim, D);
        let i = nb.i;
        let (current, reference) = (nb.current.as_ptr(), law.reference.as_ptr());
        let yi = own::<D>(current, i);
        let xi_i = own::<D>(reference, i);
        let zero = _mm256_setzero_pd();
        // K's lower triangle (K is symmetric), in the order of `lower`.
        let mut k = [zero; 6];
        // N column-major: entry (r, c) at D c + r, as `SMatrix`.
        let mut n = [zero; 9];
        let mut sxi = [zero; D];
        let s0 = nb.s0.unwrap_or(f64::INFINITY);
        let near = _mm256_set1_pd((1.0 + s0) * (1.0 + s0) * (1.0 - 1e-12));
        let s0 = _mm256_set1_pd(s0);
        // Bit b: bond b carries force (meaningful for families of up to `KEPT_BITS` bonds),
        // gathered 64 bonds at a time in `word` (a register; `kept`, indexed by b, is memory).
        let mut kept = [0u64; 4];
        let mut word = 0u64;
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let j = neighbours(nb, b);
            let d = rows::<D>(current, j, &yi);
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = keep_lanes!(DECIDE, nb, b, &d, l, s0, near, broke);
            word |= (_mm256_movemask_pd(keep) as u64) << (b % 64);
            if b % 64 == 60 {
                kept[(b / 64) & 3] = word;
                word = 0;
            }
            let s = weight::<HHB, INVERSE>(law, w, l, keep);
            let xi = rows::<D>(reference, j, &xi_i);
            // K += (ξ s) ξᵀ, N += η (ξ s)ᵀ (the generic `accumulate`, fused, with s on ξ:
            // η, ξ s and N are then all that is live, and N's nine sums stay in registers).
            let xs: [__m256d; D] = std::array::from_fn(|a| _mm256_mul_pd(xi[a], s));
            if WITH_K {
                for (e, (r, c)) in lower::<D>().enumerate() {
                    k[e] = _mm256_fmadd_pd(xs[r], xi[c], k[e]);
                }
                for a in 0..D {
                    sxi[a] = _mm256_add_pd(sxi[a], xs[a]);
                }
            }
            for r in 0..D {
                let eta = _mm256_sub_pd(d[r], xi[r]);
                for c in 0..D {
                    n[D * c + r] = _mm256_fmadd_pd(eta, xs[c], n[D * c + r]);
                }
            }
            b += 4;
        }
        kept[(b / 64) & 3] |= word;
        let mut ks = [0.0; 9];
        for (e, (r, c)) in lower::<D>().enumerate() {
            let v = sum(k[e]);
            (ks[D * c + r], ks[D * r + c]) = (v, v);
        }
        let mut ns = [0.0; 9];
        for e in 0..D * D {
            ns[e] = sum(n[e]);
        }
        let mut sx = [0.0; 3];
        for a in 0..D {
            sx[a] = sum(sxi[a]);
        }
        broke += tail(nb, b, |b, j, l, d, _| {
            kept[(b / 64) & 3] |= 1 << (b % 64);
            let s = law.omega(l) * (w.phi(l) * w.node.volume);
            let xi = law.xi::<D>(i, j);
            let xs: [f64; 3] = std::array::from_fn(|a| xi[a] * s);
            for r in 0..D {
                if WITH_K {
                    sx[r] += xs[r];
                }
                for c in 0..D {
                    if WITH_K {
                        ks[D * c + r] += xs[r] * xi[c];
                    }
                    ns[D * c + r] += (d[r] - xi[r]) * xs[c];
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

    /// The lanes of bonds b..b+4 set in `kept` (bit b: bond b carries force).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn kept_lanes(kept: &[u64; 4], b: usize) -> __m256d {
        let bits = (kept[(b / 64) & 3] >> (b % 64)) & 0xF;
        let select = _mm256_setr_epi64x(1, 2, 4, 8);
        let set = _mm256_and_si256(_mm256_set1_epi64x(bits as i64), select);
        _mm256_castsi256_pd(_mm256_cmpeq_epi64(set, select))
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn moments<
        const D: usize,
        const KEPT: bool,
        const HHB: bool,
        const INVERSE: bool,
    >(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        points: &[f64],
        stride: usize,
        kept: &[u64; 4],
    ) -> ([f64; MOMENT_WORDS], f64) {
        debug_assert!(
            nb.s0.is_none(),
            "the correspondence force pass does not decide failure"
        );
        debug_assert_eq!(nb.dim, D);
        let words = moment_words(D);
        let yi = own::<D>(nb.current.as_ptr(), nb.i);
        let zero = _mm256_setzero_pd();
        let base = points.as_ptr().add(record_moments(D));
        // Two sets of sums, for even and odd lanes: each sum then waits on one fused
        // multiply–add per two bonds instead of one per bond.
        let mut acc = [[zero; MOMENT_WORDS / 4]; 2];
        // The versions' sum, in the lane of `moment_version` (the other lanes sum u and 0).
        let last = moment_version(D) / 4;
        let mut versions = [zero; 2];
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let j = neighbours(nb, b);
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            // The bonds the pre-pass summed K and N over: from its bits, or as it decided
            // them (intact, |y| > 0) when it kept none.
            let keep = if KEPT {
                kept_lanes(kept, b)
            } else {
                let d = rows::<D>(nb.current.as_ptr(), j, &yi);
                _mm256_and_pd(
                    intact(nb.status, b),
                    _mm256_cmp_pd::<_CMP_GT_OQ>(square(&d), zero),
                )
            };
            let s = lanes(weight::<HHB, INVERSE>(law, w, l, keep));
            // acc += s m_j, one neighbour's whole record at a time (whole-row loads: no
            // gather, no shuffle).
            for (lane, &k) in j.iter().enumerate() {
                let (record, sk) = (base.add(k * stride), _mm256_set1_pd(s[lane]));
                let sums = &mut acc[lane % 2];
                for (r, sum) in sums.iter_mut().enumerate().take(words / 4) {
                    let row = _mm256_loadu_pd(record.add(4 * r));
                    *sum = _mm256_fmadd_pd(row, sk, *sum);
                    if r == last {
                        versions[lane % 2] = _mm256_add_pd(versions[lane % 2], row);
                    }
                }
            }
            b += 4;
        }
        let mut m = [0.0; MOMENT_WORDS];
        for (r, (even, odd)) in acc[0].iter().zip(&acc[1]).enumerate().take(words / 4) {
            _mm256_storeu_pd(m.as_mut_ptr().add(4 * r), _mm256_add_pd(*even, *odd));
        }
        let mut version_sum = lanes(_mm256_add_pd(versions[0], versions[1]))[moment_version(D) % 4];
        tail(nb, b, |_, j, l, _, _| {
            let s = law.omega(l) * (w.phi(l) * w.node.volume);
            let record = &points[j * stride + record_moments(D)..][..words];
            for (sum, e) in m.iter_mut().zip(record) {
                *sum += e * s;
            }
            version_sum += record[moment_version(D)];
        });
        (m, version_sum)
    }

    /// B ξ + C1 η of one bond from a record `m` (B then C1, column-major) as the lanes of
    /// `force_work` compute it: each row m₀ξ₀, then fused multiply–adds of B's other columns
    /// and of C1's lower triangle (C1 is symmetric), column by column; zero past D. The same
    /// bits as a lane, so that a bond in one end's tail and in the other end's groups gets
    /// the same pair force from both.
    #[inline(always)]
    fn linear_half<const D: usize, const CONTROL: bool>(
        m: &[f64],
        xi: &[f64; 3],
        eta: &[f64; 3],
    ) -> [f64; 3] {
        let c1 = &m[record_c1(D)..];
        let lower = |r: usize, c: usize| c1[D * r.min(c) + r.max(c)];
        let mut v = [0.0; 3];
        for r in 0..D {
            v[r] = m[r] * xi[0];
            for c in 1..D {
                v[r] = m[D * c + r].mul_add(xi[c], v[r]);
            }
            if CONTROL {
                for (c, e) in eta.iter().enumerate().take(D) {
                    v[r] = lower(r, c).mul_add(*e, v[r]);
                }
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
    pub(super) unsafe fn force_work<
        const D: usize,
        const CONTROL: bool,
        const HHB: bool,
        const INVERSE: bool,
    >(
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        energy: &UniformCriticalEnergy,
        points: &[f64],
        stride: usize,
    ) -> ([f64; 3], u64) {
        debug_assert_eq!(nb.dim, D);
        let i = nb.i;
        let previous = nb.previous.as_ptr();
        let (yi, xi_i, pi) = (
            own::<D>(nb.current.as_ptr(), i),
            own::<D>(law.reference.as_ptr(), i),
            own::<D>(previous, i),
        );
        let base = points.as_ptr();
        let zero = _mm256_setzero_pd();
        // Node i's B and C1's lower triangle (C1 is symmetric, see `add_matrices`), broadcast.
        let entry = |m: usize| _mm256_set1_pd(*base.add(i * stride + m));
        let mine_b: [__m256d; 9] = std::array::from_fn(|m| if m < D * D { entry(m) } else { zero });
        let mut mine_c1 = [zero; 6];
        for (e, (r, c)) in lower::<D>().enumerate() {
            mine_c1[e] = entry(record_c1(D) + D * c + r);
        }
        let (half, wc, volume) = (
            _mm256_set1_pd(0.5),
            _mm256_set1_pd(energy.wc),
            _mm256_set1_pd(w.node.volume),
        );
        let mut acc = [zero; D];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let j = neighbours(nb, b);
            let p = j.map(|k| base.add(k * stride));
            // The work records stream through the cache and evict the neighbours' records,
            // whose loads the loop then waited on: fetch those of two groups on.
            if b + 12 <= nb.neighbors.len() {
                prefetch_records::<D>(base, stride, neighbours(nb, b + 8));
            }
            let (y, x, c22) = positions::<D, CONTROL>(&p);
            let d: [__m256d; D] = std::array::from_fn(|a| _mm256_sub_pd(y[a], yi[a]));
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            // Intact and of non-zero length: the bonds the generic loop records work for.
            let mut keep = _mm256_and_pd(
                intact(nb.status, b),
                _mm256_cmp_pd::<_CMP_GT_OQ>(square(&d), zero),
            );
            let xi: [__m256d; D] = std::array::from_fn(|a| _mm256_sub_pd(x[a], xi_i[a]));
            let eta: [__m256d; D] = std::array::from_fn(|a| _mm256_sub_pd(d[a], xi[a]));
            // Each half's B ξ + C1 η apart, in the same order (`linear_half`): node i's from
            // its broadcast entries, the neighbours' from a −0 start (a fused multiply–add
            // onto −0 is the product itself, as the first product of node i's).
            let mut own: [__m256d; D] = std::array::from_fn(|r| {
                let mut v = _mm256_mul_pd(mine_b[r], xi[0]);
                for c in 1..D {
                    v = _mm256_fmadd_pd(mine_b[D * c + r], xi[c], v);
                }
                v
            });
            if CONTROL {
                add_symmetric::<D>(&mine_c1, &eta, &mut own);
            }
            let mut other = [_mm256_set1_pd(-0.0); D];
            add_matrices::<D, CONTROL>(&p, &xi, &eta, c22, &mut other);
            // The pair force T = ω φ (both halves), the generic `pair_force` without V; its
            // third component and that of Δη are zero in 2D (the record's padding). Each half
            // scaled, then added: from j's end the same bond gives exactly −T (its halves are
            // these negated, in the other order), so both entries record the same work.
            let wp = omega_phi::<HHB, INVERSE>(law, w, l);
            let force: [__m256d; 3] = std::array::from_fn(|a| {
                if a < D {
                    _mm256_add_pd(_mm256_mul_pd(own[a], wp), _mm256_mul_pd(other[a], wp))
                } else {
                    zero
                }
            });
            // Δη = y − (y_j − y_i at the previous evaluation).
            let dp = rows::<D>(previous, j, &pi);
            let step: [__m256d; 3] = std::array::from_fn(|a| {
                if a < D {
                    _mm256_sub_pd(d[a], dp[a])
                } else {
                    zero
                }
            });
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
                    let lanes3 =
                        std::array::from_fn(|a| if a < D { lanes(d[a]) } else { [0.0; 4] });
                    bits = in_tension(bits, lanes3, lanes(l));
                }
                if bits != 0 {
                    broke += break_lanes(nb, b, bits);
                    keep = _mm256_and_pd(keep, intact(nb.status, b));
                }
            }
            // The generic loop's T V over the bonds that hold.
            for a in 0..D {
                acc[a] = _mm256_fmadd_pd(_mm256_and_pd(force[a], keep), volume, acc[a]);
            }
            b += 4;
        }
        let mut f = [0.0; 3];
        for a in 0..D {
            f[a] = sum(acc[a]);
        }
        let pts = |k: usize| &points[k * stride..k * stride + 2 * D * D];
        let at = |v: &[f64], k: usize| flat_position(v, D, k);
        for b in b..nb.neighbors.len() {
            if nb.status[b] != INTACT {
                continue;
            }
            let j = nb.neighbors[b] as usize;
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
            // The generic loop's steps for one bond, in the lanes' arithmetic: T = ω φ (B_i ξ
            // + C1_i η) + ω φ (B_j ξ + C1_j η), its work, failure, T V.
            let l = nb.ref_lengths[b];
            let (om, p) = (law.omega(l), w.phi(l));
            let xi = law.xi::<D>(i, j);
            let eta = [d[0] - xi[0], d[1] - xi[1], d[2] - xi[2]];
            let (own_half, other) = (
                linear_half::<D, CONTROL>(pts(i), &xi, &eta),
                linear_half::<D, CONTROL>(pts(j), &xi, &eta),
            );
            let wp = om * p;
            let force: [f64; 3] = std::array::from_fn(|a| own_half[a] * wp + other[a] * wp);
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
            for a in 0..D {
                f[a] += force[a] * w.node.volume;
            }
        }
        (f, broke)
    }
}
