//! Region shapes for peridyn decks: primitives in 2D and 3D combined by
//! constructive solid geometry (union, intersection, difference).
//!
//! A [`Shape`] is deserialised 1:1 from a TOML table whose `type` key names the
//! variant, e.g.
//!
//! ```toml
//! shape = { type = "difference", base = { type = "rectangle", min = [0, 0], max = [1, 1] }, subtract = [{ type = "disk", center = [0.5, 0.5], radius = 0.1 }] }
//! ```
//!
//! Call [`Shape::validate`] once after loading a deck; [`Shape::contains`] and
//! [`Shape::bounding_box`] assume a valid shape and never panic on an invalid
//! one, but their answers for it are unspecified.

pub mod boundary;
pub mod point_cloud;
pub mod pores;

use serde::{Deserialize, Deserializer, Serialize};
use thiserror::Error;

/// A 2D segment's far end as a deck gives it: `end`, or `length` and `angle` (degrees,
/// counter-clockwise from +x) from `start`, so that a notch's length and angle are one number
/// each (seed 004 Table 2's l_c and α_c, the factors of its screening).
pub fn segment_end(
    start: [f64; 2],
    end: Option<[f64; 2]>,
    length: Option<f64>,
    angle: Option<f64>,
) -> Result<[f64; 2], String> {
    match (end, length, angle) {
        (Some(end), None, None) => Ok(end),
        (None, Some(length), Some(angle)) => {
            let (sin, cos) = angle.to_radians().sin_cos();
            Ok([start[0] + length * cos, start[1] + length * sin])
        }
        _ => Err(
            "expected either `end` = [x, y] or both `length` (m) and `angle` (degrees from +x)"
                .into(),
        ),
    }
}

/// A segment as a deck writes it, a slot's or a pre-crack's: `start` and `end`, or `start`,
/// `length` and `angle` (`segment_end`); a slot's `width` too.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SegmentDeck {
    start: [f64; 2],
    end: Option<[f64; 2]>,
    length: Option<f64>,
    angle: Option<f64>,
    pub(crate) width: Option<f64>,
}

impl SegmentDeck {
    /// Its start and end, or the error a deck reader reports for `what` ("slot", "segment").
    pub(crate) fn ends<E: serde::de::Error>(&self, what: &str) -> Result<([f64; 2], [f64; 2]), E> {
        segment_end(self.start, self.end, self.length, self.angle)
            .map(|end| (self.start, end))
            .map_err(|e| E::custom(format!("{what}: {e}")))
    }
}

fn slot_from_deck<'de, D: Deserializer<'de>>(d: D) -> Result<([f64; 2], [f64; 2], f64), D::Error> {
    let s = SegmentDeck::deserialize(d)?;
    let (start, end) = s.ends("slot")?;
    let width = s
        .width
        .ok_or_else(|| serde::de::Error::missing_field("width"))?;
    Ok((start, end, width))
}

/// Why a shape is unusable; the message is meant for the person who wrote the deck.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum GeometryError {
    /// A field has a value outside its allowed range (bad radius, empty list, ...).
    #[error("{0}")]
    Invalid(String),
    /// Parts of a composite shape live in different dimensions (2D mixed with 3D).
    #[error("{0}")]
    DimensionMismatch(String),
}

/// A region of space, 2D or 3D. Boundaries are closed: points on them are inside.
///
/// In a [`Shape::Difference`] the subtracted shapes are closed too, so points on
/// the boundary of a hole are *not* part of the result.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// 2D axis-aligned rectangle `min <= p <= max`.
    Rectangle { min: [f64; 2], max: [f64; 2] },
    /// 3D axis-aligned box `min <= p <= max` (TOML: `type = "box"`).
    Box { min: [f64; 3], max: [f64; 3] },
    /// 2D closed disk.
    Disk { center: [f64; 2], radius: f64 },
    /// 3D closed ball.
    Sphere { center: [f64; 3], radius: f64 },
    /// 3D finite right circular cylinder from `base` to `base + axis`, capped.
    Cylinder {
        base: [f64; 3],
        axis: [f64; 3],
        radius: f64,
    },
    /// 2D simple polygon, vertices in either orientation, not repeated at the end.
    Polygon { vertices: Vec<[f64; 2]> },
    /// 2D rectangle of `width` centred on the segment from `start` to `end`, square at both
    /// ends: a notch of finite width (seed 004's b_c), cut out of a body with `difference`.
    /// A deck may give `length` and `angle` instead of `end` (`segment_end`).
    #[serde(deserialize_with = "slot_from_deck")]
    Slot {
        start: [f64; 2],
        end: [f64; 2],
        width: f64,
    },
    /// 2D half-plane `(p - point) · normal <= 0`: the normal points *out* of it.
    HalfPlane { point: [f64; 2], normal: [f64; 2] },
    /// 3D half-space `(p - point) · normal <= 0`: the normal points *out* of it.
    HalfSpace { point: [f64; 3], normal: [f64; 3] },
    /// Points inside any of `shapes`.
    Union { shapes: Vec<Shape> },
    /// Points inside all of `shapes`.
    Intersection { shapes: Vec<Shape> },
    /// Points inside `base` and inside none of `subtract`.
    Difference {
        base: std::boxed::Box<Shape>,
        subtract: Vec<Shape>,
    },
}

impl Shape {
    /// The axis-aligned square (D = 2) or cube (D = 3) `[0, side]^D`.
    pub fn cube(dim: usize, side: f64) -> Shape {
        if dim == 3 {
            Shape::Box {
                min: [0.0; 3],
                max: [side; 3],
            }
        } else {
            Shape::Rectangle {
                min: [0.0; 2],
                max: [side; 2],
            }
        }
    }

