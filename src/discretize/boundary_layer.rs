//! Fictitious boundary layers (seed 001 §2.9, after Madenci & Oterkus): rows of nodes outside
//! a face of the body, a horizon wide, on which displacements are prescribed. A node near the
//! face then has a full neighbourhood, and the load acts like a local boundary condition on
//! the face instead of a volume condition on a strip of the body.

use super::NodeCloud;

/// A face of the body's bounding box: the axis normal to it and which end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Face {
    pub axis: usize,
    pub positive: bool,
}

/// Adds a layer of `width` outside `face` of `body_box` (the box of the body alone, before
/// any layer is added) and returns the indices of its nodes. Rows are `spacing` apart, normal
/// to the face; across the face the nodes tile the box in equal cells as close to `spacing` as
/// fit, so on a lattice of that spacing the layer continues the lattice exactly.
pub fn add_layer(
    cloud: &mut NodeCloud,
    dim: usize,
    face: Face,
    body_box: ([f64; 3], [f64; 3]),
    (width, spacing): (f64, f64),
    thickness: f64,
) -> Result<Vec<u32>, String> {
    if face.axis >= dim {
        return Err(format!("axis {} does not exist in {dim}D", face.axis));
    }
    let (lo, hi) = body_box;
    if !(0..dim).all(|k| hi[k] > lo[k]) {
        return Err("a boundary layer needs a body to lie against".into());
    }
    let rows = (width / spacing - 1e-9).ceil().max(1.0) as usize;
    // Across the face: equal cells over the box's extent.
    let mut counts = [1usize; 3];
    let mut steps = [0.0; 3];
    for k in (0..dim).filter(|&k| k != face.axis) {
        let extent = hi[k] - lo[k];
        counts[k] = (extent / spacing).round().max(1.0) as usize;
        steps[k] = extent / counts[k] as f64;
    }
    counts[face.axis] = rows;
    steps[face.axis] = spacing;
    let cell: f64 = steps[..dim].iter().product();
    let volume = if dim == 2 { cell * thickness } else { cell };
    let start = cloud.len() as u32;
    for i2 in 0..counts[2] {
        for i1 in 0..counts[1] {
            for i0 in 0..counts[0] {
                let index = [i0, i1, i2];
                let mut p = [0.0; 3];
                for k in 0..dim {
                    let offset = (index[k] as f64 + 0.5) * steps[k];
                    p[k] = if k != face.axis {
                        lo[k] + offset
                    } else if face.positive {
                        hi[k] + offset
                    } else {
                        lo[k] - offset
                    };
                }
                cloud.positions.push(p);
                cloud.volumes.push(volume);
                cloud.cell_sizes.push(spacing);
                cloud.blocks.push(0);
            }
        }
    }
    Ok((start..cloud.len() as u32).collect())
}

