//! Uniform square (2D) or cubic (3D) lattice over a shape: nodes at cell centres.

use super::NodeCloud;
use crate::geometry::Shape;

/// Fills `shape` with a lattice of spacing `dx`, keeping the cells whose centre lies in the
/// shape. Cells are aligned with the shape's bounding box minimum, so a rectangle of exact
/// multiples of `dx` is tiled without gaps. Volume is dx² · thickness in 2D and dx³ in 3D.
pub fn lattice(shape: &Shape, dim: usize, dx: f64, thickness: f64) -> Result<NodeCloud, String> {
    let (lo, counts) = cells(shape, dim, dx)?;
    let volume = if dim == 2 {
        dx * dx * thickness
    } else {
        dx * dx * dx
    };
    let mut cloud = NodeCloud::default();
    let mut p = [0.0; 3];
    for iz in 0..counts[2] {
        for iy in 0..counts[1] {
            for ix in 0..counts[0] {
                p[0] = lo[0] + (ix as f64 + 0.5) * dx;
                p[1] = lo[1] + (iy as f64 + 0.5) * dx;
                p[2] = if dim == 3 {
                    lo[2] + (iz as f64 + 0.5) * dx
                } else {
                    0.0
                };
                if shape.contains(&p[..dim]) {
                    cloud.positions.push(p);
                    cloud.volumes.push(volume);
                    cloud.cell_sizes.push(dx);
                    cloud.blocks.push(0);
                }
            }
        }
    }
    Ok(cloud)
}

/// Number of lattice cells in the shape's bounding box: an upper bound of the node count,
/// known before any node is made.
pub fn cell_count(shape: &Shape, dim: usize, dx: f64) -> Result<f64, String> {
    let (_, counts) = cells(shape, dim, dx)?;
    Ok(counts.iter().map(|&c| c as f64).product())
}

/// The lattice's origin (bounding-box minimum) and cell counts per axis.
fn cells(shape: &Shape, dim: usize, dx: f64) -> Result<(Vec<f64>, [usize; 3]), String> {
    let (lo, hi) = shape
        .bounding_box()
        .ok_or_else(|| "the discretized shape is unbounded (half-plane/half-space); intersect it with a bounded shape".to_string())?;
    let mut counts = [1usize; 3];
    for k in 0..dim {
        let n = ((hi[k] - lo[k]) / dx - 1e-9).ceil().max(1.0);
        if n > 1e8 {
            return Err(format!(
                "spacing {dx} gives {n} cells along axis {k}; is the spacing in metres?"
            ));
        }
        counts[k] = n as usize;
    }
    let total: f64 = counts.iter().map(|&c| c as f64).product();
    if total > 2.0e9 {
        return Err(format!(
            "the lattice would have {total:.3e} cells; the limit is 2e9 nodes"
        ));
    }
    Ok((lo, counts))
}
