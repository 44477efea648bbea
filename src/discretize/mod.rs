//! Turning a shape or a file into nodes: positions, volumes and cell sizes.

pub mod boundary_layer;
pub mod free_mesh;
pub mod gmsh;
pub mod lattice;
pub mod multigrid;
pub mod nbnug;
pub mod recombine;
pub mod reorder;

/// Nodes before they become a `Body`: reference positions (padded to 3 components),
/// volumes (m³; in 2D area × thickness) and the cell size r_j used by partial volumes.
#[derive(Debug, Clone, Default)]
pub struct NodeCloud {
    pub positions: Vec<[f64; 3]>,
    pub volumes: Vec<f64>,
    pub cell_sizes: Vec<f64>,
    pub blocks: Vec<u32>,
}

impl NodeCloud {
    /// Nodes with their areas (2D, times `thickness`) or volumes (3D); the cell size r_j is
    /// √area or ∛volume.
    pub fn from_measures(
        positions: Vec<[f64; 3]>,
        measures: &[f64],
        blocks: Vec<u32>,
        dim: usize,
        thickness: f64,
    ) -> Self {
        let two_d = dim == 2;
        NodeCloud {
            positions,
            volumes: measures
                .iter()
                .map(|&v| if two_d { v * thickness } else { v })
                .collect(),
            cell_sizes: measures
                .iter()
                .map(|&v| if two_d { v.sqrt() } else { v.cbrt() })
                .collect(),
            blocks,
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}
