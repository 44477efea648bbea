//! The coarse level of conjugate gradients' two-level preconditioner: the body cut into cells
//! of a coarse grid, each cell moving as one (a translation per cell and component), and the
//! linearised stiffness of the intact bonds restricted to those motions, solved exactly.
//!
//! Jacobi preconditioning (`ncg.rs`) leaves conjugate gradients needing about as many
//! iterations as the grid is wide in nodes: a change at a crack tip travels about one horizon
//! per iteration. The additive two-level preconditioner M⁻¹ = D⁻¹ + P A_c⁻¹ Pᵀ, with P the
//! piecewise-constant interpolation from the cells and A_c = Pᵀ K P (Smith, Bjørstad & Gropp
//! 1996, "Domain decomposition", §2.3 and §4.2; Toselli & Widlund 2005, §3.6, two-level
//! additive Schwarz), corrects the smooth part of the error over the whole body at once, so the
//! iterations grow with the cell's width in nodes instead of the body's.
//!
//! A crack that crosses a cell leaves its two sides free to move apart, a motion a cell's one
//! translation cannot represent: the coarse correction then ties the crack's faces together
//! and conjugate gradients spend thousands of iterations undoing it (docs/performance.md,
//! "Profiles of the long validation runs"). So each cell's coarse unknowns are those of its
//! *pieces*: the groups of its nodes joined through the cell's own unbroken bonds, found again
//! at every update from the bonds' status (connectivity-aware aggregation, as in algebraic
//! multigrid for fracture). An intact cell is one piece, as before. A piece holding less than
//! a quarter of its cell's nodes (a fragment, a sliver along a crack face) gets no unknown of
//! its own: hanging by a few bonds, it would give A_c a nearly singular block, and the
//! correction a huge step along it that the line search then scales the whole step down for
//! (measured: docs/performance.md, "Coarse cells split along cracks").
//!
//! K is the bond-based linearisation of the forces about the reference configuration: bond
//! i→j of stiffness k = V_i V_j C̄ (C̄ the bond stiffness `ForceEngine::pair_stiffness`,
//! broken halves taking none) adds k/2 (e_i − e_j)(e_i − e_j)ᵀ ⊗ n nᵀ (n = ξ/|ξ|) over the
//! free components, which is positive semidefinite for each directed bond, so A_c is too,
//! for any family (dual horizons included). For PMB near the reference configuration it is the
//! exact tangent (Silling & Askari 2005, Eq. 16's linearisation); for state-based models the
//! bond-based equivalent that the stable time step uses: only the speed depends on it.
//!
//! Every number is the same for any thread or rank count: the cells come from the reference
//! positions and the global bounding box, a piece is named by the smallest global index among
//! the nodes its members reach (a fixpoint that no order of visits changes), its node counts
//! are sums of integers, and the coarse matrix and each restriction Pᵀr are left folds over
//! the nodes in the global order, continued from rank to rank (`Ranks::chain_words`); each
//! rank then solves the same coarse system.

use super::ranks::Share;
use super::Simulation;
use crate::material::Material;
use crate::math::Vector;
use crate::state::BROKEN;

/// Coarse cells aimed at: in 2D the banded factorisation of 2 × 4096 unknowns (band ≈ 2·64)
/// costs about 10⁸ operations, a few force evaluations; in 3D the band grows with the cells of
/// two axes, so fewer.
const CELLS_2D: f64 = 4096.0;
const CELLS_3D: f64 = 1000.0;

/// No coarse unknown for this component of this node.
const NONE: u32 = u32::MAX;

/// Pieces a cell keeps apart; nodes of further pieces (a cell cut into many fragments) share
/// the last one.
const PIECES: usize = 8;

/// The least share of its cell's nodes a piece needs to move as one of its own.
const MIN_SHARE: f64 = 0.25;

