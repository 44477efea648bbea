//! Pre-cracks as bond filters: a bond whose reference segment crosses the crack is never created.

use crate::geometry::SegmentDeck;
use serde::{Deserialize, Deserializer, Serialize};

/// A pre-crack surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Precrack {
    /// 2D: the line segment from `start` to `end` (a deck may give `length` and `angle`
    /// instead of `end`: `geometry::SegmentDeck`).
    #[serde(deserialize_with = "segment_from_deck")]
    Segment { start: [f64; 2], end: [f64; 2] },
    /// 3D: the planar parallelogram `origin + a·edge1 + b·edge2`, a, b ∈ [0, 1].
    Rectangle {
        origin: [f64; 3],
        edge1: [f64; 3],
        edge2: [f64; 3],
    },
}

fn segment_from_deck<'de, D: Deserializer<'de>>(d: D) -> Result<([f64; 2], [f64; 2]), D::Error> {
    let s = SegmentDeck::deserialize(d)?;
    if s.width.is_some() {
        return Err(serde::de::Error::custom(
            "segment: a pre-crack has no `width` (a notch of finite width is a `slot` shape, with a segment along its middle)",
        ));
    }
    s.ends("segment")
}

impl Precrack {
    pub fn dim(&self) -> usize {
        match self {
            Precrack::Segment { .. } => 2,
            Precrack::Rectangle { .. } => 3,
        }
    }

