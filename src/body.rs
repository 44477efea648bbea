//! The reference configuration: everything about the nodes that is known before the run.

use crate::discretize::{reorder::morton_order, NodeCloud};
use crate::geometry::Shape;
use crate::math::{vector_from_slice, Vector};
use std::collections::BTreeMap;

/// Reference configuration of a discretized body. Immutable once the run starts.
#[derive(Debug, Clone)]
pub struct Body<const D: usize> {
    /// Reference positions (m).
    pub positions: Vec<Vector<D>>,
    /// Nodal volumes (m³); in 2D the nodal area times `thickness`.
    pub volumes: Vec<f64>,
    /// Cell size r_j (m): the lattice spacing, or sqrt(area) / cbrt(volume) for imported nodes.
    /// Used by the partial-volume factor (seed 000, Eqs. 12–14).
    pub cell_sizes: Vec<f64>,
    /// Horizon δ_i of each node (m). Uniform today; per node so dual-horizon PD can vary it.
    pub horizons: Vec<f64>,
    /// Block (material region) id of each node.
    pub blocks: Vec<u32>,
    /// Nodes whose bonds never break.
    pub no_fail: Vec<bool>,
    /// Named node sets, as sorted node indices.
    pub node_sets: BTreeMap<String, Vec<u32>>,
    /// Out-of-plane thickness of a 2D body (m); 1 in 3D.
    pub thickness: f64,
}

impl<const D: usize> Body<D> {
    /// Builds a body from a node cloud, reordering the nodes along a Morton curve.
    pub fn from_cloud(cloud: NodeCloud, horizon: f64, thickness: f64) -> Self {
        Self::from_cloud_with_sets(cloud, BTreeMap::new(), horizon, thickness)
    }

    /// [`from_cloud`](Self::from_cloud) with named node sets given as indices into the cloud
    /// (e.g. a mesh's physical groups); they are renumbered with the nodes.
    pub fn from_cloud_with_sets(
        cloud: NodeCloud,
        sets: BTreeMap<String, Vec<u32>>,
        horizon: f64,
        thickness: f64,
    ) -> Self {
        let typical = cloud
            .cell_sizes
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min);
        let perm = morton_order(&cloud.positions, D, typical.max(f64::MIN_POSITIVE));
        let pick = |i: &u32| *i as usize;
        let n = perm.len();
        let mut new_index = vec![0u32; n];
        for (new, &old) in perm.iter().enumerate() {
            new_index[old as usize] = new as u32;
        }
        let node_sets = sets
            .into_iter()
            .map(|(name, nodes)| {
                let mut nodes: Vec<u32> = nodes.iter().map(|&i| new_index[i as usize]).collect();
                nodes.sort_unstable();
                (name, nodes)
            })
            .collect();
        Body {
            positions: perm
                .iter()
                .map(|i| vector_from_slice::<D>(&cloud.positions[pick(i)]))
                .collect(),
            volumes: perm.iter().map(|i| cloud.volumes[pick(i)]).collect(),
            cell_sizes: perm.iter().map(|i| cloud.cell_sizes[pick(i)]).collect(),
            horizons: vec![horizon; n],
            blocks: perm.iter().map(|i| cloud.blocks[pick(i)]).collect(),
            no_fail: vec![false; n],
            node_sets,
            thickness: if D == 2 { thickness } else { 1.0 },
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Indices of the nodes whose reference position lies in `region`.
    pub fn select(&self, region: &Shape) -> Vec<u32> {
        (0..self.len())
            .filter(|&i| region.contains(self.positions[i].as_slice()))
            .map(|i| i as u32)
            .collect()
    }

    /// Adds (or replaces) a named node set selected by region.
    pub fn add_node_set(&mut self, name: &str, region: &Shape) -> usize {
        let nodes = self.select(region);
        let n = nodes.len();
        self.node_sets.insert(name.to_string(), nodes);
        n
    }

    /// The nodes of a named set, or all nodes for the reserved name `all`.
    pub fn node_set(&self, name: &str) -> Option<Vec<u32>> {
        if name == "all" {
            return Some((0..self.len() as u32).collect());
        }
        self.node_sets.get(name).cloned()
    }

    /// Assigns `block` to every node inside `region`.
    pub fn assign_block(&mut self, block: u32, region: &Shape) {
        for i in 0..self.len() {
            if region.contains(self.positions[i].as_slice()) {
                self.blocks[i] = block;
            }
        }
    }

    /// Marks the nodes of a set as never failing.
    pub fn mark_no_fail(&mut self, nodes: &[u32]) {
        for &i in nodes {
            self.no_fail[i as usize] = true;
        }
    }

    /// Total volume (m³).
    pub fn total_volume(&self) -> f64 {
        self.volumes.iter().sum()
    }

    /// Smallest cell size, the "dx" of the discretization.
    pub fn min_cell_size(&self) -> f64 {
        self.cell_sizes
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min)
    }

    /// Largest horizon.
    pub fn max_horizon(&self) -> f64 {
        self.horizons.iter().cloned().fold(0.0, f64::max)
    }
}
