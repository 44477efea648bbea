//! Cell-list neighbour search: linear in the number of nodes, parallel over node chunks,
//! deterministic (families are sorted by neighbour index).

use super::{Bonds, PartialVolume, Precrack};
use crate::body::Body;
use rayon::prelude::*;

/// Nodes per parallel work unit of the search.
const CHUNK: usize = 2048;

/// Predicted number of directed bonds, before building them: for each node, the area
/// (volume) of its horizon plus the partial-volume band over its cell's. Nodes near a surface
/// have fewer, so this is an upper estimate.
pub fn estimate_bonds<const D: usize>(body: &Body<D>, rule: PartialVolume) -> f64 {
    (0..body.len())
        .map(|i| {
            let r = body.cell_sizes[i];
            let reach = body.horizons[i] + rule.reach(r, D);
            let ball = if D == 2 {
                std::f64::consts::PI * reach * reach
            } else {
                4.0 / 3.0 * std::f64::consts::PI * reach.powi(3)
            };
            ball / r.powi(D as i32)
        })
        .sum()
}

/// Builds the families of every node: j is a neighbour of i when its cell can overlap either
/// horizon, |ξ| < max(δ_i + r_j/2, δ_j + r_i/2) (partial volumes), or |ξ| ≤ δ without them.
/// The rule is symmetric, so bond i→j exists exactly when j→i does. Bonds crossing a
/// pre-crack are not created.
pub fn build_bonds<const D: usize>(
    body: &Body<D>,
    rule: PartialVolume,
    precracks: &[Precrack],
) -> Bonds {
    let n = body.len();
    if n == 0 {
        return Bonds {
            offsets: vec![0],
            ..Default::default()
        };
    }
    let max_reach =
        body.max_horizon() + rule.reach(body.cell_sizes.iter().cloned().fold(0.0, f64::max), D);
    let grid = CellGrid::new(body, max_reach);

    let chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = (0..n)
        .collect::<Vec<_>>()
        .par_chunks(CHUNK)
        .map(|nodes| {
            let mut counts = Vec::with_capacity(nodes.len());
            let mut nbrs = Vec::new();
            let mut lens = Vec::new();
            let mut family: Vec<(u32, f64)> = Vec::new();
            for &i in nodes {
                family.clear();
                let xi = &body.positions[i];
                grid.for_each_candidate(xi.as_slice(), |j| {
                    if j == i {
                        return;
                    }
                    let len = (body.positions[j] - xi).norm();
                    let reach_ij = body.horizons[i] + rule.reach(body.cell_sizes[j], D);
                    let reach_ji = body.horizons[j] + rule.reach(body.cell_sizes[i], D);
                    let inside = match rule {
                        PartialVolume::Hhb | PartialVolume::Exact => len < reach_ij.max(reach_ji),
                        PartialVolume::None => len <= reach_ij.max(reach_ji),
                    };
                    if inside
                        && !precracks
                            .iter()
                            .any(|c| c.cuts(xi.as_slice(), body.positions[j].as_slice()))
                    {
                        family.push((j as u32, len));
                    }
                });
                family.sort_unstable_by_key(|&(j, _)| j);
                counts.push(family.len());
                for &(j, len) in &family {
                    nbrs.push(j);
                    lens.push(len);
                }
            }
            (counts, nbrs, lens)
        })
        .collect();

    let total: usize = chunks.iter().map(|c| c.1.len()).sum();
    let mut bonds = Bonds {
        offsets: Vec::with_capacity(n + 1),
        neighbors: Vec::with_capacity(total),
        ref_lengths: Vec::with_capacity(total),
    };
    bonds.offsets.push(0);
    for (counts, nbrs, lens) in chunks {
        for c in counts {
            let last = *bonds.offsets.last().unwrap();
            bonds.offsets.push(last + c);
        }
        bonds.neighbors.extend_from_slice(&nbrs);
        bonds.ref_lengths.extend_from_slice(&lens);
    }
    bonds
}

/// A uniform grid of cells of side ≥ the search radius; nodes are binned by counting sort.
struct CellGrid {
    lo: [f64; 3],
    size: f64,
    dims: [usize; 3],
    dim: usize,
    start: Vec<usize>,
    items: Vec<usize>,
}

impl CellGrid {
    fn new<const D: usize>(body: &Body<D>, radius: f64) -> Self {
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for k in 0..D {
            lo[k] = body
                .positions
                .iter()
                .map(|p| p[k])
                .fold(f64::INFINITY, f64::min);
            hi[k] = body
                .positions
                .iter()
                .map(|p| p[k])
                .fold(f64::NEG_INFINITY, f64::max);
        }
        let mut size = radius.max(f64::MIN_POSITIVE);
        // Keep the number of cells bounded (sparse bodies, tiny horizons).
        loop {
            let cells: f64 = (0..D)
                .map(|k| ((hi[k] - lo[k]) / size).floor() + 1.0)
                .product();
            if cells <= 4.0 * body.len() as f64 + 64.0 {
                break;
            }
            size *= 2.0;
        }
        let mut dims = [1usize; 3];
        for k in 0..D {
            dims[k] = ((hi[k] - lo[k]) / size).floor() as usize + 1;
        }
        let ncell = dims.iter().product::<usize>();
        let cell_of = |p: &[f64]| -> usize {
            let mut c = 0;
            for k in (0..D).rev() {
                let q = (((p[k] - lo[k]) / size) as usize).min(dims[k] - 1);
                c = c * dims[k] + q;
            }
            c
        };
        let mut start = vec![0usize; ncell + 1];
        let cells: Vec<usize> = body
            .positions
            .iter()
            .map(|p| cell_of(p.as_slice()))
            .collect();
        for &c in &cells {
            start[c + 1] += 1;
        }
        for c in 0..ncell {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut items = vec![0usize; body.len()];
        for (i, &c) in cells.iter().enumerate() {
            items[fill[c]] = i;
            fill[c] += 1;
        }
        CellGrid {
            lo,
            size,
            dims,
            dim: D,
            start,
            items,
        }
    }

    /// Calls `f` for every node in the 3^D cells around `p`.
    fn for_each_candidate(&self, p: &[f64], mut f: impl FnMut(usize)) {
        let mut q = [0isize; 3];
        for k in 0..self.dim {
            q[k] = (((p[k] - self.lo[k]) / self.size) as isize).min(self.dims[k] as isize - 1);
        }
        let (rz, ry) = if self.dim == 3 {
            (1isize, 1isize)
        } else {
            (0, 1)
        };
        for dz in -rz..=rz {
            let z = q[2] + dz;
            if z < 0 || z >= self.dims[2] as isize {
                continue;
            }
            for dy in -ry..=ry {
                let y = q[1] + dy;
                if y < 0 || y >= self.dims[1] as isize {
                    continue;
                }
                let row = (z as usize * self.dims[1] + y as usize) * self.dims[0];
                let x0 = (q[0] - 1).max(0) as usize;
                let x1 = ((q[0] + 1) as usize).min(self.dims[0] - 1);
                for &i in &self.items[self.start[row + x0]..self.start[row + x1 + 1]] {
                    f(i);
                }
            }
        }
    }
}
