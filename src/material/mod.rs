//! Constitutive models. The engine (`solver::forces`) owns every loop; a model supplies
//! pointwise laws of one bond plus, for state-based models, a per-node pre-pass. When bonds
//! break or soften is a separate policy (`damage`), which hands the model the remaining
//! fraction μ of each half of a bond.
//!
//! Adding a model touches: its file here, a variant of `MaterialDeck` and its calibration
//! (`deck/`), one arm of the dispatch in `run.rs` (and of `Mixed`), and the conformance list
//! in `tests/suite/conformance.rs`. See `docs/architecture.md`.

pub mod calibration;
pub mod correspondence;
pub mod influence;
pub mod lps;
pub mod lps_separation;
pub mod mixed;
pub mod mixed_central;
pub mod pmb;
pub mod simd;
pub mod simd_correspondence;
pub mod simd_damage;
pub mod simd_energy;
pub mod simd_nodes;
pub mod stabilisation_memo;
pub mod surface_correction;

pub use calibration::{Dimensionality, Elasticity};
pub use correspondence::Correspondence;
pub use influence::Influence;
pub use lps::Lps;
pub use mixed::Mixed;
pub use mixed_central::MixedCentral;
pub use pmb::{MicromodulusProfile, Pmb};

use crate::body::Body;
use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::{Bonds, Quadrature};
use crate::math::Vector;
use crate::solver::ranks::Share;
use simd::NodeBonds;

/// Geometry of one directed bond i→j at the current configuration, with the state of its two
/// halves.
#[derive(Debug, Clone, Copy)]
pub struct BondGeom<const D: usize> {
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
    /// Remaining fraction of node i's half (its force state T_i⟨ξ⟩): 1 intact, 0 broken.
    pub mu_ij: f64,
    /// Remaining fraction of node j's half (T_j⟨−ξ⟩).
    pub mu_ji: f64,
    /// Deformed bond vector y_j − y_i (m).
    pub y: Vector<D>,
    /// Reference bond vector x_j − x_i (m); filled only for models with `NEEDS_XI`.
    pub xi: Vector<D>,
}

impl<const D: usize> BondGeom<D> {
    /// Bond stretch s = (|ξ+η| − |ξ|)/|ξ| (seed 001, Eq. 3).
    #[inline(always)]
    pub fn stretch(&self) -> f64 {
        (self.len - self.ref_len) / self.ref_len
    }
    /// Quadrature weight of the bond in i's family, φ_ij μ_ij V_j.
    #[inline(always)]
    pub fn weight(&self) -> f64 {
        self.phi_ij * self.mu_ij * self.vol_j
    }
    /// The same bond seen from j: ξ and y negated, the halves swapped. The neighbour's volume
    /// (V_i) is not known here and is NaN: use it for force states only.
    #[inline(always)]
    pub fn reversed(&self) -> Self {
        BondGeom {
            phi_ij: self.phi_ji,
            phi_ji: self.phi_ij,
            mu_ij: self.mu_ji,
            mu_ji: self.mu_ij,
            vol_j: f64::NAN,
            y: -self.y,
            xi: -self.xi,
            ..*self
        }
    }
    /// An intact bond of the given lengths, for tests and reports.
    pub fn intact(ref_len: f64, len: f64, phi: f64, vol_j: f64) -> Self {
        BondGeom {
            ref_len,
            len,
            phi_ij: phi,
            phi_ji: phi,
            vol_j,
            mu_ij: 1.0,
            mu_ji: 1.0,
            y: Vector::zeros(),
            xi: Vector::zeros(),
        }
    }
}

/// Why a model cannot evaluate a node (e.g. a singular shape tensor).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("node {node} at x = {position:?}: {reason}")]
pub struct PointError {
    pub node: usize,
    pub position: Vec<f64>,
    pub reason: String,
}