/// A floating piece (a fragment cut loose) makes A_c singular; its diagonal is raised by this
/// fraction, which bounds the correction along its rigid motions.
const REGULARISATION: f64 = 1e-8;

/// The coarse space of one damage state.
pub struct CoarseSpace<const D: usize> {
    /// Per local node (owned, then ghosts): its cell.
    cell: Vec<u32>,
    /// Number of cells.
    cells: usize,
    /// Per local node (owned, then ghosts): its coarse unknown per component (`NONE`: fixed).
    unknowns: Vec<[u32; D]>,
    /// Number of coarse unknowns.
    size: usize,
    /// Half-bandwidth of A_c in the unknowns' order.
    band: usize,
    /// The Cholesky factor L of A_c (A_c = L Lᵀ), row r's entries in columns r − band ..= r
    /// at `r * (band + 1) + (c + band − r)`.
    factor: Vec<f64>,
}

impl<const D: usize> CoarseSpace<D> {
    /// The cells of `sim`'s body (the pieces, unknowns and factor come with `update`).
    pub fn new<M: Material<D>>(sim: &Simulation<D, M>) -> Self {
        let share = sim.share.as_deref();
        let owned = sim.owned();
        let positions = &sim.body.positions;
        // The global bounding box of the reference positions and the longest bond.
        let mut lo = [f64::INFINITY; D];
        let mut hi = [f64::NEG_INFINITY; D];
        for x in &positions[..owned] {
            for a in 0..D {
                lo[a] = lo[a].min(x[a]);
                hi[a] = hi[a].max(x[a]);
            }
        }
        let longest = sim.bonds.ref_lengths[..sim.bonds.offsets[owned]]
            .iter()
            .fold(0.0, |m: f64, &l| m.max(l));
        let (lo, hi, longest) = match share {
            None => (lo, hi, longest),
            Some(s) => (
                lo.map(|x| s.ranks.min_f64(x)),
                hi.map(|x| s.ranks.max_f64(x)),
                s.ranks.max_f64(longest),
            ),
        };
        let extent: [f64; D] = std::array::from_fn(|a| (hi[a] - lo[a]).max(0.0));
        // Cells no narrower than the longest bond (a bond then joins neighbouring cells only).
        let target = if D == 2 { CELLS_2D } else { CELLS_3D };
        let measure: f64 = extent.iter().map(|e| e.max(longest)).product();
        let width = (measure / target).powf(1.0 / D as f64).max(longest);
        let cells: [usize; D] = std::array::from_fn(|a| ((extent[a] / width) as usize).max(1));
        // The axis with the fewest cells varies fastest: the band spans the others' product.
        let mut axes: [usize; D] = std::array::from_fn(|a| a);
        axes.sort_by_key(|&a| (cells[a], a));
        let cell_of = |x: &Vector<D>| {
            let (mut index, mut stride) = (0, 1);
            for &a in &axes {
                let c = (((x[a] - lo[a]) / width) as usize).min(cells[a] - 1);
                index += c * stride;
                stride *= cells[a];
            }
            index as u32
        };
        CoarseSpace {
            cell: positions.iter().map(cell_of).collect(),
            cells: cells.iter().product(),
            unknowns: Vec::new(),
            size: 0,
            band: 0,
            factor: Vec::new(),
        }
    }

    /// Finds the cells' pieces for the bonds' current status, numbers their unknowns, and
    /// assembles and factorises A_c. Called at the start of every minimisation (a few passes
    /// over the bonds, about the cost of a few force evaluations): the factor is then a
    /// function of the state alone, so a run continued from a checkpoint builds the one the
    /// paused minimisation used.
    pub fn update<M: Material<D>>(&mut self, sim: &Simulation<D, M>) {
        let piece = self.pieces(sim);
        self.number(sim, &piece);
        let matrix = self.assemble(sim);
        self.factor = factorise(matrix, self.size, self.band);
    }

