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
    let (one_radius, chunks) = search_families(body, rule, precracks, 0..n, Ends::Own);
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
/// `build_bonds` builds. When horizons differ, a pair only one end's horizon joins is found
/// there from the other end, which may be another process's node: here each node searches as
/// far as the largest horizon reaches and keeps a neighbour when either end's own search would
/// have kept it.
pub fn build_bonds_of<const D: usize>(
    body: &Body<D>,
    rule: PartialVolume,
    precracks: &[Precrack],
    nodes: std::ops::Range<usize>,
) -> Bonds {
    let ends = if search_radii(body, rule).1 {
        Ends::Own
    } else {
        Ends::Both
    };
    to_csr(search_families(body, rule, precracks, nodes, ends).1)
}

/// Which ends of a pair a family search looks from.
#[derive(Clone, Copy, PartialEq)]
enum Ends {
    /// Node i's own search only (radius δ_i + reach(r_max)).
    Own,
    /// Node i's search and, as far as the largest radius reaches, the search node j would
    /// have made: what `with_reverse_pairs` adds, found from i's side.
    Both,
}

/// Each node's search radius δ_i + reach(r_max), and whether it is the same for every node.
fn search_radii<const D: usize>(body: &Body<D>, rule: PartialVolume) -> (Vec<f64>, bool) {
    let r_max = rule.reach(body.cell_sizes.iter().cloned().fold(0.0, f64::max), D);
    let radius: Vec<f64> = body.horizons.iter().map(|h| h + r_max).collect();
    let max_radius = radius.iter().cloned().fold(0.0, f64::max);
    let min_radius = radius.iter().cloned().fold(f64::INFINITY, f64::min);
    (radius, min_radius == max_radius)
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
    ends: Ends,
) -> (bool, Vec<(Vec<usize>, Vec<u32>, Vec<f64>)>) {
    // Node i looks as far as any j can be from it in i's own horizon, δ_i + reach(r_max). A
    // pair that only j's horizon joins (j coarse, i fine) is found from j, and added to i's
    // family by `with_reverse_pairs` (or, with `Ends::Both`, found here from i); with one
    // radius for every node each side finds it by itself.
    let (radius, one_radius) = search_radii(body, rule);
    let max_radius = radius.iter().cloned().fold(0.0, f64::max);
    let min_radius = radius.iter().cloned().fold(f64::INFINITY, f64::min);
    // Cells no smaller than a quarter of the largest radius: a fine node scans few nodes,
    // a coarse one at most 9^D cells.
    let grid = CellGrid::new(body, min_radius.max(0.25 * max_radius));
    let cuts = |a: usize, b: usize| {
        precracks
            .iter()
            .any(|c| c.cuts(body.positions[a].as_slice(), body.positions[b].as_slice()))
    };

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
                let reach = if ends == Ends::Both {
                    max_radius
                } else {
                    radius[i]
                };
                grid.for_each_candidate(xi.as_slice(), reach, |j| {
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
                    // One process keeps j when i's search finds it uncut, or (`with_reverse_pairs`)
                    // when j's search finds i uncut; each search sees the cells its radius reaches.
                    let kept = match ends {
                        Ends::Own => !cuts(i, j),
                        Ends::Both => {
                            let xj = body.positions[j].as_slice();
                            (grid.sees(xi.as_slice(), radius[i], xj) && !cuts(i, j))
                                || (grid.sees(xj, radius[j], xi.as_slice()) && !cuts(j, i))
                        }
                    };
                    if inside && kept {
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

    /// The cell of point `p`, per axis.
    fn cell(&self, p: &[f64]) -> [isize; 3] {
        let mut q = [0isize; 3];
        for k in 0..self.dim {
            q[k] = (((p[k] - self.lo[k]) / self.size) as isize).min(self.dims[k] as isize - 1);
        }
        q
    }

    /// How many cells a search of `radius` scans on each side of its own.
    fn reach(&self, radius: f64) -> isize {
        (radius / self.size).ceil().max(1.0) as isize
    }

    /// Whether a search of `radius` from `p` (`for_each_candidate`) sees point `x`.
    fn sees(&self, p: &[f64], radius: f64, x: &[f64]) -> bool {
        let (a, b, reach) = (self.cell(p), self.cell(x), self.reach(radius));
        (0..self.dim).all(|k| (a[k] - b[k]).abs() <= reach)
    }

    /// Calls `f` for every node in the cells within `radius` of `p`'s cell.
    fn for_each_candidate(&self, p: &[f64], radius: f64, mut f: impl FnMut(usize)) {
        let q = self.cell(p);
        let reach = self.reach(radius);
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

    /// A 3-level multi-grid whose horizons follow the cells (δ_i = 3Δx_i).
    fn refined_body() -> Body<2> {
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
        body
    }

    /// A process's families of its range of a body of varying horizons (and a pre-crack
    /// through the refined zone) are, row by row and bit for bit, the whole body's.
    #[test]
    fn a_range_of_varying_horizons_has_the_whole_bodys_rows() {
        let body = refined_body();
        let crack = [Precrack::Segment {
            start: [0.0, 0.0093],
            end: [0.01, 0.0093],
        }];
        for rule in [PartialVolume::Hhb, PartialVolume::None] {
            let whole = build_bonds(&body, rule, &crack);
            let n = body.len();
            for range in [0..n / 3, n / 3..n / 2 + 7, n / 2 + 7..n] {
                let part = build_bonds_of(&body, rule, &crack, range.clone());
                for (row, i) in range.clone().enumerate() {
                    let got = part.offsets[row]..part.offsets[row + 1];
                    let want = whole.family(i);
                    assert_eq!(
                        part.neighbors[got.clone()],
                        whole.neighbors[want.clone()],
                        "node {i}"
                    );
                    let bits = |l: &[f64]| l.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        bits(&part.ref_lengths[got]),
                        bits(&whole.ref_lengths[want]),
                        "node {i}"
                    );
                }
            }
        }
    }

    /// The families against the rule applied to every pair, on a 3-level multi-grid whose
    /// horizons follow the cells (δ_i = 3Δx_i): pairs that only the coarse node's horizon joins
    /// must be in both families.
    #[test]
    fn families_match_all_pairs_on_a_multigrid() {
        for rule in [PartialVolume::Hhb, PartialVolume::None] {
            let body = refined_body();
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
