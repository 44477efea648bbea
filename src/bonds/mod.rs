//! Bond families in compressed-sparse-row form.
//!
//! Each bond is stored in both endpoint families, so every node's force is a gather over its
//! own row: no atomics, a fixed summation order, bitwise-identical results for any thread count.
//! Per bond we keep a `u32` neighbour index and the `f64` reference length; the bond status
//! byte lives in `State` (13 bytes per directed bond in all).

pub mod overlap;
pub mod partial_volume;
pub mod precrack;
pub mod search;

pub use partial_volume::{PartialVolume, Quadrature};
pub use precrack::Precrack;

use std::ops::Range;

/// Families of all nodes (reference data, immutable during a run).
#[derive(Debug, Clone, Default)]
pub struct Bonds {
    /// `offsets[i]..offsets[i+1]` is the range of node i's bonds; length n + 1.
    pub offsets: Vec<usize>,
    /// Neighbour node of each directed bond.
    pub neighbors: Vec<u32>,
    /// Reference length |ξ| of each bond (m).
    pub ref_lengths: Vec<f64>,
}

impl Bonds {
    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of directed bonds (each physical bond counts twice).
    pub fn len(&self) -> usize {
        self.neighbors.len()
    }

    pub fn is_empty(&self) -> bool {
        self.neighbors.is_empty()
    }

    /// The bond range of node `i`.
    #[inline(always)]
    pub fn family(&self, i: usize) -> Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// Mean number of bonds per node.
    pub fn bonds_per_node(&self) -> f64 {
        self.len() as f64 / self.nodes().max(1) as f64
    }

    /// Bytes per directed bond of the reference data plus the status byte in `State`.
    pub const BYTES_PER_BOND: usize = 4 + 8 + 1;

    /// Index of the reverse bond (j → i) of bond `b` in node i's family, by binary search in
    /// node j's sorted family. A distributed run's rows are sorted by global index, which
    /// its local indices do not follow where a row reaches ghosts of the ranks before
    /// (`distributed::share`): there a miss of the search falls back to a scan of the row.
    pub fn reverse(&self, i: usize, b: usize) -> Option<usize> {
        let j = self.neighbors[b] as usize;
        let r = self.family(j);
        let row = &self.neighbors[r.clone()];
        let k = row.binary_search(&(i as u32)).ok();
        k.or_else(|| row.iter().position(|&n| n as usize == i))
            .map(|k| r.start + k)
    }
}