    /// Per owned node, the piece of its cell it belongs to (0..PIECES).
    fn pieces<M: Material<D>>(&self, sim: &Simulation<D, M>) -> Vec<u8> {
        let share = sim.share.as_deref();
        let owned = sim.owned();
        let (bonds, status, cell) = (&sim.bonds, &sim.state.status, &self.cell);
        // Each node's name: the smallest global index it reaches through its cell's unbroken
        // bonds. Visits lower names until none changes; any order ends at the same names.
        let first = share.map_or(0, |s| s.first);
        let mut name: Vec<f64> = (0..cell.len()).map(|i| (first + i) as f64).collect();
        loop {
            if let Some(s) = share {
                s.halo.exchange_values(s.ranks.as_ref(), &mut name);
            }
            let mut lowered = 0u64;
            for i in 0..owned {
                let mut m = name[i];
                for b in bonds.family(i) {
                    let j = bonds.neighbors[b] as usize;
                    if status[b] != BROKEN && cell[j] == cell[i] {
                        m = m.min(name[j]);
                    }
                }
                if m < name[i] {
                    name[i] = m;
                    lowered += 1;
                }
            }
            let lowered = share.map_or(lowered, |s| s.ranks.sum_u64(lowered));
            if lowered == 0 {
                break;
            }
        }
        // Per cell, the PIECES smallest names of its pieces (ascending, ∞ for none): the same
        // set whatever the order the nodes are folded in.
        let words = self.cells * PIECES;
        let fold = |mut table: Vec<f64>| {
            for i in 0..owned {
                let slots = &mut table[cell[i] as usize * PIECES..][..PIECES];
                let n = name[i];
                if n < slots[PIECES - 1] && !slots.contains(&n) {
                    let at = slots.partition_point(|&s| s < n);
                    slots[at..].rotate_right(1);
                    slots[at] = n;
                }
            }
            table
        };
        let table = match share {
            None => fold(vec![f64::INFINITY; words]),
            Some(s) => s.ranks.chain_words(words, &mut |before| match before {
                None => fold(vec![f64::INFINITY; words]),
                Some(b) => fold(b.to_vec()),
            }),
        };
        (0..owned)
            .map(|i| {
                let slots = &table[cell[i] as usize * PIECES..][..PIECES];
                slots[..PIECES - 1]
                    .iter()
                    .position(|&s| s == name[i])
                    .unwrap_or(PIECES - 1) as u8
            })
            .collect()
    }