    /// The name used for this variant in decks (`type = "..."`).
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Rectangle { .. } => "rectangle",
            Shape::Box { .. } => "box",
            Shape::Disk { .. } => "disk",
            Shape::Sphere { .. } => "sphere",
            Shape::Cylinder { .. } => "cylinder",
            Shape::Polygon { .. } => "polygon",
            Shape::Slot { .. } => "slot",
            Shape::HalfPlane { .. } => "half_plane",
            Shape::HalfSpace { .. } => "half_space",
            Shape::Union { .. } => "union",
            Shape::Intersection { .. } => "intersection",
            Shape::Difference { .. } => "difference",
        }
    }

    /// Spatial dimension, 2 or 3. Composite shapes require every part to have
    /// the same dimension; an empty composite is an error.
    pub fn dim(&self) -> Result<usize, GeometryError> {
        self.dim_at(self.kind())
    }

    fn dim_at(&self, path: &str) -> Result<usize, GeometryError> {
        match self {
            Shape::Rectangle { .. }
            | Shape::Disk { .. }
            | Shape::Polygon { .. }
            | Shape::Slot { .. }
            | Shape::HalfPlane { .. } => Ok(2),
            Shape::Box { .. }
            | Shape::Sphere { .. }
            | Shape::Cylinder { .. }
            | Shape::HalfSpace { .. } => Ok(3),
            Shape::Union { shapes } | Shape::Intersection { shapes } => {
                let parts: Vec<(String, &Shape)> = shapes
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (format!("{path}.shapes[{i}]"), s))
                    .collect();
                common_dim(path, &parts)
            }
            Shape::Difference { base, subtract } => {
                let mut parts = vec![(format!("{path}.base"), base.as_ref())];
                parts.extend(
                    subtract
                        .iter()
                        .enumerate()
                        .map(|(i, s)| (format!("{path}.subtract[{i}]"), s)),
                );
                common_dim(path, &parts)
            }
        }
    }

    /// Checks every rule a usable shape must meet: all numbers finite, radii
    /// positive, `min < max` on every axis, polygons with at least 3 vertices
    /// and non-zero area, non-zero normals and cylinder axes, non-empty
    /// composites, and one dimension throughout. Self-intersection of polygons
    /// is not checked.
    pub fn validate(&self) -> Result<(), GeometryError> {
        self.validate_at(self.kind())?;
        self.dim().map(|_| ())
    }

    /// `path` locates this shape inside the root one, e.g. `difference.subtract[1]`.
    fn validate_at(&self, path: &str) -> Result<(), GeometryError> {
        let kind = self.kind();
        // Messages lead with "<kind> <field>" and add the location only when
        // the shape is nested, where the kind alone would be ambiguous.
        let at = if path == kind {
            String::new()
        } else {
            format!(" (at {path})")
        };
        let invalid = |msg: String| Err(GeometryError::Invalid(format!("{msg}{at}")));
        let finite = |field: &str, v: &[f64]| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                invalid(format!(
                    "{kind} {field} must contain only finite numbers, found {}",
                    fmt_vec(v)
                ))
            }
        };
        let radius_ok = |r: f64| {
            if r.is_finite() && r > 0.0 {
                Ok(())
            } else {
                invalid(format!(
                    "{kind} radius must be positive and finite, found {r}"
                ))
            }
        };
        let nonzero = |field: &str, v: &[f64]| {
            finite(field, v)?;
            if v.iter().any(|&x| x != 0.0) {
                Ok(())
            } else {
                invalid(format!(
                    "{kind} {field} must be a non-zero vector, found {}",
                    fmt_vec(v)
                ))
            }
        };
        let min_max = |min: &[f64], max: &[f64]| {
            finite("min", min)?;
            finite("max", max)?;
            for (axis, (lo, hi)) in min.iter().zip(max).enumerate() {
                if lo >= hi {
                    return invalid(format!(
                        "{kind} min must be less than max on every axis, found min {} and max {} (axis {})",
                        fmt_vec(min),
                        fmt_vec(max),
                        ["x", "y", "z"][axis]
                    ));
                }
            }
            Ok(())
        };

        match self {
            Shape::Rectangle { min, max } => min_max(min, max),
            Shape::Box { min, max } => min_max(min, max),
            Shape::Disk { center, radius } => {
                finite("center", center)?;
                radius_ok(*radius)
            }
            Shape::Sphere { center, radius } => {
                finite("center", center)?;
                radius_ok(*radius)
            }
            Shape::Cylinder { base, axis, radius } => {
                finite("base", base)?;
                nonzero("axis", axis)?;
                radius_ok(*radius)
            }
            Shape::Polygon { vertices } => {
                if vertices.len() < 3 {
                    return invalid(format!(
                        "polygon vertices must list at least 3 points, found {}",
                        vertices.len()
                    ));
                }
                for (i, v) in vertices.iter().enumerate() {
                    finite(&format!("vertices[{i}]"), v)?;
                }
                let area = polygon_area(vertices);
                if area == 0.0 || !area.is_finite() {
                    return invalid(format!(
                        "polygon vertices must enclose a non-zero area, found area {area} (are all points on one line?)"
                    ));
                }
                Ok(())
            }
            Shape::Slot { start, end, width } => {
                finite("start", start)?;
                finite("end", end)?;
                if start == end {
                    return invalid(format!(
                        "a slot needs two distinct ends, found {} twice",
                        fmt_vec(start)
                    ));
                }
                if !(*width > 0.0 && width.is_finite()) {
                    return invalid(format!("slot width must be > 0 (m), found {width}"));
                }
                Ok(())
            }
            Shape::HalfPlane { point, normal } => {
                finite("point", point)?;
                nonzero("normal", normal)
            }
            Shape::HalfSpace { point, normal } => {
                finite("point", point)?;
                nonzero("normal", normal)
            }
            Shape::Union { shapes } | Shape::Intersection { shapes } => {
                if shapes.is_empty() {
                    return invalid(format!(
                        "{kind} shapes must list at least one shape, found none"
                    ));
                }
                for (i, s) in shapes.iter().enumerate() {
                    s.validate_at(&format!("{path}.shapes[{i}]"))?;
                }
                Ok(())
            }
            Shape::Difference { base, subtract } => {
                base.validate_at(&format!("{path}.base"))?;
                if subtract.is_empty() {
                    return invalid(
                        "difference subtract must list at least one shape, found none (use the base shape on its own instead)".to_string(),
                    );
                }
                for (i, s) in subtract.iter().enumerate() {
                    s.validate_at(&format!("{path}.subtract[{i}]"))?;
                }
                Ok(())
            }
        }
    }

    /// Whether point `p` lies in the shape, boundary included.
    ///
    /// 2D shapes read `p[0]` and `p[1]` and ignore any further coordinate, so a
    /// 2D shape also accepts 3D positions stored with `z = 0`. 3D shapes need
    /// `p.len() >= 3`; shorter points (and points shorter than 2) are outside.
    pub fn contains(&self, p: &[f64]) -> bool {
        match self {
            Shape::Rectangle { min, max } => {
                p2(p).is_some_and(|q| (0..2).all(|i| min[i] <= q[i] && q[i] <= max[i]))
            }
            Shape::Box { min, max } => {
                p3(p).is_some_and(|q| (0..3).all(|i| min[i] <= q[i] && q[i] <= max[i]))
            }
            Shape::Disk { center, radius } => {
                p2(p).is_some_and(|q| norm2(&sub(&q, center)) <= radius * radius)
            }
            Shape::Sphere { center, radius } => {
                p3(p).is_some_and(|q| norm2(&sub(&q, center)) <= radius * radius)
            }
            Shape::Cylinder { base, axis, radius } => p3(p).is_some_and(|q| {
                let d = sub(&q, base);
                let a2 = norm2(axis);
                // Compare the unnormalised projection with |axis|² so the caps
                // need no division.
                let s = dot(&d, axis);
                if !(0.0..=a2).contains(&s) {
                    return false;
                }
                let t = s / a2;
                let perp = [d[0] - t * axis[0], d[1] - t * axis[1], d[2] - t * axis[2]];
                norm2(&perp) <= radius * radius
            }),
            Shape::Polygon { vertices } => p2(p).is_some_and(|q| polygon_contains(vertices, q)),
            Shape::Slot { start, end, width } => p2(p).is_some_and(|q| {
                let axis = sub(end, start);
                let d = sub(&q, start);
                // Along: 0 ≤ d·a ≤ |a|²; across: |d × a| ≤ (w/2)|a|, without a division.
                let along = dot(&d, &axis);
                let across = d[0] * axis[1] - d[1] * axis[0];
                let a2 = norm2(&axis);
                (0.0..=a2).contains(&along) && across * across <= 0.25 * width * width * a2
            }),
            Shape::HalfPlane { point, normal } => {
                p2(p).is_some_and(|q| dot(&sub(&q, point), normal) <= 0.0)
            }
            Shape::HalfSpace { point, normal } => {
                p3(p).is_some_and(|q| dot(&sub(&q, point), normal) <= 0.0)
            }
            Shape::Union { shapes } => shapes.iter().any(|s| s.contains(p)),
            Shape::Intersection { shapes } => {
                !shapes.is_empty() && shapes.iter().all(|s| s.contains(p))
            }
            Shape::Difference { base, subtract } => {
                base.contains(p) && !subtract.iter().any(|s| s.contains(p))
            }
        }
    }

    /// Axis-aligned bounds `(min, max)` with one entry per dimension, or `None`
    /// when the shape is unbounded (a half-plane or half-space, a union with an
    /// unbounded part, an intersection of only unbounded parts) or an empty
    /// union/intersection.
    ///
    /// The bounds of an intersection are the overlap of its bounded parts; if
    /// those do not overlap, `min > max` on some axis, which signals an empty
    /// shape. A difference reports its base's bounds. The cylinder's bounds are
    /// exact (the hull of its two end disks).
    pub fn bounding_box(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        match self {
            Shape::Rectangle { min, max } => Some((min.to_vec(), max.to_vec())),
            Shape::Box { min, max } => Some((min.to_vec(), max.to_vec())),
            Shape::Disk { center, radius } => Some(ball_bounds(center, *radius)),
            Shape::Sphere { center, radius } => Some(ball_bounds(center, *radius)),
            Shape::Cylinder { base, axis, radius } => {
                let len = norm2(axis).sqrt();
                let mut lo = vec![0.0; 3];
                let mut hi = vec![0.0; 3];
                for i in 0..3 {
                    // An end disk extends r·sqrt(1 - (a_i/|a|)²) along axis i.
                    let c = axis[i] / len;
                    let e = radius * (1.0 - c * c).max(0.0).sqrt();
                    let (a, b) = (base[i], base[i] + axis[i]);
                    lo[i] = a.min(b) - e;
                    hi[i] = a.max(b) + e;
                }
                Some((lo, hi))
            }
            Shape::Polygon { vertices } => {
                let first = vertices.first()?;
                let (mut lo, mut hi) = (first.to_vec(), first.to_vec());
                for v in vertices {
                    for i in 0..2 {
                        lo[i] = lo[i].min(v[i]);
                        hi[i] = hi[i].max(v[i]);
                    }
                }
                Some((lo, hi))
            }
            Shape::Slot { start, end, width } => Shape::Polygon {
                vertices: slot_corners(start, end, *width).to_vec(),
            }
            .bounding_box(),
            Shape::HalfPlane { .. } | Shape::HalfSpace { .. } => None,
            Shape::Union { shapes } => {
                let mut acc: Option<(Vec<f64>, Vec<f64>)> = None;
                for s in shapes {
                    let (lo, hi) = s.bounding_box()?;
                    acc = Some(match acc {
                        None => (lo, hi),
                        Some((alo, ahi)) => (
                            alo.iter().zip(&lo).map(|(a, b)| a.min(*b)).collect(),
                            ahi.iter().zip(&hi).map(|(a, b)| a.max(*b)).collect(),
                        ),
                    });
                }
                acc
            }
            Shape::Intersection { shapes } => {
                let mut acc: Option<(Vec<f64>, Vec<f64>)> = None;
                for (lo, hi) in shapes.iter().filter_map(Shape::bounding_box) {
                    acc = Some(match acc {
                        None => (lo, hi),
                        Some((alo, ahi)) => (
                            alo.iter().zip(&lo).map(|(a, b)| a.max(*b)).collect(),
                            ahi.iter().zip(&hi).map(|(a, b)| a.min(*b)).collect(),
                        ),
                    });
                }
                acc
            }
            Shape::Difference { base, .. } => base.bounding_box(),
        }
    }
}

