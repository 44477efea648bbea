//! The crack as a 2D polyline, and how close it is to a reference path.
//!
//! The path: damaged nodes binned along an axis, each bin giving the damage-weighted mean of
//! the other coordinate, so a crack band several nodes wide becomes one line through its
//! middle (weighting by damage pulls the line to the most broken nodes).
//!
//! The comparison: both polylines sampled at n equally spaced abscissae over their common
//! range (seed 003 §4 samples 52 points at equal horizontal spacing), then the Pearson
//! correlation of the two ordinate series (seed 003 Eq. 17) and the max and mean absolute
//! distance between them. Pearson measures shape only (it is 1 for a shifted or scaled copy),
//! hence the distances alongside.

use std::collections::BTreeMap;

use crate::math::Vector;

/// The crack path of a 2D damage field: nodes with damage > `threshold` binned along `axis`
/// (0 = x, 1 = y) in bins [k h, (k + 1) h) of width `bin_width` = h (bins anchored at 0 so
/// two fields binned alike share bin edges); for each non-empty bin, its centre (k + ½) h and
/// the damage-weighted mean Σ dᵢ yᵢ / Σ dᵢ of the other coordinate. Sorted by abscissa.
/// A node exactly on a bin edge (x = k h) lands on either side as the rounding of x/h falls,
/// so on a lattice of spacing h pick a bin width that does not put columns on edges, or
/// expect a column to move to the neighbouring bin.
///
/// Panics unless `bin_width` > 0 and `threshold` ≥ 0 (weights must be positive).
pub fn crack_path(
    positions: &[Vector<2>],
    damage: &[f64],
    threshold: f64,
    axis: usize,
    bin_width: f64,
) -> Vec<(f64, f64)> {
    assert_eq!(
        positions.len(),
        damage.len(),
        "one damage value per node position"
    );
    assert!(axis < 2, "axis is 0 (x) or 1 (y)");
    assert!(
        bin_width > 0.0 && bin_width.is_finite(),
        "bin width must be positive"
    );
    assert!(threshold >= 0.0, "damage weights must be positive");
    let other = 1 - axis;
    // BTreeMap: bins come out in abscissa order, independent of node order.
    let mut bins: BTreeMap<i64, (f64, f64)> = BTreeMap::new();
    for (p, &d) in positions.iter().zip(damage) {
        if d > threshold {
            let k = (p[axis] / bin_width).floor() as i64;
            let b = bins.entry(k).or_insert((0.0, 0.0));
            b.0 += d;
            b.1 += d * p[other];
        }
    }
    bins.into_iter()
        .map(|(k, (w, wy))| ((k as f64 + 0.5) * bin_width, wy / w))
        .collect()
}

/// Pearson correlation of two equally long series (seed 003 Eq. 17):
/// Σ(xᵢ − x̄)(yᵢ − ȳ) / √(Σ(xᵢ − x̄)² Σ(yᵢ − ȳ)²).
///
/// `None` when either series is constant (zero variance: the ratio is 0/0 and the
/// correlation undefined) or has fewer than two values. "Constant" means a spread
/// max − min ≤ 1e-12 · max|v|, so rounding in the means of a flat path does not produce
/// a meaningless ±1.
pub fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    assert_eq!(x.len(), y.len(), "series of equal length");
    let n = x.len();
    if n < 2 || is_constant(x) || is_constant(y) {
        return None;
    }
    let mx = x.iter().sum::<f64>() / n as f64;
    let my = y.iter().sum::<f64>() / n as f64;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        let (dx, dy) = (a - mx, b - my);
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    // Cauchy–Schwarz bounds it by 1; rounding may not.
    Some((sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0))
}

fn is_constant(v: &[f64]) -> bool {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    let scale = lo.abs().max(hi.abs());
    hi - lo <= 1e-12 * scale
}

/// How a crack path compares with a reference path.
#[derive(Debug, Clone, PartialEq)]
pub struct PathComparison {
    /// Pearson correlation of the sampled ordinates; `None` if either is constant there.
    pub correlation: Option<f64>,
    /// Largest |y_path − y_ref| over the samples.
    pub max_distance: f64,
    /// Mean |y_path − y_ref| over the samples.
    pub mean_distance: f64,
    /// The common abscissa range [lo, hi] that was sampled.
    pub range: (f64, f64),
    /// The sample abscissae and both ordinates, for plotting.
    pub samples: Vec<(f64, f64, f64)>,
}

