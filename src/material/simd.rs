//! Bond loops on four bonds at a time with AVX2 (x86-64, 2D and 3D, uniform grids), for the
//! models that provide them (PMB force; LPS pre-pass and force). Same laws, failure rule and
//! partial-volume factor as the generic loops; only the order in which a node's bond terms are
//! summed differs (four lanes, then the tail), and it is fixed, so results stay bitwise
//! identical for any thread count. `tests/suite/kernels.rs` checks them against the generic loop.

use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::PartialVolume;
use crate::damage::critical_energy::UniformCriticalEnergy;
use crate::damage::softening::UniformSoftening;
use crate::state::{BROKEN, INTACT};

/// Whether this machine can run the kernels.
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether this machine can run the kernels that also need fused multiply–add (the
/// correspondence kernels, `simd_correspondence`).
pub fn fma_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        available() && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The family of node i as a kernel sees it.
pub struct NodeBonds<'a> {
    pub i: usize,
    /// Dimension: 3, or 2 (`planar`; every kernel takes x, y lanes there).
    pub dim: usize,
    /// Current positions, flat x, y, z (x, y in 2D).
    pub current: &'a [f64],
    pub neighbors: &'a [u32],
    pub ref_lengths: &'a [f64],
    pub status: &'a mut [u8],
    pub no_fail: &'a [bool],
    /// Critical stretch, or `None` when this pass does not decide failure.
    pub s0: Option<f64>,
    /// A uniform softening law that this pass applies instead of a critical stretch (see
    /// `with_softening`); only the PMB kernel implements it.
    pub softening: Option<UniformSoftening>,
    /// A uniform critical-energy law that this pass applies instead of a critical stretch
    /// (see `with_work`); the PMB, LPS and correspondence force kernels implement it.
    pub work: Option<UniformCriticalEnergy>,
    /// The family's history words: one per bond (the largest stretch) when `softening`, the
    /// work records when `work` (see `with_work`).
    pub history: &'a mut [f64],
    /// Current positions at the previous force evaluation, flat as `current` (empty unless
    /// `with_previous`): the work's displacement increments.
    pub previous: &'a [f64],
    /// Node i's own-half matrices at the previous evaluation (`Material::node_matrices`;
    /// empty unless `with_previous` gives them): split work.
    pub matrices: &'a [f64],
    /// Room in which one kernel leaves what it read of the family for the next one on the
    /// same node (`None` unless `with_scratch`; the correspondence pre-pass hands its bond
    /// vectors to the split-work kernel). It grows to the largest family it serves.
    pub scratch: Option<&'a mut Vec<f64>>,
}

impl<'a> NodeBonds<'a> {
    /// Node i's family; `status` is the slice of its bonds' status bytes.
    pub fn of(
        i: usize,
        current: &'a [f64],
        bonds: &'a crate::bonds::Bonds,
        status: &'a mut [u8],
        no_fail: &'a [bool],
        s0: Option<f64>,
    ) -> Self {
        let r = bonds.family(i);
        NodeBonds {
            i,
            dim: 3,
            current,
            neighbors: &bonds.neighbors[r.clone()],
            ref_lengths: &bonds.ref_lengths[r],
            status,
            no_fail,
            s0,
            softening: None,
            work: None,
            history: &mut [],
            previous: &[],
            matrices: &[],
            scratch: None,
        }
    }

    /// The same family with room for the kernels to hand data on (`scratch`).
    pub fn with_scratch(mut self, scratch: &'a mut Vec<f64>) -> Self {
        self.scratch = Some(scratch);
        self
    }

    /// The same family with the positions of the previous evaluation and node i's own-half
    /// matrices then (a non-central model's work under `with_work`; the matrices only for
    /// split work, else empty).
    pub fn with_previous(mut self, previous: &'a [f64], matrices: &'a [f64]) -> Self {
        self.previous = previous;
        self.matrices = matrices;
        self
    }

