//! Non-ordinary state-based correspondence material (Silling et al. 2007; seed 004,
//! Eqs. 6–11) with zero-energy-mode control after Wan et al. 2019 (seed 004, Eqs. 12–15) or
//! Silling 2017 (CMAME 322:42–57), in 3D, plane stress and plane strain.
//!
//! Per node: shape tensor K = Σ ω ξ⊗ξ w (Eq. 7), deformation gradient F = (Σ ω Y⊗ξ w) K⁻¹
//! (Eq. 6), Green–Lagrange strain E = ½(FᵀF − I) (Eq. 11), stress C:E (Eq. 10), first
//! Piola–Kirchhoff stress P (Eq. 9), and force state T⟨ξ⟩ = ω P K⁻¹ ξ (Eq. 8); w = φ μ V_j is
//! the bond's quadrature weight, μ its intact fraction.
//!
//! Stress. C:E, linear in the Green–Lagrange strain, is a material (second Piola–Kirchhoff)
//! stress S; the Cauchy stress is its push-forward σ = J⁻¹ F S Fᵀ, and Eq. 9, P = J σ F⁻ᵀ
//! (the paper prints F⁻¹, an erratum), gives P = F S: the St. Venant–Kirchhoff solid, whose
//! energy density is exactly W = ½ E:C:E. Taking C:E itself as the Cauchy stress,
//! P = J (C:E) F⁻ᵀ, agrees to first order in the strain but is not objective (a rigid rotation
//! Q of a strained state gives J (C:E) Q F⁻ᵀ instead of Q P: 41 % off at 0.3 rad) and has no
//! energy (f ≠ −∂W/∂u at O(|E|)); `tests/suite/correspondence.rs` and `tests/suite/conformance.rs` check
//! both properties.
//!
//! A node whose shape tensor is singular or ill-conditioned (fewer than D independent intact
//! bonds) or whose F is singular has no force state of its own ("detached", as in Peridigm):
//! its neighbours' halves of its bonds still act on it. At set-up, with every bond intact,
//! such a node is an error that names it.

use super::simd::tail;
use super::simd::NodeBonds;
use super::simd_correspondence::{self, lower, CorrespondenceLaw, MOMENT_WORDS};
use super::stabilisation_memo::{StabilisationMemo, MEMO_C1, MEMO_SUM, MEMO_WORDS};
use super::{BondGeom, Dimensionality, Elasticity, Influence, Material, PointError};
use crate::body::Body;
use crate::bonds::partial_volume::UniformWeights;
use crate::bonds::{Bonds, Quadrature};
use crate::math::{determinant, extent_middle, inverse, Vector};
use crate::per_node::PerNode;
use crate::solver::ranks::Share;
use nalgebra::{SMatrix, SVector};

/// The symmetric D×D matrix of a lower triangle given in the order of `lower`.
fn symmetric<const D: usize>(lower_triangle: &[f64]) -> SMatrix<f64, D, D> {
    let mut m = SMatrix::<f64, D, D>::zeros();
    for (&v, (r, c)) in lower_triangle.iter().zip(lower::<D>()) {
        (m[(r, c)], m[(c, r)]) = (v, v);
    }
    m
}

/// Zero-energy-mode control.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ZeroEnergyControl {
    /// None: the bare correspondence model (has zero-energy modes).
    None,
    /// Wan et al. 2019 (seed 004, Eqs. 12–15): T^S = G ω C1 z, z = Y − Fξ, C1 = C : K⁻¹ with
    /// (C1)_ab = Σ_cd C_abcd (K⁻¹)_cd; G = 1 is the paper's form.
    Wan { coefficient: f64 },
    /// Silling 2017 (CMAME 322:42–57): T^S = G c_s ω z with the scalar stiffness
    /// c_s = c/δ_i, c the bond-based micromodulus of the material's bulk modulus (18κ/(πδ⁴) in
    /// 3D, 12κ/(πδ³t) in 2D), so that G = 1 resists a non-uniform displacement of a bond at the
    /// horizon's edge as a PMB bond of the same bulk modulus resists its extension. It is
    /// Wan's form with C1 replaced by c_s I, derives from the energy ½ G c_s Σ ω |z|² w
    /// (because Σ ω z⊗ξ w = 0 by the definition of F) and is isotropic by construction.
    ///
    /// The older bond-projected hourglass force G c (z·M)/|ξ| M (M the deformed bond
    /// direction) is not offered: it has no potential, and its non-symmetric stiffness lets a
    /// free, unloaded plate gain energy exponentially (flutter: E/E0 ≈ 25 after 8000 stable
    /// steps, measured).
    Silling { coefficient: f64 },
}

/// Ratio det K / (tr K / D)^D below which a shape tensor counts as singular.
const SINGULAR: f64 = 1e-8;