/// A material law, written for one bond; the engine sums it over families.
///
/// Force convention: the force density on node i from bond i→j is V_j times the pair force
/// T_i⟨ξ⟩ φ_ij μ_ij − T_j⟨−ξ⟩ φ_ji μ_ji, the discrete form of T[x]⟨ξ⟩ − T[x']⟨−ξ⟩. A model whose
/// force states lie along the deformed bond (`CENTRAL`: bond-based and ordinary state-based)
/// gives it as a scalar per unit length, `pair_force_per_length`, which the engine multiplies
/// by y = y_j − y_i; others give the vector, `pair_force`. Energy convention: the strain
/// energy density of node i is `point_energy(i, p_i, Σ_j bond_energy(b, p_i))`.
pub trait Material<const D: usize>: Sync + Send {
    /// Per-node quantities computed in the pre-pass (θ for LPS; `()` for bond-based models).
    type Point: Copy + Default + Send + Sync;
    /// Whether the engine must run the per-node pre-pass before the force pass.
    const NEEDS_PREPASS: bool;
    /// Force states along the deformed bond: the engine asks `pair_force_per_length`.
    const CENTRAL: bool = true;
    /// The pair force of a bond with both halves intact is f = k e along the bond, k fixed
    /// (bond-based PMB): the work done on it since the reference state is then ½ f e along any
    /// path, which a critical-energy law takes without a record (`damage::Work::Stored`).
    const LINEAR_BOND: bool = false;
    /// The bond loops fill `BondGeom::xi` (the reference bond vector).
    const NEEDS_XI: bool = false;
    /// Bytes per node the model keeps besides its point state (memory reports).
    const NODE_BYTES: usize = 0;
    /// Non-central models whose own half factors through matrices of node i alone: the own
    /// half of the force density, V_j φ_ij μ_ij T_i⟨ξ⟩, is s_ij (B_i ξ + C_i η) with η = y − ξ
    /// and a scalar s_ij per bond (`own_half_weight`). The engine then sums s ξ and s η over
    /// i's family and applies i's matrices once (`own_half_force`); per bond it evaluates only
    /// the other half (`other_half`). The sum order is fixed per node, so results stay
    /// deterministic, but they differ from the per-bond `pair_force` sum by round-off.
    ///
    /// Damage laws that record the work of each pair force (`DamageLaw::ON_WORK`) need the
    /// full pair force per bond: with them the engine uses `pair_force` regardless, unless
    /// the law splits the work between a bond's entries (`DamageLaw::SPLITS_WORK`).
    const FACTORED_OWN_HALF: bool = false;
    /// Words per node of the matrices through which node i's own half is linear in the bond's
    /// ξ and η, T_i⟨ξ⟩ = ω (B_i ξ + C1_i η) (0: the model's halves are not of that form).
    /// Non-zero makes the pair force `damage::BondForce::NodeLinear`: a critical energy with
    /// one w_c then integrates each half's work apart (`own_half_work`), and the engine keeps
    /// the matrices of the previous evaluation per node (`State::previous_matrices`).
    const NODE_MATRIX_WORDS: usize = 0;

    /// Node i's matrices (`NODE_MATRIX_WORDS` words) from its point state.
    #[inline(always)]
    fn node_matrices(&self, _pi: &Self::Point, _out: &mut [f64]) {}

    /// The work of node i's own half of bond i→j since the previous evaluation (intact
    /// halves; per unit volume squared, as the pair force's), ½ (T_prev + T)·Δη with
    /// T = ω φ_ij (B_i ξ + C1_i η) from the point state and T_prev from node i's matrices
    /// at the previous evaluation (`previous`) and η − Δη; Δη is `step`.
    #[inline(always)]
    fn own_half_work(
        &self,
        _i: usize,
        _bond: &BondGeom<D>,
        _pi: &Self::Point,
        _previous: &[f64],
        _step: &Vector<D>,
    ) -> f64 {
        unimplemented!("own_half_work of a model without NODE_MATRIX_WORDS")
    }

