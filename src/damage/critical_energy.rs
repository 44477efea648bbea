//! Critical-energy failure (Foster, Silling & Chen 2011; seed 002, Eqs. 6–10; seed 004,
//! Eqs. 16–18): a bond breaks once the work done on it,
//! w = ∫ (T[x]⟨ξ⟩ − T[x']⟨−ξ⟩)·dη (seed 002, Eq. 6), reaches the critical bond energy w_c.
//!
//! The work is accumulated along the actual deformation path, from one force evaluation to
//! the next, with the trapezoidal rule, for any force state (seed 004's projected T^P of
//! Eqs. 16–17 is this work for a proportional path; the integral is exact along any path, so
//! the energy a body takes to break equals the energy its bonds dissipate):
//! - a central force f M (bond-based, LPS): M·dη = de, so w += ½ (f_prev + f)(e − e_prev);
//!   history per bond: w (f64), and f and e as f32 packed in one word (16 bytes: the loop is
//!   bound by memory traffic; single precision of the previous values changes w by ~1e-7 of
//!   itself per step, far below any calibration);
//! - any force (several materials with correspondence blocks, or w_c per node): w +=
//!   ½ (F_prev + F)·Δη, Δη from the positions of the previous evaluation, which the engine
//!   keeps per node; history: w, F (32 bytes);
//! - correspondence with one w_c (`UniformCriticalEnergy::SPLITS_WORK`): each half is linear
//!   in ξ and η through its node's matrices, T_i = ω φ (B_i ξ + C1_i η), so each entry keeps
//!   only its own half's work, w_i += ½ (T_i,prev + T_i)·Δη, from node i's matrices now and at
//!   the previous evaluation (kept per node: 2D² words) — the same trapezoidal sum, split:
//!   w = w_i + w_j. History: 8 bytes. The engine decides the bond after the force pass from
//!   the sum (the same from either end) and takes its pair force back, as if the whole pair
//!   had been recorded (`ForceEngine`'s split work).
//!
//! The pair force carries the bond's partial-volume fraction φ̄ = ½(φ_ij + φ_ji), and so does
//! the threshold: a half fails when w ≥ w_c φ̄, i.e. when the work density of the continuum bond
//! reaches w_c, and a bond cut by the horizon boundary dissipates w_c φ̄ V_i V_j, its share of
//! the integral that defines w_c.

use super::PerNode;
use super::{DamageLaw, Work};
use crate::dimensionality::Dimensionality;

/// Critical bond energy w_c (J/m⁶) per node, optionally only for bonds in tension.
#[derive(Debug, Clone)]
pub struct CriticalEnergy {
    pub wc: PerNode,
    /// Only bonds with positive extension can fail (seed 004 §2.6).
    pub tension_only: bool,
}

impl CriticalEnergy {
    /// w_c from G0 and δ, so that breaking every bond across a unit plane costs G0:
    /// 3D w_c = 4G0/(πδ⁴) (seed 002, Eq. 8); 2D w_c = 3G0/(2δ³t) (seed 002, Eq. 10, from
    /// G0 t = t² w_c ∫∫∫ ξ dφ dξ dz = t² w_c 2δ³/3 with t the thickness). Seed 004's
    /// Eq. 18b, 3G0/(πδ³h), is a factor π/2 lower and does not return G0; `tests/` proves
    /// the 2D constant by separating a bar.
    pub fn critical_energy(g0: f64, horizon: f64, dim: Dimensionality, thickness: f64) -> f64 {
        match dim {
            Dimensionality::ThreeD => 4.0 * g0 / (std::f64::consts::PI * horizon.powi(4)),
            _ => 3.0 * g0 / (2.0 * horizon.powi(3) * thickness),
        }
    }
}

/// The work record of a bond, [w, f, e] (central force) or [w, F_x, F_y, F_z]: the
/// trapezoidal rule from the previous evaluation, which then becomes the new one. The first
/// evaluation starts from the unloaded bond (f = e = 0, F = 0). Returns the work w; a
/// linear bond's work in closed form (`Work::Stored`) needs no record.
#[inline(always)]
pub fn accumulate_work(work: Work, h: &mut [f64]) -> f64 {
    match work {
        Work::Stored { energy } => return energy,
        Work::Along { force, extension } => {
            let (f_prev, e_prev) = unpack(h[1]);
            h[0] += 0.5 * (f_prev + force) * (extension - e_prev);
            h[1] = pack(force, extension);
        }
        Work::Vector { force, step } => {
            h[0] += 0.5
                * ((h[1] + force[0]) * step[0]
                    + (h[2] + force[1]) * step[1]
                    + (h[3] + force[2]) * step[2]);
            h[1] = force[0];
            h[2] = force[1];
            h[3] = force[2];
        }
    }
    h[0]
}

impl CriticalEnergy {
    /// The one-value form, if every node has the same w_c.
    pub fn uniform_form(&self) -> Option<UniformCriticalEnergy> {
        Some(UniformCriticalEnergy {
            wc: self.wc.uniform()?,
            tension_only: self.tension_only,
        })
    }
}

