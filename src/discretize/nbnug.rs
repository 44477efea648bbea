//! NB-NUG, the near-boundary non-uniform grid of seed 000 (§3 and Appendix 4): a square box
//! of side 2(R + padding) around each hole, the plate cut into rectangles by lines through
//! every box edge, uniform (mapped) cells in the rectangles outside the boxes, and a
//! boundary-fitted free mesh inside the boxes whose edges are seeded exactly like the
//! neighbouring rectangles, so the two meshes match along them. Nodes are cell centroids with
//! the cell areas as volumes.

use super::free_mesh::mesh_inside;
use super::recombine::{recombine, CellMesh};
use crate::geometry::boundary::{boundary_segments, Segment};
use crate::geometry::Shape;

/// A circular hole.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hole {
    pub center: [f64; 2],
    pub radius: f64,
}

/// The plate, its holes and the mesh parameters.
#[derive(Debug, Clone)]
pub struct NbNug {
    pub min: [f64; 2],
    pub max: [f64; 2],
    pub holes: Vec<Hole>,
    /// Element size Δx (m): the side of the uniform cells and the seeding of every edge.
    pub size: f64,
    /// Distance from a hole to its box's edges (m); seed 000 recommends at least δ.
    pub padding: f64,
    /// Merge the boxes' triangles into a quad-dominant mesh, as the paper's mesher does.
    pub quads: bool,
}

/// Division points of [a, b] into round((b − a)/size) equal pieces (at least one).
fn divisions(a: f64, b: f64, size: f64) -> Vec<f64> {
    let n = (((b - a) / size).round() as usize).max(1);
    (0..=n)
        .map(|k| {
            if k == n {
                b
            } else {
                a + (b - a) * k as f64 / n as f64
            }
        })
        .collect()
}

/// Sorted cut positions with duplicates (closer than `tol`) merged.
fn cuts(mut v: Vec<f64>, tol: f64) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup_by(|b, a| (*b - *a).abs() <= tol);
    v
}

impl NbNug {
    /// Checks the geometry: holes inside the plate, apart from each other, size and padding
    /// positive.
    pub fn check(&self) -> Result<(), String> {
        if !(self.size > 0.0 && self.size.is_finite()) {
            return Err(format!(
                "the element size must be positive, not {}",
                self.size
            ));
        }
        if !(self.padding > 0.0 && self.padding.is_finite()) {
            return Err(format!(
                "the box padding must be positive, not {}",
                self.padding
            ));
        }
        if !(self.min[0] < self.max[0] && self.min[1] < self.max[1]) {
            return Err("the plate's min must be below its max in x and y".into());
        }
        for (k, h) in self.holes.iter().enumerate() {
            let inside = (0..2).all(|a| {
                self.min[a] < h.center[a] - h.radius && h.center[a] + h.radius < self.max[a]
            });
            if h.radius.is_nan() || h.radius <= 0.0 || !inside {
                return Err(format!(
                    "hole {k} (centre {:?}, radius {}) must have a positive radius and lie inside the plate {:?}–{:?} without touching its boundary",
                    h.center, h.radius, self.min, self.max
                ));
            }
            if h.radius < self.size {
                return Err(format!(
                    "hole {k} has radius {} below the element size {}: the grid cannot resolve it",
                    h.radius, self.size
                ));
            }
            for (m, g) in self.holes.iter().enumerate().skip(k + 1) {
                let d = (h.center[0] - g.center[0]).hypot(h.center[1] - g.center[1]);
                if d <= h.radius + g.radius {
                    return Err(format!("holes {k} and {m} overlap"));
                }
            }
        }
        Ok(())
    }

    /// The box of hole k, clipped to the plate.
    fn hole_box(&self, h: &Hole) -> ([f64; 2], [f64; 2]) {
        let r = h.radius + self.padding;
        (
            [
                (h.center[0] - r).max(self.min[0]),
                (h.center[1] - r).max(self.min[1]),
            ],
            [
                (h.center[0] + r).min(self.max[0]),
                (h.center[1] + r).min(self.max[1]),
            ],
        )
    }

