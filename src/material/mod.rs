//! Constitutive models. The engine (`solver::forces`) owns every loop; a model supplies
//! pointwise laws of one bond plus, for state-based models, a per-node pre-pass.
//!
//! Adding a model touches: its file here, a variant of `MaterialSpec` (deck twin in `deck/`),
//! one arm of the dispatch in `run.rs`, and the conformance list in `tests/conformance.rs`.

pub mod calibration;
pub mod lps;
pub mod pmb;
pub mod simd;

pub use calibration::{Dimensionality, Elasticity};
pub use lps::Lps;
pub use pmb::{MicromodulusProfile, Pmb};

use crate::body::Body;
use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::{Bonds, Quadrature};
use simd::NodeBonds;

/// Geometry of one directed bond i→j at the current configuration.
#[derive(Debug, Clone, Copy)]
pub struct BondGeom {
    /// Reference length |ξ| (m).
    pub ref_len: f64,
    /// Deformed length |ξ + η| (m).
    pub len: f64,
    /// Fraction of j's volume inside i's horizon, φ_ij.
    pub phi_ij: f64,
    /// Fraction of i's volume inside j's horizon, φ_ji (equal to φ_ij on uniform grids).
    pub phi_ji: f64,
    /// Volume of the neighbour V_j (m³).
    pub vol_j: f64,
}

impl BondGeom {
    /// Bond stretch s = (|ξ+η| − |ξ|)/|ξ| (seed 001, Eq. 3).
    #[inline(always)]
    pub fn stretch(&self) -> f64 {
        (self.len - self.ref_len) / self.ref_len
    }
    /// Quadrature weight of the bond in i's family, φ_ij V_j.
    #[inline(always)]
    pub fn weight(&self) -> f64 {
        self.phi_ij * self.vol_j
    }
}

/// A material law, written for one bond; the engine sums it over families.
///
/// Force convention: `pair_force` returns the scalar `g` such that the force density on node i
/// from bond i→j is `g · V_j · (y_j − y_i)/|y_j − y_i|`. Energy convention: the strain energy
/// density of node i is `point_energy(i, p_i, Σ_j bond_energy(b, p_i))`.
pub trait Material<const D: usize>: Sync + Send {
    /// Per-node quantities computed in the pre-pass (θ for LPS; `()` for bond-based models).
    type Point: Copy + Default + Send + Sync;
    /// Whether the engine must run the per-node pre-pass before the force pass.
    const NEEDS_PREPASS: bool;

    /// Per-node constants that depend on the families (LPS weighted volume m); called once
    /// before the run, with all bonds intact.
    fn setup(&mut self, _body: &Body<D>, _bonds: &Bonds, _quad: &Quadrature) {}

    /// Pre-pass: adds the contribution of an intact bond of node i to its accumulator.
    #[inline(always)]
    fn accumulate(&self, _acc: &mut Self::Point, _bond: &BondGeom) {}

    /// Pre-pass: turns the accumulator of node i into its point state.
    #[inline(always)]
    fn finish_point(&self, _i: usize, acc: Self::Point) -> Self::Point {
        acc
    }

    /// Scalar force state t_i⟨ξ⟩ of node i on bond i→j (N/m⁶): the force state is
    /// T = t M, M the deformed bond direction. Bond-based models give half the pair force.
    fn force_state(&self, i: usize, bond: &BondGeom, pi: &Self::Point) -> f64;

    /// Scalar pair force density of bond i→j (see the trait docs for the convention):
    /// t_i⟨ξ⟩ φ_ij + t_j⟨−ξ⟩ φ_ji, the discrete form of T[x]⟨ξ⟩ − T[x']⟨−ξ⟩.
    #[inline(always)]
    fn pair_force(
        &self,
        i: usize,
        j: usize,
        bond: &BondGeom,
        pi: &Self::Point,
        pj: &Self::Point,
    ) -> f64 {
        let _ = (i, j);
        self.force_state(i, bond, pi) * bond.phi_ij + self.force_state(j, bond, pj) * bond.phi_ji
    }

    /// `pair_force / |ξ+η|`, the factor the engine multiplies the deformed bond vector by.
    /// Models override it when they can fold the division into one (the loop is bound by
    /// the divider).
    #[inline(always)]
    fn pair_force_per_length(
        &self,
        i: usize,
        j: usize,
        bond: &BondGeom,
        pi: &Self::Point,
        pj: &Self::Point,
    ) -> f64 {
        self.pair_force(i, j, bond, pi, pj) / bond.len
    }

    /// Energy contribution of an intact bond of node i (before the point-level finish).
    fn bond_energy(&self, i: usize, bond: &BondGeom, pi: &Self::Point) -> f64;

    /// Strain energy density W_i (J/m³) from the summed bond contributions.
    fn point_energy(&self, _i: usize, _pi: &Self::Point, bond_sum: f64) -> f64 {
        bond_sum
    }

    /// Critical stretch s0: an intact bond whose stretch exceeds it breaks, irreversibly.
    fn critical_stretch(&self) -> f64;

    /// Linearised bond stiffness C(ξ) = c(ξ)/|ξ| (N/m⁷) for the stable time step estimate
    /// (Silling & Askari 2005); state-based models use the bond-based equivalent of their
    /// bulk modulus.
    fn bond_stiffness(&self, ref_len: f64) -> f64;

    /// Mass density (kg/m³).
    fn density(&self) -> f64;

    /// Optional AVX2 pre-pass of one node (3D, uniform grid): its point state and the bonds
    /// it broke, or `None` to use the generic loop.
    ///
    /// # Safety
    /// `solver::simd::available()` and every neighbour index below `nb.current.len() / 3`.
    unsafe fn vector_prepass(
        &self,
        _nb: &mut NodeBonds,
        _w: &UniformWeights,
    ) -> Option<(Self::Point, u64)> {
        None
    }

    /// Optional AVX2 force pass of one node (3D, uniform grid): its force density and the
    /// bonds it broke, or `None` to use the generic loop.
    ///
    /// # Safety
    /// As for `vector_prepass`.
    unsafe fn vector_force(
        &self,
        _nb: &mut NodeBonds,
        _w: &UniformWeights,
        _points: &[Self::Point],
    ) -> Option<([f64; 3], u64)> {
        None
    }

    /// The classical elastic constants the model represents.
    fn elasticity(&self) -> Elasticity;
}
