//! AVX2 bond loops under a uniform critical-energy law (x86-64, 2D and 3D, uniform grids): the
//! PMB force and the LPS force pass. Same pair force, work, failure rule and arithmetic as
//! the generic loop (`solver::forces` with `UniformCriticalEnergy::on_work`): for LPS the work
//! since the previous evaluation by the trapezoidal rule, w += ½ (f_prev + f)(e − e_prev), with
//! f and e kept as two f32 in one word (`damage::critical_energy`; Foster, Silling & Chen 2011,
//! seed 002 Eq. 6); for PMB, whose bond is linear, the work in closed form w = ½ f e, with no
//! record (`damage::Work::Stored`); both halves break once w ≥ w_c φ̄ (unless an end is no-fail, or,
//! with `tension_only`, the bond is not in tension; seed 004 §2.6). Only the order of a node's
//! bond terms differs (four lanes, then the tail), and it is fixed, so results stay bitwise
//! identical for any thread count. `tests/suite/kernels.rs` checks them against the generic loop.
//!
//! The LPS pre-pass needs only the bond status under this law and runs the ordinary kernel
//! (`simd::lps_dilatation_sum`, with no failure decided).

#[cfg(target_arch = "x86_64")]
use super::simd::avx::{
    bond_vectors_in, intact, lps_state, omega, phi, pmb_per_length, prefetch, sum,
};
use super::simd::{length, LpsLaw, NodeBonds, PmbLaw};
use crate::bonds::partial_volume::UniformWeights;
use crate::damage::critical_energy::UniformCriticalEnergy;
use crate::damage::{DamageLaw, Work};
use crate::state::{BROKEN, INTACT};
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// A central model's pair force per unit deformed length of an intact bond on a uniform grid,
/// (t_i φ + t_j φ)/|y| (`Material::pair_force_per_length` with μ = 1), on four lanes and on
/// one bond, in the generic loop's arithmetic.
trait PairForce {
    /// The pair force is linear in the extension (PMB, `Material::LINEAR_BOND`): its work is
    /// ½ f e, with no record (`damage::Work::Stored`).
    const LINEAR: bool;

    /// Bonds b..b+4 of `nb`, of reference lengths `l`, deformed lengths `len` and φ `p`.
    ///
    /// # Safety
    /// `simd::available()`, and b + 4 ≤ the family's size.
    #[cfg(target_arch = "x86_64")]
    unsafe fn lanes(
        &self,
        nb: &NodeBonds,
        b: usize,
        l: __m256d,
        len: __m256d,
        p: __m256d,
    ) -> __m256d;

    /// Bond i→j alone.
    fn one(&self, i: usize, j: usize, l: f64, len: f64, p: f64) -> f64;
}

/// PMB: c ½(φ + φ) (|y| − |ξ|)/(|ξ||y|) (`Pmb::pair_weight` and `pair_force_per_length`,
/// seed 001 Eq. 4).
struct PmbPair<'a>(&'a PmbLaw);

impl PairForce for PmbPair<'_> {
    const LINEAR: bool = true;

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn lanes(
        &self,
        _nb: &NodeBonds,
        _b: usize,
        l: __m256d,
        len: __m256d,
        p: __m256d,
    ) -> __m256d {
        pmb_per_length(self.0, l, len, p)
    }

    #[inline(always)]
    fn one(&self, _i: usize, _j: usize, l: f64, len: f64, p: f64) -> f64 {
        self.0.per_length(l, len, p)
    }
}

/// LPS: (t_i φ + t_j φ)/|y| with t = (a θ ω|ξ| + b ω (e − c θ |ξ|)) / m (seed 002, Eqs. 3–5;
/// `Lps::pair_force_per_length`), from the dilatations and 1/m of all nodes. One type per
/// dimension D, so that each `lanes` has a single caller and is inlined into it.
struct LpsPair<'a, const D: usize> {
    law: &'a LpsLaw,
    theta: &'a [f64],
    inv_m: &'a [f64],
}

