//! Several materials in one body when every block is central (bond-based PMB or ordinary
//! state-based LPS): the same interface rule as `mixed` (each half of a bond is the force
//! state of the node that owns it, Silling et al. 2007, Eq. 9), on the engine's scalar path.
//! Every force state lies along the deformed bond, so a pair force is one number per bond
//! times y, and a bond inside one block runs its material's own folded pair force.

use super::lps::LpsPoint;
use super::mixed::{BlockMaterial, Mixed};
use super::{BondGeom, Elasticity, Lps, Material, Pmb, PointError};
use crate::body::Body;
use crate::bonds::{Bonds, Quadrature};
use crate::solver::ranks::Share;

/// The material of one central block.
#[derive(Debug, Clone)]
pub enum CentralBlock {
    Pmb(Pmb),
    Lps(Lps),
}

/// Central materials per block and the block of each node.
#[derive(Debug, Clone)]
pub struct MixedCentral {
    pub materials: Vec<CentralBlock>,
    /// Index into `materials` of each node.
    pub material_of: Vec<u16>,
}

impl Mixed {
    /// The central form of these blocks, when none is a correspondence material.
    pub fn into_central(self) -> Result<MixedCentral, Mixed> {
        let central = self
            .materials
            .iter()
            .all(|m| matches!(m, BlockMaterial::Pmb(_) | BlockMaterial::Lps(_)));
        if !central {
            return Err(self);
        }
        Ok(MixedCentral {
            materials: self
                .materials
                .into_iter()
                .map(|m| match m {
                    BlockMaterial::Pmb(m) => CentralBlock::Pmb(m),
                    BlockMaterial::Lps(m) => CentralBlock::Lps(m),
                    BlockMaterial::Correspondence(_) => unreachable!("checked above"),
                })
                .collect(),
            material_of: self.material_of,
        })
    }
}

impl MixedCentral {
    #[inline(always)]
    fn of(&self, i: usize) -> &CentralBlock {
        &self.materials[self.material_of[i] as usize]
    }
}

impl<const D: usize> Material<D> for MixedCentral {
    type Point = LpsPoint;
    const NEEDS_PREPASS: bool = true;

    /// A PMB node's point state is unused: θ, as for LPS.
    const HALO_WORDS: usize = <Lps as Material<D>>::HALO_WORDS;

    #[inline(always)]
    fn point_words(p: &LpsPoint, out: &mut Vec<f64>) {
        <Lps as Material<D>>::point_words(p, out);
    }

    #[inline(always)]
    fn point_from_words(p: &mut LpsPoint, words: &[f64]) {
        <Lps as Material<D>>::point_from_words(p, words);
    }

    /// Each block's constants (LPS's m of every node, a ghost's its owner's).
    fn share_constants(&mut self, share: &Share) {
        for m in &mut self.materials {
            match m {
                CentralBlock::Pmb(m) => Material::<D>::share_constants(m, share),
                CentralBlock::Lps(m) => Material::<D>::share_constants(m, share),
            }
        }
    }

    fn setup(
        &mut self,
        body: &Body<D>,
        bonds: &Bonds,
        quad: &Quadrature,
        owned: usize,
    ) -> Result<(), PointError> {
        for m in &mut self.materials {
            if let CentralBlock::Lps(m) = m {
                Material::<D>::setup(m, body, bonds, quad, owned)?;
            }
        }
        Ok(())
    }

    #[inline(always)]
    fn accumulate(&self, i: usize, acc: &mut LpsPoint, b: &BondGeom<D>) {
        if let CentralBlock::Lps(m) = self.of(i) {
            Material::<D>::accumulate(m, i, acc, b);
        }
    }

    fn finish_point(&self, i: usize, acc: LpsPoint) -> LpsPoint {
        match self.of(i) {
            CentralBlock::Lps(m) => Material::<D>::finish_point(m, i, acc),
            CentralBlock::Pmb(_) => acc,
        }
    }

    #[inline(always)]
    fn force_state(&self, i: usize, b: &BondGeom<D>, p: &LpsPoint) -> f64 {
        match self.of(i) {
            CentralBlock::Pmb(m) => Material::<D>::force_state(m, i, b, &()),
            CentralBlock::Lps(m) => Material::<D>::force_state(m, i, b, p),
        }
    }

    /// (t_i φ_ij μ_ij + t_j φ_ji μ_ji) / |ξ+η| with each t from its node's material.
    #[inline(always)]
    fn pair_force_per_length(
        &self,
        i: usize,
        j: usize,
        b: &BondGeom<D>,
        pi: &LpsPoint,
        pj: &LpsPoint,
    ) -> f64 {
        if self.material_of[i] == self.material_of[j] {
            return match self.of(i) {
                CentralBlock::Pmb(m) => Material::<D>::pair_force_per_length(m, i, j, b, &(), &()),
                CentralBlock::Lps(m) => Material::<D>::pair_force_per_length(m, i, j, b, pi, pj),
            };
        }
        (Material::<D>::force_state(self, i, b, pi) * (b.phi_ij * b.mu_ij)
            + Material::<D>::force_state(self, j, b, pj) * (b.phi_ji * b.mu_ji))
            / b.len
    }

    fn bond_energy(&self, i: usize, b: &BondGeom<D>, p: &LpsPoint) -> f64 {
        match self.of(i) {
            CentralBlock::Pmb(m) => Material::<D>::bond_energy(m, i, b, &()),
            CentralBlock::Lps(m) => Material::<D>::bond_energy(m, i, b, p),
        }
    }

    fn point_energy(&self, i: usize, p: &LpsPoint, bond_sum: f64) -> f64 {
        match self.of(i) {
            CentralBlock::Pmb(m) => Material::<D>::point_energy(m, i, &(), bond_sum),
            CentralBlock::Lps(m) => Material::<D>::point_energy(m, i, p, bond_sum),
        }
    }

    fn bond_stiffness(&self, i: usize, ref_len: f64) -> f64 {
        match self.of(i) {
            CentralBlock::Pmb(m) => Material::<D>::bond_stiffness(m, i, ref_len),
            CentralBlock::Lps(m) => Material::<D>::bond_stiffness(m, i, ref_len),
        }
    }

    fn density(&self, i: usize) -> f64 {
        match self.of(i) {
            CentralBlock::Pmb(m) => m.rho,
            CentralBlock::Lps(m) => m.rho,
        }
    }

    fn elasticity(&self) -> Elasticity {
        match &self.materials[0] {
            CentralBlock::Pmb(m) => m.elasticity,
            CentralBlock::Lps(m) => m.elasticity,
        }
    }
}