/// Point state: during the pre-pass the sums K (in `b`) and Σ ω η⊗ξ w (in `h`; η = Y − ξ);
/// after it, B = A − C1 H with A = P K⁻¹ (Eq. 8), the stabilisation tensor C1 (Eqs. 12–15)
/// and the displacement gradient H = F − I. A detached node has all three zero: no force
/// state and no energy of its own.
///
/// With B, a half is ω (A ξ + C1 z) = ω (B ξ + C1 η) since z = Y − F ξ = η − H ξ (Eq. 14): the
/// force pass needs no z per bond and reads only B and C1. The vector force pass reads of a
/// neighbour only its moment record (`moments`, the first two cache lines of the
/// 64-byte-aligned record in 3D). H is kept for the energy (W of E(H), and z for the
/// stabilisation energy).
///
/// The model works with H rather than F = (Σ ω Y⊗ξ w) K⁻¹: K K⁻¹ is the identity only to
/// round-off, which left a spurious stress of order ε_machine·E in the reference state and a
/// relative round-off of ε_machine/|H| on small strains.
///
/// The vector pre-pass also keeps K⁻¹, C1 and Σ s ξ with the exact set of bonds they were
/// computed over (`shape_inverse`, `c1`, `shape_xi`, `kept`): they depend only on which bonds
/// carry force, so the next pre-pass of the node reuses them, bit for bit, when that set has
/// not changed (most nodes at most steps), and sums only N.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub struct CorrespondencePoint<const D: usize> {
    /// The node's moment record (vector pre-pass only; `simd_correspondence::moment_*`):
    /// B, g = B (x − o) + C1 (y − x), y − x and the version of C1, whose weighted sums over a
    /// family give the vector force pass the other halves (see `vector_force`). It comes
    /// first: the lines its neighbours read hold the node's own B and y − x too.
    pub moments: [f64; MOMENT_WORDS],
    /// Bit b: bond b of the family carried force when `shape_inverse` was computed.
    pub kept: [u64; 4],
    /// The number of bonds of the family `kept` describes; 0: no reusable K. (A u64, not an
    /// `Option`, so that the point state is f64-sized words with no padding: the force
    /// kernels read it as a slice of f64.)
    pub kept_of: u64,
    /// Σ s ξ over the bonds of `kept`, which depends on them only, as K (z = 0 in 2D). With
    /// `kept` and `kept_of`, one cache line: what the vector force pass reads of the node
    /// itself besides its moment record.
    pub shape_xi: [f64; 3],
    /// B, as in the first D² words of `moments`: a copy for the generic loops and the split
    /// work (`node_matrices`).
    pub b: SMatrix<f64, D, D>,
    pub c1: SMatrix<f64, D, D>,
    /// The node's current and reference positions (vector pre-pass only; u of the moment
    /// record).
    pub y: SVector<f64, D>,
    pub x: SVector<f64, D>,
    pub h: SMatrix<f64, D, D>,
    /// K⁻¹ of the bonds in `kept` (vector pre-pass only; C1 is its function too).
    pub shape_inverse: SMatrix<f64, D, D>,
    /// Explicit padding to the 64-byte alignment (24 + 4D² + 2D words above, 2D here: a
    /// multiple of eight words for D = 2 and 3), so that no byte of the record is undefined.
    pad: [SVector<f64, D>; 2],
}

// The force kernels' view of the record, in 2D and 3D.
const _: () = {
    use simd_correspondence::record_moments;
    use std::mem::offset_of;
    macro_rules! check_record {
        ($d:literal) => {{
            type Record = CorrespondencePoint<$d>;
            assert!(offset_of!(Record, moments) == 8 * record_moments($d));
        }};
    }
    check_record!(2);
    check_record!(3);
    // No implicit padding (see `pad`): the record is read as a slice of f64.
    assert!(size_of::<CorrespondencePoint<3>>() == 8 * 72);
    assert!(size_of::<CorrespondencePoint<2>>() == 8 * 48);
};

impl<const D: usize> Default for CorrespondencePoint<D> {
    fn default() -> Self {
        CorrespondencePoint {
            moments: [0.0; MOMENT_WORDS],
            kept: [0; 4],
            kept_of: 0,
            shape_xi: [0.0; 3],
            b: SMatrix::zeros(),
            c1: SMatrix::zeros(),
            y: SVector::zeros(),
            x: SVector::zeros(),
            h: SMatrix::zeros(),
            shape_inverse: SMatrix::zeros(),
            pad: [SVector::zeros(); 2],
        }
    }
}

/// Correspondence material.
#[derive(Debug, Clone)]
pub struct Correspondence {
    pub elasticity: Elasticity,
    pub influence: Influence,
    pub control: ZeroEnergyControl,
    /// Reference horizon (m).
    pub horizon: f64,
    /// Horizon per node (m).
    pub horizons: PerNode,
    pub rho: f64,
    thickness: f64,
    /// Lamé constants of the plane condition: σ = λ tr(E) I + 2μ E.
    lambda: f64,
    mu: f64,
    /// Reference positions, flat (filled by `setup`; read by the vector kernels).
    reference: Vec<f64>,
    /// The centre o of the reference positions' bounding box (`setup`): the moment records
    /// hold B (x − o), whose round-off grows with |x − o| (see `vector_force`).
    origin: [f64; 3],
    /// The vector force pass's sums over C1s (`setup` sizes it).
    memo: StabilisationMemo,
}

