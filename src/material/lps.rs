//! Linear peridynamic solid (ordinary state-based; Silling et al. 2007), seed 002 §2.1,
//! Eqs. (3)–(5), in 3D, 2D plane stress (γ-scaled form) and 2D plane strain, with any
//! influence function and a horizon per node (each half of a bond uses its own node's ω, m
//! and θ, which is the dual-horizon form of the state-based equation of motion).

use super::simd::{self, NodeBonds};
use super::simd_energy;
use super::{BondGeom, Dimensionality, Elasticity, Influence, Material, PointError};
use crate::body::Body;
use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::{Bonds, Quadrature};
use crate::per_node::PerNode;
use crate::solver::ranks::Share;

/// Per-node state of the pre-pass: the dilatation θ (before: the weighted sum Σ ω|ξ| e w).
/// Transparent, so a slice of points is a slice of θ for the vector kernel.
#[derive(Debug, Clone, Copy, Default)]
#[repr(transparent)]
pub struct LpsPoint {
    pub theta: f64,
}

/// LPS material. The scalar force state of node i on bond ξ is
/// t = (a/m) θ ω|ξ| + (b/m) ω (e − c_iso θ |ξ|), with θ = (k_θ/m) Σ ω|ξ| e w.
#[derive(Debug, Clone)]
pub struct Lps {
    pub elasticity: Elasticity,
    pub influence: Influence,
    /// Reference horizon (m).
    pub horizon: f64,
    /// Horizon per node (m): enters ω for the non-constant influence functions.
    pub horizons: PerNode,
    pub rho: f64,
    /// Weighted volume m_i = Σ ω |ξ|² w_ij, fixed at its initial value (as Peridigm does).
    pub m: Vec<f64>,
    /// 1/m_i (0 for a node without bonds): the bond loop multiplies instead of dividing.
    inv_m: Vec<f64>,
    theta_factor: f64,
    a_vol: f64,
    b_dev: f64,
    c_iso: f64,
    energy_vol: f64,
    thickness: f64,
}

impl Lps {
    /// Coefficients per dimensionality:
    /// - 3D (Eqs. 3–4): θ = (3/m)Σ…, t = (3K/m)θω|ξ| + (15μ/m)ω e^d, e^d = e − θ|ξ|/3,
    ///   W = (K/2)θ² + (15μ/2m) Σ ω (e^d)² w.
    /// - plane stress (Eq. 5): θ from Eq. 3 unscaled (3/m, 2D m with V = t·A; the notes show only
    ///   this reading matches Hooke's law), γ = 4μ/(3K + 4μ), t = (γK/m)θω|ξ| + (8μ/m)ω e^d,
    ///   e^d = e − γθ|ξ|/3, W = (a/2)θ² + (4μ/m)Σ ω (e^d)² w with a = γ[K + 8μ(1−γ)/3]/3
    ///   (seed 002 notes §2.4; t = ∂W/∂e exactly).
    /// - plane strain (not in seed 002; derived the same way from W = κ/2 (tr ε)² + μ ε_d:ε_d
    ///   with κ = λ + μ): θ = (2/m)Σ…, t = (2κ/m)θω|ξ| + (8μ/m)ω e^d, e^d = e − θ|ξ|/2,
    ///   W = (κ/2)θ² + (4μ/m)Σ ω (e^d)² w.
    pub fn new(
        elasticity: Elasticity,
        influence: Influence,
        horizon: f64,
        rho: f64,
        thickness: f64,
    ) -> Self {
        let (k, mu) = (elasticity.bulk(), elasticity.shear());
        let (theta_factor, a_vol, b_dev, c_iso, energy_vol) = match elasticity.dimensionality {
            Dimensionality::ThreeD => (3.0, 3.0 * k, 15.0 * mu, 1.0 / 3.0, k),
            Dimensionality::PlaneStress => {
                let gamma = 4.0 * mu / (3.0 * k + 4.0 * mu);
                let a = gamma * (k + 8.0 * mu * (1.0 - gamma) / 3.0) / 3.0;
                (3.0, gamma * k, 8.0 * mu, gamma / 3.0, a)
            }
            Dimensionality::PlaneStrain => {
                let kappa = elasticity.in_plane_bulk();
                (2.0, 2.0 * kappa, 8.0 * mu, 0.5, kappa)
            }
        };
        Lps {
            elasticity,
            influence,
            horizon,
            horizons: PerNode::Uniform(horizon),
            rho,
            m: Vec::new(),
            inv_m: Vec::new(),
            theta_factor,
            a_vol,
            b_dev,
            c_iso,
            energy_vol,
            thickness,
        }
    }

