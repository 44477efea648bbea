//! Several materials in one body. Each node belongs to a block with its own material, and
//! each half of a bond is the force state of the node that owns it, from that node's
//! material: the bond i–j pulls with T_i⟨ξ⟩ − T_j⟨−ξ⟩, the discrete state-based equation of
//! motion (Silling et al. 2007, Eq. 9) applied across the interface. For two bond-based
//! blocks this gives the interface micromodulus ½(c_A + c_B), the arithmetic mean. Each half
//! also fails by its own block's damage law (`damage::mixed`). See `docs/models.md`.
//!
//! The cost: one `match` per half of every bond; a body of one material never comes here.

use super::correspondence::CorrespondencePoint;
use super::lps::LpsPoint;
use super::{BondGeom, Correspondence, Elasticity, Lps, Material, Pmb, PointError};
use crate::body::Body;
use crate::bonds::{Bonds, Quadrature};
use crate::math::Vector;
use crate::solver::ranks::Share;

/// The material of one block.
#[derive(Debug, Clone)]
pub enum BlockMaterial {
    Pmb(Pmb),
    Lps(Lps),
    Correspondence(Correspondence),
}

/// Materials per block and the block of each node.
#[derive(Debug, Clone)]
pub struct Mixed {
    pub materials: Vec<BlockMaterial>,
    /// Index into `materials` of each node.
    pub material_of: Vec<u16>,
}

/// The point state of any block's material.
#[derive(Debug, Clone, Copy)]
pub struct MixedPoint<const D: usize> {
    pub lps: LpsPoint,
    pub correspondence: CorrespondencePoint<D>,
}

impl<const D: usize> Default for MixedPoint<D> {
    fn default() -> Self {
        MixedPoint {
            lps: LpsPoint::default(),
            correspondence: CorrespondencePoint::default(),
        }
    }
}

impl Mixed {
    #[inline(always)]
    fn of(&self, i: usize) -> &BlockMaterial {
        &self.materials[self.material_of[i] as usize]
    }
}

/// Calls `$body` with `$m` bound to node `$i`'s material and `$p` to its part of the point.
macro_rules! with_material {
    ($self:expr, $i:expr, $point:expr, |$m:ident, $p:ident| $body:expr) => {
        match $self.of($i) {
            BlockMaterial::Pmb($m) => {
                let $p = &();
                $body
            }
            BlockMaterial::Lps($m) => {
                let $p = &$point.lps;
                $body
            }
            BlockMaterial::Correspondence($m) => {
                let $p = &$point.correspondence;
                $body
            }
        }
    };
}

impl<const D: usize> Material<D> for Mixed {
    type Point = MixedPoint<D>;
    const NEEDS_PREPASS: bool = true;
    const CENTRAL: bool = false;
    const NEEDS_XI: bool = true;

    /// Whatever a neighbour's half reads of either state-based material (LPS's θ, the
    /// correspondence model's B, C1 and moment record), whichever the ghost's block.
    const HALO_WORDS: usize =
        <Lps as Material<D>>::HALO_WORDS + <Correspondence as Material<D>>::HALO_WORDS;

    #[inline(always)]
    fn point_words(p: &Self::Point, out: &mut Vec<f64>) {
        <Lps as Material<D>>::point_words(&p.lps, out);
        <Correspondence as Material<D>>::point_words(&p.correspondence, out);
    }

    #[inline(always)]
    fn point_from_words(p: &mut Self::Point, words: &[f64]) {
        let (lps, correspondence) = words.split_at(<Lps as Material<D>>::HALO_WORDS);
        <Lps as Material<D>>::point_from_words(&mut p.lps, lps);
        <Correspondence as Material<D>>::point_from_words(&mut p.correspondence, correspondence);
    }