impl Correspondence {
    pub fn new(
        elasticity: Elasticity,
        influence: Influence,
        control: ZeroEnergyControl,
        horizon: f64,
        rho: f64,
        thickness: f64,
    ) -> Self {
        let dim = elasticity.dimensionality.dim() as f64;
        let mu = elasticity.shear();
        Correspondence {
            elasticity,
            influence,
            control,
            horizon,
            horizons: PerNode::Uniform(horizon),
            rho,
            thickness: if elasticity.dimensionality == Dimensionality::ThreeD {
                1.0
            } else {
                thickness
            },
            // κ − 2μ/D is λ in 3D and plane strain, Eν/(1 − ν²) in plane stress.
            lambda: elasticity.in_plane_bulk() - 2.0 * mu / dim,
            mu,
            reference: Vec::new(),
            origin: [0.0; 3],
            memo: StabilisationMemo::new(0),
        }
    }

    /// The same material with a horizon per node.
    pub fn with_horizons(mut self, horizons: &[f64]) -> Self {
        self.horizons = PerNode::from_values(horizons.to_vec());
        self
    }

    #[inline(always)]
    fn omega(&self, i: usize, ref_len: f64) -> f64 {
        self.influence.omega(ref_len, self.horizons.at(i))
    }

    /// Bond-based micromodulus of the in-plane bulk modulus κ at node i's horizon, per unit
    /// volume²: 18κ/(πδ⁴) in 3D, 12κ/(πδ³ t) in 2D (seed 001 Eq. 6 written with κ).
    fn bond_micromodulus(&self, i: usize) -> f64 {
        let (k, d) = (self.elasticity.in_plane_bulk(), self.horizons.at(i));
        match self.elasticity.dimensionality {
            Dimensionality::ThreeD => 18.0 * k / (std::f64::consts::PI * d.powi(4)),
            _ => 12.0 * k / (std::f64::consts::PI * d.powi(3) * self.thickness),
        }
    }

    /// S = C:E = λ tr(E) I + 2μ E (Eq. 10).
    fn stress<const D: usize>(&self, e: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
        SMatrix::<f64, D, D>::identity() * (self.lambda * e.trace()) + e * (2.0 * self.mu)
    }

    /// Green–Lagrange strain E = ½(FᵀF − I) (Eq. 11), written with H = F − I as
    /// ½(H + Hᵀ + HᵀH) so that no I cancels.
    fn strain<const D: usize>(h: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
        (h + h.transpose() + h.transpose() * h) * 0.5
    }