/// A critical-energy law with one w_c for every node: both halves break together. The engine
/// runs this form when it can. With a linear-bond material (PMB) it takes the work in closed
/// form, w = ½ f e (`Work::Stored`: what the trapezoidal record would hold, without its
/// rounding), and stores nothing per bond; the law with w_c per node keeps the record,
/// because a bond whose one half broke first is no longer the same linear spring.
#[derive(Debug, Clone, Copy)]
pub struct UniformCriticalEnergy {
    pub wc: f64,
    pub tension_only: bool,
}

impl DamageLaw for UniformCriticalEnergy {
    const HISTORY: usize = CriticalEnergy::HISTORY;
    const HISTORY_VECTOR: usize = CriticalEnergy::HISTORY_VECTOR;
    const CLOSED_FORM_WORK: bool = true;
    const HISTORY_LINEAR: usize = 0;
    const ON_WORK: bool = true;
    const HALVES_TOGETHER: bool = true;
    const SPLITS_WORK: bool = true;

    fn uniform_critical_energy(&self) -> Option<UniformCriticalEnergy> {
        Some(*self)
    }

    #[inline(always)]
    fn record_work(&self, work: Work, h: &mut [f64]) -> f64 {
        accumulate_work(work, h)
    }

    #[inline(always)]
    fn fails_on_work(&self, _node: usize, extension: f64, weight: f64, work: f64) -> bool {
        work >= self.wc * weight && !(self.tension_only && extension <= 0.0)
    }

    #[inline(always)]
    fn on_work(
        &self,
        i: usize,
        _j: usize,
        work: Work,
        extension: f64,
        weight: f64,
        protected: bool,
        history: &mut [f64],
        status: &mut u8,
    ) -> u64 {
        let w = self.record_work(work, history);
        if !protected && self.fails_on_work(i, extension, weight, w) {
            *status = super::BROKEN;
            1
        } else {
            0
        }
    }
}

/// Two values rounded to f32, in one f64 word (its bits).
#[inline(always)]
fn pack(a: f64, b: f64) -> f64 {
    f64::from_bits(((a as f32).to_bits() as u64) << 32 | (b as f32).to_bits() as u64)
}

#[inline(always)]
fn unpack(word: f64) -> (f64, f64) {
    let bits = word.to_bits();
    (
        f32::from_bits((bits >> 32) as u32) as f64,
        f32::from_bits(bits as u32) as f64,
    )
}

impl DamageLaw for CriticalEnergy {
    const HISTORY: usize = 2;
    const HISTORY_VECTOR: usize = 4;
    const ON_WORK: bool = true;

    #[inline(always)]
    fn record_work(&self, work: Work, h: &mut [f64]) -> f64 {
        accumulate_work(work, h)
    }

    #[inline(always)]
    fn fails_on_work(&self, node: usize, extension: f64, weight: f64, work: f64) -> bool {
        work >= self.wc.at(node) * weight && !(self.tension_only && extension <= 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed002_table_values() {
        // Seed 002 notes §2.6 table: G = 300 J/m², t = 0.5 mm.
        let w3 = CriticalEnergy::critical_energy(300.0, 280e-6, Dimensionality::ThreeD, 1.0);
        assert!((w3 / 6.214e16 - 1.0).abs() < 1e-3);
        let w2 = CriticalEnergy::critical_energy(300.0, 70e-6, Dimensionality::PlaneStress, 0.5e-3);
        assert!((w2 / 2.624e18 - 1.0).abs() < 1e-3);
    }

    #[test]
    fn trapezoidal_work_of_a_linear_bond_is_half_f_e() {
        let law = CriticalEnergy {
            wc: PerNode::Uniform(f64::INFINITY),
            tension_only: false,
        };
        // A linear bond along (0.6, 0.8), loaded then unloaded, written both ways.
        let (mut along, mut vector) = ([0.0; 2], [0.0; 4]);
        let path: Vec<f64> = (1..=10).chain((0..10).rev()).map(|k| k as f64).collect();
        let mut previous = 0.0;
        for (n, &k) in path.iter().enumerate() {
            let e = 1e-6 * k;
            let f = 3e12 * e;
            law.record_work(
                Work::Along {
                    force: f,
                    extension: e,
                },
                &mut along,
            );
            let de = e - previous;
            previous = e;
            law.record_work(
                Work::Vector {
                    force: [0.6 * f, 0.8 * f, 0.0],
                    step: [0.6 * de, 0.8 * de, 0.0],
                },
                &mut vector,
            );
            if n == 9 {
                // Exact for a linear force: ½ k e² (the packed form to its single precision:
                // each step rounds f and e to 2⁻²⁴ of themselves).
                assert!((along[0] / (0.5 * 3e12 * 1e-10) - 1.0).abs() < 10.0 * 2f64.powi(-22));
                assert!((vector[0] / (0.5 * 3e12 * 1e-10) - 1.0).abs() < 1e-12);
            }
        }
        // Unloading returns the work.
        let full = 0.5 * 3e12 * 1e-10;
        assert!(
            along[0].abs() < 20.0 * 2f64.powi(-22) * full,
            "{}",
            along[0] / full
        );
        assert!(vector[0].abs() < 1e-12 * full);
    }
}
