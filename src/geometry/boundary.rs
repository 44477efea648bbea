//! The boundary of a 2D shape as straight segments no longer than a target size, for meshers
//! that fit elements to it (seed 000 §3: curved boundaries are seeded at the mesh size).

use super::{GeometryError, Shape};

/// A boundary segment from `a` to `b`, with the body on its left (counter-clockwise outer
/// boundaries, clockwise holes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub a: [f64; 2],
    pub b: [f64; 2],
}

/// The boundary of `shape` (2D) as segments of length at most `size`.
///
/// Each primitive's outline is divided evenly (a circle into at least 8 chords, vertices on
/// the circle); a piece of it is kept where the shape is on exactly one side of it, tested
/// just off the primitive's own boundary at the piece's middle (for a chord, the middle of
/// its arc). Where the outlines of two primitives of a union, intersection or
/// difference cross, the corner is therefore cut within one segment length (`close_gaps`
/// joins the pieces either side of it when neither piece across the corner was kept: a hole
/// cut through the plate's edge); outlines that do not cross (holes inside a plate) are
/// exact.
pub fn boundary_segments(shape: &Shape, size: f64) -> Result<Vec<Segment>, GeometryError> {
    if shape.dim()? != 2 {
        return Err(GeometryError::Invalid(
            "a boundary-fitted mesh needs a 2D shape".into(),
        ));
    }
    if !(size > 0.0 && size.is_finite()) {
        return Err(GeometryError::Invalid(format!(
            "the mesh size must be a positive length, not {size}"
        )));
    }
    let Some((lo, hi)) = shape.bounding_box() else {
        return Err(GeometryError::Invalid(
            "a boundary-fitted mesh needs a bounded shape (a half-plane must be cut by a bounded shape)"
                .into(),
        ));
    };
    // Half-planes are cut to the shape's bounds, widened so their pieces reach past them.
    let pad = 2.0 * size;
    let frame = ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad]);
    let mut outlines = Vec::new();
    collect_outlines(shape, size, frame, &mut outlines);
    let eps = 1e-6 * size;
    let mut kept = Vec::new();
    for outline in outlines {
        for (s, m) in outline {
            let (dx, dy) = (s.b[0] - s.a[0], s.b[1] - s.a[1]);
            let len = dx.hypot(dy);
            if len == 0.0 {
                continue;
            }
            let n = [-dy / len * eps, dx / len * eps];
            let left = shape.contains(&[m[0] + n[0], m[1] + n[1]]);
            let right = shape.contains(&[m[0] - n[0], m[1] - n[1]]);
            match (left, right) {
                (true, false) => kept.push(s),
                (false, true) => kept.push(Segment { a: s.b, b: s.a }),
                _ => {}
            }
        }
    }
    if kept.is_empty() {
        return Err(GeometryError::Invalid(
            "the shape has no boundary: is it empty?".into(),
        ));
    }
    close_gaps(&mut kept, size);
    Ok(kept)
}

/// Closes the boundary where two outlines cross and both pieces across the crossing were
/// dropped (a disk centred on the plate's edge: the edge's piece there lies in the disk, the
/// disk's chord there outside the plate). A piece whose end starts no other piece is joined
/// to the nearest piece start that ends no other, within three segment lengths: the corner
/// is cut by one chord, as where a piece across it is kept. Without it the boundary is open
/// there, and a mesher that tells inside from outside by the boundary finds no inside.
fn close_gaps(segments: &mut Vec<Segment>, size: f64) {
    let key = |p: [f64; 2]| (p[0].to_bits(), p[1].to_bits());
    let starts: std::collections::HashSet<_> = segments.iter().map(|s| key(s.a)).collect();
    let ends: std::collections::HashSet<_> = segments.iter().map(|s| key(s.b)).collect();
    let open_ends: Vec<[f64; 2]> = segments
        .iter()
        .map(|s| s.b)
        .filter(|b| !starts.contains(&key(*b)))
        .collect();
    // The pieces whose start ends no other piece.
    let mut open_starts: Vec<usize> = (0..segments.len())
        .filter(|&k| !ends.contains(&key(segments[k].a)))
        .collect();
    for b in open_ends {
        let distance = |k: usize| {
            let a = segments[k].a;
            (a[0] - b[0]).hypot(a[1] - b[1])
        };
        let nearest = (0..open_starts.len())
            .min_by(|&i, &j| distance(open_starts[i]).total_cmp(&distance(open_starts[j])));
        let Some(i) = nearest.filter(|&i| distance(open_starts[i]) <= 3.0 * size) else {
            continue;
        };
        let k = open_starts.swap_remove(i);
        if distance(k) <= 1e-6 * size {
            // The outlines meet at a point both pass through (a vertex of each) but for
            // rounding: one point, not a sliver of a segment the mesher cannot fit.
            segments[k].a = b;
        } else {
            let a = segments[k].a;
            segments.push(Segment { a: b, b: a });
        }
    }
}

