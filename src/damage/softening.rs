//! Bilinear and trilinear softening bonds (seed 001 §4.1 and §4.3): the bond force rises
//! with slope c up to c·s1, then falls linearly to zero at the breaking stretch (bilinear),
//! or in two linear pieces through β·c·s1 at s2 (trilinear). Written as a damage law on a
//! bond-based material: a half keeps the fraction μ = g(s_max)/s_max of its elastic force,
//! with g the force envelope in stretch units and s_max the largest stretch the bond has
//! seen (its history, 8 bytes per bond).
//!
//! Unloading (the paper leaves it open, seed 001 notes §2.5): from a point on the softening
//! branch the bond unloads and reloads along the secant to the origin, f = c s g(s_max)/s_max,
//! as in Yang et al. 2018 (the paper's ref. [14]); in compression the same reduced stiffness
//! holds. The bond breaks, irreversibly, when s_max reaches the breaking stretch.

use super::{DamageLaw, PerNode, Stretch};
use crate::dimensionality::Dimensionality;

/// The shape of the force envelope beyond the peak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Linear from c·s1 at s1 to zero at sc.
    Bilinear,
    /// Through β·c·s1 at s2, to zero at ŝc (seed 001 Eq. 20 and notes §2.6).
    Trilinear { beta: f64 },
}

/// Softening parameters per node (uniform for one material and horizon).
#[derive(Debug, Clone)]
pub struct Softening {
    pub shape: Shape,
    /// Stretch at the peak force.
    pub s1: PerNode,
    /// Trilinear: stretch at the kink (unused for bilinear).
    pub s2: PerNode,
    /// Breaking stretch: sc (bilinear) or ŝc (trilinear).
    pub sc: PerNode,
}

/// Calibrated softening parameters of one material and horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SofteningParameters {
    pub s1: f64,
    pub s2: f64,
    pub sc: f64,
}

/// Why a softening calibration is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SofteningError {
    #[error("the breaking stretch sc = {sc:.4e} is not above the peak stretch s1 = {s1:.4e}: the horizon δ = {horizon:.4e} m exceeds the bound δ < {bound:.4e} m of seed 001, Eq. 17 ({formula}); use a smaller horizon, a lower tensile strength or a higher fracture energy")]
    HorizonTooLarge {
        s1: f64,
        sc: f64,
        horizon: f64,
        bound: f64,
        formula: &'static str,
    },
    #[error("the softening parameters need 0 < s1 < sc, found s1 = {s1:.4e}, sc = {sc:.4e}")]
    Order { s1: f64, sc: f64 },
    #[error(
        "trilinear β = {beta} and γ = {gamma} must satisfy 0 < β < 1 and γ > 1 (seed 001 §4.3)"
    )]
    Trilinear { beta: f64, gamma: f64 },
}

impl SofteningParameters {
    /// Peak stretch from the tensile strength (seed 001, Eqs. 13–15): σu is the PD stress
    /// across a plane when every bond crossing it carries its peak force c s1. With the
    /// micromodulus profile's moments M_k = ∫_0^δ g ξ^k dξ this is σu = (2π/3) c0 s1 M3 in 3D
    /// and σu = (π/2) c0 s1 M2 in 2D (c0 per unit thickness); for the constant profile
    /// s1 = σu/(2E), 2σu/(3E) (plane stress), 5σu/(8E) (plane strain), Eq. 15.
    pub fn peak_stretch(sigma_u: f64, c0_paper: f64, m2: f64, m3: f64, dim: Dimensionality) -> f64 {
        match dim {
            Dimensionality::ThreeD => sigma_u / (2.0 * std::f64::consts::PI / 3.0 * c0_paper * m3),
            _ => sigma_u / (std::f64::consts::PI / 2.0 * c0_paper * m2),
        }
    }

