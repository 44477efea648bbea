//! The analytic displacement of a fixed–free bar released from a uniform strain (seed 003
//! §4.1, Eq. 15: du/dx = ε for t < 0, v = 0; the reference of its Figs. 8–10).
//!
//! By d'Alembert, u(s, τ) = [f(s − cτ) + f(s + cτ)]/2, where s is the distance from the fixed
//! end, τ the time since the release, c the bar's wave speed and f the extension of the initial
//! field εs that is odd about the fixed end (u = 0 there) and even about the free end
//! (du/ds = 0 there), hence periodic in 4L. At s = L/2 this is the trapezoid between ±εL/2 of
//! period 4L/c that the paper plots.

use crate::math::Vector;

/// A fixed–free bar along x: fixed end at `fixed_end`, free end at `fixed_end + length`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedFreeBar {
    /// The uniform strain before the release, ε.
    pub strain: f64,
    /// L (m).
    pub length: f64,
    /// x of the fixed end (m).
    pub fixed_end: f64,
    /// The time of the release (s).
    pub release: f64,
    /// c (m/s).
    pub wave_speed: f64,
}

impl FixedFreeBar {
    /// Whether the point at `x` lies on the bar (ends included).
    pub fn contains(&self, x: f64) -> bool {
        let s = x - self.fixed_end;
        (0.0..=self.length).contains(&s)
    }

    /// The axial displacement at `x` (on the bar) and time `t`; before the release, εs.
    pub fn displacement(&self, x: f64, t: f64) -> f64 {
        let s = x - self.fixed_end;
        let travel = self.wave_speed * (t - self.release).max(0.0);
        0.5 * (self.extension(s - travel) + self.extension(s + travel))
    }

    /// The volume-weighted RMS and the largest magnitude of u − u_exact over `nodes` at time
    /// `t` (the exact field is along x only), summed in node order: the error norms of seed
    /// 003 Figs. 9–10 (at one particle, and over the bar).
    pub fn error<const D: usize>(
        &self,
        positions: &[Vector<D>],
        volumes: &[f64],
        u: &[Vector<D>],
        nodes: &[u32],
        t: f64,
    ) -> (f64, f64) {
        let (mut squares, mut volume, mut largest) = (0.0, 0.0, 0.0_f64);
        for &i in nodes {
            let i = i as usize;
            let mut e = u[i];
            e[0] -= self.displacement(positions[i][0], t);
            let e2 = e.norm_squared();
            squares += e2 * volumes[i];
            volume += volumes[i];
            largest = largest.max(e2.sqrt());
        }
        ((squares / volume).sqrt(), largest)
    }

