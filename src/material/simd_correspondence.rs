//! AVX2 + FMA bond loops of the correspondence model (2D and 3D, uniform grid, one horizon),
//! four bonds at a time: the pre-pass sums N = Σ ω η⊗ξ w and, when the caller cannot reuse it
//! (`Sums::kept`), K = Σ ω ξ⊗ξ w (seed 004, Eqs. 6–7);
//! the force pass under one critical stretch sums the neighbours' moment records s m_j
//! (`moment_*`: B, g, u and C1's version), from which the model forms the other halves
//! ω φ V (B_j ξ + C1_j η) and the own-half sum Σ s η without a product per bond (see
//! `Correspondence::vector_force` and `Material::FACTORED_OWN_HALF`);
//! under one critical energy the same force pass, and in the pre-pass, once node i's matrices
//! are known, each entry's own half of the bond work,
//! w_i += ½ (T_prev + T)·Δη with T = ω φ (B_i ξ + C1_i η) (Eq. 8 with Eq. 14 through
//! B = A − C1 H) from node i's matrices now and at the previous evaluation (Foster, Silling &
//! Chen 2011; seed 002 Eq. 6; seed 004 Eqs. 16–18, `damage::critical_energy`), on the bond
//! vectors the sums just read (`handed_words`); the engine breaks a bond when
//! w_i + w_j ≥ w_c φ̄ (`ForceEngine`'s split work).
//!
//! Same terms, failure rules and partial-volume factor as the generic loops; the sums of
//! products are fused multiply–adds (one rounding instead of two), and the order of a node's
//! bond terms is four lanes (two sets of sums, even and odd lanes, in the moment pass), then
//! the tail. Both are fixed, so results stay bitwise identical for any thread count; they
//! differ from the generic loop by round-off (10⁻¹⁴ of the forces; the moment form's grows
//! with the body's size over the horizon, see `Correspondence::moment_force`), and the
//! quantities that decide failure (|y|, the stretch, the work update from the pair force) are
//! computed in the generic loop's order. The kernels run only where the CPU has both AVX2 and
//! FMA (`simd::fma_available`). `tests/suite/kernels.rs` compares them with the generic loop
//! and checks that the two entries of every bond agree.
//!
//! Loads: the moment pass reads each neighbour's record as whole 256-bit rows (two cache
//! lines in 3D); the pre-pass and the own-half work pass read positions as 128-bit pairs, two
//! bonds per 256-bit register, interleaved with in-lane unpacks (no lane-crossing shuffle,
//! never a byte past a node's position). The kernels are generic over
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

/// Split work: what the pre-pass of a node leaves in `NodeBonds::scratch` for the work
/// kernel that follows on the same node, per group of four bonds b..b+4 at word
/// `handed_words(d) · b / 4`: d = y_j − y_i (d rows of four lanes), ξ (d rows), the lanes
/// that carry force (a mask row) and φ (a row). The work kernel then reads them in place of
/// two position gathers and the tests of the bond.
pub const fn handed_words(d: usize) -> usize {
    4 * (2 * d + 2)
}