    /// The grid's cells.
    pub fn mesh(&self) -> Result<CellMesh, String> {
        self.check()?;
        let tol = 1e-9 * self.size;
        let boxes: Vec<_> = self.holes.iter().map(|h| self.hole_box(h)).collect();
        let axis = |a: usize| {
            let mut v = vec![self.min[a], self.max[a]];
            for b in &boxes {
                v.push(b.0[a]);
                v.push(b.1[a]);
            }
            let c = cuts(v, tol);
            let div: Vec<Vec<f64>> = c
                .windows(2)
                .map(|w| divisions(w[0], w[1], self.size))
                .collect();
            (c, div)
        };
        let ((xs, xdiv), (ys, ydiv)) = (axis(0), axis(1));
        let (nx, ny) = (xs.len() - 1, ys.len() - 1);
        // A rectangle of the partition is free (inside a box) or mapped.
        let free = |i: usize, j: usize| {
            let c = [0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])];
            boxes
                .iter()
                .any(|b| (0..2).all(|a| b.0[a] < c[a] && c[a] < b.1[a]))
        };
        let mut out = CellMesh::default();
        let mut segments = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                if !free(i, j) {
                    out.append(&mapped(&xdiv[i], &ydiv[j]));
                    continue;
                }
                // Sides of the free region: towards a mapped rectangle or the plate's edge,
                // seeded as that side of the neighbour is, the region on the left.
                let (x, y) = (&xdiv[i], &ydiv[j]);
                let open = |di: isize, dj: isize| {
                    let (a, b) = (i as isize + di, j as isize + dj);
                    a < 0
                        || b < 0
                        || a >= nx as isize
                        || b >= ny as isize
                        || !free(a as usize, b as usize)
                };
                if open(0, -1) {
                    segments.extend(chain(x.iter().map(|&t| [t, ys[j]])));
                }
                if open(1, 0) {
                    segments.extend(chain(y.iter().map(|&t| [xs[i + 1], t])));
                }
                if open(0, 1) {
                    segments.extend(chain(x.iter().rev().map(|&t| [t, ys[j + 1]])));
                }
                if open(-1, 0) {
                    segments.extend(chain(y.iter().rev().map(|&t| [xs[i], t])));
                }
            }
        }
        if !self.holes.is_empty() {
            for h in &self.holes {
                let disk = Shape::Disk {
                    center: h.center,
                    radius: h.radius,
                };
                // The disk's own boundary has the disk on its left: reverse it for the plate.
                let circle = boundary_segments(&disk, self.size).map_err(|e| e.to_string())?;
                segments.extend(circle.into_iter().map(|s| Segment { a: s.b, b: s.a }));
            }
            let inside = |p: [f64; 2]| {
                let in_box = boxes
                    .iter()
                    .any(|b| (0..2).all(|a| b.0[a] <= p[a] && p[a] <= b.1[a]));
                let in_hole = self
                    .holes
                    .iter()
                    .any(|h| (p[0] - h.center[0]).hypot(p[1] - h.center[1]) <= h.radius);
                in_box && !in_hole
            };
            let triangles = mesh_inside(inside, &segments, self.size)?;
            let cells = if self.quads {
                recombine(&triangles)
            } else {
                CellMesh::from(&triangles)
            };
            out.append(&cells);
        }
        Ok(out)
    }
}

/// Consecutive points as segments.
fn chain(points: impl Iterator<Item = [f64; 2]>) -> Vec<Segment> {
    let p: Vec<[f64; 2]> = points.collect();
    p.windows(2).map(|w| Segment { a: w[0], b: w[1] }).collect()
}