    /// Critical stretch s0 for which pulling a body apart through a plane costs exactly G0
    /// (`lps_separation`: the continuum separation work of this material, influence function
    /// and dimensionality, W = G0). The customary bond-based equivalent, sqrt(5G0/(9Kδ)) in
    /// 3D, is off by −11% (3D) to +24% (2D plane stress) at ν = 0.3.
    pub fn critical_stretch_from_g0(&self, g0: f64) -> f64 {
        let state = |inv_m: f64, theta: f64, w: f64, e: f64, l: f64| {
            self.scalar_state(inv_m, theta, w, e, l)
        };
        let omega = |l: f64| self.influence.omega(l, self.horizon);
        let law = super::lps_separation::ScalarLaw {
            dim: self.elasticity.dimensionality.dim(),
            horizon: self.horizon,
            theta_factor: self.theta_factor,
            state: &state,
            omega: &omega,
        };
        (g0 / super::lps_separation::separation_work_at_unit_stretch(&law)).sqrt()
    }

    /// The critical stretch of the bond-based material with the same in-plane bulk modulus κ
    /// (Silling & Askari 2005: sqrt(5G0/(9Kδ)) in 3D; seed 001 Eq. 8 with κ in 2D:
    /// sqrt(πG0/(3κδ))): the customary approximation, kept for version-1 decks.
    pub fn bulk_equivalent_critical_stretch(&self, g0: f64) -> f64 {
        let kappa = self.elasticity.in_plane_bulk();
        match self.elasticity.dimensionality {
            Dimensionality::ThreeD => (5.0 * g0 / (9.0 * kappa * self.horizon)).sqrt(),
            _ => (std::f64::consts::PI * g0 / (3.0 * kappa * self.horizon)).sqrt(),
        }
    }

    /// The same material with a horizon per node (ω of each half uses its node's horizon).
    pub fn with_horizons(mut self, horizons: &[f64]) -> Self {
        self.horizons = PerNode::from_values(horizons.to_vec());
        self
    }

    /// The weighted volumes m and their inverses (0 for a node without bonds).
    fn set_m(&mut self, m: Vec<f64>) {
        self.inv_m = m
            .iter()
            .map(|&m| if m > 0.0 { 1.0 / m } else { 0.0 })
            .collect();
        self.m = m;
    }

    /// The constants of the force state, for the vector kernels (uniform horizon, constant
    /// or inverse influence function).
    fn law(&self) -> Option<simd::LpsLaw> {
        if self.horizons.uniform().is_none() || self.influence == Influence::Gaussian {
            return None;
        }
        Some(simd::LpsLaw {
            a_vol: self.a_vol,
            b_dev: self.b_dev,
            c_iso: self.c_iso,
            horizon: self.horizon,
            inverse_influence: self.influence == Influence::Inverse,
        })
    }

    /// ω of a bond of node i.
    #[inline(always)]
    fn omega(&self, i: usize, ref_len: f64) -> f64 {
        self.influence.omega(ref_len, self.horizons.at(i))
    }

    /// Scalar force state t⟨ξ⟩ of a node with 1/m = `inv_m` and dilatation θ, given the
    /// bond's ω and extension e.
    #[inline(always)]
    fn scalar_state(&self, inv_m: f64, theta: f64, w: f64, e: f64, ref_len: f64) -> f64 {
        (self.a_vol * theta * w * ref_len + self.b_dev * w * (e - self.c_iso * theta * ref_len))
            * inv_m
    }
}

impl<const D: usize> Material<D> for Lps {
    type Point = LpsPoint;
    const NEEDS_PREPASS: bool = true;

    fn setup(
        &mut self,
        body: &Body<D>,
        bonds: &Bonds,
        quad: &Quadrature,
        _owned: usize,
    ) -> Result<(), PointError> {
        let m = (0..body.len())
            .map(|i| {
                bonds
                    .family(i)
                    .map(|b| {
                        let l = bonds.ref_lengths[b];
                        let j = bonds.neighbors[b] as usize;
                        self.omega(i, l) * l * l * quad.phi_pair(b, i, j, l).0 * body.volumes[j]
                    })
                    .sum::<f64>()
            })
            .collect();
        self.set_m(m);
        Ok(())
    }

    const HALO_WORDS: usize = 1;

    #[inline(always)]
    fn point_words(p: &LpsPoint, out: &mut Vec<f64>) {
        out.push(p.theta);
    }

    #[inline(always)]
    fn point_from_words(p: &mut LpsPoint, words: &[f64]) {
        p.theta = words[0];
    }

