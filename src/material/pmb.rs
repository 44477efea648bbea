//! Prototype microelastic brittle (PMB) bond-based material (Silling & Askari 2005) with a
//! constant or conical micromodulus and irreversible critical-stretch failure.

use super::simd::{self, NodeBonds};
use super::simd_nodes;
#[cfg(target_arch = "x86_64")]
use super::{simd_damage, simd_energy};
use super::{BondGeom, Dimensionality, Elasticity, Material};
use crate::bonds::partial_volume::UniformWeights;
use crate::per_node::PerNode;
use crate::solver::ranks::Share;
use serde::{Deserialize, Serialize};

/// Shape of the micromodulus along the bond, c(ξ) = c0 · g(ξ).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MicromodulusProfile {
    /// g = 1 (seed 001, Eq. 6).
    #[default]
    Constant,
    /// g = 1 − |ξ|/δ.
    Conical,
}

impl MicromodulusProfile {
    /// Moment M_k = ∫_0^δ g(ξ) ξ^k dξ, the integral every calibration reduces to.
    pub fn moment(self, k: i32, horizon: f64) -> f64 {
        let kf = k as f64;
        match self {
            MicromodulusProfile::Constant => horizon.powi(k + 1) / (kf + 1.0),
            MicromodulusProfile::Conical => horizon.powi(k + 1) / ((kf + 1.0) * (kf + 2.0)),
        }
    }
}

/// How a bond between nodes of different horizons acts (seed 003 §2.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum HorizonCoupling {
    /// Dual-horizon PD (seed 003 §2.2, Eq. 8): each node's half of a bond, with its own
    /// micromodulus, acts on both ends, so forces come in equal and opposite pairs.
    #[default]
    Dual,
    /// Traditional PD with variable horizons (seed 003 §2.2): node i feels the bonds of its
    /// own horizon only, with its own micromodulus, c_i φ_ij μ_ij, and j feels no reaction
    /// when i lies outside j's horizon. Momentum is not conserved (the ghost forces and
    /// spurious reflections the paper shows); a model to compare with, not to predict with.
    Traditional,
}

/// Poisson's ratio a bond-based model is tied to: 1/3 in plane stress, 1/4 otherwise
/// (seed 001, §2.1).
pub fn bond_based_poisson_ratio(dim: Dimensionality) -> f64 {
    match dim {
        Dimensionality::PlaneStress => 1.0 / 3.0,
        _ => 0.25,
    }
}

/// PMB material with its calibrated constants. The micromodulus and horizon are per node
/// when horizons vary (dual-horizon PD, seed 003 §2.3): each half of a bond uses the constants
/// of the node that owns it.
#[derive(Debug, Clone)]
pub struct Pmb {
    /// c0 per unit volume² (N/m⁶): in 2D the per-thickness micromodulus divided by the thickness.
    pub c0: PerNode,
    /// c0 as the papers write it (per unit thickness in 2D, N/m⁵; N/m⁶ in 3D), at `horizon`.
    pub c0_paper: f64,
    pub profile: MicromodulusProfile,
    /// The reference horizon of `c0_paper` (m).
    pub horizon: f64,
    /// Horizon per node (m), for the conical profile.
    pub horizons: PerNode,
    pub rho: f64,
    pub elasticity: Elasticity,
    pub coupling: HorizonCoupling,
    dimensionality: Dimensionality,
    thickness: f64,
}

impl Pmb {
    /// Micromodulus c0 (paper units) matching the classical energy of an isotropic expansion:
    /// 3D c0 = 9K/(2π M3), 2D c0 = 4κ/(π M2). For the constant profile these are seed 001,
    /// Eq. (6): 12E/(πδ⁴), 9E/(πδ³) (plane stress), 48E/(5πδ³) (plane strain).
    pub fn micromodulus(
        e: f64,
        dim: Dimensionality,
        profile: MicromodulusProfile,
        horizon: f64,
    ) -> f64 {
        let el = Elasticity {
            youngs_modulus: e,
            poisson_ratio: bond_based_poisson_ratio(dim),
            dimensionality: dim,
        };
        match dim {
            Dimensionality::ThreeD => {
                9.0 * el.bulk() / (2.0 * std::f64::consts::PI * profile.moment(3, horizon))
            }
            _ => 4.0 * el.in_plane_bulk() / (std::f64::consts::PI * profile.moment(2, horizon)),
        }
    }

    /// Young's modulus represented by a given micromodulus (inverse of `micromodulus`).
    pub fn youngs_modulus_of(
        c0: f64,
        dim: Dimensionality,
        profile: MicromodulusProfile,
        horizon: f64,
    ) -> f64 {
        c0 / Self::micromodulus(1.0, dim, profile, horizon)
    }