/// Mapped quads of a rectangle with the given division points.
fn mapped(x: &[f64], y: &[f64]) -> CellMesh {
    let mut m = CellMesh::default();
    for &yv in y {
        for &xv in x {
            m.vertices.push([xv, yv]);
        }
    }
    let w = x.len() as u32;
    for j in 0..y.len() as u32 - 1 {
        for i in 0..w - 1 {
            let v = j * w + i;
            m.cells.push([v, v + 1, v + 1 + w, v + w]);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plate(holes: Vec<Hole>) -> NbNug {
        NbNug {
            min: [0.0, 0.0],
            max: [0.02, 0.01],
            holes,
            size: 2.5e-4,
            padding: 5e-4,
            quads: true,
        }
    }

    #[test]
    fn a_plate_with_two_holes_is_covered_and_matches_along_the_boxes() {
        let holes = vec![
            Hole {
                center: [0.006, 0.005],
                radius: 0.002,
            },
            Hole {
                center: [0.0135, 0.0045],
                radius: 0.0015,
            },
        ];
        let g = plate(holes.clone());
        let m = g.mesh().unwrap();
        let cells: Vec<_> = (0..m.cells.len()).map(|c| m.area_centroid(c)).collect();
        let total: f64 = cells.iter().map(|c| c.0).sum();
        let exact = 0.02 * 0.01
            - holes
                .iter()
                .map(|h| std::f64::consts::PI * h.radius * h.radius)
                .sum::<f64>();
        assert!((total - exact).abs() < 5e-3 * exact, "{total} vs {exact}");
        // Every node inside the plate and outside the holes; cells outside the boxes are
        // squares of the element size (the plate's sides are multiples of it).
        let boxes: Vec<_> = holes.iter().map(|h| g.hole_box(h)).collect();
        for (a, p) in &cells {
            assert!(*a > 0.0);
            assert!((0..2).all(|k| g.min[k] < p[k] && p[k] < g.max[k]));
            for h in &holes {
                assert!((p[0] - h.center[0]).hypot(p[1] - h.center[1]) > h.radius);
            }
            let in_box = boxes
                .iter()
                .any(|b| (0..2).all(|k| b.0[k] < p[k] && p[k] < b.1[k]));
            if !in_box {
                assert!(
                    (a - g.size * g.size).abs() < 0.3 * g.size * g.size,
                    "cell {a}"
                );
            }
        }
        // The free meshes match the seeding: every vertex on the left edge of a box is also a
        // vertex of the mapped cells beside it (the meshes keep their own copies).
        for b in &boxes {
            let on_edge: Vec<_> = m
                .vertices
                .iter()
                .filter(|v| (v[0] - b.0[0]).abs() < 1e-12 && v[1] > b.0[1] && v[1] < b.1[1])
                .collect();
            assert!(on_edge.len() >= 2 * ((b.1[1] - b.0[1]) / g.size) as usize - 2);
            for v in &on_edge {
                // Two copies, or more where a cut line of the partition meets the edge.
                let twins = on_edge
                    .iter()
                    .filter(|w| (w[1] - v[1]).abs() < 1e-12)
                    .count();
                assert!(twins >= 2, "vertex {v:?} on a box edge has no match");
            }
        }
        // No two nodes much closer than the local spacing.
        let mut worst = f64::INFINITY;
        for (k, (a, p)) in cells.iter().enumerate() {
            for (b, q) in &cells[k + 1..] {
                let d = (p[0] - q[0]).hypot(p[1] - q[1]);
                if d < 2.0 * g.size {
                    worst = worst.min(d / a.sqrt().min(b.sqrt()));
                }
            }
        }
        assert!(worst > 0.3, "closest pair at {worst} of the local spacing");
    }

    #[test]
    fn bad_geometry_is_refused() {
        let cut = plate(vec![Hole {
            center: [0.001, 0.005],
            radius: 0.002,
        }]);
        assert!(cut.mesh().unwrap_err().contains("inside the plate"));
        let overlap = plate(vec![
            Hole {
                center: [0.006, 0.005],
                radius: 0.002,
            },
            Hole {
                center: [0.009, 0.005],
                radius: 0.002,
            },
        ]);
        assert!(overlap.mesh().unwrap_err().contains("overlap"));
        let tiny = plate(vec![Hole {
            center: [0.006, 0.005],
            radius: 1e-4,
        }]);
        assert!(tiny.mesh().unwrap_err().contains("element size"));
    }

    #[test]
    fn without_holes_it_is_the_uniform_grid() {
        let m = plate(vec![]).mesh().unwrap();
        assert_eq!(m.cells.len(), 80 * 40);
    }
}