    /// f: εs on [0, L], odd about 0, even about L, period 4L.
    fn extension(&self, s: f64) -> f64 {
        let w = (s / self.length).rem_euclid(4.0);
        let unit = if w <= 1.0 {
            w
        } else if w <= 3.0 {
            2.0 - w
        } else {
            w - 4.0
        };
        self.strain * self.length * unit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BAR: FixedFreeBar = FixedFreeBar {
        strain: 1e-3,
        length: 1.0,
        fixed_end: 0.0,
        release: 0.0,
        wave_speed: 5000.0,
    };

    #[test]
    fn before_and_at_the_release_the_bar_holds_the_uniform_strain() {
        for x in [0.0, 0.3, 0.5, 1.0] {
            assert!((BAR.displacement(x, 0.0) - 1e-3 * x).abs() < 1e-15);
            assert!((BAR.displacement(x, -1.0) - 1e-3 * x).abs() < 1e-15);
        }
    }

    #[test]
    fn the_fixed_end_stays_and_the_free_end_carries_no_strain() {
        for t in [1e-5, 7.3e-5, 2.1e-4, 5.55e-4, 3.0e-3] {
            assert!(BAR.displacement(0.0, t).abs() < 1e-15, "t = {t}");
            let h = 1e-7;
            let slope = (BAR.displacement(1.0, t) - BAR.displacement(1.0 - h, t)) / h;
            // Away from the moments a front reaches the free end, du/dx = 0 there.
            assert!(slope.abs() < 1e-9, "t = {t}: du/dx = {slope}");
        }
    }

    #[test]
    fn the_middle_follows_the_trapezoid_of_period_4l_over_c() {
        // L/c = 0.2 ms. At s = L/2: +εL/2 until L/(2c), a ramp to −εL/2 over L/c, a plateau
        // of L/c, a ramp back; the period is 4L/c = 0.8 ms.
        let u = |t: f64| BAR.displacement(0.5, t);
        assert!((u(0.05e-3) - 0.5e-3).abs() < 1e-15);
        assert!(u(0.2e-3).abs() < 1e-15, "the ramp crosses zero at L/c");
        assert!((u(0.4e-3) + 0.5e-3).abs() < 1e-15);
        assert!((u(0.6e-3)).abs() < 1e-15, "and again at 3L/c");
        for t in [0.05e-3, 0.13e-3, 0.37e-3, 0.71e-3] {
            assert!((u(t) - u(t + 0.8e-3)).abs() < 1e-15, "t = {t}");
        }
    }

    #[test]
    fn it_is_the_modal_series_of_the_released_bar() {
        // The same solution as a sum of the bar's modes (seed 003 notes, §3.1):
        // u = Σ 8εL(−1)ⁿ/((2n+1)²π²) sin((2n+1)πs/(2L)) cos((2n+1)πcτ/(2L)); its tail after
        // N terms is below 8εL/(π²N).
        let series = |x: f64, t: f64| -> f64 {
            (0..20_000)
                .map(|n| {
                    let k = (2 * n + 1) as f64 * std::f64::consts::PI / 2.0;
                    let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
                    8.0 * 1e-3 * sign / (4.0 * k * k) * (k * x).sin() * (k * 5000.0 * t).cos()
                })
                .sum()
        };
        for (x, t) in [(0.5, 0.0), (0.5, 0.31e-3), (0.37, 1.234e-4), (0.91, 2.2e-3)] {
            let d = BAR.displacement(x, t) - series(x, t);
            assert!(d.abs() < 1e-7, "x = {x}, t = {t}: {d}");
        }
    }

    #[test]
    fn the_error_is_the_volume_weighted_rms_and_the_largest_magnitude() {
        let positions = [0.25, 0.5, 0.75].map(|x| Vector::<2>::new(x, 0.0));
        // Before the release the exact field is εx; the nodes are off by (1, 0), (0, 2) and
        // (−2, 0) µm, the last with twice the volume.
        let u = [
            Vector::<2>::new(0.25e-3 + 1e-6, 0.0),
            Vector::<2>::new(0.5e-3, 2e-6),
            Vector::<2>::new(0.75e-3 - 2e-6, 0.0),
        ];
        let volumes = [1.0, 1.0, 2.0];
        let (rms, max) = BAR.error(&positions, &volumes, &u, &[0, 1, 2], -1.0);
        let expected = ((1.0 + 4.0 + 2.0 * 4.0) / 4.0_f64).sqrt() * 1e-6;
        assert!((rms - expected).abs() < 1e-18, "{rms} against {expected}");
        assert!((max - 2e-6).abs() < 1e-18);
        let (one, _) = BAR.error(&positions, &volumes, &u, &[0], -1.0);
        assert!((one - 1e-6).abs() < 1e-18);
    }

    #[test]
    fn a_bar_elsewhere_is_the_same_bar_shifted() {
        let moved = FixedFreeBar {
            fixed_end: -2.0,
            release: 1e-3,
            ..BAR
        };
        assert!(moved.contains(-1.5) && !moved.contains(-2.1) && !moved.contains(-0.9));
        for (x, t) in [(0.2, 3e-5), (0.5, 4.4e-4), (0.9, 1.7e-3)] {
            let d = moved.displacement(x - 2.0, t + 1e-3) - BAR.displacement(x, t);
            assert!(d.abs() < 1e-15, "x = {x}, t = {t}: {d}");
        }
    }
}
