//! The top of a map's colour range, taken from the field itself.

/// The `q`-th percentile (0 to 100, nearest rank) of the finite values, the top of a colour
/// range that starts at 0: below 100 a few spikes (a crack tip's energy) cannot wash out the
/// rest of the map. 1 when that is not positive, so an all-zero field shows the low end of the
/// colour map with a readable bar.
pub fn percentile_top(values: &[f64], q: f64) -> f64 {
    let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 1.0;
    }
    let n = finite.len();
    let rank = ((q.clamp(0.0, 100.0) * n as f64 / 100.0).ceil() as usize).clamp(1, n);
    let (_, top, _) = finite.select_nth_unstable_by(rank - 1, f64::total_cmp);
    if *top > 0.0 {
        *top
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_maximum_at_100_and_a_spike_ignored_below() {
        let mut v: Vec<f64> = (1..=1000).map(f64::from).collect();
        v[17] = 1e9;
        v.push(f64::NAN);
        assert_eq!(percentile_top(&v, 100.0), 1e9);
        // 995th of 1000 values: the spike and the four largest others lie above it.
        assert_eq!(percentile_top(&v, 99.5), 996.0);
    }

    #[test]
    fn empty_or_zero_fields_get_a_unit_range() {
        assert_eq!(percentile_top(&[], 99.5), 1.0);
        assert_eq!(percentile_top(&[0.0; 10], 100.0), 1.0);
        assert_eq!(percentile_top(&[f64::NAN, -2.0], 100.0), 1.0);
        assert_eq!(percentile_top(&[3e-6], 50.0), 3e-6);
    }
}