/// Compares `path` with `reference`, both polylines (abscissa, ordinate) assumed monotone
/// along the abscissa (they are sorted by it first, so either order is accepted): both are
/// linearly interpolated at `n` equally spaced abscissae over their common range (seed 003
/// uses n = 52), then compared by Pearson correlation and absolute distance.
///
/// `None` if either path has fewer than two points or the ranges overlap in less than an
/// interval. Panics if `n` < 2.
pub fn compare_paths(
    path: &[(f64, f64)],
    reference: &[(f64, f64)],
    n: usize,
) -> Option<PathComparison> {
    assert!(n >= 2, "at least two sample points");
    if path.len() < 2 || reference.len() < 2 {
        return None;
    }
    let sorted = |p: &[(f64, f64)]| {
        let mut v = p.to_vec();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    };
    let (a, b) = (sorted(path), sorted(reference));
    let lo = a[0].0.max(b[0].0);
    let hi = a[a.len() - 1].0.min(b[b.len() - 1].0);
    if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    let samples: Vec<(f64, f64, f64)> = (0..n)
        .map(|i| {
            let x = if i == n - 1 {
                hi
            } else {
                lo + (hi - lo) * i as f64 / (n - 1) as f64
            };
            (x, interpolate(&a, x), interpolate(&b, x))
        })
        .collect();
    let ya: Vec<f64> = samples.iter().map(|s| s.1).collect();
    let yb: Vec<f64> = samples.iter().map(|s| s.2).collect();
    let dist = samples.iter().map(|s| (s.1 - s.2).abs());
    Some(PathComparison {
        correlation: pearson(&ya, &yb),
        max_distance: dist.clone().fold(0.0, f64::max),
        mean_distance: dist.sum::<f64>() / n as f64,
        range: (lo, hi),
        samples,
    })
}

/// Linear interpolation of a polyline sorted by abscissa, at `x` within its range.
fn interpolate(path: &[(f64, f64)], x: f64) -> f64 {
    // First vertex at or beyond x; the segment before it holds x.
    let j = path.partition_point(|p| p.0 < x);
    if j == 0 {
        return path[0].1;
    }
    if j == path.len() {
        return path[j - 1].1;
    }
    let ((x0, y0), (x1, y1)) = (path[j - 1], path[j]);
    if x1 == x {
        return y1;
    }
    y0 + (y1 - y0) * (x - x0) / (x1 - x0)
}

#[cfg(test)]
mod tests {
    use super::*;

    type V2 = Vector<2>;