/// The one dimension shared by `parts` (each with its location for messages).
fn common_dim(path: &str, parts: &[(String, &Shape)]) -> Result<usize, GeometryError> {
    let mut first: Option<(usize, &str, &Shape)> = None;
    for (loc, s) in parts {
        let d = s.dim_at(loc)?;
        match first {
            None => first = Some((d, loc, s)),
            Some((d0, loc0, s0)) if d0 != d => {
                return Err(GeometryError::DimensionMismatch(format!(
                    "{path} mixes dimensions: {loc0} is a {d0}D {} but {loc} is a {d}D {}; expected all parts to be 2D or all 3D",
                    s0.kind(),
                    s.kind()
                )));
            }
            Some(_) => {}
        }
    }
    first.map(|(d, _, _)| d).ok_or_else(|| {
        GeometryError::Invalid(format!(
            "{path} has no shapes, so its dimension is undefined; expected at least one shape"
        ))
    })
}

fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| x.to_string()).collect();
    format!("[{}]", parts.join(", "))
}

fn p2(p: &[f64]) -> Option<[f64; 2]> {
    (p.len() >= 2).then(|| [p[0], p[1]])
}

fn p3(p: &[f64]) -> Option<[f64; 3]> {
    (p.len() >= 3).then(|| [p[0], p[1], p[2]])
}

