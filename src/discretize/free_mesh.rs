//! Boundary-fitted free mesh in 2D (seed 000 §3, seed 001 §2.2): a quality triangle mesh of a
//! shape at a target size, by constrained Delaunay refinement (Ruppert/Chew, as implemented by
//! the `spade` crate); one PD node per triangle, at its centroid, with its area as volume.
//!
//! The boundary is seeded at the target size (`geometry::boundary`) and those segments are
//! kept unsplit, so two meshes that share a boundary piece seeded alike match along it (the
//! NB-NUG boxes rely on this).

use crate::geometry::boundary::{boundary_segments, Segment};
use crate::geometry::Shape;
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};

/// Smallest inner angle the refinement aims for (below Ruppert's 20.7° bound it always
/// terminates; spade reaches 25° in practice on these inputs, and stops at its vertex budget
/// otherwise, which is reported).
const ANGLE_LIMIT_DEG: f64 = 25.0;

/// Largest triangle area the refinement allows, per size²: an equilateral triangle of side
/// `size` has √3/4 ≈ 0.433 size²; refinement leaves triangles between a quarter of the limit
/// and the limit, so this gives a mean edge close to `size`.
const MAX_AREA_PER_SIZE2: f64 = 0.6;

/// A triangle mesh: vertices and counter-clockwise triangles.
#[derive(Debug, Clone, Default)]
pub struct TriangleMesh {
    pub vertices: Vec<[f64; 2]>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Signed area of triangle t (positive: counter-clockwise).
    pub fn area(&self, t: usize) -> f64 {
        let [a, b, c] = self.triangles[t].map(|v| self.vertices[v as usize]);
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
    }

    /// Centroid of triangle t.
    pub fn centroid(&self, t: usize) -> [f64; 2] {
        let [a, b, c] = self.triangles[t].map(|v| self.vertices[v as usize]);
        [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0]
    }

    /// Smallest inner angle of triangle t (degrees).
    pub fn min_angle_deg(&self, t: usize) -> f64 {
        let p = self.triangles[t].map(|v| self.vertices[v as usize]);
        (0..3)
            .map(|k| {
                let (o, u, v) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
                let (a, b) = ([u[0] - o[0], u[1] - o[1]], [v[0] - o[0], v[1] - o[1]]);
                let cross = a[0] * b[1] - a[1] * b[0];
                let dot = a[0] * b[0] + a[1] * b[1];
                cross.abs().atan2(dot).to_degrees()
            })
            .fold(180.0, f64::min)
    }
}

/// Meshes `shape` (2D) with triangles of about `size` (mean edge length).
pub fn free_mesh(shape: &Shape, size: f64) -> Result<TriangleMesh, String> {
    let segments = boundary_segments(shape, size).map_err(|e| e.to_string())?;
    mesh_inside(|p| shape.contains(&p), &segments, size)
}

/// Meshes the region enclosed by `segments` (seeded boundary pieces, region on their left),
/// keeping the segments as edges; `inside` tells whether a point is in the region.
pub fn mesh_inside(
    inside: impl Fn([f64; 2]) -> bool,
    segments: &[Segment],
    size: f64,
) -> Result<TriangleMesh, String> {
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
    for s in segments {
        let a = cdt
            .insert(Point2::new(s.a[0], s.a[1]))
            .map_err(|e| format!("boundary point {:?}: {e:?}", s.a))?;
        let b = cdt
            .insert(Point2::new(s.b[0], s.b[1]))
            .map_err(|e| format!("boundary point {:?}: {e:?}", s.b))?;
        if a != b {
            // Outlines of CSG parts may cross: split them where they do.
            cdt.add_constraint_and_split(a, b, |p| p);
        }
    }
    let budget = ((bounding_area(segments) / (0.1 * size * size)) as usize).max(1000);
    let result = cdt.refine(
        RefinementParameters::<f64>::new()
            .exclude_outer_faces(true)
            .keep_constraint_edges()
            .with_max_allowed_area(MAX_AREA_PER_SIZE2 * size * size)
            .with_angle_limit(AngleLimit::from_deg(ANGLE_LIMIT_DEG))
            .with_max_additional_vertices(budget),
    );
    if !result.refinement_complete {
        return Err(format!(
            "the mesh refinement did not finish within {budget} added vertices; is the mesh size {size} much smaller than the shape?"
        ));
    }
    let excluded: std::collections::HashSet<_> = result.excluded_faces.into_iter().collect();
    let mut mesh = TriangleMesh {
        vertices: cdt
            .vertices()
            .map(|v| [v.position().x, v.position().y])
            .collect(),
        triangles: Vec::new(),
    };
    for face in cdt.inner_faces() {
        if excluded.contains(&face.fix()) {
            continue;
        }
        let t = face.vertices().map(|v| v.fix().index() as u32);
        mesh.triangles.push(t);
        let k = mesh.triangles.len() - 1;
        // A pocket left inside by crossing CSG outlines is dropped by the shape itself.
        let c = mesh.centroid(k);
        if mesh.area(k) <= 0.0 || !inside(c) {
            mesh.triangles.pop();
        }
    }
    if mesh.triangles.is_empty() {
        return Err("the mesh has no triangle inside the shape".into());
    }
    Ok(mesh)
}