    /// Critical stretch from the fracture energy: the work to break every bond across a unit
    /// plane equals G0 (seed 001, Eqs. 7–8, with the corrected limit acos(z/ξ)). It reduces to
    /// G0 = (π/2) c0 s0² M4 in 3D and G0 = c0 s0² M3 in 2D, i.e. for the constant profile
    /// s0 = sqrt(5G0/(6Eδ)), sqrt(4πG0/(9Eδ)) and sqrt(5πG0/(12Eδ)).
    pub fn critical_stretch_from_g0(
        g0: f64,
        c0: f64,
        dim: Dimensionality,
        profile: MicromodulusProfile,
        horizon: f64,
    ) -> f64 {
        match dim {
            Dimensionality::ThreeD => {
                (2.0 * g0 / (std::f64::consts::PI * c0 * profile.moment(4, horizon))).sqrt()
            }
            _ => (g0 / (c0 * profile.moment(3, horizon))).sqrt(),
        }
    }

    /// Builds a PMB material. `c0_paper` is per unit thickness in 2D; `thickness` is 1 in 3D.
    pub fn new(
        c0_paper: f64,
        rho: f64,
        dim: Dimensionality,
        profile: MicromodulusProfile,
        horizon: f64,
        thickness: f64,
    ) -> Self {
        let e = Self::youngs_modulus_of(c0_paper, dim, profile, horizon);
        let thickness = if dim == Dimensionality::ThreeD {
            1.0
        } else {
            thickness
        };
        Pmb {
            c0: PerNode::Uniform(if dim == Dimensionality::ThreeD {
                c0_paper
            } else {
                c0_paper / thickness
            }),
            c0_paper,
            profile,
            horizon,
            horizons: PerNode::Uniform(horizon),
            rho,
            elasticity: Elasticity {
                youngs_modulus: e,
                poisson_ratio: bond_based_poisson_ratio(dim),
                dimensionality: dim,
            },
            coupling: HorizonCoupling::Dual,
            dimensionality: dim,
            thickness,
        }
    }

    /// Calibrated from Young's modulus (seed 001, Eq. 6).
    pub fn calibrated(
        e: f64,
        rho: f64,
        dim: Dimensionality,
        profile: MicromodulusProfile,
        horizon: f64,
        thickness: f64,
    ) -> Self {
        let c0 = Self::micromodulus(e, dim, profile, horizon);
        Self::new(c0, rho, dim, profile, horizon, thickness)
    }

    /// The same material with a horizon per node: each node's micromodulus is recalibrated
    /// to its own horizon for the same Young's modulus (dual-horizon PD, seed 003 §2.3; the
    /// half-bond form of this code already carries the factor ½ that the notes discuss for
    /// the paper's Eq. 3).
    pub fn with_horizons(mut self, horizons: &[f64]) -> Self {
        let per_node = PerNode::from_values(horizons.to_vec());
        let e = self.elasticity.youngs_modulus;
        let (dim, profile, t) = (self.dimensionality, self.profile, self.thickness);
        match per_node.uniform() {
            Some(h) if h == self.horizon => return self,
            // One horizon, another than the reference: the uniform material at that horizon.
            Some(h) => {
                let mut m = Self::calibrated(e, self.rho, dim, profile, h, t);
                m.coupling = self.coupling;
                return m;
            }
            None => {}
        }
        let mut cache: Vec<(f64, f64)> = Vec::new();
        let c0 = horizons
            .iter()
            .map(|&h| match cache.iter().find(|(k, _)| *k == h) {
                Some(&(_, c)) => c,
                None => {
                    let c = Self::micromodulus(e, dim, profile, h) / t;
                    cache.push((h, c));
                    c
                }
            })
            .collect();
        self.c0 = PerNode::Varying(c0);
        self.horizons = per_node;
        self
    }

    /// c(ξ) of node i's half, per unit volume², at a bond length.
    #[inline(always)]
    fn c(&self, i: usize, ref_len: f64) -> f64 {
        match self.profile {
            MicromodulusProfile::Constant => self.c0.at(i),
            MicromodulusProfile::Conical => {
                self.c0.at(i) * (1.0 - ref_len / self.horizons.at(i)).max(0.0)
            }
        }
    }