    /// The vector kernels' view of the model: one horizon, ω = 1 or δ/|ξ|, after `setup`, on a
    /// CPU with AVX2 and FMA.
    fn kernel_law<const D: usize>(&self, nodes: usize) -> Option<CorrespondenceLaw<'_>> {
        let PerNode::Uniform(horizon) = self.horizons else {
            return None;
        };
        let inverse_influence = match self.influence {
            Influence::Constant => false,
            Influence::Inverse => true,
            Influence::Gaussian => return None,
        };
        (self.reference.len() == D * nodes && super::simd::fma_available()).then_some(
            CorrespondenceLaw {
                reference: &self.reference,
                horizon,
                inverse_influence,
                control: self.control != ZeroEnergyControl::None,
            },
        )
    }

    /// Whether a shape tensor is too close to singular to invert.
    fn singular<const D: usize>(k: &SMatrix<f64, D, D>) -> bool {
        let scale = (k.trace() / D as f64).powi(D as i32);
        !(scale > 0.0 && determinant(k) > SINGULAR * scale)
    }

    /// K⁻¹, or `None` for a singular or ill-conditioned K (a detached node).
    fn shape_inverse<const D: usize>(k: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
        if Self::singular(k) {
            return None;
        }
        inverse(k)
    }

    /// Node i's stabilisation tensor C1 from its K⁻¹: Wan's G C:K⁻¹ = G (λ tr(K⁻¹) I + 2μ K⁻¹)
    /// (Eqs. 12–15), Silling's G c_s I, or zero without control. Symmetric, as K⁻¹ is.
    fn stabilisation<const D: usize>(
        &self,
        i: usize,
        k_inv: &SMatrix<f64, D, D>,
    ) -> SMatrix<f64, D, D> {
        match self.control {
            ZeroEnergyControl::Wan { coefficient } => {
                (SMatrix::<f64, D, D>::identity() * (self.lambda * k_inv.trace())
                    + k_inv * (2.0 * self.mu))
                    * coefficient
            }
            ZeroEnergyControl::Silling { coefficient } => {
                SMatrix::<f64, D, D>::identity()
                    * (coefficient * self.bond_micromodulus(i) / self.horizons.at(i))
            }
            ZeroEnergyControl::None => SMatrix::zeros(),
        }
    }

    /// (B, H) of a node from its K⁻¹, C1 and N = Σ ω η⊗ξ w: H = N K⁻¹, F = I + H, P = F S
    /// (Eq. 9), A = P K⁻¹ (Eq. 8), B = A − C1 H; `None` when F is singular (detached).
    fn deformed<const D: usize>(
        &self,
        k_inv: &SMatrix<f64, D, D>,
        c1: &SMatrix<f64, D, D>,
        n: &SMatrix<f64, D, D>,
    ) -> Option<(SMatrix<f64, D, D>, SMatrix<f64, D, D>)> {
        let h = n * k_inv;
        let f = h + SMatrix::<f64, D, D>::identity();
        let j = determinant(&f);
        if j == 0.0 || !j.is_finite() {
            return None;
        }
        // P = J σ F⁻ᵀ with σ = J⁻¹ F S Fᵀ, S = C:E: P = F S (see the module notes).
        let p = f * self.stress(&Self::strain(&h));
        let a = p * k_inv;
        let b = match self.control {
            ZeroEnergyControl::None => a,
            _ => a - c1 * h,
        };
        Some((b, h))
    }

    /// Node i's force state on a bond seen from i (ξ, Y), times ω (the weights φ μ are
    /// applied by the caller): ω (A ξ + C1 z) with z = Y − F ξ = η − H ξ (Eq. 14), written
    /// ω (B ξ + C1 η) with B = A − C1 H and η = Y − ξ; C1 is the node's stabilisation tensor
    /// (Wan's G C:K⁻¹ or Silling's G c_s I; zero without control). A detached node has B and
    /// C1 zero.
    #[inline(always)]
    fn half<const D: usize>(
        &self,
        i: usize,
        p: &CorrespondencePoint<D>,
        xi: &Vector<D>,
        y: &Vector<D>,
        ref_len: f64,
    ) -> Vector<D> {
        self.linear_half(p, xi, &(y - xi)) * self.omega(i, ref_len)
    }

    /// B ξ + C1 η (the C1 term only with zero-energy control).
    #[inline(always)]
    fn linear_half<const D: usize>(
        &self,
        p: &CorrespondencePoint<D>,
        xi: &Vector<D>,
        eta: &Vector<D>,
    ) -> Vector<D> {
        match self.control {
            ZeroEnergyControl::None => p.b * xi,
            _ => p.b * xi + p.c1 * eta,
        }
    }

    /// The constants of the split-work kernel from node i's point state and its matrices at
    /// the previous evaluation (`node_matrices`): ½ (B + B') column-major, and ½ C1 and
    /// ½ C1' as lower triangles (the order of `simd_correspondence::lower`).
    fn work_matrices<const D: usize>(
        p: &CorrespondencePoint<D>,
        previous: &[f64],
    ) -> ([f64; 9], [f64; 6], [f64; 6]) {
        let (b, c1) = (p.b.as_slice(), p.c1.as_slice());
        let mut mean_b = [0.0; 9];
        for k in 0..D * D {
            mean_b[k] = (b[k] + previous[k]) * 0.5;
        }
        let (mut half, mut half_prev) = ([0.0; 6], [0.0; 6]);
        for (e, (r, c)) in simd_correspondence::lower::<D>().enumerate() {
            half[e] = 0.5 * c1[D * c + r];
            half_prev[e] = 0.5 * previous[D * D + D * c + r];
        }
        (mean_b, half, half_prev)
    }

    /// Non-uniform deformation state z = Y − F ξ (Eq. 14), as (Y − ξ) − H ξ.
    #[inline(always)]
    fn z<const D: usize>(p: &CorrespondencePoint<D>, xi: &Vector<D>, y: &Vector<D>) -> Vector<D> {
        (y - xi) - p.h * xi
    }

    /// Node i's moment record (`simd_correspondence::moment_*`) from its point state and
    /// the version of its C1: B, g = B x̂ + C1 u, u, with x̂ = x − o and u = y − x.
    fn moment_record<const D: usize>(
        &self,
        i: usize,
        p: &CorrespondencePoint<D>,
        version: f64,
    ) -> [f64; MOMENT_WORDS] {
        use simd_correspondence::{moment_g, moment_u, moment_version};
        let u = p.y - p.x;
        let g = p.b * self.x_hat::<D>(i) + p.c1 * u;
        let mut m = [0.0; MOMENT_WORDS];
        m[..D * D].copy_from_slice(p.b.as_slice());
        m[moment_g(D)..moment_g(D) + D].copy_from_slice(g.as_slice());
        m[moment_u(D)..moment_u(D) + D].copy_from_slice(u.as_slice());
        m[moment_version(D)] = version;
        m
    }

    /// The reference positions `setup` kept, as vectors.
    fn reference_points<const D: usize>(&self) -> Vec<Vector<D>> {
        self.reference
            .chunks_exact(D)
            .map(Vector::<D>::from_column_slice)
            .collect()
    }

    /// Node i's reference position less the origin o, x̂ = x − o.
    fn x_hat<const D: usize>(&self, i: usize) -> Vector<D> {
        Vector::<D>::from_fn(|a, _| self.reference[D * i + a] - self.origin[a])
    }

    /// Node i's memo (`StabilisationMemo`): W = Σ s C1_j over its bonds that carry force
    /// (intact, |y| > 0, as the pre-pass decided), its own C1 and S = Σ s.
    fn stabilisation_sums<const D: usize>(
        &self,
        nb: &mut NodeBonds,
        law: &CorrespondenceLaw,
        w: &UniformWeights,
        points: &[CorrespondencePoint<D>],
    ) -> [f64; MEMO_WORDS] {
        let mut memo = [0.0; MEMO_WORDS];
        tail(nb, 0, |_, j, l, _, _| {
            let s = law.omega(l) * (w.phi(l) * w.node.volume);
            for (e, (r, c)) in lower::<D>().enumerate() {
                memo[e] += s * points[j].c1[(r, c)];
            }
            memo[MEMO_SUM] += s;
        });
        for (e, (r, c)) in lower::<D>().enumerate() {
            memo[MEMO_C1 + e] = points[nb.i].c1[(r, c)];
        }
        memo
    }

    /// Node i's force density, Σ_j (T_i⟨ξ⟩ − T_j⟨−ξ⟩) V_j with T = ω (B ξ + C1 η) (seed 004
    /// Eqs. 8 and 12–14, see `half`), from the moment sums M = Σ s m_j over its bonds
    /// (`correspondence_moments`), its memo and its own record, with ξ = x̂_j − x̂_i and
    /// η = u_j − u_i: the other halves Σ s (B_j ξ + C1_j η) = Σ s g_j − (Σ s B_j) x̂_i − W u_i
    /// and its own halves B_i Σ s ξ + C1_i Σ s η with Σ s η = Σ s u_j − S u_i.
    ///
    /// The same sums as the bond-by-bond loop's, regrouped: the round-off of the other
    /// halves grows from ε |B| |ξ| to ε |B| |x − o| per bond term, by the body's half-size
    /// over the horizon (10⁻¹³ of a bond's force at 1000 horizons across).
    fn moment_force<const D: usize>(
        &self,
        i: usize,
        m: &[f64; MOMENT_WORDS],
        memo: &[f64; MEMO_WORDS],
        pi: &CorrespondencePoint<D>,
    ) -> Vector<D> {
        use simd_correspondence::{moment_g, moment_u};
        let at = |m: &[f64], k: usize| Vector::<D>::from_column_slice(&m[k..k + D]);
        let u = at(&pi.moments, moment_u(D));
        let (w, c1) = (
            symmetric::<D>(&memo[..MEMO_C1]),
            symmetric::<D>(&memo[MEMO_C1..MEMO_SUM]),
        );
        let sum_b = SMatrix::<f64, D, D>::from_column_slice(&m[..D * D]);
        let other = at(m, moment_g(D)) - sum_b * self.x_hat::<D>(i) - w * u;
        let sum_eta = at(m, moment_u(D)) - u * memo[MEMO_SUM];
        let b = SMatrix::<f64, D, D>::from_column_slice(&pi.moments[..D * D]);
        other + b * at(&pi.shape_xi, 0) + c1 * sum_eta
    }

    /// The set-up check: with every bond intact, the shape tensor of each node that
    /// satisfies `member` must be invertible; the first that is not is named.
    pub fn check_shape_tensors<const D: usize>(
        &self,
        body: &Body<D>,
        bonds: &Bonds,
        quad: &Quadrature,
        member: impl Fn(usize) -> bool,
    ) -> Result<(), PointError> {
        for i in (0..body.len()).filter(|&i| member(i)) {
            let mut k = SMatrix::<f64, D, D>::zeros();
            for b in bonds.family(i) {
                let j = bonds.neighbors[b] as usize;
                let l = bonds.ref_lengths[b];
                let xi = body.positions[j] - body.positions[i];
                k += xi
                    * xi.transpose()
                    * (self.omega(i, l) * quad.phi_pair(b, i, j, l).0 * body.volumes[j]);
            }
            if Self::singular(&k) {
                return Err(PointError {
                    node: i,
                    position: body.positions[i].iter().cloned().collect(),
                    reason: format!(
                        "its shape tensor K is singular with {} bonds (the correspondence model needs bonds in {D} independent directions); raise the horizon ratio δ/Δx or check the discretization around this node",
                        bonds.family(i).len()
                    ),
                });
            }
        }
        Ok(())
    }
}