/// Area of the segments' bounding box.
fn bounding_area(segments: &[Segment]) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for s in segments {
        for p in [s.a, s.b] {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    (hi[0] - lo[0]) * (hi[1] - lo[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plate_with_hole() -> Shape {
        Shape::Difference {
            base: Box::new(Shape::Rectangle {
                min: [0.0, 0.0],
                max: [0.05, 0.05],
            }),
            subtract: vec![Shape::Disk {
                center: [0.025, 0.025],
                radius: 0.005,
            }],
        }
    }

    #[test]
    fn a_plate_with_a_hole_is_covered_once_with_good_triangles() {
        let shape = plate_with_hole();
        let size = 1e-3;
        let mesh = free_mesh(&shape, size).unwrap();
        let total: f64 = (0..mesh.triangles.len()).map(|t| mesh.area(t)).sum();
        let exact = 0.05 * 0.05 - std::f64::consts::PI * 0.005 * 0.005;
        assert!(
            (total - exact).abs() < 5e-3 * exact,
            "area {total} vs {exact}"
        );
        let worst = (0..mesh.triangles.len())
            .map(|t| mesh.min_angle_deg(t))
            .fold(180.0, f64::min);
        assert!(worst > 20.0, "smallest angle {worst}°");
        // Mean spacing: the side of the mean cell is close to the target size.
        let mean_side = (total / mesh.triangles.len() as f64).sqrt();
        assert!(mean_side > 0.4 * size && mean_side < size, "{mean_side}");
        for t in 0..mesh.triangles.len() {
            assert!(shape.contains(&mesh.centroid(t)));
        }
        // The hole is fitted: no vertex inside it, and the vertices on it lie on the circle.
        let on_hole = mesh
            .vertices
            .iter()
            .map(|v| (v[0] - 0.025).hypot(v[1] - 0.025))
            .filter(|&r| r < 0.005 + 0.2 * size)
            .inspect(|r| assert!((r - 0.005).abs() < 1e-12, "vertex at r = {r}"))
            .count();
        assert_eq!(
            on_hole,
            (std::f64::consts::TAU * 0.005 / size).ceil() as usize
        );
    }

    #[test]
    fn crossing_outlines_of_a_union_mesh_the_union() {
        let cross = Shape::Union {
            shapes: vec![
                Shape::Rectangle {
                    min: [0.0, 0.4],
                    max: [1.0, 0.6],
                },
                Shape::Rectangle {
                    min: [0.4, 0.0],
                    max: [0.6, 1.0],
                },
            ],
        };
        let mesh = free_mesh(&cross, 0.05).unwrap();
        let total: f64 = (0..mesh.triangles.len()).map(|t| mesh.area(t)).sum();
        assert!((total - 0.36).abs() < 5e-3 * 0.36, "{total}");
    }

    /// Holes through the plate's edge (a disk centred on it, one off it, a notch cut from
    /// outside) mesh the plate less the hole (they gave no triangle before the boundary was
    /// closed where the outlines cross).
    #[test]
    fn holes_through_the_edge_mesh_the_plate_less_the_hole() {
        let plate = |hole: Shape| Shape::Difference {
            base: Box::new(Shape::Rectangle {
                min: [0.0, 0.0],
                max: [0.01, 0.01],
            }),
            subtract: vec![hole],
        };
        let disk = |y: f64| Shape::Disk {
            center: [0.005, y],
            radius: 0.002,
        };
        // The part of a disk of radius r whose centre is h inside the edge.
        let segment = |h: f64| {
            let r: f64 = 0.002;
            let theta = 2.0 * (h / r).acos();
            let cap = 0.5 * r * r * (theta - theta.sin());
            std::f64::consts::PI * r * r - cap
        };
        for (hole, area) in [
            (disk(0.0), 0.5 * std::f64::consts::PI * 4e-6),
            (disk(0.001), segment(0.001)),
            (
                Shape::Rectangle {
                    min: [0.004, -0.001],
                    max: [0.0045, 0.003],
                },
                0.5e-3 * 3e-3,
            ),
        ] {
            let mesh = free_mesh(&plate(hole), 0.5e-3).unwrap();
            let total: f64 = (0..mesh.triangles.len()).map(|t| mesh.area(t)).sum();
            let exact = 1e-4 - area;
            assert!((total - exact).abs() < 5e-3 * exact, "{total} vs {exact}");
        }
    }
}