    /// The pair weight c φ̄ of a bond: c ½(φ_ij μ_ij + φ_ji μ_ji) with one micromodulus,
    /// ½(c_i φ_ij μ_ij + c_j φ_ji μ_ji) with one per node (dual-horizon PD, seed 003 §2.2, Eq. 8);
    /// c_i φ_ij μ_ij, node i's own half only, in traditional PD (seed 003 §2.2).
    #[inline(always)]
    fn pair_weight<const D: usize>(&self, i: usize, j: usize, b: &BondGeom<D>) -> f64 {
        let traditional = self.coupling == HorizonCoupling::Traditional;
        match self.c0 {
            PerNode::Uniform(c0) => {
                let c = match self.profile {
                    MicromodulusProfile::Constant => c0,
                    MicromodulusProfile::Conical => c0 * (1.0 - b.ref_len / self.horizon).max(0.0),
                };
                if traditional {
                    c * (b.phi_ij * b.mu_ij)
                } else {
                    c * 0.5 * (b.phi_ij * b.mu_ij + b.phi_ji * b.mu_ji)
                }
            }
            PerNode::Varying(_) => {
                let own = self.c(i, b.ref_len) * (b.phi_ij * b.mu_ij);
                if traditional {
                    own
                } else {
                    0.5 * (own + self.c(j, b.ref_len) * (b.phi_ji * b.mu_ji))
                }
            }
        }
    }
}

impl<const D: usize> Material<D> for Pmb {
    type Point = ();
    const NEEDS_PREPASS: bool = false;

    /// A ghost's micromodulus is its owner's (a surface correction's factor comes from the
    /// node's family, which is on its owner), and the ranks agree on whether it varies (the
    /// bond weight's form and the vector kernel depend on it): a rank whose nodes all have
    /// one value keeps them one by one when another rank's vary, as one process does.
    fn share_constants(&mut self, share: &Share) {
        let ranks = &*share.ranks;
        let varying = matches!(self.c0, PerNode::Varying(_));
        if ranks.max_f64(f64::from(u8::from(varying))) == 0.0 {
            return;
        }
        let nodes = share.owned + share.halo.ghosts();
        let mut c0 = match &self.c0 {
            PerNode::Uniform(c) => vec![*c; nodes],
            PerNode::Varying(c) => c.clone(),
        };
        share.halo.exchange_values(ranks, &mut c0);
        self.c0 = PerNode::Varying(c0);
    }
    /// f = c(ξ) ½(φ_ij + φ_ji) e/|ξ| along the bond (seed 001 Eq. 4), c(ξ) and φ fixed.
    const LINEAR_BOND: bool = true;

    /// c φ̄ s / |ξ+η| = c φ̄ (|ξ+η| − |ξ|) / (|ξ| |ξ+η|): one division instead of two
    /// (f = c(ξ) s, seed 001 Eq. 4, weighted by the halves so that the force is the exact
    /// gradient of the discrete energy on non-uniform grids too).
    #[inline(always)]
    fn pair_force_per_length(&self, i: usize, j: usize, b: &BondGeom<D>, _: &(), _: &()) -> f64 {
        self.pair_weight(i, j, b) * (b.len - b.ref_len) / (b.ref_len * b.len)
    }

    /// Half the pair force goes to each end's force state.
    #[inline(always)]
    fn force_state(&self, i: usize, b: &BondGeom<D>, _: &()) -> f64 {
        0.5 * self.c(i, b.ref_len) * b.stretch()
    }

    /// Half of the bond micropotential ω = ½ c s² |ξ| (seed 001, Eq. 3) goes to each end.
    #[inline(always)]
    fn bond_energy(&self, i: usize, b: &BondGeom<D>, _: &()) -> f64 {
        let s = b.stretch();
        0.25 * self.c(i, b.ref_len) * s * s * b.ref_len * b.weight()
    }

    fn bond_stiffness(&self, i: usize, ref_len: f64) -> f64 {
        self.c(i, ref_len) / ref_len
    }

    fn density(&self, _i: usize) -> f64 {
        self.rho
    }

    unsafe fn vector_force(
        &self,
        nb: &mut NodeBonds,
        w: &UniformWeights,
        _: &[()],
    ) -> Option<([f64; 3], u64)> {
        // The kernels sum both halves of each bond (dual-horizon PD).
        if self.coupling == HorizonCoupling::Traditional {
            return None;
        }
        let law = |c0| simd::PmbLaw {
            c0,
            horizon: self.horizon,
            conical: self.profile == MicromodulusProfile::Conical,
        };
        match &self.c0 {
            // SAFETY: forwarded from the caller.
            PerNode::Uniform(c0) => Some(unsafe { kernel(nb, &law(*c0), w) }),
            // A micromodulus per node on one horizon (a surface correction): one critical
            // stretch only; per-node horizons never reach here (their weights vary).
            PerNode::Varying(c0) => {
                let one_law = nb.softening.is_none() && nb.work.is_none();
                (one_law && self.horizons.uniform() == Some(self.horizon)).then(|| {
                    // The law's own c0 is not read: each node's comes from `c0`.
                    // SAFETY: forwarded from the caller; `c0` covers every node (and ghost).
                    unsafe { simd::pmb_force_per_node(nb, &law(f64::NAN), w, c0) }
                })
            }
        }
    }

