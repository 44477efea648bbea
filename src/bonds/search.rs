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
        .map(|i| estimate_node_bonds(body, rule, i))
        .sum()
}

/// Node i's share of `estimate_bonds`.
pub fn estimate_node_bonds<const D: usize>(body: &Body<D>, rule: PartialVolume, i: usize) -> f64 {
    let r = body.cell_sizes[i];
    let reach = body.horizons[i] + rule.reach(r, D);
    let ball = if D == 2 {
        std::f64::consts::PI * reach * reach
    } else {
        4.0 / 3.0 * std::f64::consts::PI * reach.powi(3)
    };
    ball / r.powi(D as i32)
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
    let (one_radius, chunks) = search_families(body, rule, precracks, 0..n);
    let chunks = if one_radius {
        chunks
    } else {
        with_reverse_pairs(n, chunks)
    };
    to_csr(chunks)
}

/// The searched chunks' families as one CSR.
fn to_csr(chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)>) -> Bonds {
    let total: usize = chunks.iter().map(|c| c.1.len()).sum();
    let rows: usize = chunks.iter().map(|c| c.0.len()).sum();
    let mut bonds = Bonds {
        offsets: Vec::with_capacity(rows + 1),
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

/// The families of the nodes `nodes` only (neighbours in global indices), for a process
/// that owns that range of a body distributed over several: each row is bit for bit the one
/// `build_bonds` builds. `None` when the nodes' horizons differ (a pair only one end's
/// horizon joins is found from the other end, which may be another process's).
pub fn build_bonds_of<const D: usize>(
    body: &Body<D>,
    rule: PartialVolume,
    precracks: &[Precrack],
    nodes: std::ops::Range<usize>,
) -> Option<Bonds> {
    let (one_radius, chunks) = search_families(body, rule, precracks, nodes);
    one_radius.then(|| to_csr(chunks))
}

/// The searched families of `nodes`, per chunk of `CHUNK` nodes: (counts, neighbours,
/// lengths); and whether every node searched as far (then every pair is found from both
/// ends).
#[allow(clippy::type_complexity)]
fn search_families<const D: usize>(
    body: &Body<D>,
    rule: PartialVolume,
    precracks: &[Precrack],
    nodes: std::ops::Range<usize>,
) -> (bool, Vec<(Vec<usize>, Vec<u32>, Vec<f64>)>) {
    // Node i looks as far as any j can be from it in i's own horizon, δ_i + reach(r_max). A
    // pair that only j's horizon joins (j coarse, i fine) is found from j, and added to i's
    // family below; with one radius for every node each side finds it by itself.
    let r_max = rule.reach(body.cell_sizes.iter().cloned().fold(0.0, f64::max), D);
    let radius: Vec<f64> = body.horizons.iter().map(|h| h + r_max).collect();
    let max_radius = radius.iter().cloned().fold(0.0, f64::max);
    let min_radius = radius.iter().cloned().fold(f64::INFINITY, f64::min);
    let one_radius = min_radius == max_radius;
    // Cells no smaller than a quarter of the largest radius: a fine node scans few nodes,
    // a coarse one at most 9^D cells.
    let grid = CellGrid::new(body, min_radius.max(0.25 * max_radius));

    let chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = nodes
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
                grid.for_each_candidate(xi.as_slice(), radius[i], |j| {
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
    (one_radius, chunks)
}

/// Adds to each family the nodes that found it but that it did not find (the pairs only the
/// other node's horizon joins), keeping every family sorted and free of repeats.
fn with_reverse_pairs(
    n: usize,
    chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)>,
) -> Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> {
    // Flatten the searched families into CSR form.
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0usize);
    let mut nbrs = Vec::new();
    let mut lens = Vec::new();
    for (counts, c_nbrs, c_lens) in chunks {
        for c in counts {
            offsets.push(offsets.last().unwrap() + c);
        }
        nbrs.extend(c_nbrs);
        lens.extend(c_lens);
    }
    // The transpose: who found whom.
    let mut t_start = vec![0usize; n + 1];
    for &j in &nbrs {
        t_start[j as usize + 1] += 1;
    }
    for k in 0..n {
        t_start[k + 1] += t_start[k];
    }
    let mut fill = t_start.clone();
    let mut t_items = vec![(0u32, 0.0f64); nbrs.len()];
    for i in 0..n {
        for b in offsets[i]..offsets[i + 1] {
            let j = nbrs[b] as usize;
            t_items[fill[j]] = (i as u32, lens[b]);
            fill[j] += 1;
        }
    }
    (0..n)
        .collect::<Vec<_>>()
        .par_chunks(CHUNK)
        .map(|nodes| {
            let mut counts = Vec::with_capacity(nodes.len());
            let mut out_nbrs = Vec::new();
            let mut out_lens = Vec::new();
            for &i in nodes {
                // Both lists are sorted by neighbour: merge them.
                let own = offsets[i]..offsets[i + 1];
                let found_by = &t_items[t_start[i]..t_start[i + 1]];
                let before = out_nbrs.len();
                let (mut a, mut b) = (own.start, 0);
                while a < own.end || b < found_by.len() {
                    let next_own = (a < own.end).then(|| nbrs[a]);
                    let next_rev = found_by.get(b).map(|p| p.0);
                    match (next_own, next_rev) {
                        (Some(x), Some(y)) if x == y => {
                            out_nbrs.push(x);
                            out_lens.push(lens[a]);
                            a += 1;
                            b += 1;
                        }
                        (Some(x), Some(y)) if x < y => {
                            out_nbrs.push(x);
                            out_lens.push(lens[a]);
                            a += 1;
                        }
                        (Some(x), None) => {
                            out_nbrs.push(x);
                            out_lens.push(lens[a]);
                            a += 1;
                        }
                        (_, Some(y)) => {
                            out_nbrs.push(y);
                            out_lens.push(found_by[b].1);
                            b += 1;
                        }
                        (None, None) => unreachable!(),
                    }
                }
                counts.push(out_nbrs.len() - before);
            }
            (counts, out_nbrs, out_lens)
        })
        .collect()
}

/// A uniform grid of cells; nodes are binned by counting sort.
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

    /// Calls `f` for every node in the cells within `radius` of `p`'s cell.
    fn for_each_candidate(&self, p: &[f64], radius: f64, mut f: impl FnMut(usize)) {
        let mut q = [0isize; 3];
        for k in 0..self.dim {
            q[k] = (((p[k] - self.lo[k]) / self.size) as isize).min(self.dims[k] as isize - 1);
        }
        let reach = (radius / self.size).ceil().max(1.0) as isize;
        let (rz, ry) = if self.dim == 3 {
            (reach, reach)
        } else {
            (0, reach)
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
                let x0 = (q[0] - reach).max(0) as usize;
                let x1 = ((q[0] + reach).max(0) as usize).min(self.dims[0] - 1);
                for &i in &self.items[self.start[row + x0]..self.start[row + x1 + 1]] {
                    f(i);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discretize::multigrid::{multigrid, Refinement};
    use crate::geometry::Shape;

    /// The families against the rule applied to every pair, on a 3-level multi-grid whose
    /// horizons follow the cells (δ_i = 3Δx_i): pairs that only the coarse node's horizon joins
    /// must be in both families.
    #[test]
    fn families_match_all_pairs_on_a_multigrid() {
        for rule in [PartialVolume::Hhb, PartialVolume::None] {
            let cloud = multigrid(
                &Shape::cube(2, 0.02),
                2,
                1e-3,
                1.0,
                &[Refinement {
                    region: Shape::Rectangle {
                        min: [0.006, 0.006],
                        max: [0.012, 0.012],
                    },
                    level: 2,
                }],
            )
            .unwrap();
            let mut body = Body::<2>::from_cloud(cloud, 3e-3, 1.0);
            for i in 0..body.len() {
                body.horizons[i] = 3.0 * body.cell_sizes[i];
            }
            let bonds = build_bonds(&body, rule, &[]);
            let mut joined_by_one_side = 0;
            for i in 0..body.len() {
                let mut expected = Vec::new();
                for j in 0..body.len() {
                    let len = (body.positions[j] - body.positions[i]).norm();
                    let ij = body.horizons[i] + rule.reach(body.cell_sizes[j], 2);
                    let ji = body.horizons[j] + rule.reach(body.cell_sizes[i], 2);
                    let inside = match rule {
                        PartialVolume::None => len <= ij.max(ji),
                        _ => len < ij.max(ji),
                    };
                    if j != i && inside {
                        expected.push(j as u32);
                        joined_by_one_side += (len >= ij.min(ji)) as usize;
                    }
                }
                let got: Vec<u32> = bonds.family(i).map(|b| bonds.neighbors[b]).collect();
                assert_eq!(got, expected, "node {i}");
            }
            assert!(joined_by_one_side > 100, "the test needs one-sided pairs");
        }
    }
}