/// Pieces of a primitive's outline, each with the point of the outline at its middle.
type Outline = Vec<(Segment, [f64; 2])>;

/// A closed polyline through `points`, each edge divided into pieces of at most `size`.
fn divided_loop(points: &[[f64; 2]], size: f64) -> Outline {
    let mut out = Vec::new();
    for k in 0..points.len() {
        let (a, b) = (points[k], points[(k + 1) % points.len()]);
        out.extend(divided(a, b, size).map(with_middle));
    }
    out
}

fn with_middle(s: Segment) -> (Segment, [f64; 2]) {
    (s, [0.5 * (s.a[0] + s.b[0]), 0.5 * (s.a[1] + s.b[1])])
}

/// The segment a–b divided evenly into pieces of at most `size`.
fn divided(a: [f64; 2], b: [f64; 2], size: f64) -> impl Iterator<Item = Segment> {
    let len = (b[0] - a[0]).hypot(b[1] - a[1]);
    let n = ((len / size).ceil() as usize).max(1);
    let at = move |k: usize| {
        if k == n {
            return b;
        }
        let t = k as f64 / n as f64;
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
    };
    (0..n).map(move |k| Segment {
        a: at(k),
        b: at(k + 1),
    })
}

/// The outlines of every primitive in `shape`'s tree.
fn collect_outlines(shape: &Shape, size: f64, frame: ([f64; 2], [f64; 2]), out: &mut Vec<Outline>) {
    match shape {
        Shape::Rectangle { min, max } => out.push(divided_loop(
            &[*min, [max[0], min[1]], *max, [min[0], max[1]]],
            size,
        )),
        Shape::Disk { center, radius } => {
            let n = ((std::f64::consts::TAU * radius / size).ceil() as usize).max(8);
            let at = |k: f64| {
                let t = std::f64::consts::TAU * k / n as f64;
                [center[0] + radius * t.cos(), center[1] + radius * t.sin()]
            };
            out.push(
                (0..n)
                    .map(|k| {
                        // The last chord ends exactly where the first starts.
                        let s = Segment {
                            a: at(k as f64),
                            b: at(((k + 1) % n) as f64),
                        };
                        (s, at(k as f64 + 0.5))
                    })
                    .collect(),
            );
        }
        Shape::Polygon { vertices } => out.push(divided_loop(vertices, size)),
        Shape::Slot { start, end, width } => {
            out.push(divided_loop(&super::slot_corners(start, end, *width), size))
        }
        Shape::HalfPlane { point, normal } => {
            if let Some((a, b)) = clip_line(*point, [-normal[1], normal[0]], frame) {
                out.push(divided(a, b, size).map(with_middle).collect());
            }
        }
        Shape::Union { shapes } | Shape::Intersection { shapes } => {
            for s in shapes {
                collect_outlines(s, size, frame, out);
            }
        }
        Shape::Difference { base, subtract } => {
            collect_outlines(base, size, frame, out);
            for s in subtract {
                collect_outlines(s, size, frame, out);
            }
        }
        // 3D shapes are refused before this.
        Shape::Box { .. }
        | Shape::Sphere { .. }
        | Shape::Cylinder { .. }
        | Shape::HalfSpace { .. } => {}
    }
}