/// The box the cloud's cells fill: node positions ± half their cell size.
pub fn cell_box(cloud: &NodeCloud, dim: usize) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (p, &r) in cloud.positions.iter().zip(&cloud.cell_sizes) {
        for k in 0..dim {
            lo[k] = lo[k].min(p[k] - 0.5 * r);
            hi[k] = hi[k].max(p[k] + 0.5 * r);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discretize::lattice::lattice;
    use crate::geometry::Shape;

    fn rectangle(min: [f64; 2], max: [f64; 2]) -> Shape {
        Shape::Rectangle { min, max }
    }

    /// A layer on a lattice continues it: the same nodes as a lattice over the larger box.
    #[test]
    fn a_layer_continues_the_lattice() {
        let dx = 0.1;
        let mut cloud = lattice(&rectangle([0.0, 0.0], [1.0, 2.0]), 2, dx, 0.5).unwrap();
        let body = cloud.len();
        let top = Face {
            axis: 1,
            positive: true,
        };
        let body_box = cell_box(&cloud, 2);
        let layer = add_layer(&mut cloud, 2, top, body_box, (0.3, dx), 0.5).unwrap();
        assert_eq!(layer.len(), 30, "3 rows of 10");
        assert_eq!(layer[0] as usize, body);
        let whole = lattice(&rectangle([0.0, 0.0], [1.0, 2.3]), 2, dx, 0.5).unwrap();
        let key = |p: &[f64; 3]| ((p[1] * 1e6).round() as i64, (p[0] * 1e6).round() as i64);
        let mut mine: Vec<_> = cloud.positions.iter().map(key).collect();
        let mut theirs: Vec<_> = whole.positions.iter().map(key).collect();
        mine.sort_unstable();
        theirs.sort_unstable();
        assert_eq!(mine, theirs);
        whole.volumes.iter().chain(&cloud.volumes).for_each(|&v| {
            assert!((v - dx * dx * 0.5).abs() < 1e-15);
        });
        assert!(cloud.positions[body..]
            .iter()
            .all(|p| p[1] > 2.0 && p[1] < 2.3));
    }

    /// The layer lies outside the face it is on, one horizon wide, and tiles the face's width.
    #[test]
    fn layers_on_each_face_of_a_box_in_3d() {
        let dx = 0.25;
        let shape = Shape::Box {
            min: [0.0, 0.0, 0.0],
            max: [1.0, 1.0, 2.0],
        };
        for (axis, positive) in [(0, false), (1, true), (2, false)] {
            let mut cloud = lattice(&shape, 3, dx, 1.0).unwrap();
            let body = cloud.len();
            let face = Face { axis, positive };
            let body_box = cell_box(&cloud, 3);
            let layer = add_layer(&mut cloud, 3, face, body_box, (0.6, dx), 1.0).unwrap();
            // 0.6 / 0.25 rounds up to 3 rows; the face is 4 × 4 or 4 × 8 cells.
            let across = if axis == 2 { 16 } else { 32 };
            assert_eq!(layer.len(), 3 * across, "axis {axis}");
            let volume: f64 = cloud.volumes[body..].iter().sum();
            let face_area = if axis == 2 { 1.0 } else { 2.0 };
            assert!((volume - face_area * 0.75).abs() < 1e-12);
            let limit = if positive { 1.0 } else { 0.0 };
            for p in &cloud.positions[body..] {
                let beyond = if positive {
                    p[axis] - limit
                } else {
                    limit - p[axis]
                };
                assert!(beyond > 0.0 && beyond < 0.75, "axis {axis}: {p:?}");
            }
        }
    }

    /// Cells of a mesh that do not fit the spacing: equal cells across the face.
    #[test]
    fn an_uneven_face_gets_equal_cells() {
        let mut cloud = NodeCloud {
            positions: vec![[0.05, 0.05, 0.0], [0.98, 0.05, 0.0]],
            volumes: vec![0.01, 0.0016],
            cell_sizes: vec![0.1, 0.04],
            blocks: vec![0, 0],
        };
        let bottom = Face {
            axis: 1,
            positive: false,
        };
        let body_box = cell_box(&cloud, 2);
        let layer = add_layer(&mut cloud, 2, bottom, body_box, (0.1, 0.1), 1.0).unwrap();
        // The box spans x from 0 to 1.0: 10 cells of 0.1.
        assert_eq!(layer.len(), 10);
        let xs: Vec<f64> = layer
            .iter()
            .map(|&i| cloud.positions[i as usize][0])
            .collect();
        assert!((xs[0] - 0.05).abs() < 1e-12 && (xs[9] - 0.95).abs() < 1e-12);
        assert!(layer
            .iter()
            .all(|&i| (cloud.positions[i as usize][1] + 0.05).abs() < 1e-12));
        let z = Face {
            axis: 2,
            positive: true,
        };
        assert!(add_layer(&mut cloud, 2, z, body_box, (0.1, 0.1), 1.0).is_err());
    }
}
