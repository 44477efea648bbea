//! The dissipation rate of a running crack, Γ = dE_diss/dā (seed 002, Eq. 13), with ā the
//! area of a single crack, (a − a_0)·w: the tip's advance along the tracking direction times
//! the crack's width (the thickness in 2D). Branches and rough faces are not counted in ā, so
//! Γ/G0 above 1 signals extra crack surface, and in 2D Γ/G0 > 2 macroscopic branching
//! (seed 002 §4.2.2).
//!
//! Like the crack speed, Γ is a forward difference over a window of samples; a window over
//! which the tip did not advance gives no value (the rate is undefined, not infinite).

/// Γ over one window, stamped at the window's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateSample {
    /// (t_i + t_{i+w}) / 2.
    pub time: f64,
    /// (a_i + a_{i+w}) / 2: the crack length the rate belongs to (m).
    pub crack_length: f64,
    /// (E_{i+w} − E_i) / ((a_{i+w} − a_i) w) (J/m²).
    pub rate: f64,
}

/// Γ from samples of time, crack length a − a_0 (m) and dissipated energy (J), over
/// `window` samples, for a crack of width `width` (m). Windows where the crack did not grow
/// are skipped.
///
/// Panics if the lengths differ or `window` is 0.
pub fn dissipation_rate(
    times: &[f64],
    lengths: &[f64],
    energies: &[f64],
    window: usize,
    width: f64,
) -> Vec<RateSample> {
    assert!(
        times.len() == lengths.len() && lengths.len() == energies.len(),
        "one time and one energy per crack length"
    );
    assert!(window >= 1, "the difference window is at least one sample");
    (0..times.len().saturating_sub(window))
        .filter_map(|i| {
            let j = i + window;
            let da = lengths[j] - lengths[i];
            (da > 0.0).then(|| RateSample {
                time: 0.5 * (times[i] + times[j]),
                crack_length: 0.5 * (lengths[i] + lengths[j]),
                rate: (energies[j] - energies[i]) / (da * width),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_crack_that_dissipates_g_per_unit_area_has_rate_g() {
        // 2 mm thick, G = 300 J/m²: E = G · a · w, sampled every 0.1 mm.
        let (g, w) = (300.0, 2e-3);
        let lengths: Vec<f64> = (0..20).map(|k| k as f64 * 1e-4).collect();
        let energies: Vec<f64> = lengths.iter().map(|a| g * a * w).collect();
        let times: Vec<f64> = (0..20).map(|k| k as f64 * 1e-6).collect();
        let rates = dissipation_rate(&times, &lengths, &energies, 3, w);
        assert_eq!(rates.len(), 17);
        for r in &rates {
            assert!((r.rate - g).abs() < 1e-9 * g, "{r:?}");
        }
        assert!((rates[0].crack_length - 1.5e-4).abs() < 1e-15);
        assert!((rates[0].time - 1.5e-6).abs() < 1e-18);
    }

    #[test]
    fn windows_without_growth_give_no_rate() {
        let times = [0.0, 1.0, 2.0, 3.0];
        let lengths = [0.0, 0.0, 1.0, 1.0];
        let energies = [0.0, 5.0, 7.0, 9.0];
        let rates = dissipation_rate(&times, &lengths, &energies, 1, 1.0);
        // Only the window 1 → 2 grew: Γ = (7 − 5)/1.
        assert_eq!(
            rates,
            vec![RateSample {
                time: 1.5,
                crack_length: 0.5,
                rate: 2.0
            }]
        );
    }
}
