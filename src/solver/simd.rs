//! The PMB force pass on four bonds at a time with AVX2 (x86-64, 3D, uniform
//! grids). Same law, failure rule and partial-volume factor as the generic loop; only the
//! order in which a node's bond forces are summed differs (four lanes, then the tail), and it
//! is fixed, so results stay bitwise identical for any thread count.

use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::PartialVolume;
use crate::material::MicromodulusProfile;
use crate::state::{BROKEN, INTACT};

/// A PMB bond law on a uniform grid, ready for the vector kernel.
#[derive(Debug, Clone, Copy)]
pub struct PmbKernel {
    pub c0: f64,
    pub horizon: f64,
    pub conical: bool,
    pub s0: f64,
    weights: UniformWeights,
}

impl PmbKernel {
    /// The kernel, if this machine has AVX2 and the grid is uniform.
    pub fn new(
        c0: f64,
        horizon: f64,
        profile: MicromodulusProfile,
        s0: f64,
        weights: Option<UniformWeights>,
    ) -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") {
                return weights.map(|weights| PmbKernel {
                    c0,
                    horizon,
                    conical: profile == MicromodulusProfile::Conical,
                    s0,
                    weights,
                });
            }
        }
        let _ = (c0, horizon, profile, s0, weights);
        None
    }

    /// Scalar bond law of the tail lanes: c(ξ) φ (|y| − |ξ|)/(|ξ||y|) V (seed 001, Eq. 4).
    #[inline(always)]
    fn coefficient(&self, ref_len: f64, len: f64) -> f64 {
        let c = if self.conical {
            self.c0 * (1.0 - ref_len / self.horizon).max(0.0)
        } else {
            self.c0
        };
        let phi = self.weights.phi(ref_len);
        c * 0.5 * (phi + phi) * (len - ref_len) / (ref_len * len) * self.weights.node.volume
    }

    /// Force density on node i and the number of bonds it broke. `current` is the flat
    /// x, y, z array of current positions.
    ///
    /// # Safety
    /// Every neighbour index must be below `current.len() / 3` (the engine checks this once
    /// for its immutable bonds before using the kernel).
    pub unsafe fn node_force(
        &self,
        i: usize,
        current: &[f64],
        neighbors: &[u32],
        ref_lengths: &[f64],
        status: &mut [u8],
        no_fail: &[bool],
    ) -> ([f64; 3], u64) {
        assert!(neighbors.len() == ref_lengths.len() && neighbors.len() == status.len());
        // SAFETY: `new` returned Some only where AVX2 is available; the caller guarantees the
        // gather indices are in bounds.
        #[cfg(target_arch = "x86_64")]
        unsafe {
            self.node_force_avx2(i, current, neighbors, ref_lengths, status, no_fail)
        }
        #[cfg(not(target_arch = "x86_64"))]
        unreachable!("PmbKernel::new returns None off x86-64")
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn node_force_avx2(
        &self,
        i: usize,
        current: &[f64],
        neighbors: &[u32],
        ref_lengths: &[f64],
        status: &mut [u8],
        no_fail: &[bool],
    ) -> ([f64; 3], u64) {
        use std::arch::x86_64::*;
        let base = current.as_ptr();
        let (xi, yi, zi) = (current[3 * i], current[3 * i + 1], current[3 * i + 2]);
        let (vxi, vyi, vzi) = (_mm256_set1_pd(xi), _mm256_set1_pd(yi), _mm256_set1_pd(zi));
        let zero = _mm256_setzero_pd();
        let xyz_mask = _mm256_set_epi64x(0, -1, -1, -1);
        let one = _mm256_set1_pd(1.0);
        let (c0, half, s0) = (
            _mm256_set1_pd(self.c0),
            _mm256_set1_pd(0.5),
            _mm256_set1_pd(self.s0),
        );
        let delta = _mm256_set1_pd(self.horizon);
        let n = &self.weights.node;
        let (reach, inv_cell, horizon, volume) = (
            _mm256_set1_pd(n.horizon + n.half_cell),
            _mm256_set1_pd(n.inv_cell),
            _mm256_set1_pd(n.horizon),
            _mm256_set1_pd(n.volume),
        );
        let (mut ax, mut ay, mut az) = (zero, zero, zero);
        let mut broke = 0u64;
        let count = neighbors.len();
        let mut b = 0;
        while b + 4 <= count {
            let st = u32::from_le_bytes([status[b], status[b + 1], status[b + 2], status[b + 3]]);
            if st == u32::from_le_bytes([BROKEN; 4]) {
                b += 4;
                continue;
            }
            // Load (x, y, z) of the four neighbours (masked: never past a node) and transpose.
            let row = |lane: usize| {
                _mm256_maskload_pd(base.add(3 * neighbors[b + lane] as usize), xyz_mask)
            };
            let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
            let (t0, t1) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
            let (t2, t3) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
            let dx = _mm256_sub_pd(_mm256_permute2f128_pd::<0x20>(t0, t2), vxi);
            let dy = _mm256_sub_pd(_mm256_permute2f128_pd::<0x20>(t1, t3), vyi);
            let dz = _mm256_sub_pd(_mm256_permute2f128_pd::<0x31>(t0, t2), vzi);
            let len = _mm256_sqrt_pd(_mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                _mm256_mul_pd(dz, dz),
            ));
            let l = _mm256_loadu_pd(ref_lengths.as_ptr().add(b));
            let intact_of = |st: u32| {
                _mm256_castsi256_pd(_mm256_cmpeq_epi64(
                    _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(st as i32)),
                    _mm256_setzero_si256(),
                ))
            };
            let mut intact = intact_of(st);
            // Failure: s > s0, i.e. |y| − |ξ| > s0 |ξ| (same arithmetic as the generic walker).
            let over = _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_GT_OQ>(_mm256_sub_pd(len, l), _mm256_mul_pd(s0, l)),
                intact,
            );
            let bits = _mm256_movemask_pd(over);
            if bits != 0 {
                for lane in 0..4 {
                    let j = neighbors[b + lane] as usize;
                    if bits & (1 << lane) != 0 && !(no_fail[i] || no_fail[j]) {
                        status[b + lane] = BROKEN;
                        broke += 1;
                    }
                }
                let st =
                    u32::from_le_bytes([status[b], status[b + 1], status[b + 2], status[b + 3]]);
                intact = intact_of(st);
            }
            let keep = _mm256_and_pd(intact, _mm256_cmp_pd::<_CMP_GT_OQ>(len, zero));
            let c = if self.conical {
                _mm256_mul_pd(
                    c0,
                    _mm256_max_pd(_mm256_sub_pd(one, _mm256_div_pd(l, delta)), zero),
                )
            } else {
                c0
            };
            let phi = match self.weights.rule {
                PartialVolume::Hhb => _mm256_min_pd(
                    _mm256_max_pd(_mm256_mul_pd(_mm256_sub_pd(reach, l), inv_cell), zero),
                    one,
                ),
                PartialVolume::None => _mm256_and_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(l, horizon), one),
            };
            let coef = _mm256_mul_pd(
                _mm256_div_pd(
                    _mm256_mul_pd(
                        _mm256_mul_pd(_mm256_mul_pd(c, half), _mm256_add_pd(phi, phi)),
                        _mm256_sub_pd(len, l),
                    ),
                    _mm256_mul_pd(l, len),
                ),
                volume,
            );
            let coef = _mm256_and_pd(coef, keep);
            ax = _mm256_add_pd(ax, _mm256_mul_pd(coef, dx));
            ay = _mm256_add_pd(ay, _mm256_mul_pd(coef, dy));
            az = _mm256_add_pd(az, _mm256_mul_pd(coef, dz));
            b += 4;
        }
        let lanes = |v: __m256d| {
            let mut a = [0.0; 4];
            _mm256_storeu_pd(a.as_mut_ptr(), v);
            (a[0] + a[1]) + (a[2] + a[3])
        };
        let mut f = [lanes(ax), lanes(ay), lanes(az)];
        for b in b..count {
            if status[b] != INTACT {
                continue;
            }
            let j = neighbors[b] as usize;
            let d = [
                current[3 * j] - xi,
                current[3 * j + 1] - yi,
                current[3 * j + 2] - zi,
            ];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let l = ref_lengths[b];
            if len - l > self.s0 * l && !(no_fail[i] || no_fail[j]) {
                status[b] = BROKEN;
                broke += 1;
                continue;
            }
            if len > 0.0 {
                let coef = self.coefficient(l, len);
                for a in 0..3 {
                    f[a] += coef * d[a];
                }
            }
        }
        (f, broke)
    }
}