    /// f64 words of a point state that a distributed run sends each evaluation to the ranks
    /// that have the node as a ghost: what a neighbour's half of a bond reads (LPS: θ). 0:
    /// none (bond-based models; a state-based model without them is not distributed).
    const HALO_WORDS: usize = 0;

    /// Appends the `HALO_WORDS` words of a point state.
    #[inline(always)]
    fn point_words(_p: &Self::Point, _out: &mut Vec<f64>) {}

    /// The point state of a ghost from its owner's `HALO_WORDS` words.
    #[inline(always)]
    fn point_from_words(_p: &mut Self::Point, _words: &[f64]) {}

    /// A distributed run: `setup`'s per-node constants of the ghosts (computed here from
    /// their empty rows) replaced by their owners' (`Halo::exchange_values` sets the ghosts'
    /// entries of a per-node array), and any constant of the whole body agreed over the
    /// ranks.
    fn share_constants(&mut self, _share: &Share) {}

    /// Per-node constants that depend on the families (LPS weighted volume m); called once
    /// before the run, with all bonds intact. Nodes below `owned` have their rows in `bonds`;
    /// a distributed run's ghosts follow with empty rows (`share_constants` gives them their
    /// owners' constants). Fails, naming the node, when an owned node cannot be evaluated
    /// (e.g. a singular shape tensor).
    fn setup(
        &mut self,
        _body: &Body<D>,
        _bonds: &Bonds,
        _quad: &Quadrature,
        _owned: usize,
    ) -> Result<(), PointError> {
        Ok(())
    }

    /// Pre-pass: adds the contribution of a bond of node i (weighted by μ_ij) to its
    /// accumulator.
    #[inline(always)]
    fn accumulate(&self, _i: usize, _acc: &mut Self::Point, _bond: &BondGeom<D>) {}

    /// Pre-pass: turns the accumulator of node i into its point state.
    #[inline(always)]
    fn finish_point(&self, _i: usize, acc: Self::Point) -> Self::Point {
        acc
    }

    /// Scalar force state t_i⟨ξ⟩ of node i on bond i→j (N/m⁶) of an intact half, for a
    /// central model: T = t M, M the deformed bond direction. Bond-based models give half
    /// the pair force.
    fn force_state(&self, i: usize, bond: &BondGeom<D>, pi: &Self::Point) -> f64;

    /// Vector force state T_i⟨ξ⟩ of an intact half (N/m⁶); central models: t M.
    #[inline(always)]
    fn force_state_vector(&self, i: usize, bond: &BondGeom<D>, pi: &Self::Point) -> Vector<D> {
        bond.y * (self.force_state(i, bond, pi) / bond.len)
    }

    /// Central models: (t_i φ_ij μ_ij + t_j φ_ji μ_ji) / |ξ+η|, the factor the engine
    /// multiplies y by. Models override it when they can fold divisions (the loop is bound
    /// by the divider).
    #[inline(always)]
    fn pair_force_per_length(
        &self,
        i: usize,
        j: usize,
        bond: &BondGeom<D>,
        pi: &Self::Point,
        pj: &Self::Point,
    ) -> f64 {
        let _ = j;
        (self.force_state(i, bond, pi) * (bond.phi_ij * bond.mu_ij)
            + self.force_state(j, bond, pj) * (bond.phi_ji * bond.mu_ji))
            / bond.len
    }

    /// Non-central models: the pair force T_i⟨ξ⟩ φ_ij μ_ij − T_j⟨−ξ⟩ φ_ji μ_ji (N/m⁶). It must
    /// be the exact negation of the value computed from j's side (swap i and j, negate y and
    /// ξ), so that bond work and failure are the same from either end.
    #[inline(always)]
    fn pair_force(
        &self,
        i: usize,
        j: usize,
        bond: &BondGeom<D>,
        pi: &Self::Point,
        pj: &Self::Point,
    ) -> Vector<D> {
        bond.y * self.pair_force_per_length(i, j, bond, pi, pj)
    }