    /// The same family under a uniform softening law with its history (one word per bond).
    pub fn with_softening(mut self, law: UniformSoftening, history: &'a mut [f64]) -> Self {
        debug_assert_eq!(history.len(), self.neighbors.len());
        self.s0 = None;
        self.softening = Some(law);
        self.history = history;
        self
    }

    /// The same family in 2D: `current` holds x, y per node.
    pub fn planar(mut self) -> Self {
        self.dim = 2;
        self
    }

    /// The same family in dimension `dim` (3, or 2: `planar`) under the engine's uniform law:
    /// a softening law or a critical energy with the family's history words, if either.
    pub fn under(
        mut self,
        dim: usize,
        softening: Option<UniformSoftening>,
        work: Option<UniformCriticalEnergy>,
        history: &'a mut [f64],
    ) -> Self {
        if dim == 2 {
            self = self.planar();
        }
        match (softening, work) {
            (Some(law), _) => self.with_softening(law, history),
            (None, Some(law)) => self.with_work(law, history),
            (None, None) => self,
        }
    }

    /// Node k's current position, z = 0 in 2D (`flat_position`).
    #[inline(always)]
    pub fn position(&self, k: usize) -> [f64; 3] {
        flat_position(self.current, self.dim, k)
    }

    /// The same family under a uniform critical-energy law with its work records (none for a
    /// linear bond, two words per bond for another central force, four for a vector force,
    /// one for split work; `damage::critical_energy`). Failure is then decided from the work
    /// (in the force pass, or after it with split work), not from the stretch.
    pub fn with_work(mut self, law: UniformCriticalEnergy, history: &'a mut [f64]) -> Self {
        debug_assert!([0, 1, 2, 4]
            .map(|w| w * self.neighbors.len())
            .contains(&history.len()));
        self.s0 = None;
        self.work = Some(law);
        self.history = history;
        self
    }
}

/// Constants of a PMB bond law (seed 001, Eq. 4), per unit volume².
#[derive(Debug, Clone, Copy)]
pub struct PmbLaw {
    pub c0: f64,
    pub horizon: f64,
    pub conical: bool,
}

/// Constants of the LPS force state t = (a θ ω|ξ| + b ω (e − c θ |ξ|)) / m (seed 002, Eqs. 3–5).
#[derive(Debug, Clone, Copy)]
pub struct LpsLaw {
    pub a_vol: f64,
    pub b_dev: f64,
    pub c_iso: f64,
    pub horizon: f64,
    /// ω = δ/|ξ| instead of 1.
    pub inverse_influence: bool,
}

/// Asks for the cache line that holds `value` (a hint: no effect on results).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing; SSE is part of x86-64.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            value as *const T as *const i8,
        )
    }
}