    /// Bilinear law from σu and G0 (seed 001, Eqs. 12, 15, 16): s1 from σu, and s1·sc = s0²,
    /// s0 the PMB critical stretch for the same G0 and δ (equal areas under the curves).
    /// Refuses sc ≤ s1 naming the Eq. 17 bound on the horizon.
    pub fn bilinear_from_strength(
        s1: f64,
        s0: f64,
        horizon: f64,
        dim: Dimensionality,
    ) -> Result<Self, SofteningError> {
        let sc = s0 * s0 / s1;
        if sc <= s1 {
            // sc/s1 ∝ 1/δ: the bound is where sc = s1.
            let formula = match dim {
                Dimensionality::ThreeD => "δ < 10 E G0 / (3 σu²) in 3D",
                Dimensionality::PlaneStress => "δ < π E G0 / σu² in plane stress",
                Dimensionality::PlaneStrain => "δ < 16π E G0 / (15 σu²) in plane strain",
            };
            return Err(SofteningError::HorizonTooLarge {
                s1,
                sc,
                horizon,
                bound: horizon * sc / s1,
                formula,
            });
        }
        Ok(SofteningParameters { s1, s2: sc, sc })
    }

    /// Parameters given directly.
    pub fn bilinear(s1: f64, sc: f64) -> Result<Self, SofteningError> {
        if !(s1 > 0.0 && sc > s1) {
            return Err(SofteningError::Order { s1, sc });
        }
        Ok(SofteningParameters { s1, s2: sc, sc })
    }

    /// Trilinear law with the same fracture energy as the bilinear one (seed 001, Eq. 20):
    /// s2 = (sc + βγ s1)/(1 + βγ), ŝc = s1 + γ (s2 − s1).
    pub fn trilinear(bilinear: Self, beta: f64, gamma: f64) -> Result<Self, SofteningError> {
        if !(beta > 0.0 && beta < 1.0 && gamma > 1.0) {
            return Err(SofteningError::Trilinear { beta, gamma });
        }
        let (s1, sc) = (bilinear.s1, bilinear.sc);
        let s2 = (sc + beta * gamma * s1) / (1.0 + beta * gamma);
        Ok(SofteningParameters {
            s1,
            s2,
            sc: s1 + gamma * (s2 - s1),
        })
    }

    /// The generic concrete values of Yang et al. (seed 001 §4.3): β = 1/4, γ = 28/3.
    pub const GENERIC_BETA: f64 = 0.25;
    pub const GENERIC_GAMMA: f64 = 28.0 / 3.0;
}

impl Softening {
    pub fn uniform(shape: Shape, p: SofteningParameters) -> Self {
        Softening {
            shape,
            s1: PerNode::Uniform(p.s1),
            s2: PerNode::Uniform(p.s2),
            sc: PerNode::Uniform(p.sc),
        }
    }

    pub fn name(&self) -> &'static str {
        match self.shape {
            Shape::Bilinear => "bilinear softening",
            Shape::Trilinear { .. } => "trilinear softening",
        }
    }

    /// Force envelope g(s) in stretch units (force = c·g), for s ≥ 0.
    #[inline(always)]
    pub fn envelope(&self, node: usize, s: f64) -> f64 {
        self.at(node).envelope(s)
    }

    /// The parameters of node i's half.
    #[inline(always)]
    pub fn at(&self, node: usize) -> UniformSoftening {
        UniformSoftening {
            shape: self.shape,
            s1: self.s1.at(node),
            s2: self.s2.at(node),
            sc: self.sc.at(node),
        }
    }

    /// The one-parameter-set form, if every node has the same parameters.
    pub fn uniform_form(&self) -> Option<UniformSoftening> {
        Some(UniformSoftening {
            shape: self.shape,
            s1: self.s1.uniform()?,
            s2: self.s2.uniform()?,
            sc: self.sc.uniform()?,
        })
    }
}

/// A softening law with one set of parameters for every node: both halves soften and break
/// together, and μ is computed once per bond. The engine runs this form when it can.
#[derive(Debug, Clone, Copy)]
pub struct UniformSoftening {
    pub shape: Shape,
    pub s1: f64,
    pub s2: f64,
    pub sc: f64,
}