impl<const D: usize> PairForce for LpsPair<'_, D> {
    const LINEAR: bool = false;

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn lanes(
        &self,
        nb: &NodeBonds,
        b: usize,
        l: __m256d,
        len: __m256d,
        p: __m256d,
    ) -> __m256d {
        let (theta, inv_m) = (self.theta, self.inv_m);
        let i = nb.i;
        let j = |lane: usize| nb.neighbors[b + lane] as usize;
        let theta_j = _mm256_set_pd(theta[j(3)], theta[j(2)], theta[j(1)], theta[j(0)]);
        let inv_m_j = _mm256_set_pd(inv_m[j(3)], inv_m[j(2)], inv_m[j(1)], inv_m[j(0)]);
        let (om, e) = (omega(self.law, l), _mm256_sub_pd(len, l));
        let ti = lps_state(
            self.law,
            _mm256_set1_pd(theta[i]),
            _mm256_set1_pd(inv_m[i]),
            om,
            e,
            l,
        );
        let tj = lps_state(self.law, theta_j, inv_m_j, om, e, l);
        _mm256_div_pd(
            _mm256_add_pd(_mm256_mul_pd(ti, p), _mm256_mul_pd(tj, p)),
            len,
        )
    }

    #[inline(always)]
    fn one(&self, i: usize, j: usize, l: f64, len: f64, p: f64) -> f64 {
        let (om, e) = (self.law.omega(l), len - l);
        let ti = self.law.state(self.inv_m[i], self.theta[i], om, e, l);
        let tj = self.law.state(self.inv_m[j], self.theta[j], om, e, l);
        (ti * p + tj * p) / len
    }
}

/// PMB force density on node i under a uniform critical-energy law, and the bonds broken.
///
/// # Safety
/// `simd::available()` must be true and every neighbour index below
/// `current.len() / nb.dim`; `nb.history` may be empty (PMB keeps no work record).
#[cfg(target_arch = "x86_64")]
pub unsafe fn pmb_force_work(
    nb: &mut NodeBonds,
    law: &PmbLaw,
    w: &UniformWeights,
    energy: &UniformCriticalEnergy,
) -> ([f64; 3], u64) {
    let pair = PmbPair(law);
    // SAFETY: forwarded from the caller.
    unsafe {
        match nb.dim {
            2 => force_with_work::<2, _>(nb, w, energy, &pair),
            _ => force_with_work::<3, _>(nb, w, energy, &pair),
        }
    }
}