impl<const D: usize> Material<D> for Correspondence {
    type Point = CorrespondencePoint<D>;
    const NEEDS_PREPASS: bool = true;
    const CENTRAL: bool = false;
    const NEEDS_XI: bool = true;
    const FACTORED_OWN_HALF: bool = true;
    const NODE_MATRIX_WORDS: usize = 2 * D * D;
    const NODE_BYTES: usize = super::stabilisation_memo::SLOT_BYTES;

    /// Checks every owned node's shape tensor with all bonds intact (a ghost's row is
    /// empty: its owner checks it).
    fn setup(
        &mut self,
        body: &Body<D>,
        bonds: &Bonds,
        quad: &Quadrature,
        owned: usize,
    ) -> Result<(), PointError> {
        self.reference = body
            .positions
            .iter()
            .flat_map(|x| x.iter().copied())
            .collect();
        self.origin = std::array::from_fn(|a| {
            if a < D {
                extent_middle(&body.positions, a)
            } else {
                0.0
            }
        });
        self.memo = StabilisationMemo::new(body.len());
        self.check_shape_tensors(body, bonds, quad, |i| i < owned)
    }

    /// The origin o is the middle of the whole body's extent, as one process takes it: a
    /// rank's positions (its owned nodes and ghosts) lie inside it, so the smallest and
    /// largest coordinate over the ranks are the whole body's.
    fn share_constants(&mut self, share: &Share) {
        let ranks = &*share.ranks;
        let points = self.reference_points::<D>();
        for (a, origin) in self.origin.iter_mut().enumerate().take(D) {
            let [lo, hi] = crate::math::extent(&points, a);
            let (lo, hi) = (ranks.min_f64(lo), ranks.max_f64(hi));
            *origin = if lo <= hi { 0.5 * (lo + hi) } else { 0.0 };
        }
    }