impl UniformSoftening {
    /// Force envelope g(s) in stretch units (force = c·g), for s ≥ 0.
    #[inline(always)]
    pub fn envelope(&self, s: f64) -> f64 {
        let (s1, sc) = (self.s1, self.sc);
        if s <= s1 {
            return s;
        }
        if s >= sc {
            return 0.0;
        }
        match self.shape {
            Shape::Bilinear => s1 * (sc - s) / (sc - s1),
            Shape::Trilinear { beta } => {
                let s2 = self.s2;
                if s <= s2 {
                    s1 * (1.0 - (1.0 - beta) * (s - s1) / (s2 - s1))
                } else {
                    beta * s1 * (sc - s) / (sc - s2)
                }
            }
        }
    }

    /// G(s) = ∫₀ˢ g: the work per unit c done on the bond up to stretch s, along the envelope.
    pub fn work(&self, s: f64) -> f64 {
        let (s1, s2, sc) = (self.s1, self.s2, self.sc);
        let s = s.min(sc);
        if s <= s1 {
            return 0.5 * s * s;
        }
        // The area under a line from (a, g(a)) to (s, g(s)).
        let trapezoid = |a: f64| 0.5 * (self.envelope(a) + self.envelope(s)) * (s - a);
        match self.shape {
            Shape::Bilinear => 0.5 * s1 * s1 + trapezoid(s1),
            Shape::Trilinear { .. } if s <= s2 => 0.5 * s1 * s1 + trapezoid(s1),
            Shape::Trilinear { beta } => {
                0.5 * s1 * s1 + 0.5 * (1.0 + beta) * s1 * (s2 - s1) + trapezoid(s2)
            }
        }
    }

    /// The energy a bond loaded to s_max has dissipated, over the energy ½ c s² of an intact
    /// bond at s = min(s_max, sc): the work G(s) less what unloading along the secant gives
    /// back, ½ g(s) s (seed 001 §4.1; the secant is the unloading path). 0 before the peak;
    /// 2G(sc)/sc² once broken, the whole area under the envelope.
    pub fn dissipated_fraction(&self, s_max: f64) -> f64 {
        let s = s_max.min(self.sc);
        if s <= self.s1 {
            return 0.0;
        }
        (2.0 * self.work(s) - self.envelope(s) * s) / (s * s)
    }

    /// μ = g(s_max)/s_max beyond the peak (the secant to the origin), 1 before it.
    #[inline(always)]
    pub fn secant(&self, s_max: f64) -> f64 {
        if s_max <= self.s1 {
            1.0
        } else {
            self.envelope(s_max) / s_max
        }
    }
}

impl DamageLaw for UniformSoftening {
    const HISTORY: usize = 1;
    const ON_STRETCH: bool = true;
    const PARTIAL: bool = true;
    const HALVES_TOGETHER: bool = true;

    fn uniform_softening(&self) -> Option<UniformSoftening> {
        Some(*self)
    }

    #[inline(always)]
    fn record_stretch(&self, st: Stretch, h: &mut [f64]) {
        record_largest(st, h);
    }

    #[inline(always)]
    fn fails_on_stretch(&self, _node: usize, _: Stretch, h: &[f64]) -> bool {
        h[0] >= self.sc
    }

    /// Both halves share the secant: computed once.
    #[inline(always)]
    fn factors(&self, _i: usize, _j: usize, h: &[f64], _status: u8) -> (f64, f64) {
        let mu = self.secant(h[0]);
        (mu, mu)
    }

    /// Only a new largest stretch costs a division; a bond with a no-fail end is recorded up
    /// to the peak stretch only, so it stays elastic and never breaks.
    #[inline(always)]
    fn on_stretch(
        &self,
        _i: usize,
        _j: usize,
        st: Stretch,
        protected: impl Fn() -> bool,
        h: &mut [f64],
        status: &mut u8,
    ) -> u64 {
        if st.exceeds(h[0]) {
            let s = st.s();
            if s > self.s1 && protected() {
                return 0;
            }
            h[0] = s;
            if s >= self.sc {
                *status = super::BROKEN;
                return 1;
            }
        }
        0
    }
}

