//! Crack speed from a tip history, and the Rayleigh wave speed that bounds it.
//!
//! The speed is a forward difference over a window of `w` samples (seed 000 Appendix 2 with
//! w = 30 samples; seed 002 §2.12 samples every 100 steps and differences consecutive samples,
//! w = 1): v_i = |a_{i+w} − a_i| / (t_{i+w} − t_i), a the tip position. A window averages out
//! the one-spacing jumps of a tip that can only sit on nodes.
//!
//! The Rayleigh speed c_R is the root ξ = c_R/c_s in (0, 1) of the Rayleigh equation
//! (Rayleigh 1885; Achenbach, Wave Propagation in Elastic Solids, 1973, ch. 5):
//! (2 − ξ²)² = 4 √(1 − ξ² c_s²/c_d²) √(1 − ξ²). Plane stress is the same equation with the
//! plate's λ* = 2λμ/(λ + 2μ) in place of λ, which turns c_d into √(E/(ρ(1 − ν²))).

use crate::math::Vector;

/// Crack speed over one window, stamped at the window's centre time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedSample {
    /// (t_i + t_{i+w}) / 2: the forward difference is a second-order estimate of the speed at
    /// the interval's midpoint, not at its start (for unevenly spaced samples this is the
    /// middle of the time interval, not the time of the middle sample).
    pub time: f64,
    /// |a_{i+w} − a_i| / (t_{i+w} − t_i) (m/s for positions in m and times in s).
    pub speed: f64,
}

/// Crack speeds of one branch from its tip history (`times[i]`, `tips[i]`): one value per i
/// with i + `window` < n, so n − w values (none if n ≤ w). The distance is the Euclidean
/// norm of the displacement of the tip, so a tip moving along a curved path at constant
/// speed reads slightly low over a long window (chord, not arc).
///
/// Panics if the lengths differ, `window` is 0, or times do not strictly increase over a
/// window.
pub fn crack_speed<const D: usize>(
    times: &[f64],
    tips: &[Vector<D>],
    window: usize,
) -> Vec<SpeedSample> {
    assert_eq!(times.len(), tips.len(), "one time per tip position");
    assert!(window >= 1, "the difference window is at least one sample");
    let n = times.len();
    (0..n.saturating_sub(window))
        .map(|i| {
            let j = i + window;
            let dt = times[j] - times[i];
            assert!(
                dt > 0.0,
                "tip times must increase: t[{i}] = {}, t[{j}] = {}",
                times[i],
                times[j]
            );
            SpeedSample {
                time: 0.5 * (times[i] + times[j]),
                speed: (tips[j] - tips[i]).norm() / dt,
            }
        })
        .collect()
}

/// Which elastic setting the wave speeds are for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaveSetting {
    /// 2D thin plate: c_d = √(E / (ρ (1 − ν²))) (the plate or "bar" wave speed).
    PlaneStress,
    /// 2D thick body: the 3D speeds, c_d = √((λ + 2μ)/ρ).
    PlaneStrain,
    /// 3D bulk: c_d = √((λ + 2μ)/ρ).
    ThreeD,
}

/// Shear, dilatational and Rayleigh wave speeds (m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaveSpeeds {
    pub shear: f64,
    pub dilatational: f64,
    pub rayleigh: f64,
}

/// The wave speeds of an isotropic material with Young's modulus `young` (Pa), Poisson's ratio
/// `poisson` and density `density` (kg/m³): c_s = √(μ/ρ) with μ = E/(2(1 + ν)); c_d as per
/// `WaveSetting` with λ = Eν/((1 + ν)(1 − 2ν)); c_R from the Rayleigh equation.
///
/// Panics unless E > 0, ρ > 0 and −1 < ν < 1/2.
pub fn wave_speeds(young: f64, poisson: f64, density: f64, setting: WaveSetting) -> WaveSpeeds {
    assert!(
        young > 0.0 && density > 0.0,
        "E and ρ must be positive (got E = {young}, ρ = {density})"
    );
    assert!(
        poisson > -1.0 && poisson < 0.5,
        "Poisson's ratio must lie in (−1, 1/2) (got {poisson})"
    );
    let mu = young / (2.0 * (1.0 + poisson));
    let shear = (mu / density).sqrt();
    let dilatational = match setting {
        WaveSetting::PlaneStress => (young / (density * (1.0 - poisson * poisson))).sqrt(),
        WaveSetting::PlaneStrain | WaveSetting::ThreeD => {
            let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
            ((lambda + 2.0 * mu) / density).sqrt()
        }
    };
    let rayleigh = shear * rayleigh_ratio(shear * shear / (dilatational * dilatational));
    WaveSpeeds {
        shear,
        dilatational,
        rayleigh,
    }
}