    /// Checks the crack surface is not degenerate.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            Precrack::Segment { start, end } => {
                if start.iter().chain(end).any(|v| !v.is_finite()) {
                    return Err("segment coordinates must be finite".into());
                }
                if start == end {
                    return Err("segment start and end coincide: the crack has zero length".into());
                }
            }
            Precrack::Rectangle {
                origin,
                edge1,
                edge2,
            } => {
                if origin
                    .iter()
                    .chain(edge1)
                    .chain(edge2)
                    .any(|v| !v.is_finite())
                {
                    return Err("rectangle coordinates must be finite".into());
                }
                let n = cross(edge1, edge2);
                if dot(&n, &n) == 0.0 {
                    return Err("rectangle edges edge1 and edge2 are parallel or zero: the crack has zero area".into());
                }
            }
        }
        Ok(())
    }

    /// True if the straight bond from `p` to `q` crosses the crack surface. A node lying
    /// exactly on the crack's line (plane) counts as lying on its positive side (left of the
    /// segment's direction; along the rectangle's normal edge1 × edge2): a crack laid along a
    /// row of nodes, as a lattice puts one on a mid-line, then separates that row from the
    /// nodes on the other side. Were such nodes on neither side, none of their bonds would be
    /// cut and the row would bridge the crack's faces.
    pub fn cuts(&self, p: &[f64], q: &[f64]) -> bool {
        match self {
            Precrack::Segment { start, end } => segments_cross(p, q, start, end),
            Precrack::Rectangle {
                origin,
                edge1,
                edge2,
            } => {
                let n = cross(edge1, edge2);
                let dp = (0..3).map(|k| (p[k] - origin[k]) * n[k]).sum::<f64>();
                let dq = (0..3).map(|k| (q[k] - origin[k]) * n[k]).sum::<f64>();
                if (dp >= 0.0) == (dq >= 0.0) {
                    return false;
                }
                let t = dp / (dp - dq);
                let hit: [f64; 3] = std::array::from_fn(|k| p[k] + t * (q[k] - p[k]) - origin[k]);
                // Solve hit = a e1 + b e2 in the plane by the 2×2 Gram system.
                let (g11, g12, g22) = (dot(edge1, edge1), dot(edge1, edge2), dot(edge2, edge2));
                let (r1, r2) = (dot(&hit, edge1), dot(&hit, edge2));
                let det = g11 * g22 - g12 * g12;
                let a = (r1 * g22 - r2 * g12) / det;
                let b = (r2 * g11 - r1 * g12) / det;
                (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)
            }
        }
    }
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn orient(a: &[f64], b: &[f64], c: &[f64]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether pq crosses the segment ab: p and q on different sides of ab's line (a point on
/// the line on its left side, `Precrack::cuts`) and the crossing within ab; a bond passing
/// through an end of the crack segment counts (the crack tip cuts it).
fn segments_cross(p: &[f64], q: &[f64], a: &[f64; 2], b: &[f64; 2]) -> bool {
    let left = |x: &[f64]| orient(a, b, x) >= 0.0;
    if left(p) == left(q) {
        return false;
    }
    let d3 = orient(p, q, a);
    let d4 = orient(p, q, b);
    d3 * d4 <= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_cuts_crossing_bonds_only() {
        let c = Precrack::Segment {
            start: [0.0, 0.0],
            end: [1.0, 0.0],
        };
        assert!(c.cuts(&[0.5, -0.1], &[0.5, 0.1]));
        assert!(!c.cuts(&[1.5, -0.1], &[1.5, 0.1]));
        assert!(!c.cuts(&[0.5, 0.1], &[0.6, 0.2]));
        // A node on the crack belongs to its left side (here above): its bonds down are cut,
        // its bonds up are not, and a bond along the crack is not.
        assert!(!c.cuts(&[0.5, 0.0], &[0.5, 0.2]));
        assert!(c.cuts(&[0.5, 0.0], &[0.5, -0.2]));
        assert!(c.cuts(&[0.5, -0.2], &[0.5, 0.0]));
        assert!(!c.cuts(&[0.2, 0.0], &[0.6, 0.0]));
        // Beyond the crack's end a node on its line is not separated from anything.
        assert!(!c.cuts(&[1.5, 0.0], &[1.5, -0.2]));
    }

    /// A crack along a row of a lattice cuts exactly the bonds a crack between that row and
    /// the row below cuts: every bond from the row and above to the rows below (the crack
    /// runs through the whole patch, so no tip decides). With nodes on the crack on neither
    /// side, none of the row's bonds were cut, and the row bridged the crack.
    #[test]
    fn a_crack_along_a_row_of_nodes_cuts_as_one_between_rows() {
        let (dx, horizon) = (1.0, 3.0);
        let nodes: Vec<[f64; 2]> = (-8..=8)
            .flat_map(|i| (-8..=8).map(move |j| [i as f64 * dx, j as f64 * dx]))
            .collect();
        let cut = |y: f64| {
            let crack = Precrack::Segment {
                start: [-20.0, y],
                end: [20.0, y],
            };
            let mut n = 0;
            for p in &nodes {
                for q in &nodes {
                    let r = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
                    if r > 0.0 && r <= horizon && crack.cuts(p, q) {
                        n += 1;
                    }
                }
            }
            n
        };
        let between_rows = cut(-0.5 * dx);
        assert!(between_rows > 100, "{between_rows}");
        assert_eq!(cut(0.0), between_rows);
    }

    /// A segment given by its length and angle cuts the bonds the segment to its end cuts:
    /// 1 long, straight down from (0.5, 0.5).
    #[test]
    fn segment_by_length_and_angle_is_the_segment_to_its_end() {
        #[derive(serde::Deserialize)]
        struct Deck {
            precracks: Vec<Precrack>,
        }
        let text =
            "[[precracks]]\ntype = \"segment\"\nstart = [0.5, 0.5]\nlength = 1.0\nangle = -90.0\n";
        let deck: Deck = toml::from_str(text).unwrap();
        let Precrack::Segment { start, end } = deck.precracks[0] else {
            panic!("a segment");
        };
        assert_eq!(start, [0.5, 0.5]);
        assert!(
            (end[0] - 0.5).abs() < 1e-15 && (end[1] + 0.5).abs() < 1e-15,
            "{end:?}"
        );
        assert!(deck.precracks[0].cuts(&[0.4, 0.0], &[0.6, 0.0]));
        assert!(!deck.precracks[0].cuts(&[0.4, -0.6], &[0.6, -0.6]));
    }

    #[test]
    fn rectangle_cuts_crossing_bonds_only() {
        let c = Precrack::Rectangle {
            origin: [0.0, 0.0, 0.0],
            edge1: [1.0, 0.0, 0.0],
            edge2: [0.0, 0.0, 1.0],
        };
        assert!(c.cuts(&[0.5, -0.1, 0.5], &[0.5, 0.1, 0.5]));
        assert!(!c.cuts(&[0.5, -0.1, 1.5], &[0.5, 0.1, 1.5]));
        assert!(!c.cuts(&[0.5, 0.1, 0.5], &[0.5, 0.2, 0.5]));
    }
}