/// LPS force density on node i under a uniform critical-energy law, from the dilatations and
/// 1/m of all nodes, and the bonds broken.
///
/// # Safety
/// As for `pmb_force_work`; `theta` and `inv_m` have one entry per node.
pub unsafe fn lps_force_work(
    nb: &mut NodeBonds,
    law: &LpsLaw,
    w: &UniformWeights,
    energy: &UniformCriticalEnergy,
    theta: &[f64],
    inv_m: &[f64],
) -> ([f64; 3], u64) {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: forwarded from the caller.
        unsafe {
            match nb.dim {
                2 => force_with_work::<2, _>(nb, w, energy, &LpsPair::<2> { law, theta, inv_m }),
                _ => force_with_work::<3, _>(nb, w, energy, &LpsPair::<3> { law, theta, inv_m }),
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (nb, law, w, energy, theta, inv_m);
        unreachable!("simd::available() is false off x86-64")
    }
}

/// The force pass of one node under the law in dimension D: for every intact bond of non-zero
/// length, the pair force, its work recorded, failure decided, and the force of the bonds that
/// hold summed (z = 0 in 2D).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn force_with_work<const D: usize, P: PairForce>(
    nb: &mut NodeBonds,
    w: &UniformWeights,
    energy: &UniformCriticalEnergy,
    pair: &P,
) -> ([f64; 3], u64) {
    let i = nb.i;
    let yi = nb.position(i);
    let yi_lanes = yi.map(|c| _mm256_set1_pd(c));
    let (half, zero) = (_mm256_set1_pd(0.5), _mm256_setzero_pd());
    let (wc, volume) = (_mm256_set1_pd(energy.wc), _mm256_set1_pd(w.node.volume));
    // The f32 halves of four packed words [e, f] (low, high): f of the four, then e.
    let split = _mm256_setr_epi32(1, 3, 5, 7, 0, 2, 4, 6);
    let mut acc = [zero; 3];
    let mut broke = 0;
    let mut b = 0;
    while b + 4 <= nb.neighbors.len() {
        let [dx, dy, dz, len] = bond_vectors_in::<D>(nb, b, yi_lanes);
        prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
        let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
        // Intact and of non-zero length: the bonds the generic loop records work for.
        let mut keep = _mm256_and_pd(intact(nb.status, b), _mm256_cmp_pd::<_CMP_GT_OQ>(len, zero));
        let p = phi(w, l);
        let per_length = pair.lanes(nb, b, l, len, p);
        let along = _mm256_mul_pd(per_length, len);
        let e = _mm256_sub_pd(len, l);
        prefetch::<512, _>(nb.neighbors.as_ptr().add(b));
        let w_new = if P::LINEAR {
            // The work of a linear bond, ½ f e (`Work::Stored`).
            _mm256_mul_pd(_mm256_mul_pd(half, along), e)
        } else {
            // The work record [w, (f, e)] of the four bonds, as lanes.
            let hp = nb.history.as_mut_ptr().add(2 * b);
            prefetch::<2048, _>(hp);
            let (h0, h1) = (_mm256_loadu_pd(hp), _mm256_loadu_pd(hp.add(4)));
            let w_old = _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpacklo_pd(h0, h1));
            let packed = _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpackhi_pd(h0, h1));
            let fe = _mm256_permutevar8x32_ps(_mm256_castpd_ps(packed), split);
            let f_prev = _mm256_cvtps_pd(_mm256_castps256_ps128(fe));
            let e_prev = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(fe));
            // `accumulate_work`: w += ½ (f_prev + f)(e − e_prev), with f = (per length) |y|.
            let w_new = _mm256_add_pd(
                w_old,
                _mm256_mul_pd(
                    _mm256_mul_pd(half, _mm256_add_pd(f_prev, along)),
                    _mm256_sub_pd(e, e_prev),
                ),
            );
            // `pack`: f and e rounded to f32 (to nearest, as `as f32`), f in the high half.
            let (f32s, e32s) = (_mm256_cvtpd_ps(along), _mm256_cvtpd_ps(e));
            let packed_new = _mm256_castps_pd(_mm256_set_m128(
                _mm_unpackhi_ps(e32s, f32s),
                _mm_unpacklo_ps(e32s, f32s),
            ));
            // Lanes outside `keep` keep their record.
            let w_st = _mm256_blendv_pd(w_old, w_new, keep);
            let p_st = _mm256_blendv_pd(packed, packed_new, keep);
            let (lo, hi) = (
                _mm256_unpacklo_pd(w_st, p_st),
                _mm256_unpackhi_pd(w_st, p_st),
            );
            _mm256_storeu_pd(hp, _mm256_permute2f128_pd::<0x20>(lo, hi));
            _mm256_storeu_pd(hp.add(4), _mm256_permute2f128_pd::<0x31>(lo, hi));
            w_new
        };
        // `fails_on_work`: w ≥ w_c φ̄, φ̄ = ½(φ + φ), and in tension if `tension_only`.
        let mut over = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(
                w_new,
                _mm256_mul_pd(wc, _mm256_mul_pd(half, _mm256_add_pd(p, p))),
            ),
            keep,
        );
        if energy.tension_only {
            over = _mm256_and_pd(over, _mm256_cmp_pd::<_CMP_GT_OQ>(e, zero));
        }
        let bits = _mm256_movemask_pd(over);
        if bits != 0 {
            for lane in 0..4 {
                let j = nb.neighbors[b + lane] as usize;
                if bits & (1 << lane) != 0 && !(nb.no_fail[nb.i] || nb.no_fail[j]) {
                    nb.status[b + lane] = BROKEN;
                    broke += 1;
                }
            }
            keep = _mm256_and_pd(keep, intact(nb.status, b));
        }
        // The generic loop's y (per length) V.
        let pl = _mm256_and_pd(per_length, keep);
        for (a, d) in [dx, dy, dz].into_iter().enumerate().take(D) {
            acc[a] = _mm256_add_pd(acc[a], _mm256_mul_pd(_mm256_mul_pd(d, pl), volume));
        }
        b += 4;
    }
    let mut f = [sum(acc[0]), sum(acc[1]), sum(acc[2])];
    for b in b..nb.neighbors.len() {
        if nb.status[b] != INTACT {
            continue;
        }
        let j = nb.neighbors[b] as usize;
        let y = nb.position(j);
        let d = [y[0] - yi[0], y[1] - yi[1], y[2] - yi[2]];
        // In the lanes' order, (x² + y²) + z² (z = 0 in 2D: the 2D length to the bit).
        let len = length(&d);
        if len <= 0.0 {
            continue;
        }
        // The generic loop's steps for one bond, with the law's own scalar code.
        let l = nb.ref_lengths[b];
        let p = w.phi(l);
        let per_length = pair.one(i, j, l, len, p);
        let (along, extension) = (per_length * len, len - l);
        let (work, record) = if P::LINEAR {
            (
                Work::Stored {
                    energy: 0.5 * along * extension,
                },
                &mut [][..],
            )
        } else {
            let work = Work::Along {
                force: along,
                extension,
            };
            (work, &mut nb.history[2 * b..2 * b + 2])
        };
        broke += energy.on_work(
            i,
            j,
            work,
            extension,
            0.5 * (p + p),
            nb.no_fail[i] || nb.no_fail[j],
            record,
            &mut nb.status[b],
        );
        if nb.status[b] == BROKEN {
            continue;
        }
        for a in 0..D {
            f[a] += d[a] * per_length * w.node.volume;
        }
    }
    (f, broke)
}