/// The Rayleigh wave speed alone: `wave_speeds(..).rayleigh`.
pub fn rayleigh_speed(young: f64, poisson: f64, density: f64, setting: WaveSetting) -> f64 {
    wave_speeds(young, poisson, density, setting).rayleigh
}

/// The Rayleigh equation's left minus right side, divided by ξ²: R(ξ) = (2 − ξ²)² −
/// 4 √(1 − kξ²) √(1 − ξ²), k = c_s²/c_d², has the trivial root ξ = 0 (R ≈ 2(k − 1)ξ² near
/// it), which would make a sign test near 0 rest on rounding. Multiplying by the conjugate,
/// R = ξ² (ξ⁶ − 8ξ⁴ + (24 − 16k)ξ² − 16(1 − k)) / ((2 − ξ²)² + 4 √(1 − kξ²) √(1 − ξ²))
/// (the classic Rayleigh cubic in ξ², Achenbach 1973 ch. 5), so R/ξ² has the same non-zero
/// roots and no cancellation at 0.
fn rayleigh_reduced(xi: f64, k: f64) -> f64 {
    let x2 = xi * xi;
    let cubic = x2 * x2 * x2 - 8.0 * x2 * x2 + (24.0 - 16.0 * k) * x2 - 16.0 * (1.0 - k);
    let conj = (2.0 - x2).powi(2) + 4.0 * (1.0 - k * x2).sqrt() * (1.0 - x2).sqrt();
    cubic / conj
}