    /// The coarse unknowns of the owned nodes' pieces (one per component with a free node, for
    /// pieces not too small), their ghosts' from their owners, and A_c's half-bandwidth.
    fn number<M: Material<D>>(&mut self, sim: &Simulation<D, M>, piece: &[u8]) {
        let share = sim.share.as_deref();
        let owned = sim.owned();
        let mask = &sim.constrained_mask;
        let slot = |i: usize| self.cell[i] as usize * PIECES + piece[i] as usize;
        // Per piece: its nodes, then its nodes free in each component; sums of integers, the
        // same in any order.
        let per = D + 1;
        let words = self.cells * PIECES * per;
        let mut count = vec![0.0; words];
        for (i, m) in mask[..owned].iter().enumerate() {
            let c = &mut count[slot(i) * per..][..per];
            c[0] += 1.0;
            for k in 0..D {
                if !m[k] {
                    c[1 + k] += 1.0;
                }
            }
        }
        if let Some(s) = share {
            count = s.ranks.chain_words(words, &mut |before| match before {
                None => count.clone(),
                Some(b) => count.iter().zip(b).map(|(u, b)| u + b).collect(),
            });
        }
        // A piece's component is an unknown when a node of it is free in that component and
        // the piece holds at least MIN_SHARE of its cell's nodes (smaller ones, fragments,
        // are left to Jacobi: see the module's comment).
        let mut number = vec![NONE; self.cells * PIECES * D];
        let mut size = 0u32;
        for (cell, counts) in count.chunks(PIECES * per).enumerate() {
            let nodes: f64 = counts.chunks(per).map(|c| c[0]).sum();
            for (p, c) in counts.chunks(per).enumerate() {
                if c[0] < MIN_SHARE * nodes {
                    continue;
                }
                for k in 0..D {
                    if c[1 + k] > 0.0 {
                        number[(cell * PIECES + p) * D + k] = size;
                        size += 1;
                    }
                }
            }
        }
        let mut unknowns = vec![[NONE; D]; self.cell.len()];
        for (i, u) in unknowns[..owned].iter_mut().enumerate() {
            *u = std::array::from_fn(|k| {
                if mask[i][k] {
                    NONE
                } else {
                    number[slot(i) * D + k]
                }
            });
        }
        if let Some(s) = share {
            // A ghost's piece and constraints are its owner's to know.
            s.halo.exchange_items(
                s.ranks.as_ref(),
                D,
                &mut unknowns,
                |u, buf| buf.extend(u.iter().map(|&k| k as f64)),
                |u, w| *u = std::array::from_fn(|k| w[k] as u32),
            );
        }
        // The half-bandwidth over the unbroken bonds' pairs of unknowns.
        let mut band = D - 1;
        for i in 0..owned {
            for b in sim.bonds.family(i) {
                if sim.state.status[b] == BROKEN {
                    continue;
                }
                let j = sim.bonds.neighbors[b] as usize;
                for p in unknowns[i].iter().filter(|p| **p != NONE) {
                    for q in unknowns[j].iter().filter(|q| **q != NONE) {
                        band = band.max(p.abs_diff(*q) as usize);
                    }
                }
            }
        }
        let band = match share {
            None => band,
            Some(s) => s.ranks.max_f64(band as f64) as usize,
        };
        self.unknowns = unknowns;
        self.size = size as usize;
        self.band = band.min((size as usize).saturating_sub(1));
    }

    /// A_c's lower band: the left fold of every owned node's bonds, in the global node order.
    fn assemble<M: Material<D>>(&self, sim: &Simulation<D, M>) -> Vec<f64> {
        let (band, width) = (self.band, self.band + 1);
        let (bonds, positions) = (&sim.bonds, &sim.body.positions);
        let (volumes, status) = (&sim.body.volumes, &sim.state.status);
        let unknowns = &self.unknowns;
        let owned = sim.owned();
        let fold = |mut a: Vec<f64>| {
            let mut add = |r: u32, c: u32, value: f64| {
                if r != NONE && c != NONE && c <= r {
                    let (r, c) = (r as usize, c as usize);
                    a[r * width + c + band - r] += value;
                }
            };
            for i in 0..owned {
                for b in bonds.family(i) {
                    let s = status[b];
                    if s == BROKEN {
                        continue;
                    }
                    let j = bonds.neighbors[b] as usize;
                    let half = 0.5
                        * volumes[i]
                        * volumes[j]
                        * sim.engine.pair_stiffness(&sim.bonds, b, i, j, s);
                    if half == 0.0 {
                        continue;
                    }
                    let n = (positions[j] - positions[i]) / bonds.ref_lengths[b];
                    let (ui, uj) = (&unknowns[i], &unknowns[j]);
                    for k in 0..D {
                        for l in 0..D {
                            let v = half * n[k] * n[l];
                            add(ui[k], ui[l], v);
                            add(uj[k], uj[l], v);
                            add(ui[k], uj[l], -v);
                            add(uj[k], ui[l], -v);
                        }
                    }
                }
            }
            a
        };
        let words = self.size * width;
        match sim.share.as_deref() {
            None => fold(vec![0.0; words]),
            Some(s) => s.ranks.chain_words(words, &mut |before| match before {
                None => fold(vec![0.0; words]),
                Some(b) => fold(b.to_vec()),
            }),
        }
    }

