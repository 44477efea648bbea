//! AVX2 bond loops for damage laws other than one critical stretch (x86-64, 2D and 3D, uniform
//! grids): the PMB force under a uniform softening law. Same law, history update, failure
//! rule and arithmetic as the generic loop (`solver::forces`, `UniformSoftening::on_stretch`
//! and `factors`); only the order of a node's bond terms differs (four lanes, then the tail),
//! and it is fixed, so results stay bitwise identical for any thread count.
//! `tests/suite/kernels.rs` checks it against the generic loop.

#[cfg(target_arch = "x86_64")]
use super::simd::avx::{
    add_force, bond_vectors_in, intact, own_position, phi, pmb_per_length, prefetch, sum,
};
use super::simd::{length, NodeBonds, PmbLaw};
use crate::bonds::partial_volume::UniformWeights;
use crate::damage::softening::UniformSoftening;
use crate::damage::{DamageLaw, Stretch};
use crate::state::BROKEN;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// One bond entry b of node i under the softening law, in scalar arithmetic exactly as the
/// generic loop does it: records the largest stretch and breaks the bond at s_c
/// (`UniformSoftening::on_stretch`), then returns μ = g(s_max)/s_max (the secant,
/// `UniformSoftening::factors`; seed 001 §3), or `None` if the bond carries no force (broken,
/// or of zero length). Adds 1 to `broke` for a bond broken now.
#[inline(always)]
fn soften_one(
    nb: &mut NodeBonds,
    soft: &UniformSoftening,
    b: usize,
    len: f64,
    broke: &mut u64,
) -> Option<f64> {
    if nb.status[b] != crate::state::INTACT {
        return None;
    }
    let (i, j) = (nb.i, nb.neighbors[b] as usize);
    let no_fail = nb.no_fail;
    let st = Stretch {
        len,
        ref_len: nb.ref_lengths[b],
    };
    *broke += soft.on_stretch(
        i,
        j,
        st,
        || no_fail[i] || no_fail[j],
        &mut nb.history[b..b + 1],
        &mut nb.status[b],
    );
    if nb.status[b] == BROKEN || len <= 0.0 {
        return None;
    }
    Some(soft.factors(i, j, &nb.history[b..b + 1], nb.status[b]).0)
}

/// PMB force density on node i under a uniform softening law in dimension D (`nb.dim`), and
/// the bonds broken.
///
/// # Safety
/// `simd::available()` must be true and every neighbour index below `current.len() / D`;
/// `nb.history` holds one word per bond of the family.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub unsafe fn pmb_force_softening<const D: usize>(
    nb: &mut NodeBonds,
    law: &PmbLaw,
    w: &UniformWeights,
    soft: &UniformSoftening,
) -> ([f64; 3], u64) {
    debug_assert_eq!(nb.dim, D);
    let yi = own_position(nb);
    let (one, zero) = (_mm256_set1_pd(1.0), _mm256_setzero_pd());
    let (s1, sc) = (_mm256_set1_pd(soft.s1), _mm256_set1_pd(soft.sc));
    let volume = _mm256_set1_pd(w.node.volume);
    let mut acc = [zero; 3];
    let mut broke = 0;
    let mut b = 0;
    while b + 4 <= nb.neighbors.len() {
        let [dx, dy, dz, len] = bond_vectors_in::<D>(nb, b, yi);
        prefetch::<512, _>(nb.ref_lengths.as_ptr().add(b));
        let l = _mm256_loadu_pd(nb.ref_lengths.as_ptr().add(b));
        let live = intact(nb.status, b);
        prefetch::<512, _>(nb.history.as_ptr().add(b));
        let h = _mm256_loadu_pd(nb.history.as_ptr().add(b));
        // A new largest stretch, `Stretch::exceeds` without a division: |y| − |ξ| > s_max |ξ|;
        // then s = (|y| − |ξ|)/|ξ| (seed 001, Eq. 3), as `on_stretch` records it.
        let e = _mm256_sub_pd(len, l);
        let exceeds = _mm256_and_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(e, _mm256_mul_pd(h, l)), live);
        let h_new = _mm256_blendv_pd(h, _mm256_div_pd(e, l), exceeds);
        // Lanes past the peak (μ < 1, a no-fail end matters, or the bond breaks) take the
        // scalar path; elsewhere μ = 1 (`UniformSoftening::secant`).
        let hot = _mm256_and_pd(
            _mm256_or_pd(
                _mm256_cmp_pd::<_CMP_GT_OQ>(h_new, s1),
                _mm256_cmp_pd::<_CMP_GE_OQ>(h_new, sc),
            ),
            live,
        );
        let (mu, keep) = if _mm256_movemask_pd(hot) == 0 {
            // Intact lanes record the new largest stretch; the others keep theirs.
            _mm256_storeu_pd(nb.history.as_mut_ptr().add(b), h_new);
            (
                one,
                _mm256_and_pd(live, _mm256_cmp_pd::<_CMP_GT_OQ>(len, zero)),
            )
        } else {
            let mut lens = [0.0; 4];
            _mm256_storeu_pd(lens.as_mut_ptr(), len);
            let mut mu = [1.0; 4];
            for lane in 0..4 {
                if let Some(m) = soften_one(nb, soft, b + lane, lens[lane], &mut broke) {
                    mu[lane] = m;
                }
            }
            (
                _mm256_loadu_pd(mu.as_ptr()),
                _mm256_and_pd(intact(nb.status, b), _mm256_cmp_pd::<_CMP_GT_OQ>(len, zero)),
            )
        };
        // c ½(φ μ + φ μ) (|y| − |ξ|)/(|ξ||y|) V: `Pmb::pair_weight` and
        // `pair_force_per_length` (seed 001, Eq. 4) with the halves' μ, times V.
        let pm = _mm256_mul_pd(phi(w, l), mu);
        let coef = _mm256_mul_pd(pmb_per_length(law, l, len, pm), volume);
        add_force(&mut acc, coef, keep, [dx, dy, dz]);
        b += 4;
    }
    let mut f = [sum(acc[0]), sum(acc[1]), sum(acc[2])];
    let yi = nb.position(nb.i);
    for b in b..nb.neighbors.len() {
        let y = nb.position(nb.neighbors[b] as usize);
        let d = [y[0] - yi[0], y[1] - yi[1], y[2] - yi[2]];
        let len = length(&d);
        if let Some(mu) = soften_one(nb, soft, b, len, &mut broke) {
            // As in the lanes: c ½(φ μ + φ μ) (|y| − |ξ|)/(|ξ||y|) V (seed 001, Eq. 4).
            let l = nb.ref_lengths[b];
            let coef = law.per_length(l, len, w.phi(l) * mu) * w.node.volume;
            for a in 0..3 {
                f[a] += coef * d[a];
            }
        }
    }
    (f, broke)
}
