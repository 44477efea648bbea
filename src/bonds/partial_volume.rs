//! Quadrature weights of a bond: the neighbour's volume times the fraction of it that lies
//! inside the horizon.

use serde::{Deserialize, Serialize};

/// How the volume of a neighbour cut by the horizon boundary is counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum PartialVolume {
    /// Hu–Ha–Bobaru factor (seed 000, Eq. 12 on uniform grids); on non-uniform grids its
    /// generalisation with r_j = sqrt(V_j) (Eqs. 13–14) — one formula with the node's cell size r_j.
    #[default]
    Hhb,
    /// Whole volume if |ξ| ≤ δ, nothing otherwise.
    None,
}

impl PartialVolume {
    /// Search radius beyond δ that can still give a non-zero factor.
    pub fn reach(self, cell_size: f64) -> f64 {
        match self {
            PartialVolume::Hhb => 0.5 * cell_size,
            PartialVolume::None => 0.0,
        }
    }

    /// Fraction φ of neighbour j's cell inside a horizon δ at distance `len`.
    /// Seed 000, Eqs. 12–13: φ = 1 for |ξ| ≤ δ − r/2, (δ + r/2 − |ξ|)/r in the band, 0 beyond.
    /// (The paper writes φ(‖ξ+η‖) but its cases use ‖ξ‖: we use the reference length.)
    #[inline(always)]
    pub fn factor(self, len: f64, horizon: f64, cell_size: f64) -> f64 {
        match self {
            PartialVolume::Hhb => ((horizon + 0.5 * cell_size - len) / cell_size).clamp(0.0, 1.0),
            PartialVolume::None => {
                if len <= horizon {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// Per-node data the bond loop needs to weight a neighbour, packed together so one cache
/// line serves the whole lookup.
#[derive(Debug, Clone, Copy, Default)]
pub struct NodeWeight {
    pub volume: f64,
    pub half_cell: f64,
    pub inv_cell: f64,
    pub horizon: f64,
}

/// Quadrature weights w_ij = φ_ij V_j (and φ_ji), evaluated on the fly from node data so that no
/// per-bond storage is spent on them.
#[derive(Debug, Clone)]
pub struct Quadrature {
    pub rule: PartialVolume,
    pub nodes: Vec<NodeWeight>,
    /// Set when every node has the same volume, cell size and horizon.
    uniform: Option<NodeWeight>,
}

/// Quadrature weights of a uniform grid: φ depends on |ξ| only.
#[derive(Debug, Clone, Copy)]
pub struct UniformWeights {
    pub rule: PartialVolume,
    pub node: NodeWeight,
}

impl UniformWeights {
    /// φ(|ξ|) of seed 000, Eq. 12.
    #[inline(always)]
    pub fn phi(&self, len: f64) -> f64 {
        let n = &self.node;
        match self.rule {
            PartialVolume::Hhb => ((n.horizon + n.half_cell - len) * n.inv_cell).clamp(0.0, 1.0),
            PartialVolume::None => {
                if len <= n.horizon {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

impl Quadrature {
    pub fn new(rule: PartialVolume, volumes: &[f64], cell_sizes: &[f64], horizons: &[f64]) -> Self {
        let nodes = (0..volumes.len())
            .map(|i| NodeWeight {
                volume: volumes[i],
                half_cell: 0.5 * cell_sizes[i],
                inv_cell: 1.0 / cell_sizes[i],
                horizon: horizons[i],
            })
            .collect::<Vec<NodeWeight>>();
        let first = nodes.first().copied();
        let uniform = first.filter(|f| {
            nodes.iter().all(|n| {
                n.volume == f.volume && n.half_cell == f.half_cell && n.horizon == f.horizon
            })
        });
        Quadrature {
            rule,
            nodes,
            uniform,
        }
    }

    /// The constant weights of a uniform grid, if the grid is uniform.
    pub fn uniform(&self) -> Option<UniformWeights> {
        self.uniform.map(|node| UniformWeights {
            rule: self.rule,
            node,
        })
    }

    /// Fraction of node j's cell inside a horizon `horizon` at distance `len` (φ of Eqs. 12–14).
    #[inline(always)]
    pub fn phi(&self, len: f64, horizon: f64, j: usize) -> f64 {
        let n = &self.nodes[j];
        match self.rule {
            PartialVolume::Hhb => ((horizon + n.half_cell - len) * n.inv_cell).clamp(0.0, 1.0),
            PartialVolume::None => {
                if len <= horizon {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hhb_factor_matches_eq12() {
        let (d, dx) = (3.0, 1.0);
        let f = |l| PartialVolume::Hhb.factor(l, d, dx);
        assert_eq!(f(2.5), 1.0);
        assert_eq!(f(1.0), 1.0);
        assert!((f(3.0) - 0.5).abs() < 1e-15);
        assert!((f(3.25) - 0.25).abs() < 1e-15);
        assert_eq!(f(3.5), 0.0);
        assert_eq!(f(4.0), 0.0);
    }
}
