//! The generated grids of a deck: lattices with multi-grid refinement, boundary-fitted free
//! meshes and NB-NUG, each optionally with random pores cut out.

use super::schema::{CellKind, PoresDeck, RefineDeck};
use crate::discretize::free_mesh::free_mesh;
use crate::discretize::multigrid::{multigrid, Refinement};
use crate::discretize::nbnug::{Hole, NbNug};
use crate::discretize::recombine::{recombine, CellMesh};
use crate::discretize::{lattice, NodeCloud};
use crate::geometry::pores::{pores_text, random_pores, Pore, PoreSpec};
use crate::geometry::Shape;

/// The pores of a deck, drawn in the shape's bounding box, and their realisation as text
/// (`pores.txt`: what a run needs to be repeated and inspected).
pub fn pores_of(shape: &Shape, dim: usize, p: &PoresDeck) -> Result<(Vec<Pore>, String), String> {
    let Some((min, max)) = shape.bounding_box() else {
        return Err("pores need a bounded shape".into());
    };
    let spec = PoreSpec {
        min,
        max,
        count: p.count,
        radius_min: p.radius[0],
        radius_max: p.radius[1],
        clearance: p.clearance,
        seed: p.seed,
    };
    let pores = random_pores(&spec)?;
    debug_assert!(pores.iter().all(|q| q.center.len() == dim));
    let text = pores_text(&spec, &pores);
    Ok((pores, text))
}

/// `shape` with the pores cut out.
fn without(shape: &Shape, pores: &[Pore]) -> Shape {
    if pores.is_empty() {
        return shape.clone();
    }
    let holes = pores
        .iter()
        .map(|p| match p.center.len() {
            2 => Shape::Disk {
                center: [p.center[0], p.center[1]],
                radius: p.radius,
            },
            _ => Shape::Sphere {
                center: [p.center[0], p.center[1], p.center[2]],
                radius: p.radius,
            },
        })
        .collect();
    Shape::Difference {
        base: Box::new(shape.clone()),
        subtract: holes,
    }
}

/// A lattice, refined where the deck says.
pub fn lattice_grid(
    shape: &Shape,
    dim: usize,
    spacing: f64,
    thickness: f64,
    refine: &[RefineDeck],
    pores: &[Pore],
) -> Result<NodeCloud, String> {
    let shape = without(shape, pores);
    if refine.is_empty() {
        return lattice::lattice(&shape, dim, spacing, thickness);
    }
    let regions: Vec<Refinement> = refine
        .iter()
        .map(|r| Refinement {
            region: r.region.clone(),
            level: r.levels,
        })
        .collect();
    multigrid(&shape, dim, spacing, thickness, &regions)
}

fn cells_of(triangles: &crate::discretize::free_mesh::TriangleMesh, kind: CellKind) -> CellMesh {
    match kind {
        CellKind::QuadDominant => recombine(triangles),
        CellKind::Triangles => CellMesh::from(triangles),
    }
}

/// A boundary-fitted free mesh of a 2D shape.
pub fn free_mesh_grid(
    shape: &Shape,
    size: f64,
    thickness: f64,
    cells: CellKind,
    pores: &[Pore],
) -> Result<NodeCloud, String> {
    let triangles = free_mesh(&without(shape, pores), size)?;
    Ok(cells_of(&triangles, cells).centroid_cloud(thickness))
}

/// NB-NUG of a rectangle with holes (a rectangle, or a rectangle minus disks) and pores.
pub fn nbnug_grid(
    shape: &Shape,
    size: f64,
    padding: f64,
    thickness: f64,
    cells: CellKind,
    pores: &[Pore],
) -> Result<NodeCloud, String> {
    let not_a_plate = || {
        "NB-NUG needs a rectangle, or a difference of a rectangle and disks (the holes)".to_string()
    };
    let (rect, subtract): (&Shape, &[Shape]) = match shape {
        Shape::Difference { base, subtract } => (base, subtract),
        s => (s, &[]),
    };
    let Shape::Rectangle { min, max } = rect else {
        return Err(not_a_plate());
    };
    let mut holes = Vec::new();
    for s in subtract {
        let Shape::Disk { center, radius } = s else {
            return Err(not_a_plate());
        };
        holes.push(Hole {
            center: *center,
            radius: *radius,
        });
    }
    holes.extend(pores.iter().map(|p| Hole {
        center: [p.center[0], p.center[1]],
        radius: p.radius,
    }));
    let grid = NbNug {
        min: *min,
        max: *max,
        holes,
        size,
        padding,
        quads: cells == CellKind::QuadDominant,
    };
    Ok(grid.mesh()?.centroid_cloud(thickness))
}