    /// A ghost's m is its owner's (its family is there).
    fn share_constants(&mut self, share: &Share) {
        let mut m = std::mem::take(&mut self.m);
        share.halo.exchange_values(&*share.ranks, &mut m);
        self.set_m(m);
    }

    #[inline(always)]
    fn accumulate(&self, i: usize, acc: &mut LpsPoint, b: &BondGeom<D>) {
        acc.theta += self.omega(i, b.ref_len) * b.ref_len * (b.len - b.ref_len) * b.weight();
    }

    #[inline(always)]
    fn finish_point(&self, i: usize, acc: LpsPoint) -> LpsPoint {
        LpsPoint {
            theta: self.theta_factor * acc.theta * self.inv_m[i],
        }
    }

    /// Seed 002, Eqs. (4)–(5); the engine pairs it with t_j⟨−ξ⟩ as in Eq. (1).
    #[inline(always)]
    fn force_state(&self, i: usize, b: &BondGeom<D>, p: &LpsPoint) -> f64 {
        self.scalar_state(
            self.inv_m[i],
            p.theta,
            self.omega(i, b.ref_len),
            b.len - b.ref_len,
            b.ref_len,
        )
    }

    /// (t_i⟨ξ⟩ φ_ij μ_ij + t_j⟨−ξ⟩ φ_ji μ_ji) / |ξ+η|, sharing ω and e between the two
    /// states when the horizon is uniform.
    #[inline(always)]
    fn pair_force_per_length(
        &self,
        i: usize,
        j: usize,
        b: &BondGeom<D>,
        pi: &LpsPoint,
        pj: &LpsPoint,
    ) -> f64 {
        let e = b.len - b.ref_len;
        let (wi, wj) = match self.horizons {
            PerNode::Uniform(h) => {
                let w = self.influence.omega(b.ref_len, h);
                (w, w)
            }
            PerNode::Varying(_) => (self.omega(i, b.ref_len), self.omega(j, b.ref_len)),
        };
        let ti = self.scalar_state(self.inv_m[i], pi.theta, wi, e, b.ref_len);
        let tj = self.scalar_state(self.inv_m[j], pj.theta, wj, e, b.ref_len);
        (ti * (b.phi_ij * b.mu_ij) + tj * (b.phi_ji * b.mu_ji)) / b.len
    }

    #[inline(always)]
    fn bond_energy(&self, i: usize, b: &BondGeom<D>, p: &LpsPoint) -> f64 {
        let ed = (b.len - b.ref_len) - self.c_iso * p.theta * b.ref_len;
        0.5 * self.b_dev * self.inv_m[i] * self.omega(i, b.ref_len) * ed * ed * b.weight()
    }

    unsafe fn vector_prepass(
        &self,
        nb: &mut NodeBonds,
        w: &UniformWeights,
        point: &mut LpsPoint,
    ) -> Option<u64> {
        if nb.softening.is_some() {
            return None; // no LPS kernel for softening
        }
        let law = self.law()?;
        // SAFETY: forwarded from the caller.
        let (sum, broke) = unsafe { simd::lps_dilatation_sum(nb, &law, w) };
        *point = Material::<D>::finish_point(self, nb.i, LpsPoint { theta: sum });
        Some(broke)
    }

    unsafe fn vector_force(
        &self,
        nb: &mut NodeBonds,
        w: &UniformWeights,
        points: &[LpsPoint],
    ) -> Option<([f64; 3], u64)> {
        if nb.softening.is_some() {
            return None; // no LPS kernel for softening
        }
        let law = self.law()?;
        // SAFETY: `LpsPoint` is a transparent f64.
        let theta =
            unsafe { std::slice::from_raw_parts(points.as_ptr() as *const f64, points.len()) };
        if let Some(energy) = nb.work {
            // SAFETY: forwarded from the caller.
            return Some(unsafe {
                simd_energy::lps_force_work(nb, &law, w, &energy, theta, &self.inv_m)
            });
        }
        // SAFETY: forwarded from the caller.
        Some((
            unsafe { simd::lps_force(nb, &law, w, theta, &self.inv_m) },
            0,
        ))
    }

    fn point_energy(&self, _i: usize, p: &LpsPoint, bond_sum: f64) -> f64 {
        0.5 * self.energy_vol * p.theta * p.theta + bond_sum
    }

    /// Bond-based equivalent with the same P-wave modulus.
    fn bond_stiffness(&self, i: usize, ref_len: f64) -> f64 {
        super::calibration::equivalent_bond_stiffness(
            &self.elasticity,
            self.horizons.at(i),
            self.thickness,
            ref_len,
        )
    }

    fn density(&self, _i: usize) -> f64 {
        self.rho
    }

    fn elasticity(&self) -> Elasticity {
        self.elasticity
    }
}