/// ξ = c_R/c_s for k = c_s²/c_d² in (0, 1): bisection on (0, 1) to an interval of 1e-12.
/// R/ξ² is −2(1 − k) < 0 at ξ → 0 and +1 at ξ = 1, so the bracket always holds a root.
fn rayleigh_ratio(k: f64) -> f64 {
    assert!(k > 0.0 && k < 1.0, "c_s < c_d is required (k = {k})");
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    debug_assert!(rayleigh_reduced(lo, k) < 0.0 && rayleigh_reduced(hi, k) > 0.0);
    while hi - lo > 1e-12 {
        let mid = 0.5 * (lo + hi);
        if rayleigh_reduced(mid, k) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    type V2 = Vector<2>;

    #[test]
    fn constant_speed_on_a_lattice_is_exact() {
        // A tip jumping one lattice spacing h = 0.25 mm every Δt = 0.5 μs along (3, 4)/5:
        // speed h/Δt = 500 m/s, every window.
        let h = 0.25e-3;
        let dt = 0.5e-6;
        let e = V2::new(0.6, 0.8);
        let times: Vec<f64> = (0..40).map(|i| 1e-6 + i as f64 * dt).collect();
        let tips: Vec<V2> = (0..40)
            .map(|i| V2::new(1.0, 2.0) + e * (i as f64 * h))
            .collect();
        for w in [1, 3, 30] {
            let v = crack_speed(&times, &tips, w);
            assert_eq!(v.len(), 40 - w);
            for (i, s) in v.iter().enumerate() {
                assert!((s.speed - 500.0).abs() < 1e-8, "w = {w}: {}", s.speed);
                let centre = 0.5 * (times[i] + times[i + w]);
                assert_eq!(s.time, centre);
            }
        }
        // Too short a history: nothing.
        assert!(crack_speed(&times[..30], &tips[..30], 30).is_empty());
    }

    #[test]
    fn window_differences_are_over_the_window_not_per_step() {
        // A tip that stalls then jumps: x = 0, 0, 3, 3, 6 at t = 0..4. Over w = 2 the
        // speeds are |3 − 0|/2, |3 − 0|/2, |6 − 3|/2 = 1.5 each; over w = 1 they are 0, 3, 0, 3.
        let times = [0.0, 1.0, 2.0, 3.0, 4.0];
        let tips: Vec<V2> = [0.0, 0.0, 3.0, 3.0, 6.0]
            .iter()
            .map(|&x| V2::new(x, 0.0))
            .collect();
        let v: Vec<f64> = crack_speed(&times, &tips, 2)
            .iter()
            .map(|s| s.speed)
            .collect();
        assert_eq!(v, vec![1.5, 1.5, 1.5]);
        let v: Vec<f64> = crack_speed(&times, &tips, 1)
            .iter()
            .map(|s| s.speed)
            .collect();
        assert_eq!(v, vec![0.0, 3.0, 0.0, 3.0]);
        // Uneven sampling: the stamp is the middle of the interval.
        let t = [0.0, 1.0, 4.0];
        let p = [V2::zeros(), V2::new(0.0, 1.0), V2::new(0.0, 2.0)];
        let v = crack_speed(&t, &p, 2);
        assert_eq!(v[0].time, 2.0);
        assert_eq!(v[0].speed, 0.5);
    }

    #[test]
    #[should_panic(expected = "tip times must increase")]
    fn non_increasing_times_are_refused() {
        crack_speed(&[0.0, 0.0], &[V2::zeros(), V2::new(1.0, 0.0)], 1);
    }

    /// Seed 002's PMMA: E = 3.09 GPa, ν = 0.35, ρ = 1180 kg/m³.
    const E: f64 = 3.09e9;
    const NU: f64 = 0.35;
    const RHO: f64 = 1180.0;

    #[test]
    fn seed_002_wave_speeds() {
        let ps = wave_speeds(E, NU, RHO, WaveSetting::PlaneStress);
        assert!((ps.shear - 984.8).abs() < 0.1, "c_s = {}", ps.shear);
        assert!(
            (ps.dilatational - 1727.5).abs() < 0.1,
            "c_d = {}",
            ps.dilatational
        );
        assert!((ps.rayleigh - 906.9).abs() < 0.1, "c_R = {}", ps.rayleigh);
        for setting in [WaveSetting::ThreeD, WaveSetting::PlaneStrain] {
            let s = wave_speeds(E, NU, RHO, setting);
            assert!((s.shear - 984.8).abs() < 0.1);
            assert!((s.rayleigh - 920.8).abs() < 0.1, "c_R = {}", s.rayleigh);
            assert_eq!(rayleigh_speed(E, NU, RHO, setting), s.rayleigh);
        }
    }

    #[test]
    fn rayleigh_root_satisfies_the_unreduced_equation_and_the_classic_fit() {
        // The root found on the reduced form must satisfy the Rayleigh equation as written,
        // and (3D, ν ≥ 1/4, where the fit is good to 0.2 %; it drifts to 1.4 % at ν = 0) match
        // Viktorov's fit c_R ≈ c_s (0.862 + 1.14ν)/(1 + ν).
        for nu in [-0.5, 0.0, 0.1, 0.25, 0.35, 0.45, 0.49] {
            for setting in [WaveSetting::PlaneStress, WaveSetting::ThreeD] {
                let s = wave_speeds(E, nu, RHO, setting);
                let xi = s.rayleigh / s.shear;
                let k = (s.shear / s.dilatational).powi(2);
                let lhs = (2.0 - xi * xi).powi(2);
                let rhs = 4.0 * (1.0 - xi * xi * k).sqrt() * (1.0 - xi * xi).sqrt();
                assert!((lhs - rhs).abs() < 1e-10, "ν = {nu}: {lhs} vs {rhs}");
                assert!(xi > 0.0 && xi < 1.0);
                if setting == WaveSetting::ThreeD && nu >= 0.25 {
                    let fit = s.shear * (0.862 + 1.14 * nu) / (1.0 + nu);
                    assert!((s.rayleigh / fit - 1.0).abs() < 2e-3, "ν = {nu}");
                }
            }
        }
        // ν = 1/4 in 3D (Poisson solid): ξ² = 2 − 2/√3 exactly (Rayleigh 1885).
        let s = wave_speeds(E, 0.25, RHO, WaveSetting::ThreeD);
        let exact = (2.0 - 2.0 / 3f64.sqrt()).sqrt();
        assert!((s.rayleigh / s.shear - exact).abs() < 1e-11);
    }
}
