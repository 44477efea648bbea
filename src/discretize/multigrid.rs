//! Multi-grid (multi-resolution) lattices, seed 003 §3.1: the shape is filled with cells of
//! spacing Δx; inside refinement regions each cell splits into 2^D children at ±Δx/4 with
//! volume V/2^D, level after level; neighbouring cells then differ by at most one level (2:1),
//! as every example of the paper does and as its transition rule asks (the size jump must stay
//! below the finer horizon). Nodes sit at cell centres; the cell size goes with each node, so
//! the horizon δ_i = m Δx_i and the partial volumes follow it.

use super::lattice::lattice;
use super::NodeCloud;
use crate::geometry::Shape;
use std::collections::HashSet;

/// A region refined to `level` (1: cells of Δx/2, 2: Δx/4, ...).
#[derive(Debug, Clone)]
pub struct Refinement {
    pub region: Shape,
    pub level: u32,
}

/// Deepest level allowed (cells of Δx/256).
pub const MAX_LEVEL: u32 = 8;

/// A cell: its level and integer coordinates at that level (cell size Δx / 2^level).
type Cell = (u32, [i64; 3]);

/// Fills `shape` with a lattice of spacing `dx` refined in `regions`, balanced 2:1.
pub fn multigrid(
    shape: &Shape,
    dim: usize,
    dx: f64,
    thickness: f64,
    regions: &[Refinement],
) -> Result<NodeCloud, String> {
    for (k, r) in regions.iter().enumerate() {
        if r.level == 0 || r.level > MAX_LEVEL {
            return Err(format!(
                "refinement {k}: level {} must be between 1 and {MAX_LEVEL}",
                r.level
            ));
        }
        match r.region.dim() {
            Ok(d) if d == dim => {}
            _ => return Err(format!("refinement {k}: the region must be a {dim}D shape")),
        }
    }
    // Level-0 cells: the lattice's nodes, in integer coordinates from the lattice origin.
    let base = lattice(shape, dim, dx, 1.0)?;
    let Some((lo, _)) = shape.bounding_box() else {
        return Err("the shape must be bounded".into());
    };
    let origin: [f64; 3] = std::array::from_fn(|a| if a < dim { lo[a] } else { 0.0 });
    let size = |level: u32| dx / (1u64 << level) as f64;
    let centre = |(level, c): &Cell| -> [f64; 3] {
        let h = size(*level);
        std::array::from_fn(|a| {
            if a < dim {
                origin[a] + (c[a] as f64 + 0.5) * h
            } else {
                0.0
            }
        })
    };
    let mut leaves: HashSet<Cell> = base
        .positions
        .iter()
        .map(|p| {
            let c = std::array::from_fn(|a| {
                if a < dim {
                    ((p[a] - origin[a]) / dx).floor() as i64
                } else {
                    0
                }
            });
            (0, c)
        })
        .collect();
    let children = |(level, c): &Cell| -> Vec<Cell> {
        let n = 1usize << dim;
        (0..n)
            .map(|k| {
                let child = std::array::from_fn(|a| {
                    if a < dim {
                        2 * c[a] + ((k >> a) & 1) as i64
                    } else {
                        0
                    }
                });
                (level + 1, child)
            })
            .collect()
    };
    let split = |leaves: &mut HashSet<Cell>, cell: &Cell| {
        leaves.remove(cell);
        for child in children(cell) {
            // A child whose centre leaves the shape is dropped, as the lattice drops cells.
            if shape.contains(&centre(&child)[..dim]) {
                leaves.insert(child);
            }
        }
    };
    // Refine level by level: a leaf splits if a region of a deeper level holds its centre.
    let deepest = regions.iter().map(|r| r.level).max().unwrap_or(0);
    for level in 0..deepest {
        let mut todo: Vec<Cell> = leaves
            .iter()
            .filter(|cell| {
                cell.0 == level
                    && regions
                        .iter()
                        .any(|r| r.level > level && r.region.contains(&centre(cell)[..dim]))
            })
            .cloned()
            .collect();
        todo.sort_unstable();
        for cell in &todo {
            split(&mut leaves, cell);
        }
    }
    // Balance 2:1: a leaf next to (sharing a face, edge or corner with) a leaf two or more
    // levels finer splits, until none does.
    loop {
        let mut todo: Vec<Cell> = Vec::new();
        for cell in &leaves {
            let (level, c) = *cell;
            if level < 2 {
                continue;
            }
            for offset in neighbour_offsets(dim) {
                let probe: [i64; 3] = std::array::from_fn(|a| c[a] + offset[a]);
                // The leaf covering the probe cell at a level ≤ level − 2 is too coarse.
                for coarse in 0..level - 1 {
                    let shift = level - coarse;
                    let at = std::array::from_fn(|a| if a < dim { probe[a] >> shift } else { 0 });
                    if leaves.contains(&(coarse, at)) {
                        todo.push((coarse, at));
                    }
                }
            }
        }
        if todo.is_empty() {
            break;
        }
        todo.sort_unstable();
        todo.dedup();
        for cell in &todo {
            if leaves.contains(cell) {
                split(&mut leaves, cell);
            }
        }
    }
    let mut cells: Vec<Cell> = leaves.into_iter().collect();
    cells.sort_unstable_by(|a, b| {
        let (pa, pb) = (centre(a), centre(b));
        (pa[2], pa[1], pa[0])
            .partial_cmp(&(pb[2], pb[1], pb[0]))
            .expect("finite")
    });
    let mut cloud = NodeCloud::default();
    for cell in &cells {
        let h = size(cell.0);
        cloud.positions.push(centre(cell));
        cloud.volumes.push(if dim == 2 {
            h * h * thickness
        } else {
            h * h * h
        });
        cloud.cell_sizes.push(h);
        cloud.blocks.push(0);
    }
    Ok(cloud)
}