    /// What a bond's other half reads of its neighbour j, which a distributed run sends
    /// from j's owner in every evaluation: B and C1 (the generic loops' `other_half` and
    /// `pair_force`, the stabilisation sums of the vector force pass) and the moment record
    /// (B, g, u and the version of C1: the vector force pass). K⁻¹, H and Σ s ξ are read by
    /// j's own passes only.
    const HALO_WORDS: usize = 2 * D * D + simd_correspondence::moment_words(D);

    #[inline(always)]
    fn point_words(p: &Self::Point, out: &mut Vec<f64>) {
        out.extend_from_slice(p.b.as_slice());
        out.extend_from_slice(p.c1.as_slice());
        out.extend_from_slice(&p.moments[..simd_correspondence::moment_words(D)]);
    }

    #[inline(always)]
    fn point_from_words(p: &mut Self::Point, words: &[f64]) {
        let (b, rest) = words.split_at(D * D);
        let (c1, moments) = rest.split_at(D * D);
        p.b = SMatrix::from_column_slice(b);
        p.c1 = SMatrix::from_column_slice(c1);
        p.moments[..moments.len()].copy_from_slice(moments);
    }

    /// K += ω ξ⊗ξ w (Eq. 7) and N += ω η⊗ξ w (η = Y − ξ; Eq. 6 less K), kept in `b` and `h`
    /// until `finish_point`.
    #[inline(always)]
    fn accumulate(&self, i: usize, acc: &mut Self::Point, b: &BondGeom<D>) {
        let w = self.omega(i, b.ref_len) * b.weight();
        let xt = b.xi.transpose();
        acc.b += (b.xi * w) * xt;
        acc.h += ((b.y - b.xi) * w) * xt;
    }

    /// K⁻¹ (`shape_inverse`), C1 (`stabilisation`) and B, H (`deformed`); a detached node gets
    /// the zero point state.
    fn finish_point(&self, i: usize, acc: Self::Point) -> Self::Point {
        let detached = CorrespondencePoint::default();
        let Some(k_inv) = Self::shape_inverse(&acc.b) else {
            return detached;
        };
        let c1 = self.stabilisation(i, &k_inv);
        let Some((b, h)) = self.deformed(&k_inv, &c1, &acc.h) else {
            return detached;
        };
        CorrespondencePoint {
            b,
            c1,
            h,
            ..Default::default()
        }
    }

    fn force_state(&self, i: usize, b: &BondGeom<D>, p: &Self::Point) -> f64 {
        Material::<D>::force_state_vector(self, i, b, p).dot(&b.y) / b.len
    }

    #[inline(always)]
    fn force_state_vector(&self, i: usize, b: &BondGeom<D>, p: &Self::Point) -> Vector<D> {
        self.half(i, p, &b.xi, &b.y, b.ref_len)
    }

    /// T_i⟨ξ⟩ φ_ij μ_ij − T_j⟨−ξ⟩ φ_ji μ_ji, each half evaluated from its own node's side, so
    /// that the value from j's side is the exact negation.
    #[inline(always)]
    fn pair_force(
        &self,
        i: usize,
        j: usize,
        b: &BondGeom<D>,
        pi: &Self::Point,
        pj: &Self::Point,
    ) -> Vector<D> {
        let (nxi, ny) = (-b.xi, -b.y);
        self.half(i, pi, &b.xi, &b.y, b.ref_len) * (b.phi_ij * b.mu_ij)
            - self.half(j, pj, &nxi, &ny, b.ref_len) * (b.phi_ji * b.mu_ji)
    }

    /// B and C1, column-major.
    #[inline(always)]
    fn node_matrices(&self, pi: &Self::Point, out: &mut [f64]) {
        out[..D * D].copy_from_slice(pi.b.as_slice());
        out[D * D..2 * D * D].copy_from_slice(pi.c1.as_slice());
    }