    unsafe fn vector_force_nodes(
        &self,
        nb: &mut NodeBonds,
        nodes: &simd_nodes::NodeConstants,
    ) -> Option<([f64; 3], u64)> {
        if self.coupling == HorizonCoupling::Traditional {
            return None;
        }
        let pmb = simd_nodes::PmbNodes {
            c0: &self.c0,
            horizons: &self.horizons,
            horizon: self.horizon,
            conical: self.profile == MicromodulusProfile::Conical,
        };
        // SAFETY: forwarded from the caller; a per-node c0 covers every node and ghost.
        Some(unsafe { simd_nodes::pmb_force(nb, &pmb, nodes) })
    }

    fn elasticity(&self) -> Elasticity {
        self.elasticity
    }
}

/// PMB's kernel for the pass's damage law: softening, one critical energy, or one critical
/// stretch.
///
/// # Safety
/// As for `simd::pmb_force`; under softening or critical energy, `nb.history` as the law's
/// kernel says.
unsafe fn kernel(nb: &mut NodeBonds, law: &simd::PmbLaw, w: &UniformWeights) -> ([f64; 3], u64) {
    #[cfg(target_arch = "x86_64")]
    {
        match (nb.softening, nb.work) {
            (Some(soft), _) if nb.dim == 2 => {
                simd_damage::pmb_force_softening::<2>(nb, law, w, &soft)
            }
            (Some(soft), _) => simd_damage::pmb_force_softening::<3>(nb, law, w, &soft),
            (None, Some(work)) => simd_energy::pmb_force_work(nb, law, w, &work),
            (None, None) => simd::pmb_force(nb, law, w),
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("simd::available() is false off x86-64")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn constant_profile_reproduces_seed001_eq6_and_eq8() {
        let (e, g0, d) = (192e9, 83e3, 3e-3);
        let c = Pmb::micromodulus(e, Dimensionality::ThreeD, MicromodulusProfile::Constant, d);
        assert!((c / (12.0 * e / (PI * d.powi(4))) - 1.0).abs() < 1e-14);
        let c = Pmb::micromodulus(
            e,
            Dimensionality::PlaneStress,
            MicromodulusProfile::Constant,
            d,
        );
        assert!((c / (9.0 * e / (PI * d.powi(3))) - 1.0).abs() < 1e-14);
        let s0 = Pmb::critical_stretch_from_g0(
            g0,
            c,
            Dimensionality::PlaneStress,
            MicromodulusProfile::Constant,
            d,
        );
        assert!((s0 / (4.0 * PI * g0 / (9.0 * e * d)).sqrt() - 1.0).abs() < 1e-14);
        let c = Pmb::micromodulus(
            e,
            Dimensionality::PlaneStrain,
            MicromodulusProfile::Constant,
            d,
        );
        assert!((c / (48.0 * e / (5.0 * PI * d.powi(3))) - 1.0).abs() < 1e-14);
        let s0 = Pmb::critical_stretch_from_g0(
            g0,
            c,
            Dimensionality::PlaneStrain,
            MicromodulusProfile::Constant,
            d,
        );
        assert!((s0 / (5.0 * PI * g0 / (12.0 * e * d)).sqrt() - 1.0).abs() < 1e-14);
        let c = Pmb::micromodulus(e, Dimensionality::ThreeD, MicromodulusProfile::Constant, d);
        let s0 = Pmb::critical_stretch_from_g0(
            g0,
            c,
            Dimensionality::ThreeD,
            MicromodulusProfile::Constant,
            d,
        );
        assert!((s0 / (5.0 * g0 / (6.0 * e * d)).sqrt() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn seed000_pmma_table_values() {
        // Seed 000 notes, §2.3 table: E = 3.24 GPa, G0 = 200 J/m², δ = 0.2 mm → c = 1.160e21, s0 = 0.02076.
        let c = Pmb::micromodulus(
            3.24e9,
            Dimensionality::PlaneStress,
            MicromodulusProfile::Constant,
            0.2e-3,
        );
        assert!((c / 1.160e21 - 1.0).abs() < 1e-3);
        let s0 = Pmb::critical_stretch_from_g0(
            200.0,
            c,
            Dimensionality::PlaneStress,
            MicromodulusProfile::Constant,
            0.2e-3,
        );
        assert!((s0 / 0.02076 - 1.0).abs() < 1e-3);
    }
}