    /// Each block's constants (LPS's m of every node, a ghost's its owner's); every rank
    /// has the same blocks, so the exchanges match.
    fn share_constants(&mut self, share: &Share) {
        for m in &mut self.materials {
            match m {
                BlockMaterial::Pmb(m) => Material::<D>::share_constants(m, share),
                BlockMaterial::Lps(m) => Material::<D>::share_constants(m, share),
                BlockMaterial::Correspondence(m) => Material::<D>::share_constants(m, share),
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
        let owners = self.material_of.clone();
        for (k, m) in self.materials.iter_mut().enumerate() {
            let member = |i: usize| i < owned && owners[i] as usize == k;
            match m {
                BlockMaterial::Pmb(_) => {}
                BlockMaterial::Lps(m) => Material::<D>::setup(m, body, bonds, quad, owned)?,
                BlockMaterial::Correspondence(m) => {
                    m.check_shape_tensors(body, bonds, quad, member)?
                }
            }
        }
        Ok(())
    }

    #[inline(always)]
    fn accumulate(&self, i: usize, acc: &mut Self::Point, b: &BondGeom<D>) {
        match self.of(i) {
            BlockMaterial::Pmb(_) => {}
            BlockMaterial::Lps(m) => Material::<D>::accumulate(m, i, &mut acc.lps, b),
            BlockMaterial::Correspondence(m) => {
                Material::<D>::accumulate(m, i, &mut acc.correspondence, b)
            }
        }
    }

    fn finish_point(&self, i: usize, mut acc: Self::Point) -> Self::Point {
        match self.of(i) {
            BlockMaterial::Pmb(_) => {}
            BlockMaterial::Lps(m) => acc.lps = Material::<D>::finish_point(m, i, acc.lps),
            BlockMaterial::Correspondence(m) => {
                acc.correspondence = Material::<D>::finish_point(m, i, acc.correspondence)
            }
        }
        acc
    }

    fn force_state(&self, i: usize, b: &BondGeom<D>, p: &Self::Point) -> f64 {
        with_material!(self, i, p, |m, q| Material::<D>::force_state(m, i, b, q))
    }

    #[inline(always)]
    fn force_state_vector(&self, i: usize, b: &BondGeom<D>, p: &Self::Point) -> Vector<D> {
        with_material!(self, i, p, |m, q| Material::<D>::force_state_vector(
            m, i, b, q
        ))
    }

    /// T_i⟨ξ⟩ φ_ij μ_ij − T_j⟨−ξ⟩ φ_ji μ_ji with each half from its node's material, seen
    /// from its node's side (so the value from j's side is the exact negation).
    #[inline(always)]
    fn pair_force(
        &self,
        i: usize,
        j: usize,
        b: &BondGeom<D>,
        pi: &Self::Point,
        pj: &Self::Point,
    ) -> Vector<D> {
        let r = b.reversed();
        let own = Material::<D>::force_state_vector(self, i, b, pi);
        let other = Material::<D>::force_state_vector(self, j, &r, pj);
        own * (b.phi_ij * b.mu_ij) - other * (b.phi_ji * b.mu_ji)
    }

    fn bond_energy(&self, i: usize, b: &BondGeom<D>, p: &Self::Point) -> f64 {
        with_material!(self, i, p, |m, q| Material::<D>::bond_energy(m, i, b, q))
    }

    fn point_energy(&self, i: usize, p: &Self::Point, bond_sum: f64) -> f64 {
        with_material!(self, i, p, |m, q| Material::<D>::point_energy(
            m, i, q, bond_sum
        ))
    }

    fn bond_stiffness(&self, i: usize, ref_len: f64) -> f64 {
        match self.of(i) {
            BlockMaterial::Pmb(m) => Material::<D>::bond_stiffness(m, i, ref_len),
            BlockMaterial::Lps(m) => Material::<D>::bond_stiffness(m, i, ref_len),
            BlockMaterial::Correspondence(m) => Material::<D>::bond_stiffness(m, i, ref_len),
        }
    }

    fn density(&self, i: usize) -> f64 {
        match self.of(i) {
            BlockMaterial::Pmb(m) => m.rho,
            BlockMaterial::Lps(m) => m.rho,
            BlockMaterial::Correspondence(m) => m.rho,
        }
    }

    fn elasticity(&self) -> Elasticity {
        match &self.materials[0] {
            BlockMaterial::Pmb(m) => m.elasticity,
            BlockMaterial::Lps(m) => m.elasticity,
            BlockMaterial::Correspondence(m) => m.elasticity,
        }
    }
}