    /// ½ (T_prev + T)·Δη = ω φ_ij (½ (B_i + B'_i) ξ + ½ (C1_i η + C1'_i η'))·Δη, with B'_i,
    /// C1'_i node i's matrices at the previous evaluation and η' = η − Δη (the
    /// trapezoidal rule of `damage::critical_energy` on node i's half: T linear in ξ, η).
    #[inline(always)]
    fn own_half_work(
        &self,
        i: usize,
        b: &BondGeom<D>,
        pi: &Self::Point,
        previous: &[f64],
        step: &Vector<D>,
    ) -> f64 {
        let b_prev = SMatrix::<f64, D, D>::from_column_slice(&previous[..D * D]);
        let c1_prev = SMatrix::<f64, D, D>::from_column_slice(&previous[D * D..2 * D * D]);
        let eta = b.y - b.xi;
        let eta_prev = eta - step;
        let mean = ((pi.b + b_prev) * 0.5) * b.xi + (pi.c1 * eta + c1_prev * eta_prev) * 0.5;
        self.omega(i, b.ref_len) * b.phi_ij * mean.dot(step)
    }

    /// ω_i φ_ij μ_ij V_j: node i's half of the pair force is this times B_i ξ + C1_i η.
    #[inline(always)]
    fn own_half_weight(&self, i: usize, b: &BondGeom<D>) -> f64 {
        self.omega(i, b.ref_len) * b.weight()
    }

    /// −T_j⟨−ξ⟩ φ_ji μ_ji V_j = ω_j φ_ji μ_ji V_j (B_j ξ + C1_j η), since node j sees the bond
    /// as (−ξ, −η).
    #[inline(always)]
    fn other_half(&self, _i: usize, j: usize, b: &BondGeom<D>, pj: &Self::Point) -> Vector<D> {
        let s = self.omega(j, b.ref_len) * (b.phi_ji * b.mu_ji * b.vol_j);
        self.linear_half(pj, &b.xi, &(b.y - b.xi)) * s
    }

    /// Σ_j s_ij (B_i ξ + C1_i η) = B_i Σ s ξ + C1_i Σ s η.
    #[inline(always)]
    fn own_half_force(
        &self,
        _i: usize,
        pi: &Self::Point,
        sum_xi: &Vector<D>,
        sum_eta: &Vector<D>,
    ) -> Vector<D> {
        self.linear_half(pi, sum_xi, sum_eta)
    }