    /// `FACTORED_OWN_HALF` models: the scalar s_ij with V_j φ_ij μ_ij T_i⟨ξ⟩ = s_ij (B_i ξ + C_i η).
    #[inline(always)]
    fn own_half_weight(&self, _i: usize, _bond: &BondGeom<D>) -> f64 {
        unimplemented!("own_half_weight of a model without FACTORED_OWN_HALF")
    }

    /// `FACTORED_OWN_HALF` models: the other half of the force density on node i,
    /// −T_j⟨−ξ⟩ φ_ji μ_ji V_j, so that `pair_force` × V_j is the own half plus this.
    #[inline(always)]
    fn other_half(
        &self,
        _i: usize,
        _j: usize,
        _bond: &BondGeom<D>,
        _pj: &Self::Point,
    ) -> Vector<D> {
        unimplemented!("other_half of a model without FACTORED_OWN_HALF")
    }

    /// `FACTORED_OWN_HALF` models: node i's own halves summed over its family,
    /// B_i Σ s ξ + C_i Σ s η, from `sum_xi` = Σ s ξ and `sum_eta` = Σ s η.
    #[inline(always)]
    fn own_half_force(
        &self,
        _i: usize,
        _pi: &Self::Point,
        _sum_xi: &Vector<D>,
        _sum_eta: &Vector<D>,
    ) -> Vector<D> {
        unimplemented!("own_half_force of a model without FACTORED_OWN_HALF")
    }

    /// Energy contribution of a bond of node i (before the point-level finish).
    fn bond_energy(&self, i: usize, bond: &BondGeom<D>, pi: &Self::Point) -> f64;

    /// Strain energy density W_i (J/m³) from the summed bond contributions.
    fn point_energy(&self, _i: usize, _pi: &Self::Point, bond_sum: f64) -> f64 {
        bond_sum
    }

    /// Linearised stiffness of a bond whose both halves were like node i's, C(ξ) = c(ξ)/|ξ|
    /// (N/m⁷), for the stable time step (Silling & Askari 2005); state-based models use the
    /// bond-based equivalent of their P-wave modulus.
    fn bond_stiffness(&self, i: usize, ref_len: f64) -> f64;

    /// Mass density of node i (kg/m³).
    fn density(&self, i: usize) -> f64;

    /// Optional AVX2 pre-pass of one node (2D or 3D, `nb.dim`; uniform grid, one critical
    /// stretch, or the uniform law `nb` carries): writes its point state over `point`, the node's state from
    /// the last evaluation (the default before the first; a model may reuse parts of it), and
    /// returns the bonds it broke (with split work, `DamageLaw::SPLITS_WORK`, the entries
    /// that may fail, their own halves of the work added); or `None`, leaving `point` as it
    /// was, to use the generic loop.
    ///
    /// # Safety
    /// `simd::available()` and every neighbour index below `nb.current.len() / nb.dim`.
    unsafe fn vector_prepass(
        &self,
        _nb: &mut NodeBonds,
        _w: &UniformWeights,
        _point: &mut Self::Point,
    ) -> Option<u64> {
        None
    }

    /// Optional AVX2 force pass of one node (2D or 3D, `nb.dim`; uniform grid, one critical
    /// stretch, or the uniform law `nb` carries: softening, critical energy): its force
    /// density (z = 0 in 2D) and the bonds it broke, or `None` to use the generic loop.
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

    /// Optional AVX2 force pass of one node on a grid whose nodes differ (their cells,
    /// horizons and critical stretches in `nodes`), under a critical stretch, for a model
    /// without a pre-pass: as `vector_force`.
    ///
    /// # Safety
    /// As for `vector_prepass`; `nodes` covers every neighbour index.
    unsafe fn vector_force_nodes(
        &self,
        _nb: &mut NodeBonds,
        _nodes: &simd_nodes::NodeConstants,
    ) -> Option<([f64; 3], u64)> {
        None
    }

    /// The classical elastic constants the model represents (of the first block for
    /// several materials).
    fn elasticity(&self) -> Elasticity;
}