    fn assert_close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b}");
    }

    #[test]
    fn bins_give_damage_weighted_means() {
        let pos = vec![
            V2::new(0.2, 1.0),
            V2::new(0.7, 2.0),
            V2::new(1.5, 3.0),
            V2::new(1.6, 9.0), // below the threshold: ignored
            V2::new(3.2, -1.0),
        ];
        let d = vec![1.0, 0.5, 0.9, 0.3, 0.6];
        let p = crack_path(&pos, &d, 0.4, 0, 1.0);
        assert_eq!(p.len(), 3, "bin [2, 3) is empty: {p:?}");
        assert_eq!(p[0].0, 0.5);
        assert_close(p[0].1, (1.0 * 1.0 + 0.5 * 2.0) / 1.5, 1e-15);
        assert_eq!(p[1], (1.5, 3.0));
        assert_eq!(p[2], (3.5, -1.0));
        // The same field with x and y swapped, binned along y: the same path.
        let swapped: Vec<V2> = pos.iter().map(|p| V2::new(p[1], p[0])).collect();
        assert_eq!(crack_path(&swapped, &d, 0.4, 1, 1.0), p);
        // Negative abscissae bin below zero: x = −0.2 falls in [−1, 0), centre −0.5.
        let p = crack_path(&[V2::new(-0.2, 4.0)], &[1.0], 0.0, 0, 1.0);
        assert_eq!(p, vec![(-0.5, 4.0)]);
    }

    #[test]
    fn a_wide_symmetric_band_gives_its_centre_line() {
        // Crack band three nodes wide around y = 0.1 x + 0.3 on a lattice, damage highest on
        // the middle row and equal on the outer rows: the weighted mean is the middle row.
        // Columns sit mid-bin (a node on a bin edge goes to whichever side rounding puts it).
        let h = 0.1;
        let mut pos = Vec::new();
        let mut d = Vec::new();
        for i in 0..50 {
            let x = (i as f64 + 0.5) * h;
            let yc = 0.1 * x + 0.3;
            for (dy, dm) in [(-h, 0.5), (0.0, 1.0), (h, 0.5)] {
                pos.push(V2::new(x, yc + dy));
                d.push(dm);
            }
        }
        let p = crack_path(&pos, &d, 0.4, 0, h);
        assert_eq!(p.len(), 50);
        for (k, &(xc, y)) in p.iter().enumerate() {
            assert_close(xc, (k as f64 + 0.5) * h, 1e-12);
            assert_close(y, 0.1 * xc + 0.3, 1e-12);
        }
    }

    fn line(slope: f64, offset: f64, x0: f64, x1: f64, m: usize) -> Vec<(f64, f64)> {
        (0..m)
            .map(|i| {
                let x = x0 + (x1 - x0) * i as f64 / (m - 1) as f64;
                (x, slope * x + offset)
            })
            .collect()
    }

    fn wavy(shift: f64) -> Vec<(f64, f64)> {
        (0..80)
            .map(|i| {
                let x = i as f64 * 0.125;
                (x, (0.7 * x).sin() + 0.05 * x * x + shift)
            })
            .collect()
    }

    #[test]
    fn a_path_with_itself_correlates_perfectly() {
        let p = wavy(0.0);
        let c = compare_paths(&p, &p, 52).unwrap();
        assert_close(c.correlation.unwrap(), 1.0, 1e-12);
        assert_eq!(c.max_distance, 0.0);
        assert_eq!(c.mean_distance, 0.0);
        assert_eq!(c.samples.len(), 52);
        assert_eq!(c.range, (0.0, 79.0 * 0.125));
    }

    #[test]
    fn a_shifted_copy_correlates_perfectly_but_is_at_the_shift() {
        let c = compare_paths(&wavy(0.25), &wavy(0.0), 52).unwrap();
        assert_close(c.correlation.unwrap(), 1.0, 1e-12);
        assert_close(c.mean_distance, 0.25, 1e-12);
        assert_close(c.max_distance, 0.25, 1e-12);
    }

    #[test]
    fn a_scaled_copy_correlates_perfectly_too() {
        // Pearson sees shape, not size: y and 3y correlate at 1, at distance 2|y|.
        let a = line(0.5, 0.0, 0.0, 4.0, 5);
        let b: Vec<(f64, f64)> = a.iter().map(|&(x, y)| (x, 3.0 * y)).collect();
        let c = compare_paths(&b, &a, 52).unwrap();
        assert_close(c.correlation.unwrap(), 1.0, 1e-12);
        assert_close(c.max_distance, 2.0 * 0.5 * 4.0, 1e-12);
        assert_close(c.mean_distance, 2.0 * 0.5 * 2.0, 1e-12);
    }

    #[test]
    fn perpendicular_slopes_anticorrelate() {
        // y = x against y = −x on [0, 2]: correlation −1, distance 2x (max 4, mean 2).
        let c = compare_paths(
            &line(1.0, 0.0, 0.0, 2.0, 3),
            &line(-1.0, 0.0, 0.0, 2.0, 7),
            52,
        )
        .unwrap();
        assert_close(c.correlation.unwrap(), -1.0, 1e-12);
        assert_close(c.max_distance, 4.0, 1e-12);
        assert_close(c.mean_distance, 2.0, 1e-12);
    }

    #[test]
    fn only_the_common_range_is_sampled_and_interpolation_is_linear() {
        // A line sampled at 3 points over [0, 10] against the same line at 41 points over
        // [2, 12], given in decreasing order: range [2, 10], identical ordinates.
        let a = line(0.3, -1.0, 0.0, 10.0, 3);
        let mut b = line(0.3, -1.0, 2.0, 12.0, 41);
        b.reverse();
        let c = compare_paths(&a, &b, 52).unwrap();
        assert_eq!(c.range, (2.0, 10.0));
        assert_eq!(c.samples[0].0, 2.0);
        assert_eq!(c.samples[51].0, 10.0);
        assert_close(c.samples[1].0, 2.0 + 8.0 / 51.0, 1e-14);
        for &(x, ya, yb) in &c.samples {
            assert_close(ya, 0.3 * x - 1.0, 1e-12);
            assert_close(yb, 0.3 * x - 1.0, 1e-12);
        }
        assert_close(c.correlation.unwrap(), 1.0, 1e-12);
        assert!(c.max_distance < 1e-12);
        // Disjoint ranges, or too few points: no comparison.
        assert!(compare_paths(
            &line(1.0, 0.0, 0.0, 1.0, 2),
            &line(1.0, 0.0, 2.0, 3.0, 2),
            52
        )
        .is_none());
        assert!(compare_paths(&[(0.0, 0.0)], &a, 52).is_none());
    }

    #[test]
    fn a_constant_path_has_no_correlation() {
        // Zero variance: Pearson is 0/0, reported as None; the distances are still defined.
        let flat = line(0.0, 0.2, 0.0, 1.0, 11);
        let sloped = line(1.0, 0.0, 0.0, 1.0, 11);
        let c = compare_paths(&flat, &sloped, 52).unwrap();
        assert_eq!(c.correlation, None);
        assert_close(c.max_distance, 0.8, 1e-12);
        let mean = (0..52).map(|i| (0.2 - i as f64 / 51.0).abs()).sum::<f64>() / 52.0;
        assert_close(c.mean_distance, mean, 1e-12);
        assert_eq!(compare_paths(&flat, &flat, 52).unwrap().correlation, None);
        // pearson itself: constants of any size, including 0.
        assert_eq!(pearson(&[0.0; 4], &[1.0, 2.0, 3.0, 4.0]), None);
        assert_eq!(pearson(&[1e-3; 4], &[1.0, 2.0, 3.0, 4.0]), None);
        assert_eq!(pearson(&[1.0], &[2.0]), None);
        // A known value: x = 1..4, y = 1, 3, 2, 4 → Σdxdy = 4, Σdx² = Σdy² = 5 → 0.8.
        assert_close(
            pearson(&[1.0, 2.0, 3.0, 4.0], &[1.0, 3.0, 2.0, 4.0]).unwrap(),
            0.8,
            1e-15,
        );
    }
}