    /// s += P A_c⁻¹ Pᵀ r on the owned nodes.
    pub fn correct(&self, share: Option<&Share>, r: &[Vector<D>], s: &mut [Vector<D>]) {
        if self.size == 0 {
            return;
        }
        let unknowns = &self.unknowns;
        let restrict = |mut acc: Vec<f64>| {
            for (u, r) in unknowns.iter().zip(r) {
                for k in 0..D {
                    if u[k] != NONE {
                        acc[u[k] as usize] += r[k];
                    }
                }
            }
            acc
        };
        let mut z = match share {
            None => restrict(vec![0.0; self.size]),
            Some(sh) => sh.ranks.chain_words(self.size, &mut |before| match before {
                None => restrict(vec![0.0; self.size]),
                Some(b) => restrict(b.to_vec()),
            }),
        };
        solve(&self.factor, self.band, &mut z);
        for (u, s) in unknowns.iter().zip(s.iter_mut()) {
            for k in 0..D {
                if u[k] != NONE {
                    s[k] += z[u[k] as usize];
                }
            }
        }
    }
}

/// The Cholesky factor of the symmetric band matrix `a` (lower band, `band` below the
/// diagonal), each diagonal raised by `REGULARISATION` of itself; an unknown that no stiffness
/// reaches (nothing on its diagonal) gets an infinite pivot: no correction.
fn factorise(mut a: Vec<f64>, n: usize, band: usize) -> Vec<f64> {
    let width = band + 1;
    let at = |r: usize, c: usize| r * width + c + band - r;
    for r in 0..n {
        let d = a[at(r, r)];
        a[at(r, r)] = if d > 0.0 {
            d * (1.0 + REGULARISATION)
        } else {
            f64::INFINITY
        };
    }
    for r in 0..n {
        let first = r.saturating_sub(band);
        for c in first..=r {
            let mut sum = a[at(r, c)];
            for k in first.max(c.saturating_sub(band))..c {
                sum -= a[at(r, k)] * a[at(c, k)];
            }
            a[at(r, c)] = if c == r {
                // The regularisation keeps the pivot positive but for rounding.
                sum.max(f64::MIN_POSITIVE).sqrt()
            } else {
                sum / a[at(c, c)]
            };
        }
    }
    a
}

/// z ← (L Lᵀ)⁻¹ z.
fn solve(factor: &[f64], band: usize, z: &mut [f64]) {
    let n = z.len();
    let width = band + 1;
    let at = |r: usize, c: usize| r * width + c + band - r;
    for r in 0..n {
        let mut sum = z[r];
        for c in r.saturating_sub(band)..r {
            sum -= factor[at(r, c)] * z[c];
        }
        z[r] = sum / factor[at(r, r)];
    }
    for r in (0..n).rev() {
        let mut sum = z[r];
        for c in r + 1..(r + width).min(n) {
            sum -= factor[at(c, r)] * z[c];
        }
        z[r] = sum / factor[at(r, r)];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_factor_solves_a_band_system() {
        // A tridiagonal (band 1) symmetric positive definite system with a known solution.
        let n = 6;
        let band = 1;
        let mut a = vec![0.0; n * (band + 1)];
        for r in 0..n {
            a[r * 2 + 1] = 4.0;
            if r > 0 {
                a[r * 2] = -1.0;
            }
        }
        let x: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let mut b: Vec<f64> = (0..n)
            .map(|r| {
                4.0 * x[r]
                    - if r > 0 { x[r - 1] } else { 0.0 }
                    - if r + 1 < n { x[r + 1] } else { 0.0 }
            })
            .collect();
        let factor = factorise(a, n, band);
        solve(&factor, band, &mut b);
        for (got, want) in b.iter().zip(&x) {
            // The regularisation moves the solution by about 10⁻⁸ of itself.
            assert!((got - want).abs() < 1e-7 * want, "{got} against {want}");
        }
    }
}