/// |y| of a deformed bond vector, in the order the vector lanes use.
#[inline(always)]
pub(crate) fn length(d: &[f64; 3]) -> f64 {
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// The scalar tail of a family: calls `f(b, j, |ξ|, y, |y|)` for each bond b from `from` on
/// that carries force (intact after failure is decided as the lanes do, |y| > 0). Returns the
/// bonds broken.
#[inline(always)] // so that the caller's closure (which inherits `avx2`) is inlined too
pub(crate) fn tail(
    nb: &mut NodeBonds,
    from: usize,
    mut f: impl FnMut(usize, usize, f64, [f64; 3], f64),
) -> u64 {
    let i = nb.i;
    let own = nb.position(i);
    let mut broke = 0;
    for b in from..nb.neighbors.len() {
        if nb.status[b] != INTACT {
            continue;
        }
        let j = nb.neighbors[b] as usize;
        let y = nb.position(j);
        let d = [y[0] - own[0], y[1] - own[1], y[2] - own[2]];
        let len = length(&d);
        let l = nb.ref_lengths[b];
        if let Some(s0) = nb.s0 {
            if len - l > s0 * l && !(nb.no_fail[i] || nb.no_fail[j]) {
                nb.status[b] = BROKEN;
                broke += 1;
                continue;
            }
        }
        if len > 0.0 {
            f(b, j, l, d, len);
        }
    }
    broke
}

impl PmbLaw {
    /// c(ξ) ½(pm + pm) (|y| − |ξ|) / (|ξ||y|) with pm = φ μ of both halves: the generic loop's
    /// `pair_force_per_length` (`Pmb::pair_weight`, seed 001 Eq. 4) on a uniform grid.
    #[inline(always)]
    pub(crate) fn per_length(&self, l: f64, len: f64, pm: f64) -> f64 {
        self.c0 * self.profile(l) * 0.5 * (pm + pm) * (len - l) / (l * len)
    }

    /// `per_length` of an intact bond times V.
    #[inline(always)]
    pub(crate) fn coefficient(&self, w: &UniformWeights, l: f64, len: f64) -> f64 {
        self.per_length(l, len, w.phi(l)) * w.node.volume
    }

    /// The profile g(|ξ|) of c(ξ) = c0 g (1, or 1 − |ξ|/δ).
    #[inline(always)]
    fn profile(&self, l: f64) -> f64 {
        if self.conical {
            (1.0 - l / self.horizon).max(0.0)
        } else {
            1.0
        }
    }

    /// `coefficient` with the micromodulus of each end, c0_i and c0_j: ½(c_i pm + c_j pm)
    /// (|y| − |ξ|) / (|ξ||y|) V, the generic loop's `Pmb::pair_weight` for a varying c0.
    #[inline(always)]
    pub(crate) fn coefficient_per_node(
        &self,
        w: &UniformWeights,
        (c0_i, c0_j): (f64, f64),
        l: f64,
        len: f64,
    ) -> f64 {
        let (g, pm) = (self.profile(l), w.phi(l));
        let weight = 0.5 * (c0_i * g * pm + c0_j * g * pm);
        weight * (len - l) / (l * len) * w.node.volume
    }
}

impl LpsLaw {
    #[inline(always)]
    pub(crate) fn omega(&self, l: f64) -> f64 {
        if self.inverse_influence {
            self.horizon / l
        } else {
            1.0
        }
    }
    #[inline(always)]
    pub(crate) fn state(&self, inv_m: f64, theta: f64, w: f64, e: f64, l: f64) -> f64 {
        (self.a_vol * theta * w * l + self.b_dev * w * (e - self.c_iso * theta * l)) * inv_m
    }
}

/// Node k's position in positions stored flat, `dim` (2 or 3) per node, with z = 0 in 2D (so
/// that a 3D length, (x² + y²) + z², is the 2D one to the bit).
#[inline(always)]
pub(crate) fn flat_position(flat: &[f64], dim: usize, k: usize) -> [f64; 3] {
    let c = &flat[dim * k..dim * k + dim];
    [c[0], c[1], if dim == 3 { c[2] } else { 0.0 }]
}

/// PMB force density on node i and the bonds broken, under one critical stretch (the
/// softening and critical-energy kernels are `simd_damage` and `simd_energy`; `Pmb` picks).
///
/// # Safety
/// `available()` must be true and every neighbour index below `current.len() / nb.dim`.
pub unsafe fn pmb_force(nb: &mut NodeBonds, law: &PmbLaw, w: &UniformWeights) -> ([f64; 3], u64) {
    debug_assert!(nb.softening.is_none() && nb.work.is_none());
    #[cfg(target_arch = "x86_64")]
    {
        if nb.dim == 2 {
            avx::pmb_force::<2>(nb, law, w)
        } else {
            avx::pmb_force::<3>(nb, law, w)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("available() is false off x86-64")
}

/// `pmb_force` with a micromodulus per node, `c0[k]` of node k (a surface correction's
/// factors on a uniform grid, seed 000 Eq. 11): each bond's weight is ½(c_i + c_j)φ, in the
/// generic `Pmb::pair_weight`'s arithmetic.
///
/// # Safety
/// As for `pmb_force`; `c0` has an entry for every neighbour index.
pub unsafe fn pmb_force_per_node(
    nb: &mut NodeBonds,
    law: &PmbLaw,
    w: &UniformWeights,
    c0: &[f64],
) -> ([f64; 3], u64) {
    debug_assert!(nb.softening.is_none() && nb.work.is_none());
    #[cfg(target_arch = "x86_64")]
    {
        if nb.dim == 2 {
            avx::pmb_force_per_node::<2>(nb, law, w, c0)
        } else {
            avx::pmb_force_per_node::<3>(nb, law, w, c0)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("available() is false off x86-64")
}

/// LPS pre-pass of node i: the raw sum Σ ω|ξ| e φ V over intact bonds, and the bonds broken.
///
/// # Safety
/// As for `pmb_force`.
pub unsafe fn lps_dilatation_sum(
    nb: &mut NodeBonds,
    law: &LpsLaw,
    w: &UniformWeights,
) -> (f64, u64) {
    #[cfg(target_arch = "x86_64")]
    {
        if nb.dim == 2 {
            avx::lps_dilatation_sum::<2>(nb, law, w)
        } else {
            avx::lps_dilatation_sum::<3>(nb, law, w)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("available() is false off x86-64")
}

/// LPS force density on node i from the dilatations and 1/m of all nodes.
///
/// # Safety
/// As for `pmb_force`; `theta` and `inv_m` have one entry per node.
pub unsafe fn lps_force(
    nb: &mut NodeBonds,
    law: &LpsLaw,
    w: &UniformWeights,
    theta: &[f64],
    inv_m: &[f64],
) -> [f64; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        if nb.dim == 2 {
            avx::lps_force::<2>(nb, law, w, theta, inv_m)
        } else {
            avx::lps_force::<3>(nb, law, w, theta, inv_m)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("available() is false off x86-64")
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx {
    use super::*;
    use std::arch::x86_64::*;

    /// Deformed bond vectors and lengths of bonds b..b+4 (masked loads: never past a node).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn bond_vectors(nb: &NodeBonds, b: usize, yi: [__m256d; 3]) -> [__m256d; 4] {
        // No closure here: one was compiled out of line and called per row.
        let base = nb.current.as_ptr();
        let mask = _mm256_set_epi64x(0, -1, -1, -1);
        let js = &nb.neighbors[b..b + 4];
        let r0 = _mm256_maskload_pd(base.add(3 * js[0] as usize), mask);
        let r1 = _mm256_maskload_pd(base.add(3 * js[1] as usize), mask);
        let r2 = _mm256_maskload_pd(base.add(3 * js[2] as usize), mask);
        let r3 = _mm256_maskload_pd(base.add(3 * js[3] as usize), mask);
        let (t0, t1) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
        let (t2, t3) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
        let dx = _mm256_sub_pd(_mm256_permute2f128_pd::<0x20>(t0, t2), yi[0]);
        let dy = _mm256_sub_pd(_mm256_permute2f128_pd::<0x20>(t1, t3), yi[1]);
        let dz = _mm256_sub_pd(_mm256_permute2f128_pd::<0x31>(t0, t2), yi[2]);
        let len = _mm256_sqrt_pd(_mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
            _mm256_mul_pd(dz, dz),
        ));
        [dx, dy, dz, len]
    }

    /// Deformed bond vectors (x, y, and z = 0) and lengths of bonds b..b+4 in 2D, as
    /// `bond_vectors` in 3D (the generic loop's |y| = sqrt(x² + y²)).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn bond_vectors_2d(
        nb: &NodeBonds,
        b: usize,
        yi: [__m256d; 3],
    ) -> [__m256d; 4] {
        let base = nb.current.as_ptr();
        let row = |lane: usize| _mm_loadu_pd(base.add(2 * nb.neighbors[b + lane] as usize));
        // [x0, y0, x2, y2] and [x1, y1, x3, y3].
        let even = _mm256_set_m128d(row(2), row(0));
        let odd = _mm256_set_m128d(row(3), row(1));
        let dx = _mm256_sub_pd(_mm256_unpacklo_pd(even, odd), yi[0]);
        let dy = _mm256_sub_pd(_mm256_unpackhi_pd(even, odd), yi[1]);
        let len = _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)));
        [dx, dy, _mm256_setzero_pd(), len]
    }

    /// `bond_vectors` in 3D, `bond_vectors_2d` in 2D.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn bond_vectors_in<const D: usize>(
        nb: &NodeBonds,
        b: usize,
        yi: [__m256d; 3],
    ) -> [__m256d; 4] {
        if D == 3 {
            bond_vectors(nb, b, yi)
        } else {
            bond_vectors_2d(nb, b, yi)
        }
    }

    /// Asks for the cache line `AHEAD` bytes past `p` in a per-bond array. The bond arrays are
    /// streamed once per step and outgrow the caches; left to the hardware prefetcher alone,
    /// the kernels wait on memory (measured on `peridyn bench`, 1 thread: +56 % node-steps/s on
    /// `pmb-energy-3d` with its work record prefetched 512 bytes ahead, +70 % at 2048; +5–15 %
    /// on `pmb-3d` with the reference lengths prefetched). Never dereferenced: a prefetch past
    /// the end of the array is harmless.
    #[inline(always)]
    pub(crate) unsafe fn prefetch<const AHEAD: usize, T>(p: *const T) {
        _mm_prefetch::<_MM_HINT_T0>((p as *const i8).wrapping_add(AHEAD));
    }

    /// Lanes of bonds b..b+4 that are intact, as a mask.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn intact(status: &[u8], b: usize) -> __m256d {
        _mm256_castsi256_pd(_mm256_cmpeq_epi64(
            status_lanes(status, b),
            _mm256_setzero_si256(),
        ))
    }

    /// The status bytes of bonds b..b+4 as 64-bit lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn status_lanes(status: &[u8], b: usize) -> __m256i {
        // One unaligned 4-byte read: the kernels call this only for b + 4 <= status.len().
        debug_assert!(b + 4 <= status.len());
        let st = u32::from_le((status.as_ptr().add(b) as *const u32).read_unaligned());
        _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(st as i32))
    }

    /// Four lanes of a per-node array at the neighbours `js` of four bonds.
    #[inline(always)]
    pub(crate) unsafe fn gather(values: &[f64], js: &[usize; 4]) -> __m256d {
        _mm256_set_pd(values[js[3]], values[js[2]], values[js[1]], values[js[0]])
    }

    /// The neighbours of bonds b..b+4.
    #[inline(always)]
    pub(crate) fn neighbours(nb: &NodeBonds, b: usize) -> [usize; 4] {
        let n = &nb.neighbors[b..b + 4];
        [n[0] as usize, n[1] as usize, n[2] as usize, n[3] as usize]
    }

    /// Failure of bonds b..b+4 (s > s0, unless an end is no-fail), then the mask of lanes that
    /// carry force: intact and of non-zero length.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn fail_and_keep(
        nb: &mut NodeBonds,
        b: usize,
        len: __m256d,
        l: __m256d,
        broke: &mut u64,
    ) -> __m256d {
        let mut keep = intact(nb.status, b);
        if let Some(s0) = nb.s0 {
            let over = _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_GT_OQ>(
                    _mm256_sub_pd(len, l),
                    _mm256_mul_pd(_mm256_set1_pd(s0), l),
                ),
                keep,
            );
            let bits = _mm256_movemask_pd(over);
            if bits != 0 {
                break_lanes(nb, b, bits, broke);
                keep = intact(nb.status, b);
            }
        }
        _mm256_and_pd(keep, _mm256_cmp_pd::<_CMP_GT_OQ>(len, _mm256_setzero_pd()))
    }

    /// Breaks the lanes of bonds b..b+4 set in `bits` unless an end is no-fail. Rare, and kept
    /// out of line so that `fail_and_keep` stays small enough to be inlined into every kernel.
    #[cold]
    #[inline(never)]
    fn break_lanes(nb: &mut NodeBonds, b: usize, bits: i32, broke: &mut u64) {
        for lane in 0..4 {
            let j = nb.neighbors[b + lane] as usize;
            if bits & (1 << lane) != 0 && !(nb.no_fail[nb.i] || nb.no_fail[j]) {
                nb.status[b + lane] = BROKEN;
                *broke += 1;
            }
        }
    }

    /// φ(|ξ|) of seed 000, Eq. 12, on four lanes with the scalar rule's arithmetic.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn phi(w: &UniformWeights, l: __m256d) -> __m256d {
        match w.rule {
            PartialVolume::Hhb => phi_of::<true>(w, l),
            // `uniform()` is never Some for the exact rule, so it does not reach the kernels.
            PartialVolume::None | PartialVolume::Exact => phi_of::<false>(w, l),
        }
    }

    /// `phi` with the rule fixed at compile time (`HHB`: the rule is `PartialVolume::Hhb`, else
    /// no partial volumes), for kernels whose loop is too long for the compiler to hoist the
    /// rule's test out of it.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn phi_of<const HHB: bool>(w: &UniformWeights, l: __m256d) -> __m256d {
        let n = &w.node;
        if HHB {
            _mm256_min_pd(
                _mm256_max_pd(
                    _mm256_mul_pd(
                        _mm256_sub_pd(_mm256_set1_pd(n.horizon + n.half_cell), l),
                        _mm256_set1_pd(n.inv_cell),
                    ),
                    _mm256_setzero_pd(),
                ),
                _mm256_set1_pd(1.0),
            )
        } else {
            _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_LE_OQ>(l, _mm256_set1_pd(n.horizon)),
                _mm256_set1_pd(1.0),
            )
        }
    }

    /// acc += coef · (dx, dy, dz) on the lanes in `keep`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn add_force(
        acc: &mut [__m256d; 3],
        coef: __m256d,
        keep: __m256d,
        d: [__m256d; 3],
    ) {
        let coef = _mm256_and_pd(coef, keep);
        for a in 0..3 {
            acc[a] = _mm256_add_pd(acc[a], _mm256_mul_pd(coef, d[a]));
        }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn sum(v: __m256d) -> f64 {
        let mut a = [0.0; 4];
        _mm256_storeu_pd(a.as_mut_ptr(), v);
        (a[0] + a[1]) + (a[2] + a[3])
    }

    /// Node i's position on four lanes (z = 0 in 2D).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn own_position(nb: &NodeBonds) -> [__m256d; 3] {
        nb.position(nb.i).map(|c| _mm256_set1_pd(c))
    }

    /// PMB under one critical stretch in dimension D (`nb.dim`; z = 0 in 2D).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn pmb_force<const D: usize>(
        nb: &mut NodeBonds,
        law: &PmbLaw,
        w: &UniformWeights,
    ) -> ([f64; 3], u64) {
        debug_assert_eq!(nb.dim, D);
        let yi = own_position(nb);
        let volume = _mm256_set1_pd(w.node.volume);
        let mut acc = [_mm256_setzero_pd(); 3];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let [dx, dy, dz, len] = bond_vectors_in::<D>(nb, b, yi);
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = fail_and_keep(nb, b, len, l, &mut broke);
            let coef = _mm256_mul_pd(pmb_per_length(law, l, len, phi(w, l)), volume);
            add_force(&mut acc, coef, keep, [dx, dy, dz]);
            b += 4;
        }
        let mut f = [sum(acc[0]), sum(acc[1]), sum(acc[2])];
        broke += tail(nb, b, |_, _, l, d, len| {
            let coef = law.coefficient(w, l, len);
            for a in 0..3 {
                f[a] += coef * d[a];
            }
        });
        (f, broke)
    }

    /// PMB with a micromodulus per node under one critical stretch in dimension D.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn pmb_force_per_node<const D: usize>(
        nb: &mut NodeBonds,
        law: &PmbLaw,
        w: &UniformWeights,
        c0: &[f64],
    ) -> ([f64; 3], u64) {
        debug_assert_eq!(nb.dim, D);
        let yi = own_position(nb);
        let c0_i = _mm256_set1_pd(c0[nb.i]);
        let volume = _mm256_set1_pd(w.node.volume);
        let mut acc = [_mm256_setzero_pd(); 3];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let [dx, dy, dz, len] = bond_vectors_in::<D>(nb, b, yi);
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = fail_and_keep(nb, b, len, l, &mut broke);
            let c0_j = gather(c0, &neighbours(nb, b));
            let g = pmb_profile(law, l);
            let pm = phi(w, l);
            // ½(c_i φ + c_j φ), c = c0 g: `Pmb::pair_weight`'s order.
            let weight = _mm256_mul_pd(
                _mm256_set1_pd(0.5),
                _mm256_add_pd(
                    _mm256_mul_pd(_mm256_mul_pd(c0_i, g), pm),
                    _mm256_mul_pd(_mm256_mul_pd(c0_j, g), pm),
                ),
            );
            let per_length = _mm256_div_pd(
                _mm256_mul_pd(weight, _mm256_sub_pd(len, l)),
                _mm256_mul_pd(l, len),
            );
            add_force(
                &mut acc,
                _mm256_mul_pd(per_length, volume),
                keep,
                [dx, dy, dz],
            );
            b += 4;
        }
        let mut f = [sum(acc[0]), sum(acc[1]), sum(acc[2])];
        let c0_i = c0[nb.i];
        broke += tail(nb, b, |_, j, l, d, len| {
            let coef = law.coefficient_per_node(w, (c0_i, c0[j]), l, len);
            for a in 0..3 {
                f[a] += coef * d[a];
            }
        });
        (f, broke)
    }

    /// `PmbLaw::profile` on four lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn pmb_profile(law: &PmbLaw, l: __m256d) -> __m256d {
        if law.conical {
            conical(l, _mm256_set1_pd(law.horizon))
        } else {
            _mm256_set1_pd(1.0)
        }
    }

    /// The conical profile g = max(1 − |ξ|/δ, 0) on four lanes, a horizon per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn conical(l: __m256d, horizon: __m256d) -> __m256d {
        let one_minus = _mm256_sub_pd(_mm256_set1_pd(1.0), _mm256_div_pd(l, horizon));
        _mm256_max_pd(one_minus, _mm256_setzero_pd())
    }

    /// `PmbLaw::per_length` on four lanes, in its arithmetic: c(ξ) ½(pm + pm)(|y| − |ξ|) /
    /// (|ξ||y|), pm = φ μ (seed 001 Eq. 4).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn pmb_per_length(
        law: &PmbLaw,
        l: __m256d,
        len: __m256d,
        pm: __m256d,
    ) -> __m256d {
        let c0 = _mm256_set1_pd(law.c0);
        let c = if law.conical {
            _mm256_mul_pd(c0, conical(l, _mm256_set1_pd(law.horizon)))
        } else {
            c0
        };
        _mm256_div_pd(
            _mm256_mul_pd(
                _mm256_mul_pd(_mm256_mul_pd(c, _mm256_set1_pd(0.5)), _mm256_add_pd(pm, pm)),
                _mm256_sub_pd(len, l),
            ),
            _mm256_mul_pd(l, len),
        )
    }

    /// `LpsLaw::state` on four lanes, in its order: t = (a θ ω |ξ| + b ω (e − c θ |ξ|)) / m
    /// (seed 002, Eqs. 3–5).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn lps_state(
        law: &LpsLaw,
        theta: __m256d,
        inv_m: __m256d,
        om: __m256d,
        e: __m256d,
        l: __m256d,
    ) -> __m256d {
        let (a, bd, c) = (
            _mm256_set1_pd(law.a_vol),
            _mm256_set1_pd(law.b_dev),
            _mm256_set1_pd(law.c_iso),
        );
        _mm256_mul_pd(
            _mm256_add_pd(
                _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(a, theta), om), l),
                _mm256_mul_pd(
                    _mm256_mul_pd(bd, om),
                    _mm256_sub_pd(e, _mm256_mul_pd(_mm256_mul_pd(c, theta), l)),
                ),
            ),
            inv_m,
        )
    }

    /// ω(|ξ|) on four lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn omega(law: &LpsLaw, l: __m256d) -> __m256d {
        if law.inverse_influence {
            _mm256_div_pd(_mm256_set1_pd(law.horizon), l)
        } else {
            _mm256_set1_pd(1.0)
        }
    }

    /// LPS pre-pass in dimension D (`nb.dim`; z = 0 in 2D).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn lps_dilatation_sum<const D: usize>(
        nb: &mut NodeBonds,
        law: &LpsLaw,
        w: &UniformWeights,
    ) -> (f64, u64) {
        debug_assert_eq!(nb.dim, D);
        let yi = own_position(nb);
        let volume = _mm256_set1_pd(w.node.volume);
        let mut acc = _mm256_setzero_pd();
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let [_, _, _, len] = bond_vectors_in::<D>(nb, b, yi);
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = fail_and_keep(nb, b, len, l, &mut broke);
            // ω |ξ| e φ V, in the generic `accumulate`'s order.
            let term = _mm256_mul_pd(
                _mm256_mul_pd(_mm256_mul_pd(omega(law, l), l), _mm256_sub_pd(len, l)),
                _mm256_mul_pd(phi(w, l), volume),
            );
            acc = _mm256_add_pd(acc, _mm256_and_pd(term, keep));
            b += 4;
        }
        let mut s = sum(acc);
        broke += tail(nb, b, |_, _, l, _, len| {
            s += law.omega(l) * l * (len - l) * (w.phi(l) * w.node.volume)
        });
        (s, broke)
    }

    /// LPS force pass under one critical stretch in dimension D (`nb.dim`; z = 0 in 2D).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn lps_force<const D: usize>(
        nb: &mut NodeBonds,
        law: &LpsLaw,
        w: &UniformWeights,
        theta: &[f64],
        inv_m: &[f64],
    ) -> [f64; 3] {
        debug_assert_eq!(nb.dim, D);
        let i = nb.i;
        let yi = own_position(nb);
        let (theta_i, inv_m_i) = (_mm256_set1_pd(theta[i]), _mm256_set1_pd(inv_m[i]));
        let volume = _mm256_set1_pd(w.node.volume);
        let mut acc = [_mm256_setzero_pd(); 3];
        let mut broke = 0;
        let mut b = 0;
        while b + 4 <= nb.neighbors.len() {
            let [dx, dy, dz, len] = bond_vectors_in::<D>(nb, b, yi);
            prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
            let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
            let keep = fail_and_keep(nb, b, len, l, &mut broke);
            let js = neighbours(nb, b);
            let (theta_j, inv_m_j) = (gather(theta, &js), gather(inv_m, &js));
            let (om, e, p) = (omega(law, l), _mm256_sub_pd(len, l), phi(w, l));
            let ti = lps_state(law, theta_i, inv_m_i, om, e, l);
            let tj = lps_state(law, theta_j, inv_m_j, om, e, l);
            let coef = _mm256_mul_pd(
                _mm256_div_pd(
                    _mm256_add_pd(_mm256_mul_pd(ti, p), _mm256_mul_pd(tj, p)),
                    len,
                ),
                volume,
            );
            add_force(&mut acc, coef, keep, [dx, dy, dz]);
            b += 4;
        }
        let mut f = [sum(acc[0]), sum(acc[1]), sum(acc[2])];
        tail(nb, b, |_, j, l, d, len| {
            let (om, e, p) = (law.omega(l), len - l, w.phi(l));
            let ti = law.state(inv_m[i], theta[i], om, e, l);
            let tj = law.state(inv_m[j], theta[j], om, e, l);
            let coef = (ti * p + tj * p) / len * w.node.volume;
            for k in 0..3 {
                f[k] += coef * d[k];
            }
        });
        debug_assert_eq!(broke, 0, "the LPS force pass does not decide failure");
        f
    }
}