/// The history of a softening bond: the largest stretch it has seen.
#[inline(always)]
pub fn record_largest(st: Stretch, h: &mut [f64]) {
    let s = st.s();
    if s > h[0] {
        h[0] = s;
    }
}

impl DamageLaw for Softening {
    const HISTORY: usize = 1;
    const ON_STRETCH: bool = true;
    const PARTIAL: bool = true;

    #[inline(always)]
    fn record_stretch(&self, st: Stretch, h: &mut [f64]) {
        record_largest(st, h);
    }

    #[inline(always)]
    fn fails_on_stretch(&self, node: usize, _: Stretch, h: &[f64]) -> bool {
        h[0] >= self.sc.at(node)
    }

    /// μ = g(s_max)/s_max beyond the peak: the secant to the origin.
    #[inline(always)]
    fn factor(&self, node: usize, h: &[f64]) -> f64 {
        self.at(node).secant(h[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{MicromodulusProfile, Pmb};

    /// Seed 001 notes §7 test 1: Table 1 for E = 192 GPa, G0 = 83 kJ/m², plane stress.
    #[test]
    fn seed001_table1() {
        let (e, g0) = (192e9, 83e3);
        let dim = Dimensionality::PlaneStress;
        let profile = MicromodulusProfile::Constant;
        for (sigma_u, s1_paper, sc_paper) in [
            (0.576e9, 0.002, [0.1006, 0.2012, 0.4024, 0.8048]),
            (1.44e9, 0.005, [0.04024, 0.08048, 0.1610, 0.3219]),
        ] {
            for (k, delta) in [3e-3, 1.5e-3, 0.75e-3, 0.375e-3].into_iter().enumerate() {
                let c = Pmb::micromodulus(e, dim, profile, delta);
                let s1 = SofteningParameters::peak_stretch(
                    sigma_u,
                    c,
                    profile.moment(2, delta),
                    profile.moment(3, delta),
                    dim,
                );
                let s0 = Pmb::critical_stretch_from_g0(g0, c, dim, profile, delta);
                let p = SofteningParameters::bilinear_from_strength(s1, s0, delta, dim).unwrap();
                assert!((p.s1 / s1_paper - 1.0).abs() < 1e-12, "s1 {}", p.s1);
                assert!(
                    (p.sc / sc_paper[k] - 1.0).abs() < 2e-3,
                    "sc {} vs {}",
                    p.sc,
                    sc_paper[k]
                );
                assert!((p.s1 * p.sc / (s0 * s0) - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn eq15_in_3d_and_plane_strain() {
        let (e, su, d) = (30e9, 3e6, 1e-2);
        for (dim, expected) in [
            (Dimensionality::ThreeD, su / (2.0 * e)),
            (Dimensionality::PlaneStrain, 5.0 * su / (8.0 * e)),
        ] {
            let p = MicromodulusProfile::Constant;
            let c = Pmb::micromodulus(e, dim, p, d);
            let s1 = SofteningParameters::peak_stretch(su, c, p.moment(2, d), p.moment(3, d), dim);
            assert!((s1 / expected - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn horizon_bound_is_eq17() {
        // Plane stress: δ < π E G0 / σu².
        let (e, g0, su) = (192e9, 83e3, 1.44e9);
        let bound = std::f64::consts::PI * e * g0 / (su * su);
        let dim = Dimensionality::PlaneStress;
        let p = MicromodulusProfile::Constant;
        let delta = 1.2 * bound;
        let c = Pmb::micromodulus(e, dim, p, delta);
        let s1 =
            SofteningParameters::peak_stretch(su, c, p.moment(2, delta), p.moment(3, delta), dim);
        let s0 = Pmb::critical_stretch_from_g0(g0, c, dim, p, delta);
        match SofteningParameters::bilinear_from_strength(s1, s0, delta, dim) {
            Err(SofteningError::HorizonTooLarge { bound: b, .. }) => {
                assert!((b / bound - 1.0).abs() < 1e-9)
            }
            other => panic!("expected the Eq. 17 refusal, got {other:?}"),
        }
    }

    /// G(s) is the area under the envelope (midpoint rule), and a broken bond has dissipated
    /// all of it.
    #[test]
    fn work_is_the_area_under_the_envelope() {
        let bi = SofteningParameters::bilinear(0.002, 0.02).unwrap();
        let tri = SofteningParameters::trilinear(bi, 0.25, 28.0 / 3.0).unwrap();
        for (shape, p) in [
            (Shape::Bilinear, bi),
            (Shape::Trilinear { beta: 0.25 }, tri),
        ] {
            let law = Softening::uniform(shape, p).uniform_form().unwrap();
            for frac in [0.05, 0.1, 0.3, 0.5, 0.8, 1.0, 1.2] {
                let s = frac * p.sc;
                let n = 100_000;
                let h = s.min(p.sc) / n as f64;
                let area: f64 = (0..n).map(|k| law.envelope((k as f64 + 0.5) * h) * h).sum();
                assert!(
                    (law.work(s) / area - 1.0).abs() < 1e-6,
                    "{shape:?} at {frac}"
                );
            }
            assert_eq!(law.dissipated_fraction(0.9 * p.s1), 0.0);
            let broken = law.dissipated_fraction(2.0 * p.sc);
            assert!((broken * p.sc * p.sc / 2.0 / (0.5 * bi.s1 * bi.sc) - 1.0).abs() < 1e-12);
        }
    }

    /// Seed 001 notes §7 test 5: the trilinear curve encloses the bilinear area c s1 sc / 2.
    #[test]
    fn trilinear_has_the_bilinear_area() {
        let bi = SofteningParameters::bilinear(0.002, 0.1006).unwrap();
        for (beta, gamma) in [(0.25, 28.0 / 3.0), (0.29 / 2.27, 1.42 / 0.25)] {
            let tri = SofteningParameters::trilinear(bi, beta, gamma).unwrap();
            let law = Softening::uniform(Shape::Trilinear { beta }, tri);
            let n = 200_000;
            let area: f64 = (0..n)
                .map(|k| {
                    let s = (k as f64 + 0.5) * tri.sc / n as f64;
                    law.envelope(0, s) * tri.sc / n as f64
                })
                .sum();
            assert!(
                (area / (0.5 * bi.s1 * bi.sc) - 1.0).abs() < 1e-6,
                "area {area}"
            );
        }
        // Seed 001 notes §3.5: δ = 3 mm gives s2 = 0.03158, ŝc = 0.2781.
        let tri = SofteningParameters::trilinear(bi, 0.25, 28.0 / 3.0).unwrap();
        assert!((tri.s2 / 0.03158 - 1.0).abs() < 1e-3 && (tri.sc / 0.2781 - 1.0).abs() < 1e-3);
    }

    #[test]
    fn secant_unloading_and_irreversible_break() {
        let law = Softening::uniform(
            Shape::Bilinear,
            SofteningParameters::bilinear(0.01, 0.05).unwrap(),
        );
        let st = |s: f64| Stretch {
            len: 1.0 + s,
            ref_len: 1.0,
        };
        let mut h = [0.0];
        let mut status = 0u8;
        // Load to 0.03 (on the softening branch): g = 0.01·0.02/0.04 = 0.005.
        law.on_stretch(0, 1, st(0.03), || false, &mut h, &mut status);
        let (mu, _) = law.factors(0, 1, &h, status);
        assert!((mu * 0.03 - 0.005).abs() < 1e-15);
        // Unload to 0.015: secant force c·0.015·μ, history unchanged.
        let peak = h[0];
        law.on_stretch(0, 1, st(0.015), || false, &mut h, &mut status);
        assert_eq!(h[0], peak);
        assert_eq!(law.factors(0, 1, &h, status).0, mu);
        // Beyond sc: broken, and stays broken on unloading.
        assert_eq!(
            law.on_stretch(0, 1, st(0.06), || false, &mut h, &mut status),
            1
        );
        law.on_stretch(0, 1, st(0.0), || false, &mut h, &mut status);
        assert_eq!(status, super::super::BROKEN);
    }
}
