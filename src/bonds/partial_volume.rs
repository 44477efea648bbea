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
    /// The exact fraction of the neighbour's cell (square/cube of side r_j) inside the horizon
    /// ball, computed once per bond (`overlap.rs`) and stored as a byte per direction
    /// (resolution 1/255). More accurate than HHB in 3D, at 2 bytes per bond.
    Exact,
}

impl PartialVolume {
    /// Search radius beyond δ that can still give a non-zero factor.
    pub fn reach(self, cell_size: f64, dim: usize) -> f64 {
        match self {
            PartialVolume::Hhb => 0.5 * cell_size,
            PartialVolume::None => 0.0,
            PartialVolume::Exact => 0.5 * cell_size * (dim as f64).sqrt(),
        }
    }

    /// Fraction φ of neighbour j's cell inside a horizon δ at distance `len`.
    /// Seed 000, Eqs. 12–13: φ = 1 for |ξ| ≤ δ − r/2, (δ + r/2 − |ξ|)/r in the band, 0 beyond.
    /// (The paper writes φ(‖ξ+η‖) but its cases use ‖ξ‖: we use the reference length.)
    #[inline(always)]
    pub fn factor(self, len: f64, horizon: f64, cell_size: f64) -> f64 {
        match self {
            PartialVolume::Hhb => ((horizon + 0.5 * cell_size - len) / cell_size).clamp(0.0, 1.0),
            PartialVolume::None | PartialVolume::Exact => {
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
/// line serves the whole lookup (in this order: `simd_nodes` loads it as four f64).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C)]
pub struct NodeWeight {
    pub volume: f64,
    pub half_cell: f64,
    pub inv_cell: f64,
    pub horizon: f64,
}

impl NodeWeight {
    /// Fraction φ of this cell inside a horizon `horizon` at distance `len` (seed 000,
    /// Eqs. 12–14) under `rule`, for the rules that depend on |ξ| only.
    #[inline(always)]
    pub fn phi(&self, rule: PartialVolume, len: f64, horizon: f64) -> f64 {
        match rule {
            PartialVolume::Hhb => {
                ((horizon + self.half_cell - len) * self.inv_cell).clamp(0.0, 1.0)
            }
            PartialVolume::None | PartialVolume::Exact => {
                if len <= horizon {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// Quadrature weights w_ij = φ_ij V_j (and φ_ji), evaluated on the fly from node data so that no
/// per-bond storage is spent on them.
#[derive(Debug, Clone)]
pub struct Quadrature {
    pub rule: PartialVolume,
    pub nodes: Vec<NodeWeight>,
    /// Set when every node has the same volume, cell size and horizon.
    uniform: Option<NodeWeight>,
    /// Exact rule only: (φ_ij, φ_ji) of each directed bond, in 1/255.
    stored: Vec<[u8; 2]>,
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
        self.node.phi(self.rule, len, self.node.horizon)
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
            stored: Vec::new(),
        }
    }

    /// The quadrature of a body and its bonds; the exact rule computes and stores its
    /// fractions here (cached per lattice offset on uniform grids).
    pub fn for_body<const D: usize>(
        rule: PartialVolume,
        body: &crate::body::Body<D>,
        bonds: &super::Bonds,
    ) -> Self {
        Self::for_body_agreed(rule, body, bonds, |uniform| uniform)
    }

    /// `for_body` with the grid's uniformity settled by `agree` from this body's: a
    /// distributed run's ranks take the whole body's, so that each weighs its bonds, and
    /// picks its bond loops, as one process does.
    pub fn for_body_agreed<const D: usize>(
        rule: PartialVolume,
        body: &crate::body::Body<D>,
        bonds: &super::Bonds,
        agree: impl FnOnce(Option<NodeWeight>) -> Option<NodeWeight>,
    ) -> Self {
        let mut q = Self::new(rule, &body.volumes, &body.cell_sizes, &body.horizons);
        q.uniform = agree(q.uniform);
        if rule == PartialVolume::Exact {
            let mut lattice = q
                .uniform
                .map(|n| super::overlap::LatticeFractions::new(2.0 * n.half_cell, n.horizon));
            let mut fraction = |offset: &[f64], cell: f64, horizon: f64| match &mut lattice {
                Some(l) => l.fraction(offset),
                None => super::overlap::cell_fraction(offset, cell, horizon),
            };
            let quantise = |phi: f64| (phi * 255.0).round() as u8;
            q.stored = Vec::with_capacity(bonds.len());
            for i in 0..body.len() {
                for b in bonds.family(i) {
                    let j = bonds.neighbors[b] as usize;
                    let xi = body.positions[j] - body.positions[i];
                    let ij = fraction(xi.as_slice(), body.cell_sizes[j], body.horizons[i]);
                    let ji = fraction((-xi).as_slice(), body.cell_sizes[i], body.horizons[j]);
                    q.stored.push([quantise(ij), quantise(ji)]);
                }
            }
        }
        q
    }

    /// The constant weights of a uniform grid, if the grid is uniform and the rule depends on
    /// |ξ| only.
    pub fn uniform(&self) -> Option<UniformWeights> {
        if self.rule == PartialVolume::Exact {
            return None;
        }
        self.uniform.map(|node| UniformWeights {
            rule: self.rule,
            node,
        })
    }

    /// (φ_ij, φ_ji) of bond b = i→j of reference length `len`.
    #[inline(always)]
    pub fn phi_pair(&self, b: usize, i: usize, j: usize, len: f64) -> (f64, f64) {
        if self.rule == PartialVolume::Exact {
            let [ij, ji] = self.stored[b];
            return (ij as f64 / 255.0, ji as f64 / 255.0);
        }
        (
            self.phi(len, self.nodes[i].horizon, j),
            self.phi(len, self.nodes[j].horizon, i),
        )
    }

    /// Bytes per directed bond this rule stores.
    pub fn bytes_per_bond(&self) -> usize {
        if self.rule == PartialVolume::Exact {
            2
        } else {
            0
        }
    }

    /// Fraction of node j's cell inside a horizon `horizon` at distance `len` (φ of Eqs. 12–14),
    /// for the rules that depend on |ξ| only (use `phi_pair` for any rule).
    #[inline(always)]
    fn phi(&self, len: f64, horizon: f64, j: usize) -> f64 {
        self.nodes[j].phi(self.rule, len, horizon)
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