/// The first word of the mask row and of the φ row in a group's `handed_words` (after the
/// 2d rows of d and ξ).
const fn handed_keep(d: usize) -> usize {
    4 * 2 * d
}
const fn handed_phi(d: usize) -> usize {
    4 * (2 * d + 1)
}

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
/// failure like the generic loop, and which bonds carried force. Given `nb.scratch` and no
/// critical stretch, it also leaves there what the work kernel reads (`handed_words`).
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
        // With `scratch` (split work, where this pass decides no failure), the groups'
        // bond vectors for the work kernel (`handed_words`).
        let groups = nb.neighbors.len() / 4;
        let hand = match nb.scratch.as_deref_mut() {
            Some(room) if nb.s0.is_none() => {
                if room.len() < handed_words(dim) * groups {
                    room.resize(handed_words(dim) * groups, 0.0);
                }
                room.as_mut_ptr()
            }
            _ => std::ptr::null_mut(),
        };
        let args = (nb, law, w, hand);
        match (args.0.s0.is_some(), with_k, !hand.is_null()) {
            (true, true, _) => {
                avx::with_flags!(avx::sums, dim, [true, true, false], hhb, law, (args))
            }
            (true, false, _) => {
                avx::with_flags!(avx::sums, dim, [true, false, false], hhb, law, (args))
            }
            (false, true, false) => {
                avx::with_flags!(avx::sums, dim, [false, true, false], hhb, law, (args))
            }
            (false, false, false) => {
                avx::with_flags!(avx::sums, dim, [false, false, false], hhb, law, (args))
            }
            (false, true, true) => {
                avx::with_flags!(avx::sums, dim, [false, true, true], hhb, law, (args))
            }
            (false, false, true) => {
                avx::with_flags!(avx::sums, dim, [false, false, true], hhb, law, (args))
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

/// Split work of node i under a uniform critical-energy law: adds each intact bond's own
/// half of the work since the previous evaluation to its word in `nb.history`,
/// w_i += ω φ (½ (B + B') ξ + ½ C1 η + ½ C1' η')·Δη (the generic
/// `Correspondence::own_half_work`, with η' = η − Δη from the previous positions
/// `nb.previous`), and returns how many entries may fail with their bond's other half
/// (w_i ≥ ½ w_c φ̄, less a margin for rounding). `mean_b` is ½ (B + B') column-major,
/// `half_c1` ½ C1 and ½ C1' as lower triangles (C1 only with zero-energy control). The
/// groups of four bonds take d, ξ, their lanes and φ from `nb.scratch`, where this node's
/// pre-pass (`correspondence_sums` of this evaluation, positions and status unchanged since)
/// left them (`handed_words`); the tail reads the positions.
///
/// # Safety
/// As for `correspondence_sums`; `nb.history.len() == nb.neighbors.len()`,
/// `nb.previous.len() == nb.current.len()`, and `nb.scratch` as above.
pub unsafe fn correspondence_own_work(
    nb: &mut NodeBonds,
    law: &CorrespondenceLaw,
    w: &UniformWeights,
    energy: &UniformCriticalEnergy,
    mean_b: &[f64; 9],
    half_c1: [&[f64; 6]; 2],
) -> u64 {
    debug_assert_eq!(nb.history.len(), nb.neighbors.len());
    debug_assert_eq!(nb.previous.len(), nb.current.len());
    debug_assert!(nb
        .scratch
        .as_ref()
        .is_some_and(|room| room.len() >= handed_words(nb.dim) * (nb.neighbors.len() / 4)));
    #[cfg(target_arch = "x86_64")]
    {
        let (dim, hhb) = (nb.dim, w.rule == PartialVolume::Hhb);
        let args = (nb, law, w, energy, mean_b, half_c1);
        // C1 changes only with K: most steps it is C1' and ½ C1 (η + η') one product.
        match (law.control, half_c1[0] != half_c1[1]) {
            (true, true) => avx::with_flags!(avx::own_work, dim, [true, true], hhb, law, (args)),
            (true, false) => avx::with_flags!(avx::own_work, dim, [true, false], hhb, law, (args)),
            (false, _) => avx::with_flags!(avx::own_work, dim, [false, false], hhb, law, (args)),
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("fma_available() is false off x86-64")
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::*;
    use crate::material::simd::avx::{intact, phi_of, prefetch, sum};
    use crate::material::simd::tail;
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

    /// The neighbours of bonds b..b+4 (`neighbors` a family's).
    #[inline(always)]
    unsafe fn neighbours(neighbors: &[u32], b: usize) -> [usize; 4] {
        std::array::from_fn(|k| *neighbors.get_unchecked(b + k) as usize)
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

    /// The index of entry (r, c) of a symmetric D×D matrix in the order of `lower`: columns
    /// 0..c hold D, D − 1, … entries.
    #[inline(always)]
    const fn lower_index<const D: usize>(r: usize, c: usize) -> usize {
        let (r, c) = if r >= c { (r, c) } else { (c, r) };
        c * (2 * D - c + 1) / 2 + (r - c)
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

    /// ω(|ξ|) φ V on four lanes (φ = φ(|ξ|)), zero outside `keep`: the generic ω · (φ μ V).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn weight<const INVERSE: bool>(
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        l: __m256d,
        phi: __m256d,
        keep: __m256d,
    ) -> __m256d {
        let pv = _mm256_mul_pd(phi, _mm256_set1_pd(w.node.volume));
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
        const HAND: bool,
        const HHB: bool,
        const INVERSE: bool,
    >(
        (nb, law, w, hand): (
            &mut NodeBonds,
            &CorrespondenceLaw,
            &UniformWeights,
            *mut f64,
        ),
    ) -> Sums {
        debug_assert_eq!(nb.dim, D);
        // A local copy: the stores through `hand` could alias it (every group loaded its
        // constants again).
        let w = &w.clone();
        let (neighbors, lengths) = (nb.neighbors, nb.ref_lengths);
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
        while b + 4 <= neighbors.len() {
            let j = neighbours(neighbors, b);
            let d = rows::<D>(current, j, &yi);
            prefetch::<512, _>(lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(lengths.as_ptr().add(b));
            let keep = keep_lanes!(DECIDE, nb, b, &d, l, s0, near, broke);
            word |= (_mm256_movemask_pd(keep) as u64) << (b % 64);
            if b % 64 == 60 {
                kept[(b / 64) & 3] = word;
                word = 0;
            }
            let phi = phi_of::<HHB>(w, l);
            let s = weight::<INVERSE>(law, w, l, phi, keep);
            let xi = rows::<D>(reference, j, &xi_i);
            if HAND {
                let out = hand.add(handed_words(D) * (b / 4));
                for a in 0..D {
                    _mm256_storeu_pd(out.add(4 * a), d[a]);
                    _mm256_storeu_pd(out.add(4 * (D + a)), xi[a]);
                }
                _mm256_storeu_pd(out.add(handed_keep(D)), keep);
                _mm256_storeu_pd(out.add(handed_phi(D)), phi);
            }
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
            let j = neighbours(nb.neighbors, b);
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
            let s = lanes(weight::<INVERSE>(law, w, l, phi_of::<HHB>(w, l), keep));
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

    /// Lane k of v.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn lanes(v: __m256d) -> [f64; 4] {
        let mut a = [0.0; 4];
        _mm256_storeu_pd(a.as_mut_ptr(), v);
        a
    }

    /// The lower bound on a bond's own half of the work above which the entry may fail with
    /// the other half: ½ w_c φ̄ less 10⁻⁹ of it (w_i + w_j ≥ w_c φ̄ needs one half at least
    /// ½ w_c φ̄; the margin covers the rounding of the sum).
    const HALF_MARGIN: f64 = 0.5 * (1.0 - 1e-9);

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn own_work<
        const D: usize,
        const CONTROL: bool,
        const NEW_C1: bool,
        const HHB: bool,
        const INVERSE: bool,
    >(
        (nb, law, w, energy, mean_b, half_c1): (
            &mut NodeBonds,
            &CorrespondenceLaw,
            &UniformWeights,
            &UniformCriticalEnergy,
            &[f64; 9],
            [&[f64; 6]; 2],
        ),
    ) -> u64 {
        debug_assert_eq!(nb.dim, D);
        // Local copies: the stores to the work words cannot alias them, so their entries
        // stay in registers.
        let (law, w) = (&law.clone(), &w.clone());
        let i = nb.i;
        let previous = nb.previous.as_ptr();
        let pi = own::<D>(previous, i);
        // The pre-pass's d, ξ, lanes and φ of each group (`handed_words`).
        let handed = nb
            .scratch
            .as_deref()
            .map_or(std::ptr::null(), |v| v.as_ptr());
        let zero = _mm256_setzero_pd();
        let m: [__m256d; 9] = std::array::from_fn(|k| _mm256_set1_pd(mean_b[k]));
        let c: [[__m256d; 6]; 2] = half_c1.map(|h| h.map(|x| _mm256_set1_pd(x)));
        let bound = _mm256_set1_pd(HALF_MARGIN * energy.wc);
        let mut flagged = 0;
        let mut b = 0;
        let words = nb.history.as_mut_ptr();
        // The family's arrays as locals: the stores to the work words could alias `nb`, which
        // made every group load them again.
        let (neighbors, lengths) = (nb.neighbors, nb.ref_lengths);
        while b + 4 <= neighbors.len() {
            let j = neighbours(neighbors, b);
            let dp = rows::<D>(previous, j, &pi);
            let at = handed.add(handed_words(D) * (b / 4));
            let d: [__m256d; D] = std::array::from_fn(|a| _mm256_loadu_pd(at.add(4 * a)));
            let xi: [__m256d; D] = std::array::from_fn(|a| _mm256_loadu_pd(at.add(4 * (D + a))));
            // Intact and of non-zero length: the bonds the generic loop visits.
            let keep = _mm256_loadu_pd(at.add(handed_keep(D)));
            let phi = _mm256_loadu_pd(at.add(handed_phi(D)));
            prefetch::<512, _>(words.add(b));
            // t = ½ (B + B') ξ + ½ C1 η + ½ C1' η', then its work t·Δη.
            let mut t: [__m256d; D] = std::array::from_fn(|r| {
                let mut v = _mm256_mul_pd(m[r], xi[0]);
                for col in 1..D {
                    v = _mm256_fmadd_pd(m[D * col + r], xi[col], v);
                }
                v
            });
            if CONTROL {
                let eta: [__m256d; D] = std::array::from_fn(|a| _mm256_sub_pd(d[a], xi[a]));
                let eta_prev: [__m256d; D] = std::array::from_fn(|a| _mm256_sub_pd(dp[a], xi[a]));
                if NEW_C1 {
                    add_symmetric::<D>(&c[0], &eta, &mut t);
                    add_symmetric::<D>(&c[1], &eta_prev, &mut t);
                } else {
                    let sum = std::array::from_fn(|a| _mm256_add_pd(eta[a], eta_prev[a]));
                    add_symmetric::<D>(&c[0], &sum, &mut t);
                }
            }
            let mut work = zero;
            for r in 0..D {
                work = _mm256_fmadd_pd(t[r], _mm256_sub_pd(d[r], dp[r]), work);
            }
            // w_i += ω φ t·Δη on the lanes kept (the others add ω φ · 0).
            let wp = times_omega::<INVERSE>(law, _mm256_loadu_pd(lengths.as_ptr().add(b)), phi);
            let old = _mm256_loadu_pd(words.add(b));
            let new = _mm256_fmadd_pd(wp, _mm256_and_pd(work, keep), old);
            _mm256_storeu_pd(words.add(b), new);
            let over = _mm256_cmp_pd::<_CMP_GE_OQ>(new, _mm256_mul_pd(bound, phi));
            let bits = _mm256_movemask_pd(_mm256_and_pd(over, keep));
            if bits != 0 {
                flagged += bits.count_ones() as u64;
            }
            b += 4;
        }
        let at = |v: &[f64], k: usize| flat_position(v, D, k);
        let (yi, pi) = (at(nb.current, i), at(nb.previous, i));
        for b in b..nb.neighbors.len() {
            let j = nb.neighbors[b] as usize;
            let (yj, pj) = (at(nb.current, j), at(nb.previous, j));
            let d: [f64; 3] = std::array::from_fn(|a| yj[a] - yi[a]);
            if nb.status[b] != INTACT || d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= 0.0 {
                continue;
            }
            let l = nb.ref_lengths[b];
            let xi = law.xi::<D>(i, j);
            let dp: [f64; 3] = std::array::from_fn(|a| pj[a] - pi[a]);
            let mut t = [0.0; 3];
            for r in 0..D {
                for col in 0..D {
                    t[r] = mean_b[D * col + r].mul_add(xi[col], t[r]);
                    if CONTROL {
                        let e = lower_index::<D>(r, col);
                        let (eta, eta_prev) = (d[col] - xi[col], dp[col] - xi[col]);
                        if NEW_C1 {
                            t[r] = half_c1[0][e].mul_add(eta, t[r]);
                            t[r] = half_c1[1][e].mul_add(eta_prev, t[r]);
                        } else {
                            t[r] = half_c1[0][e].mul_add(eta + eta_prev, t[r]);
                        }
                    }
                }
            }
            let work: f64 = (0..D).map(|r| t[r] * (d[r] - dp[r])).sum();
            let (omega, phi) = (law.omega(l), w.phi(l));
            nb.history[b] += omega * phi * work;
            if nb.history[b] >= HALF_MARGIN * energy.wc * phi {
                flagged += 1;
            }
        }
        flagged
    }
}
