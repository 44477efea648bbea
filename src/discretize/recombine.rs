//! Quad-dominant cells from a triangle mesh: pairs of neighbouring triangles that form a
//! nearly rectangular convex quadrilateral are merged (greedy recombination, best pairs
//! first). Seed 000 §3 meshes its boxes quad-dominant: cells then have areas close to Δx²
//! and aspect ratios near 1, which the partial-volume rule r_j = √V_j assumes (its Eq. 13).

use super::free_mesh::TriangleMesh;
use super::NodeCloud;
use std::collections::HashMap;

/// Merged quads keep every inner angle within this many degrees of 90°.
const MAX_ANGLE_DEVIATION_DEG: f64 = 45.0;

/// Marks the unused fourth corner of a triangle cell.
const NONE: u32 = u32::MAX;

/// Cells of three or four vertices, counter-clockwise (a triangle's fourth entry is `NONE`).
#[derive(Debug, Clone, Default)]
pub struct CellMesh {
    pub vertices: Vec<[f64; 2]>,
    pub cells: Vec<[u32; 4]>,
}

impl CellMesh {
    /// The corners of cell c.
    pub fn corners(&self, c: usize) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.cells[c]
            .iter()
            .take_while(|&&v| v != NONE)
            .map(|&v| self.vertices[v as usize])
    }

    /// Area and centroid of cell c (shoelace formula over its corners).
    pub fn area_centroid(&self, c: usize) -> (f64, [f64; 2]) {
        let p: Vec<[f64; 2]> = self.corners(c).collect();
        let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
        for k in 0..p.len() {
            let (u, v) = (p[k], p[(k + 1) % p.len()]);
            let cross = u[0] * v[1] - v[0] * u[1];
            a += cross;
            cx += (u[0] + v[0]) * cross;
            cy += (u[1] + v[1]) * cross;
        }
        (0.5 * a, [cx / (3.0 * a), cy / (3.0 * a)])
    }

    /// Number of quadrilateral cells.
    pub fn quads(&self) -> usize {
        self.cells.iter().filter(|c| c[3] != NONE).count()
    }

    /// Appends another mesh's cells (its vertices are copied, not merged).
    pub fn append(&mut self, other: &CellMesh) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.cells.extend(
            other
                .cells
                .iter()
                .map(|c| c.map(|v| if v == NONE { NONE } else { v + base })),
        );
    }

    /// One node per cell: centroid, area × `thickness` as volume, √area as cell size.
    pub fn centroid_cloud(&self, thickness: f64) -> NodeCloud {
        let mut cloud = NodeCloud::default();
        for c in 0..self.cells.len() {
            let (a, p) = self.area_centroid(c);
            cloud.positions.push([p[0], p[1], 0.0]);
            cloud.volumes.push(a * thickness);
            cloud.cell_sizes.push(a.sqrt());
            cloud.blocks.push(0);
        }
        cloud
    }
}

impl From<&TriangleMesh> for CellMesh {
    fn from(m: &TriangleMesh) -> Self {
        CellMesh {
            vertices: m.vertices.clone(),
            cells: m
                .triangles
                .iter()
                .map(|t| [t[0], t[1], t[2], NONE])
                .collect(),
        }
    }
}

/// Largest deviation of a quadrilateral's inner angles from 90° (degrees), or `None` if it is
/// not strictly convex.
fn deviation(p: [[f64; 2]; 4]) -> Option<f64> {
    let mut worst: f64 = 0.0;
    for k in 0..4 {
        let (prev, o, next) = (p[(k + 3) % 4], p[k], p[(k + 1) % 4]);
        let (a, b) = (
            [next[0] - o[0], next[1] - o[1]],
            [prev[0] - o[0], prev[1] - o[1]],
        );
        let cross = a[0] * b[1] - a[1] * b[0];
        if cross <= 0.0 {
            return None;
        }
        let angle = cross.atan2(a[0] * b[0] + a[1] * b[1]).to_degrees();
        worst = worst.max((angle - 90.0).abs());
    }
    Some(worst)
}

/// Merges pairs of triangles into quads, best-shaped pairs first; deterministic.
pub fn recombine(mesh: &TriangleMesh) -> CellMesh {
    // Each interior edge and the two triangles that share it.
    let mut first: HashMap<(u32, u32), usize> = HashMap::new();
    let mut pairs = Vec::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            match first.remove(&key) {
                Some(s) => {
                    // t = (a, b, d) and s = (b, a, c), both counter-clockwise: the union's
                    // boundary runs a → c → b (along s), b → d → a (along t).
                    let d = tri[(k + 2) % 3];
                    let st = mesh.triangles[s];
                    let m = (0..3).find(|&m| st[m] == b).expect("shared edge");
                    let c = st[(m + 2) % 3];
                    let quad = [a, c, b, d];
                    if let Some(dev) = deviation(quad.map(|v| mesh.vertices[v as usize])) {
                        if dev <= MAX_ANGLE_DEVIATION_DEG {
                            pairs.push((dev, s, t, quad));
                        }
                    }
                }
                None => {
                    first.insert(key, t);
                }
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    let mut used = vec![false; mesh.triangles.len()];
    let mut out = CellMesh {
        vertices: mesh.vertices.clone(),
        cells: Vec::with_capacity(mesh.triangles.len()),
    };
    for (_, s, t, quad) in pairs {
        if !used[s] && !used[t] {
            used[s] = true;
            used[t] = true;
            out.cells.push(quad);
        }
    }
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if !used[t] {
            out.cells.push([tri[0], tri[1], tri[2], NONE]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discretize::free_mesh::free_mesh;
    use crate::geometry::Shape;

    #[test]
    fn two_triangles_of_a_square_become_one_quad() {
        let mesh = TriangleMesh {
            vertices: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        let cells = recombine(&mesh);
        assert_eq!(cells.cells.len(), 1);
        let (a, c) = cells.area_centroid(0);
        assert_eq!((a, c), (1.0, [0.5, 0.5]));
    }

    #[test]
    fn a_plate_with_a_hole_becomes_quad_dominant_with_its_area() {
        let shape = Shape::Difference {
            base: Box::new(Shape::Rectangle {
                min: [0.0, 0.0],
                max: [0.05, 0.05],
            }),
            subtract: vec![Shape::Disk {
                center: [0.025, 0.025],
                radius: 0.005,
            }],
        };
        let tri = free_mesh(&shape, 1e-3).unwrap();
        let cells = recombine(&tri);
        let total_tri: f64 = (0..tri.triangles.len()).map(|t| tri.area(t)).sum();
        let total: f64 = (0..cells.cells.len())
            .map(|c| cells.area_centroid(c).0)
            .sum();
        assert!((total - total_tri).abs() < 1e-12 * total_tri);
        // Most triangles pair up (greedy matching leaves about a quarter alone: 76 % merged
        // here; an optimal matching would merge nearly all).
        let merged = 2 * cells.quads();
        assert!(
            merged as f64 > 0.7 * tri.triangles.len() as f64,
            "{merged} of {}",
            tri.triangles.len()
        );
        for c in 0..cells.cells.len() {
            let (a, p) = cells.area_centroid(c);
            assert!(a > 0.0 && shape.contains(&p));
        }
    }
}