    /// N on four bonds at a time (`simd_correspondence`) and the node's B and H (`deformed`),
    /// written over its previous point state; K, K⁻¹, C1 and Σ s ξ too unless the family
    /// carries force through exactly the bonds (`kept`) they were computed for, and then C1
    /// takes a new version (`StabilisationMemo`). Then the moment record, and with split
    /// work (`nb.work` with node i's previous matrices `nb.matrices`) each entry's own half
    /// of the work (`own_half_work`), returning the number of entries that may fail in place
    /// of the bonds broken.
    unsafe fn vector_prepass(
        &self,
        nb: &mut NodeBonds,
        w: &UniformWeights,
        point: &mut Self::Point,
    ) -> Option<u64> {
        // Under a critical-energy law (`nb.work`) the pre-pass reads only the bond status.
        let law = self.kernel_law::<D>(nb.current.len() / D)?;
        // Split work reads the previous positions, one work word per bond, node i's
        // matrices at the previous evaluation and what the sums hand on in `scratch`. The
        // engine gives them to every node or none: a node left to the generic pre-pass
        // would have no moment record for the force kernel, so a mismatch is a bug.
        let split = nb.work.is_some() && !nb.matrices.is_empty();
        assert!(
            !split
                || (nb.previous.len() == nb.current.len()
                    && nb.history.len() == nb.neighbors.len()
                    && nb.matrices.len() == 2 * D * D
                    && nb.scratch.is_some()
                    && nb.s0.is_none()),
            "split work of node {} without its inputs",
            nb.i
        );
        let family = nb.neighbors.len();
        // A family too large for `kept` sums K with N in one pass, as it cannot reuse it.
        let large = family > simd_correspondence::KEPT_BITS;
        // SAFETY: forwarded from the caller (with FMA, checked by `kernel_law`); `reference`
        // has one position per node.
        let sums = unsafe { simd_correspondence::correspondence_sums(nb, &law, w, large) };
        let (i, family) = (nb.i, family as u64);
        let vector = |v: &[f64]| SVector::<f64, D>::from_fn(|a, _| v[a]);
        // The positions (u of the moment record), a detached node's too.
        point.y = vector(&nb.current[D * i..]);
        point.x = vector(&self.reference[D * i..]);
        // A detached node: no force state, nothing kept to reuse (its C1 is zero), its
        // positions still read by its neighbours.
        let detach = |p: &mut CorrespondencePoint<D>| {
            *p = CorrespondencePoint {
                y: p.y,
                x: p.x,
                ..Default::default()
            }
        };
        let reuse =
            matches!(sums.kept, Some(kept) if point.kept_of == family && point.kept == kept);
        let version = point.moments[simd_correspondence::moment_version(D)];
        // Whether C1 changed (a new K, or detached): then it takes a new version.
        let changed = 'update: {
            if !reuse {
                let again;
                let (k, sum_xi) = if large {
                    (&sums.k, &sums.sum_xi)
                } else {
                    // The status is now decided: this pass breaks nothing and sums the same N.
                    let s0 = nb.s0.take();
                    // SAFETY: as above.
                    again = unsafe { simd_correspondence::correspondence_sums(nb, &law, w, true) };
                    nb.s0 = s0;
                    (&again.k, &again.sum_xi)
                };
                let Some(k_inv) = Self::shape_inverse(&SMatrix::from_column_slice(&k[..D * D]))
                else {
                    detach(point);
                    break 'update true;
                };
                point.shape_inverse = k_inv;
                point.c1 = self.stabilisation(i, &k_inv);
                point.shape_xi = *sum_xi;
                point.kept = sums.kept.unwrap_or_default();
                point.kept_of = if sums.kept.is_some() { family } else { 0 };
            }
            match self.deformed(
                &point.shape_inverse,
                &point.c1,
                &SMatrix::from_column_slice(&sums.n[..D * D]),
            ) {
                Some((b, h)) => {
                    (point.b, point.h) = (b, h);
                    !reuse
                }
                None => {
                    detach(point);
                    true
                }
            }
        };
        let version = if changed {
            self.memo.next_version()
        } else {
            version
        };
        point.moments = self.moment_record(i, point, version);
        match nb.work {
            Some(energy) if split => {
                debug_assert_eq!(sums.broke, 0, "a critical energy breaks nothing here");
                let (mean_b, half_c1, half_c1_prev) = Self::work_matrices::<D>(point, nb.matrices);
                // SAFETY: forwarded from the caller; the previous positions and the work
                // words checked above.
                Some(unsafe {
                    simd_correspondence::correspondence_own_work(
                        nb,
                        &law,
                        w,
                        &energy,
                        &mean_b,
                        [&half_c1, &half_c1_prev],
                    )
                })
            }
            _ => Some(sums.broke),
        }
    }

    /// The neighbours' moment records summed on four bonds at a time, the memo of the C1 sums
    /// (summed again when a version changed), then `moment_force`: the engine's factored loop
    /// with the other halves regrouped. Not under a critical energy: the split work is the
    /// pre-pass's (`vector_prepass`), and the pair record of the work has no kernel.
    unsafe fn vector_force(
        &self,
        nb: &mut NodeBonds,
        w: &UniformWeights,
        points: &[Self::Point],
    ) -> Option<([f64; 3], u64)> {
        if nb.work.is_some() {
            return None;
        }
        let law = self.kernel_law::<D>(points.len())?;
        let stride = std::mem::size_of::<Self::Point>() / std::mem::size_of::<f64>();
        // SAFETY: `CorrespondencePoint` is `repr(C)` of f64 and u64 fields only (no padding),
        // its moment record where `simd_correspondence::record_moments` says (checked at
        // compile time).
        let flat = unsafe {
            std::slice::from_raw_parts(points.as_ptr() as *const f64, points.len() * stride)
        };
        let (i, pi) = (nb.i, &points[nb.i]);
        // What only the next node's own force pass reads: a line of its record, its memo.
        if let Some(next) = points.get(i + 1) {
            super::simd::prefetch(&next.kept);
            self.memo.prefetch(i + 1);
        }
        // The bonds that carry force, as the pre-pass found them, when it kept them.
        let kept = (pi.kept_of == nb.neighbors.len() as u64).then_some(&pi.kept);
        // SAFETY: forwarded from the caller; the points are this evaluation's, from
        // `vector_prepass` (which runs whenever this does: the same `kernel_law`), and
        // `kept` is its set of bonds.
        let (m, versions) =
            unsafe { simd_correspondence::correspondence_moments(nb, &law, w, flat, stride, kept) };
        let key = [versions, pi.moments[simd_correspondence::moment_version(D)]];
        let memo = match self.memo.get(i, key) {
            Some(memo) => memo,
            None => {
                let memo = self.stabilisation_sums::<D>(nb, &law, w, points);
                self.memo.set(i, key, &memo);
                memo
            }
        };
        let f = self.moment_force::<D>(i, &m, &memo, pi);
        Some((std::array::from_fn(|a| if a < D { f[a] } else { 0.0 }), 0))
    }

    /// The stabilisation energy of the bond, ½ ω z·C1 z w: its gradient is exactly T^S
    /// because Σ ω z⊗ξ w = 0 by the definition of F (Wan's and Silling's forms alike).
    fn bond_energy(&self, i: usize, b: &BondGeom<D>, p: &Self::Point) -> f64 {
        if self.control == ZeroEnergyControl::None {
            return 0.0;
        }
        // A detached node has C1 = 0: no energy.
        let z = Self::z(p, &b.xi, &b.y);
        0.5 * self.omega(i, b.ref_len) * z.dot(&(p.c1 * z)) * b.weight()
    }

    /// W = ½ E:C:E of the node's F (exact for P = F C:E), plus the stabilisation energy of its
    /// bonds (zero for a detached node, whose H and C1 are zero).
    fn point_energy(&self, _i: usize, p: &Self::Point, bond_sum: f64) -> f64 {
        let e = Self::strain(&p.h);
        0.5 * self.stress(&e).dot(&e) + bond_sum
    }

    /// The bond-based equivalent of the P-wave modulus, as for LPS.
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
