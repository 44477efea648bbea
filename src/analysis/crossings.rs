//! How many cracks cross a line, and where: the damaged nodes (damage > threshold) within a
//! strip about a 2D segment, ordered along it and split into separate crossings wherever two
//! consecutive ones are more than ℓ apart — the clustering `branching` applies across its
//! bands, here on one band the user places. Two cracks that run side by side, which a search
//! box would count as one (seed 000 §4.2: four cracks from the hole of a uniform lattice, two
//! of them in each of the boxes above and below it), are two crossings of a line across them.

use super::branching::clusters;
use crate::math::Vector;

/// A segment across which cracks are counted, with the strip about it that is searched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossingLine {
    pub from: Vector<2>,
    pub to: Vector<2>,
    /// The strip's full width (m): nodes within half of it of the segment are searched. It
    /// must hold at least one node row of the grid, or a crack crossing it is missed.
    pub width: f64,
}

/// One crack crossing a line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Distance from the line's start to the crossing (m): the mean over its damaged nodes.
    pub along: f64,
    /// The crossing on the line: `from + along · (to − from)/|to − from|`.
    pub point: Vector<2>,
    /// Damaged nodes of the strip in the crossing.
    pub nodes: usize,
}

/// The crossings of `line` by the damaged nodes of a 2D field, in order from `line.from`:
/// nodes within `line.width / 2` of the segment (their projection on it between its ends) with
/// damage > `threshold`, split where consecutive distances along the line differ by more than
/// `link`. Deterministic: the result does not depend on the order of the nodes.
///
/// Panics unless the segment has a length, `width` > 0 and `link` > 0.
pub fn crossings(
    positions: &[Vector<2>],
    damage: &[f64],
    threshold: f64,
    line: &CrossingLine,
    link: f64,
) -> Vec<Crossing> {
    assert_eq!(
        positions.len(),
        damage.len(),
        "one damage value per node position"
    );
    let span = line.to - line.from;
    let length = span.norm();
    assert!(
        length > 0.0 && length.is_finite(),
        "a crossing line needs two distinct ends"
    );
    assert!(
        line.width > 0.0 && line.width.is_finite(),
        "a crossing line's strip needs a width"
    );
    assert!(
        link > 0.0 && link.is_finite(),
        "linking distance must be positive"
    );
    let e = span / length;
    let n = Vector::<2>::new(-e[1], e[0]);
    // (distance across, distance along): `clusters` splits on gaps in the second.
    let strip: Vec<(f64, f64)> = positions
        .iter()
        .zip(damage)
        .filter(|&(_, &d)| d > threshold)
        .map(|(p, _)| ((p - line.from).dot(&n), (p - line.from).dot(&e)))
        .filter(|&(across, along)| {
            across.abs() <= 0.5 * line.width && (0.0..=length).contains(&along)
        })
        .collect();
    clusters(strip, link)
        .into_iter()
        .map(|c| Crossing {
            along: c.r,
            point: line.from + e * c.r,
            nodes: c.nodes,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    type V2 = Vector<2>;

    /// A lattice of spacing h over [0, 1]², damage 1 within `half` of x = each of `cracks`
    /// (vertical cracks), for y ≥ `from_y`.
    fn vertical_cracks(h: f64, cracks: &[f64], half: f64, from_y: f64) -> (Vec<V2>, Vec<f64>) {
        let n = (1.0 / h).round() as usize;
        let mut pos = Vec::new();
        let mut d = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let p = V2::new(i as f64 * h, j as f64 * h);
                let near = cracks.iter().any(|&x| (p[0] - x).abs() <= half) && p[1] >= from_y;
                pos.push(p);
                d.push(if near { 0.5 } else { 0.1 });
            }
        }
        (pos, d)
    }

    fn horizontal(y: f64, width: f64) -> CrossingLine {
        CrossingLine {
            from: V2::new(0.0, y),
            to: V2::new(1.0, y),
            width,
        }
    }

    #[test]
    fn two_cracks_side_by_side_are_two_crossings_where_they_are() {
        let h = 0.01;
        let (pos, d) = vertical_cracks(h, &[0.3, 0.45], 0.011, 0.0);
        let found = crossings(&pos, &d, 0.35, &horizontal(0.505, 2.0 * h), 3.0 * h);
        assert_eq!(found.len(), 2, "{found:?}");
        for (c, x) in found.iter().zip([0.3, 0.45]) {
            assert!((c.along - x).abs() < 1e-12, "{c:?}");
            assert!((c.point - V2::new(x, 0.505)).norm() < 1e-12, "{c:?}");
            // Three columns (x − h, x, x + h) in each of the strip's two rows.
            assert_eq!(c.nodes, 6, "{c:?}");
        }
    }

    #[test]
    fn cracks_closer_than_the_link_are_one_crossing() {
        let h = 0.01;
        let (pos, d) = vertical_cracks(h, &[0.3, 0.34], 0.0, 0.0);
        // Gap 0.04: two crossings with ℓ = 0.03, one with ℓ = 0.05.
        assert_eq!(
            crossings(&pos, &d, 0.35, &horizontal(0.5, 2.0 * h), 0.03).len(),
            2
        );
        assert_eq!(
            crossings(&pos, &d, 0.35, &horizontal(0.5, 2.0 * h), 0.05).len(),
            1
        );
    }

    #[test]
    fn a_crack_that_stops_short_of_the_line_does_not_cross_it() {
        let h = 0.01;
        let (pos, d) = vertical_cracks(h, &[0.5], 0.0, 0.6);
        assert!(crossings(&pos, &d, 0.35, &horizontal(0.5, 2.0 * h), 3.0 * h).is_empty());
        assert_eq!(
            crossings(&pos, &d, 0.35, &horizontal(0.7, 2.0 * h), 3.0 * h).len(),
            1
        );
        // Below the threshold nothing is damaged.
        assert!(crossings(&pos, &d, 0.5, &horizontal(0.7, 2.0 * h), 3.0 * h).is_empty());
    }

    #[test]
    fn only_the_segment_between_its_ends_is_searched() {
        let h = 0.01;
        let (pos, d) = vertical_cracks(h, &[0.2, 0.8], 0.0, 0.0);
        let half = CrossingLine {
            from: V2::new(0.0, 0.5),
            to: V2::new(0.5, 0.5),
            width: 2.0 * h,
        };
        let found = crossings(&pos, &d, 0.35, &half, 3.0 * h);
        assert_eq!(found.len(), 1);
        assert!((found[0].point[0] - 0.2).abs() < 1e-12);
    }

    #[test]
    fn a_line_in_any_direction_and_any_node_order_gives_the_same_crossings() {
        let h = 0.01;
        let (mut pos, mut d) = vertical_cracks(h, &[0.3, 0.6], 0.0, 0.0);
        // A line from right to left, tilted: the crossings come in its own order.
        let line = CrossingLine {
            from: V2::new(0.9, 0.55),
            to: V2::new(0.1, 0.45),
            width: 3.0 * h,
        };
        let found = crossings(&pos, &d, 0.35, &line, 3.0 * h);
        assert_eq!(found.len(), 2);
        assert!(found[0].point[0] > found[1].point[0]);
        assert!((found[0].point[0] - 0.6).abs() < 2.0 * h, "{found:?}");
        pos.reverse();
        d.reverse();
        assert_eq!(crossings(&pos, &d, 0.35, &line, 3.0 * h), found);
    }
}