/// A slot's four corners, counter-clockwise from the one beside `start` on the right of the
/// direction start → end.
pub fn slot_corners(start: &[f64; 2], end: &[f64; 2], width: f64) -> [[f64; 2]; 4] {
    let axis = sub(end, start);
    let h = 0.5 * width / norm2(&axis).sqrt();
    let n = [-axis[1] * h, axis[0] * h];
    [
        [start[0] - n[0], start[1] - n[1]],
        [end[0] - n[0], end[1] - n[1]],
        [end[0] + n[0], end[1] + n[1]],
        [start[0] + n[0], start[1] + n[1]],
    ]
}

fn sub<const N: usize>(a: &[f64; N], b: &[f64; N]) -> [f64; N] {
    std::array::from_fn(|i| a[i] - b[i])
}

fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm2<const N: usize>(a: &[f64; N]) -> f64 {
    dot(a, a)
}

fn ball_bounds(center: &[f64], r: f64) -> (Vec<f64>, Vec<f64>) {
    (
        center.iter().map(|c| c - r).collect(),
        center.iter().map(|c| c + r).collect(),
    )
}

/// Signed shoelace area (positive for counter-clockwise vertices).
fn polygon_area(v: &[[f64; 2]]) -> f64 {
    let n = v.len();
    let twice: f64 = (0..n)
        .map(|i| {
            let (a, b) = (v[i], v[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    0.5 * twice
}

/// Even-odd crossing test, with points exactly on an edge counted as inside.
fn polygon_contains(v: &[[f64; 2]], q: [f64; 2]) -> bool {
    let n = v.len();
    if n < 3 {
        return false;
    }
    let mut inside = false;
    for i in 0..n {
        let a = v[i];
        let b = v[(i + 1) % n];
        // On-edge check first: the crossing test alone is arbitrary there.
        let cross = (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]);
        if cross == 0.0
            && a[0].min(b[0]) <= q[0]
            && q[0] <= a[0].max(b[0])
            && a[1].min(b[1]) <= q[1]
            && q[1] <= a[1].max(b[1])
        {
            return true;
        }
        // Half-open rule on y so a ray through a vertex is counted once.
        if (a[1] > q[1]) != (b[1] > q[1]) {
            let x = a[0] + (q[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if q[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Shape {
        Shape::Rectangle {
            min: [x0, y0],
            max: [x1, y1],
        }
    }

    fn disk(cx: f64, cy: f64, r: f64) -> Shape {
        Shape::Disk {
            center: [cx, cy],
            radius: r,
        }
    }

    fn err(s: &Shape) -> String {
        match s.validate() {
            Ok(()) => panic!("expected {s:?} to be invalid"),
            Err(e) => e.to_string(),
        }
    }

    #[derive(Debug, Deserialize)]
    struct Wrapper {
        shape: Shape,
    }

    fn from_toml(text: &str) -> Result<Shape, toml::de::Error> {
        toml::from_str::<Wrapper>(text).map(|w| w.shape)
    }

    // ---- primitives ----

    #[test]
    fn rectangle_contains() {
        let r = rect(0.0, 0.0, 2.0, 1.0);
        assert!(r.contains(&[1.0, 0.5]));
        assert!(!r.contains(&[2.1, 0.5]));
        assert!(!r.contains(&[1.0, -0.1]));
        assert!(r.contains(&[2.0, 0.5]), "edge");
        assert!(r.contains(&[0.0, 0.0]), "corner");
        assert!(r.contains(&[1.0, 0.5, 7.0]), "2D shape ignores z");
        assert!(!r.contains(&[1.0]), "too short");
    }

    #[test]
    fn box_contains() {
        let b = Shape::Box {
            min: [0.0; 3],
            max: [1.0, 2.0, 3.0],
        };
        assert!(b.contains(&[0.5, 1.0, 1.5]));
        assert!(!b.contains(&[0.5, 1.0, 3.5]));
        assert!(b.contains(&[1.0, 2.0, 3.0]));
        assert!(!b.contains(&[0.5, 1.0]), "3D shape needs z");
    }

    #[test]
    fn disk_contains() {
        let d = disk(1.0, 1.0, 0.5);
        assert!(d.contains(&[1.2, 1.1]));
        assert!(!d.contains(&[1.4, 1.4]));
        assert!(d.contains(&[1.5, 1.0]));
        assert!(d.contains(&[1.0, 0.5]));
    }

    #[test]
    fn sphere_contains() {
        let s = Shape::Sphere {
            center: [0.0; 3],
            radius: 2.0,
        };
        assert!(s.contains(&[1.0, 1.0, 1.0]));
        assert!(!s.contains(&[1.2, 1.2, 1.2]));
        assert!(s.contains(&[0.0, 0.0, -2.0]));
    }

    #[test]
    fn cylinder_axis_aligned() {
        let c = Shape::Cylinder {
            base: [0.0; 3],
            axis: [0.0, 0.0, 2.0],
            radius: 1.0,
        };
        assert!(c.contains(&[0.5, 0.5, 1.0]));
        assert!(c.contains(&[1.0, 0.0, 1.0]), "side");
        assert!(c.contains(&[0.0, 0.0, 2.0]), "top cap");
        assert!(c.contains(&[0.0, 1.0, 0.0]), "bottom rim");
        assert!(!c.contains(&[0.0, 0.0, 2.01]));
        assert!(!c.contains(&[0.0, 0.0, -0.01]));
        assert!(!c.contains(&[0.8, 0.8, 1.0]));
    }

    #[test]
    fn cylinder_oblique_axis() {
        // Axis along (1,1,1), length sqrt(3)·3, radius 0.5.
        let c = Shape::Cylinder {
            base: [1.0, 1.0, 1.0],
            axis: [3.0, 3.0, 3.0],
            radius: 0.5,
        };
        assert!(c.contains(&[2.5, 2.5, 2.5]), "on the axis");
        assert!(c.contains(&[1.0, 1.0, 1.0]), "base centre");
        assert!(c.contains(&[4.0, 4.0, 4.0]), "top centre");
        assert!(!c.contains(&[4.1, 4.1, 4.1]), "beyond the top");
        assert!(!c.contains(&[0.9, 0.9, 0.9]), "before the base");
        // (1,-1,0)/sqrt2 is perpendicular to the axis.
        let u = [1.0 / 2f64.sqrt(), -1.0 / 2f64.sqrt(), 0.0];
        let at = |s: f64| [2.5 + s * u[0], 2.5 + s * u[1], 2.5];
        assert!(c.contains(&at(0.49)));
        assert!(!c.contains(&at(0.51)));
        // Inside the infinite cylinder's radius but off the end, near the top rim.
        assert!(!c.contains(&[4.0 + 0.3 + 0.05, 4.0 - 0.3 + 0.05, 4.05]));
        // Axis-aligned box test would wrongly include this corner point.
        assert!(!c.contains(&[1.0, 4.0, 1.0]));
    }

    #[test]
    fn polygon_concave_l_shape() {
        // L-shape: 2x2 square with the top-right 1x1 quadrant removed.
        let l = Shape::Polygon {
            vertices: vec![
                [0.0, 0.0],
                [2.0, 0.0],
                [2.0, 1.0],
                [1.0, 1.0],
                [1.0, 2.0],
                [0.0, 2.0],
            ],
        };
        assert!(l.contains(&[0.5, 0.5]));
        assert!(l.contains(&[1.5, 0.5]));
        assert!(l.contains(&[0.5, 1.5]));
        assert!(!l.contains(&[1.5, 1.5]), "the notch");
        assert!(!l.contains(&[2.5, 0.5]));
        assert!(!l.contains(&[-0.5, 1.0]));
        assert!(l.contains(&[1.5, 1.0]), "inner edge");
        assert!(l.contains(&[1.0, 1.5]), "inner edge");
        assert!(l.contains(&[1.0, 1.0]), "reflex vertex");
        assert!(l.contains(&[2.0, 0.0]), "convex vertex");
        assert!(
            l.contains(&[0.0, 1.0]),
            "outer edge through a ray at a vertex height"
        );
        // Same set clockwise.
        let mut cw = l.clone();
        if let Shape::Polygon { vertices } = &mut cw {
            vertices.reverse();
        }
        for p in [[0.5, 0.5], [1.5, 1.5], [1.5, 1.0], [0.5, 1.0], [2.0, 1.0]] {
            assert_eq!(l.contains(&p), cw.contains(&p), "{p:?}");
        }
    }

    #[test]
    fn polygon_oblique_edge() {
        let tri = Shape::Polygon {
            vertices: vec![[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]],
        };
        assert!(tri.contains(&[1.0, 1.0]));
        assert!(tri.contains(&[2.0, 2.0]), "on the hypotenuse, exact");
        assert!(!tri.contains(&[2.1, 2.0]));
    }

    #[test]
    fn half_plane_orientation() {
        // Normal +x at x = 1: inside is x <= 1.
        let h = Shape::HalfPlane {
            point: [1.0, 0.0],
            normal: [1.0, 0.0],
        };
        assert!(h.contains(&[0.0, 100.0]));
        assert!(h.contains(&[1.0, -5.0]), "boundary");
        assert!(!h.contains(&[1.5, 0.0]));
        // Oblique normal (1,1) through the origin: inside is x + y <= 0.
        let o = Shape::HalfPlane {
            point: [0.0, 0.0],
            normal: [1.0, 1.0],
        };
        assert!(o.contains(&[-1.0, 0.5]));
        assert!(!o.contains(&[1.0, -0.5]));
    }

    #[test]
    fn half_space_orientation() {
        let h = Shape::HalfSpace {
            point: [0.0, 0.0, 2.0],
            normal: [0.0, 0.0, -1.0],
        };
        assert!(h.contains(&[0.0, 0.0, 3.0]));
        assert!(h.contains(&[5.0, 5.0, 2.0]));
        assert!(!h.contains(&[0.0, 0.0, 1.0]));
    }

    // ---- CSG ----

    #[test]
    fn plate_with_hole() {
        let plate = Shape::Difference {
            base: std::boxed::Box::new(rect(0.0, 0.0, 1.0, 1.0)),
            subtract: vec![disk(0.5, 0.5, 0.1)],
        };
        assert!(plate.validate().is_ok());
        assert!(plate.contains(&[0.1, 0.1]));
        assert!(!plate.contains(&[0.5, 0.5]), "inside the hole");
        assert!(
            !plate.contains(&[0.6, 0.5]),
            "hole boundary belongs to the hole"
        );
        assert!(plate.contains(&[0.61, 0.5]));
        assert!(plate.contains(&[1.0, 1.0]), "outer boundary");
        assert!(!plate.contains(&[1.1, 0.5]));
    }

    #[test]
    fn plate_with_notch() {
        // Thin pre-crack from the left edge to the middle.
        let plate = Shape::Difference {
            base: std::boxed::Box::new(rect(0.0, 0.0, 1.0, 1.0)),
            subtract: vec![rect(-0.1, 0.499, 0.5, 0.501)],
        };
        assert!(!plate.contains(&[0.25, 0.5]));
        assert!(!plate.contains(&[0.0, 0.5]));
        assert!(plate.contains(&[0.25, 0.49]));
        assert!(plate.contains(&[0.25, 0.51]));
        assert!(plate.contains(&[0.75, 0.5]), "ahead of the notch tip");
    }

    #[test]
    fn union_and_intersection() {
        let a = rect(0.0, 0.0, 2.0, 1.0);
        let b = disk(2.0, 0.5, 0.5);
        let u = Shape::Union {
            shapes: vec![a.clone(), b.clone()],
        };
        let i = Shape::Intersection { shapes: vec![a, b] };
        assert!(u.contains(&[0.5, 0.5]));
        assert!(u.contains(&[2.4, 0.5]));
        assert!(!u.contains(&[2.6, 0.5]));
        assert!(!i.contains(&[0.5, 0.5]));
        assert!(i.contains(&[1.8, 0.5]));
        assert!(i.contains(&[2.0, 0.5]), "shared boundary");
        assert!(!i.contains(&[2.1, 0.5]));
    }

    #[test]
    fn nested_csg_3d() {
        // A block clipped by a half-space, with a cylindrical hole drilled through.
        let s = Shape::Difference {
            base: std::boxed::Box::new(Shape::Intersection {
                shapes: vec![
                    Shape::Box {
                        min: [0.0; 3],
                        max: [2.0; 3],
                    },
                    Shape::HalfSpace {
                        point: [0.0, 0.0, 1.0],
                        normal: [0.0, 0.0, 1.0],
                    },
                ],
            }),
            subtract: vec![Shape::Cylinder {
                base: [1.0, 1.0, -1.0],
                axis: [0.0, 0.0, 3.0],
                radius: 0.25,
            }],
        };
        assert_eq!(s.dim(), Ok(3));
        assert!(s.validate().is_ok());
        assert!(s.contains(&[0.5, 0.5, 0.5]));
        assert!(!s.contains(&[0.5, 0.5, 1.5]), "cut by the half-space");
        assert!(!s.contains(&[1.0, 1.1, 0.5]), "in the hole");
        assert_eq!(
            s.bounding_box(),
            Some((vec![0.0; 3], vec![2.0; 3])),
            "difference reports its base's bounds"
        );
    }

    // ---- bounding boxes ----

    #[test]
    fn bounding_boxes_of_primitives() {
        assert_eq!(
            rect(0.0, 1.0, 2.0, 3.0).bounding_box(),
            Some((vec![0.0, 1.0], vec![2.0, 3.0]))
        );
        assert_eq!(
            disk(1.0, 2.0, 0.5).bounding_box(),
            Some((vec![0.5, 1.5], vec![1.5, 2.5]))
        );
        let poly = Shape::Polygon {
            vertices: vec![[0.0, 0.0], [3.0, 1.0], [-1.0, 2.0]],
        };
        assert_eq!(poly.bounding_box(), Some((vec![-1.0, 0.0], vec![3.0, 2.0])));
        let sph = Shape::Sphere {
            center: [1.0, 1.0, 1.0],
            radius: 1.0,
        };
        assert_eq!(sph.bounding_box(), Some((vec![0.0; 3], vec![2.0; 3])));
        let hp = Shape::HalfPlane {
            point: [0.0, 0.0],
            normal: [1.0, 0.0],
        };
        assert_eq!(hp.bounding_box(), None);
    }

    #[test]
    fn bounding_box_of_cylinder() {
        let c = Shape::Cylinder {
            base: [0.0; 3],
            axis: [0.0, 0.0, 2.0],
            radius: 1.0,
        };
        assert_eq!(
            c.bounding_box(),
            Some((vec![-1.0, -1.0, 0.0], vec![1.0, 1.0, 2.0]))
        );
        // Oblique: every point must lie inside the reported box.
        let c = Shape::Cylinder {
            base: [1.0, 0.0, -1.0],
            axis: [1.0, 2.0, 2.0],
            radius: 0.5,
        };
        let (lo, hi) = c.bounding_box().expect("bounded");
        let r = 0.5;
        // End-disk extents along x: r·sqrt(1 - (1/3)²).
        let ex = r * (1.0f64 - 1.0 / 9.0).sqrt();
        assert!((lo[0] - (1.0 - ex)).abs() < 1e-12);
        assert!((hi[0] - (2.0 + ex)).abs() < 1e-12);
        let n = 20;
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    let p = [
                        lo[0] - 0.1 + (hi[0] - lo[0] + 0.2) * i as f64 / n as f64,
                        lo[1] - 0.1 + (hi[1] - lo[1] + 0.2) * j as f64 / n as f64,
                        lo[2] - 0.1 + (hi[2] - lo[2] + 0.2) * k as f64 / n as f64,
                    ];
                    if c.contains(&p) {
                        assert!((0..3).all(|a| lo[a] <= p[a] && p[a] <= hi[a]), "{p:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn bounding_boxes_of_composites() {
        let hp = Shape::HalfPlane {
            point: [0.5, 0.0],
            normal: [1.0, 0.0],
        };
        let u = Shape::Union {
            shapes: vec![rect(0.0, 0.0, 1.0, 1.0), disk(2.0, 0.0, 0.5)],
        };
        assert_eq!(u.bounding_box(), Some((vec![0.0, -0.5], vec![2.5, 1.0])));
        let u_open = Shape::Union {
            shapes: vec![rect(0.0, 0.0, 1.0, 1.0), hp.clone()],
        };
        assert_eq!(u_open.bounding_box(), None);
        let i = Shape::Intersection {
            shapes: vec![
                rect(0.0, 0.0, 2.0, 2.0),
                hp.clone(),
                rect(1.0, -1.0, 3.0, 1.0),
            ],
        };
        assert_eq!(
            i.bounding_box(),
            Some((vec![1.0, 0.0], vec![2.0, 1.0])),
            "half-plane ignored, bounded parts intersected"
        );
        let i_open = Shape::Intersection {
            shapes: vec![hp.clone(), hp],
        };
        assert_eq!(i_open.bounding_box(), None);
    }

    // ---- dimension ----

    #[test]
    fn dimension_of_shapes() {
        assert_eq!(rect(0.0, 0.0, 1.0, 1.0).dim(), Ok(2));
        let u = Shape::Union {
            shapes: vec![
                rect(0.0, 0.0, 1.0, 1.0),
                Shape::Sphere {
                    center: [0.0; 3],
                    radius: 1.0,
                },
            ],
        };
        let e = u.dim().unwrap_err().to_string();
        assert_eq!(
            e,
            "union mixes dimensions: union.shapes[0] is a 2D rectangle but union.shapes[1] is a 3D sphere; expected all parts to be 2D or all 3D"
        );
        assert!(u.validate().is_err());
        let d = Shape::Difference {
            base: std::boxed::Box::new(rect(0.0, 0.0, 1.0, 1.0)),
            subtract: vec![Shape::HalfSpace {
                point: [0.0; 3],
                normal: [1.0, 0.0, 0.0],
            }],
        };
        assert!(matches!(d.dim(), Err(GeometryError::DimensionMismatch(_))));
    }

    // ---- validation, one test per rule ----

    #[test]
    fn invalid_radius() {
        assert_eq!(
            err(&disk(0.0, 0.0, -1.0)),
            "disk radius must be positive and finite, found -1"
        );
        assert_eq!(
            err(&disk(0.0, 0.0, 0.0)),
            "disk radius must be positive and finite, found 0"
        );
        let s = Shape::Sphere {
            center: [0.0; 3],
            radius: f64::INFINITY,
        };
        assert_eq!(
            err(&s),
            "sphere radius must be positive and finite, found inf"
        );
    }

    #[test]
    fn invalid_min_max() {
        assert_eq!(
            err(&rect(0.0, 1.0, 1.0, 1.0)),
            "rectangle min must be less than max on every axis, found min [0, 1] and max [1, 1] (axis y)"
        );
        let b = Shape::Box {
            min: [0.0, 0.0, 2.0],
            max: [1.0, 1.0, 1.0],
        };
        assert!(err(&b).contains("(axis z)"));
    }

    #[test]
    fn invalid_non_finite_number() {
        assert_eq!(
            err(&disk(f64::NAN, 0.0, 1.0)),
            "disk center must contain only finite numbers, found [NaN, 0]"
        );
    }

    #[test]
    fn invalid_polygon_too_few_vertices() {
        let p = Shape::Polygon {
            vertices: vec![[0.0, 0.0], [1.0, 0.0]],
        };
        assert_eq!(
            err(&p),
            "polygon vertices must list at least 3 points, found 2"
        );
    }

    #[test]
    fn invalid_polygon_zero_area() {
        let p = Shape::Polygon {
            vertices: vec![[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]],
        };
        assert!(err(&p).starts_with("polygon vertices must enclose a non-zero area, found area 0"));
    }

    #[test]
    fn slot_is_the_rectangle_of_its_width_about_its_segment() {
        // A 3-4-5 segment from (1, 1) to (4, 5), 0.4 wide: unit direction (0.6, 0.8), normal
        // (−0.8, 0.6).
        let slot = Shape::Slot {
            start: [1.0, 1.0],
            end: [4.0, 5.0],
            width: 0.4,
        };
        let at = |s: f64, r: f64| [1.0 + 0.6 * s - 0.8 * r, 1.0 + 0.8 * s + 0.6 * r];
        for (s, r, inside) in [
            (2.5, 0.0, true),
            (2.5, 0.19, true),
            (2.5, -0.19, true),
            (2.5, 0.21, false),
            (2.5, -0.21, false),
            (0.01, 0.1, true),
            (-0.01, 0.0, false),
            (4.99, -0.1, true),
            (5.01, 0.0, false),
        ] {
            assert_eq!(slot.contains(&at(s, r)), inside, "s = {s}, r = {r}");
        }
        let corners = slot_corners(&[1.0, 1.0], &[4.0, 5.0], 0.4);
        for (c, (s, r)) in corners
            .iter()
            .zip([(0.0, -0.2), (5.0, -0.2), (5.0, 0.2), (0.0, 0.2)])
        {
            let expected = at(s, r);
            assert!((c[0] - expected[0]).abs() < 1e-12 && (c[1] - expected[1]).abs() < 1e-12);
        }
        let (lo, hi) = slot.bounding_box().unwrap();
        assert!((lo[0] - (1.0 - 0.16)).abs() < 1e-12 && (hi[1] - (5.0 + 0.12)).abs() < 1e-12);
        assert_eq!(slot.dim(), Ok(2));
        // Cut from a plate: the notch's nodes are gone, the plate's beside it stay.
        let plate = Shape::Difference {
            base: std::boxed::Box::new(Shape::Rectangle {
                min: [0.0, 0.0],
                max: [6.0, 6.0],
            }),
            subtract: vec![slot.clone()],
        };
        assert!(!plate.contains(&at(2.5, 0.0)) && plate.contains(&at(2.5, 0.3)));
    }

    /// A slot given by its length and angle is the slot to the end they point at: the 3-4-5
    /// segment above, 5 long at atan2(4, 3) = 53.13°.
    #[test]
    fn slot_by_length_and_angle_ends_where_they_point() {
        let angle = 4.0f64.atan2(3.0).to_degrees();
        let text = format!(
            "shape = {{ type = \"slot\", start = [1.0, 1.0], length = 5.0, angle = {angle}, width = 0.4 }}"
        );
        let Ok(Shape::Slot { start, end, width }) = from_toml(&text) else {
            panic!("{text}");
        };
        assert_eq!((start, width), ([1.0, 1.0], 0.4));
        assert!(
            (end[0] - 4.0).abs() < 1e-12 && (end[1] - 5.0).abs() < 1e-12,
            "{end:?}"
        );
        // Left of −x, 33° below it (seed 004's notch direction): 213° from +x.
        let end = segment_end([0.0, 0.0], None, Some(2.0), Some(213.0)).unwrap();
        let (c, s) = (33f64.to_radians().cos(), 33f64.to_radians().sin());
        assert!((end[0] + 2.0 * c).abs() < 1e-12 && (end[1] + 2.0 * s).abs() < 1e-12);
        for (end, length, angle) in [
            (Some([1.0, 1.0]), Some(1.0), Some(0.0)),
            (None, Some(1.0), None),
            (None, None, Some(1.0)),
            (None, None, None),
        ] {
            assert!(segment_end([0.0, 0.0], end, length, angle).is_err());
        }
    }

    #[test]
    fn invalid_slot() {
        let slot = |end: [f64; 2], width: f64| Shape::Slot {
            start: [0.0, 0.0],
            end,
            width,
        };
        assert!(err(&slot([0.0, 0.0], 1.0)).contains("two distinct ends"));
        assert!(err(&slot([1.0, 0.0], 0.0)).contains("slot width must be > 0"));
        assert!(err(&slot([1.0, f64::NAN], 1.0)).contains("end"));
        assert!(slot([1.0, 0.0], 0.1).validate().is_ok());
    }

    #[test]
    fn invalid_zero_normal() {
        let h = Shape::HalfPlane {
            point: [0.0, 0.0],
            normal: [0.0, 0.0],
        };
        assert_eq!(
            err(&h),
            "half_plane normal must be a non-zero vector, found [0, 0]"
        );
    }

    #[test]
    fn invalid_cylinder_axis() {
        let c = Shape::Cylinder {
            base: [0.0; 3],
            axis: [0.0; 3],
            radius: 1.0,
        };
        assert_eq!(
            err(&c),
            "cylinder axis must be a non-zero vector, found [0, 0, 0]"
        );
    }

    #[test]
    fn invalid_empty_composite() {
        assert_eq!(
            err(&Shape::Union { shapes: vec![] }),
            "union shapes must list at least one shape, found none"
        );
        assert_eq!(
            err(&Shape::Intersection { shapes: vec![] }),
            "intersection shapes must list at least one shape, found none"
        );
        let d = Shape::Difference {
            base: std::boxed::Box::new(rect(0.0, 0.0, 1.0, 1.0)),
            subtract: vec![],
        };
        assert!(err(&d).starts_with("difference subtract must list at least one shape"));
    }

    #[test]
    fn invalid_nested_shape_is_located() {
        let d = Shape::Difference {
            base: std::boxed::Box::new(rect(0.0, 0.0, 1.0, 1.0)),
            subtract: vec![
                disk(0.2, 0.2, 0.1),
                Shape::Union {
                    shapes: vec![disk(0.5, 0.5, -0.1)],
                },
            ],
        };
        assert_eq!(
            err(&d),
            "disk radius must be positive and finite, found -0.1 (at difference.subtract[1].shapes[0])"
        );
    }

    // ---- deserialisation ----

    #[test]
    fn toml_difference() {
        let s = from_toml(
            r#"shape = { type = "difference", base = { type = "rectangle", min = [0,0], max = [1,1] }, subtract = [{ type = "disk", center = [0.5,0.5], radius = 0.1 }] }"#,
        )
        .expect("valid deck");
        assert_eq!(
            s,
            Shape::Difference {
                base: std::boxed::Box::new(rect(0.0, 0.0, 1.0, 1.0)),
                subtract: vec![disk(0.5, 0.5, 0.1)],
            }
        );
        assert!(s.validate().is_ok());
    }

    #[test]
    fn toml_every_variant_name() {
        let text = r#"
            [shape]
            type = "union"
            [[shape.shapes]]
            type = "box"
            min = [0, 0, 0]
            max = [1, 1, 1]
            [[shape.shapes]]
            type = "sphere"
            center = [0, 0, 0]
            radius = 1
            [[shape.shapes]]
            type = "cylinder"
            base = [0, 0, 0]
            axis = [0, 0, 1]
            radius = 0.5
            [[shape.shapes]]
            type = "half_space"
            point = [0, 0, 0]
            normal = [0, 0, 1]
            [[shape.shapes]]
            type = "intersection"
            shapes = [{ type = "box", min = [0, 0, 0], max = [1, 1, 1] }]
        "#;
        let s = from_toml(text).expect("valid deck");
        assert_eq!(s.dim(), Ok(3));
        assert!(s.validate().is_ok());
        let text2 = r#"shape = { type = "union", shapes = [
            { type = "polygon", vertices = [[0, 0], [1, 0], [0, 1]] },
            { type = "half_plane", point = [0, 0], normal = [0, 1] },
            { type = "slot", start = [0, 0], end = [1, 0], width = 0.1 },
        ] }"#;
        let s2 = from_toml(text2).expect("valid deck");
        assert_eq!(s2.dim(), Ok(2));
    }

    #[test]
    fn toml_round_trip() {
        let s = Shape::Union {
            shapes: vec![
                disk(0.0, 0.0, 1.0),
                Shape::HalfPlane {
                    point: [0.0, 0.0],
                    normal: [1.0, 0.0],
                },
            ],
        };
        #[derive(Serialize)]
        struct W<'a> {
            shape: &'a Shape,
        }
        let text = toml::to_string(&W { shape: &s }).expect("serialises");
        assert_eq!(from_toml(&text).expect("parses back"), s);
    }

    #[test]
    fn toml_rejects_unknown_key() {
        let e = from_toml(r#"shape = { type = "disk", center = [0, 0], radius = 1, radios = 2 }"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `radios`"), "{e}");
        let nested = from_toml(
            r#"shape = { type = "difference", base = { type = "rectangle", min = [0,0], max = [1,1], colour = "red" }, subtract = [] }"#,
        );
        let e = nested.unwrap_err().to_string();
        assert!(e.contains("unknown field `colour`"), "{e}");
    }

    #[test]
    fn toml_rejects_unknown_type_and_missing_field() {
        let e = from_toml(r#"shape = { type = "ellipse", center = [0, 0] }"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown variant `ellipse`"), "{e}");
        let e = from_toml(r#"shape = { type = "disk", center = [0, 0] }"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing field `radius`"), "{e}");
        let e = from_toml(r#"shape = { type = "disk", center = [0, 0, 0], radius = 1 }"#);
        assert!(e.is_err(), "3 coordinates for a 2D centre");
    }
}