/// Offsets to the 3^D − 1 cells around a cell.
fn neighbour_offsets(dim: usize) -> Vec<[i64; 3]> {
    let r = |a: usize| if a < dim { -1..=1 } else { 0..=0 };
    let mut out = Vec::new();
    for z in r(2) {
        for y in r(1) {
            for x in r(0) {
                if (x, y, z) != (0, 0, 0) {
                    out.push([x, y, z]);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(min: [f64; 2], max: [f64; 2]) -> Shape {
        Shape::Rectangle { min, max }
    }

    /// Largest level jump between touching cells (centres within the sum of half diagonals).
    fn worst_jump(cloud: &NodeCloud) -> f64 {
        let mut worst: f64 = 1.0;
        for (i, p) in cloud.positions.iter().enumerate() {
            for (j, q) in cloud.positions.iter().enumerate().skip(i + 1) {
                let reach = 0.5 * (cloud.cell_sizes[i] + cloud.cell_sizes[j]) * 1.0001;
                if (p[0] - q[0]).abs() <= reach && (p[1] - q[1]).abs() <= reach {
                    let r = cloud.cell_sizes[i] / cloud.cell_sizes[j];
                    worst = worst.max(r.max(1.0 / r));
                }
            }
        }
        worst
    }

    #[test]
    fn refinement_keeps_the_area_and_the_2_to_1_rule() {
        let shape = square([0.0, 0.0], [0.04, 0.02]);
        let dx = 1e-3;
        let regions = [Refinement {
            region: square([0.015, 0.005], [0.025, 0.015]),
            level: 3,
        }];
        let cloud = multigrid(&shape, 2, dx, 1.0, &regions).unwrap();
        let area: f64 = cloud.volumes.iter().sum();
        assert!((area - 0.04 * 0.02).abs() < 1e-12 * area, "{area}");
        assert_eq!(worst_jump(&cloud), 2.0);
        // The region itself is at the finest level.
        let finest = dx / 8.0;
        for (p, h) in cloud.positions.iter().zip(&cloud.cell_sizes) {
            if regions[0].region.contains(&p[..2]) {
                assert_eq!(*h, finest, "{p:?}");
            }
        }
        // Children sit at ±Δx/4 of their parent (seed 003 §3.1): every level-1 centre is a
        // quarter cell off the coarse lattice.
        for (p, h) in cloud.positions.iter().zip(&cloud.cell_sizes) {
            if *h == dx / 2.0 {
                let f = (p[0] / dx).fract();
                assert!((f - 0.25).abs() < 1e-9 || (f - 0.75).abs() < 1e-9, "{f}");
            }
        }
    }

    #[test]
    fn three_d_cells_split_in_eight() {
        let shape = Shape::Box {
            min: [0.0; 3],
            max: [0.006; 3],
        };
        let regions = [Refinement {
            region: Shape::Sphere {
                center: [0.003; 3],
                radius: 1e-3,
            },
            level: 1,
        }];
        let cloud = multigrid(&shape, 3, 1e-3, 1.0, &regions).unwrap();
        let volume: f64 = cloud.volumes.iter().sum();
        assert!((volume - 0.006f64.powi(3)).abs() < 1e-12 * volume);
        let fine = cloud.cell_sizes.iter().filter(|&&h| h == 5e-4).count();
        assert_eq!(fine % 8, 0);
        assert!(fine > 0 && fine < cloud.len());
    }

    #[test]
    fn bad_refinements_are_refused() {
        let shape = square([0.0, 0.0], [0.01, 0.01]);
        let bad = [Refinement {
            region: shape.clone(),
            level: 0,
        }];
        assert!(multigrid(&shape, 2, 1e-3, 1.0, &bad)
            .unwrap_err()
            .contains("level 0"));
        let ball = [Refinement {
            region: Shape::Sphere {
                center: [0.0; 3],
                radius: 1.0,
            },
            level: 1,
        }];
        assert!(multigrid(&shape, 2, 1e-3, 1.0, &ball)
            .unwrap_err()
            .contains("2D shape"));
    }
}