/// The part of the line through `p` along `d` inside the rectangle `frame`.
fn clip_line(
    p: [f64; 2],
    d: [f64; 2],
    frame: ([f64; 2], [f64; 2]),
) -> Option<([f64; 2], [f64; 2])> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..2 {
        if d[k] == 0.0 {
            if p[k] < frame.0[k] || p[k] > frame.1[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((frame.0[k] - p[k]) / d[k], (frame.1[k] - p[k]) / d[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 < t1).then(|| {
        (
            [p[0] + t0 * d[0], p[1] + t0 * d[1]],
            [p[0] + t1 * d[0], p[1] + t1 * d[1]],
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn length(segments: &[Segment]) -> f64 {
        segments
            .iter()
            .map(|s| (s.b[0] - s.a[0]).hypot(s.b[1] - s.a[1]))
            .sum()
    }

    #[test]
    fn plate_with_a_hole_has_both_outlines_and_the_body_on_the_left() {
        let plate = Shape::Difference {
            base: Box::new(Shape::Rectangle {
                min: [0.0, 0.0],
                max: [4.0, 2.0],
            }),
            subtract: vec![Shape::Disk {
                center: [2.0, 1.0],
                radius: 0.5,
            }],
        };
        let s = boundary_segments(&plate, 0.1).unwrap();
        assert!(s
            .iter()
            .all(|s| (s.b[0] - s.a[0]).hypot(s.b[1] - s.a[1]) <= 0.1 + 1e-12));
        let chords = (std::f64::consts::TAU * 0.5 / 0.1).ceil();
        let circle = 2.0 * chords * 0.5 * (std::f64::consts::PI / chords).sin();
        assert!(
            (length(&s) - (12.0 + circle)).abs() < 1e-9,
            "{}",
            length(&s)
        );
        // Signed area by the shoelace formula: body on the left gives the plate minus the
        // inscribed polygon of the hole.
        let area: f64 = s
            .iter()
            .map(|s| 0.5 * (s.a[0] * s.b[1] - s.b[0] * s.a[1]))
            .sum();
        let hole = 0.5 * chords * 0.25 * (std::f64::consts::TAU / chords).sin();
        assert!((area - (8.0 - hole)).abs() < 1e-9, "{area}");
    }

    #[test]
    fn a_half_plane_cuts_a_disk() {
        let half_disk = Shape::Intersection {
            shapes: vec![
                Shape::Disk {
                    center: [0.0, 0.0],
                    radius: 1.0,
                },
                Shape::HalfPlane {
                    point: [0.0, 0.0],
                    normal: [0.0, -1.0],
                },
            ],
        };
        let s = boundary_segments(&half_disk, 0.05).unwrap();
        assert!(s.iter().all(|s| s.a[1] >= -1e-12 && s.b[1] >= -1e-12));
        let area: f64 = s
            .iter()
            .map(|s| 0.5 * (s.a[0] * s.b[1] - s.b[0] * s.a[1]))
            .sum();
        assert!((area - 0.5 * std::f64::consts::PI).abs() < 0.01, "{area}");
    }

    /// A hole through the plate's edge (a disk centred on it, a notch cut from outside) leaves
    /// a closed boundary: every piece's end starts another, and the enclosed area is the
    /// plate's less the part of the hole inside it, within the corners cut.
    #[test]
    fn a_hole_through_the_edge_leaves_a_closed_boundary() {
        let plate = |hole: Shape| Shape::Difference {
            base: Box::new(Shape::Rectangle {
                min: [0.0, 0.0],
                max: [10.0, 10.0],
            }),
            subtract: vec![hole],
        };
        let half_disk = 0.5 * std::f64::consts::PI * 4.0;
        for (hole, area) in [
            (
                Shape::Disk {
                    center: [5.0, 0.0],
                    radius: 2.0,
                },
                100.0 - half_disk,
            ),
            (
                Shape::Rectangle {
                    min: [4.0, -1.0],
                    max: [4.5, 3.0],
                },
                100.0 - 1.5,
            ),
        ] {
            let s = boundary_segments(&plate(hole), 0.3).unwrap();
            let starts: Vec<[f64; 2]> = s.iter().map(|s| s.a).collect();
            assert!(s.iter().all(|s| starts.contains(&s.b)), "an open end");
            // Where the outlines meet at a vertex of both but for rounding (the circle's
            // point at 180° on the edge y = 0), one point, no sliver the mesher cannot fit.
            let shortest = s
                .iter()
                .map(|s| (s.b[0] - s.a[0]).hypot(s.b[1] - s.a[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(shortest > 1e-3, "a sliver {shortest} long");
            let enclosed: f64 = s
                .iter()
                .map(|s| 0.5 * (s.a[0] * s.b[1] - s.b[0] * s.a[1]))
                .sum();
            assert!((enclosed - area).abs() < 0.3, "{enclosed} against {area}");
        }
    }

    #[test]
    fn bad_input_is_refused() {
        let disk = Shape::Disk {
            center: [0.0, 0.0],
            radius: 1.0,
        };
        assert!(boundary_segments(&disk, 0.0).is_err());
        let plane = Shape::HalfPlane {
            point: [0.0, 0.0],
            normal: [1.0, 0.0],
        };
        assert!(boundary_segments(&plane, 0.1).is_err());
        let ball = Shape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        };
        assert!(boundary_segments(&ball, 0.1).is_err());
    }
}
