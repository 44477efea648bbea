//! Seeing a discretization before a long run: grid statistics for `peridyn check`, and
//! `peridyn grid DECK`, which writes the nodes (VTU: volume, cell size, horizon, block,
//! surface-correction factor) and a PNG of the node positions, sized and coloured by cell
//! size, with the shape's outline.

use crate::body::Body;
use crate::bonds::Bonds;
use crate::deck::build::{build_constitution, build_model};
use crate::deck::schema::Discretization;
use crate::deck::DeckError;
use crate::deck::LoadedDeck;
use crate::geometry::boundary::boundary_segments;
use crate::geometry::Shape;
use crate::material::surface_correction::SurfaceCorrection;
use crate::observe::vtu::{write_vtu, Field, FieldData};
use crate::plot::damage_map::{write_scalar_map_png, MapStyle};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

/// Samples per axis when the shape's area (2D) or volume (3D) is measured.
const SAMPLES_2D: usize = 2000;
const SAMPLES_3D: usize = 200;

/// What a grid is made of.
#[derive(Debug, Clone, Serialize)]
pub struct GridReport {
    pub nodes: usize,
    /// Smallest and largest distance from a node to its nearest neighbour (m).
    pub min_spacing: f64,
    pub max_spacing: f64,
    /// Sum of the nodes' areas (2D, without the thickness) or volumes (3D), boundary layers
    /// left out.
    pub measure: f64,
    /// Nodes and measure of the fictitious boundary layers.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub layers: Option<(usize, f64)>,
    /// The shape's area or volume, measured by sampling, when the deck gives a shape.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shape_measure: Option<f64>,
}

impl std::fmt::Display for GridReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "grid             {} nodes, nearest-neighbour spacing {:.4e} to {:.4e} m, node measure {:.6e}",
            self.nodes, self.min_spacing, self.max_spacing, self.measure
        )?;
        if let Some(s) = self.shape_measure {
            write!(
                f,
                " ({:+.3} % of the shape's {:.6e})",
                100.0 * (self.measure / s - 1.0),
                s
            )?;
        }
        if let Some((nodes, measure)) = self.layers {
            write!(f, "; boundary layers {nodes} nodes, measure {measure:.6e}")?;
        }
        Ok(())
    }
}

/// The shape a deck's discretization fills, if it names one.
pub fn deck_shape(ld: &LoadedDeck) -> Option<&Shape> {
    match &ld.deck.discretization {
        Discretization::Lattice { shape, .. }
        | Discretization::FreeMesh { shape, .. }
        | Discretization::Nbnug { shape, .. } => Some(shape),
        Discretization::PointCloud { .. } | Discretization::Gmsh { .. } => None,
    }
}

/// Statistics of a body and its bonds (the nearest neighbour of a node is among its bonds),
/// the deck's boundary layers counted apart.
pub fn grid_report<const D: usize>(ld: &LoadedDeck, body: &Body<D>, bonds: &Bonds) -> GridReport {
    let nearest: Vec<f64> = (0..body.len())
        .into_par_iter()
        .map(|i| {
            bonds
                .family(i)
                .map(|b| bonds.ref_lengths[b])
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let spacing = (
        nearest.iter().cloned().fold(f64::INFINITY, f64::min),
        nearest
            .iter()
            .cloned()
            .filter(|d| d.is_finite())
            .fold(0.0, f64::max),
    );
    grid_report_spaced(ld, body, spacing)
}

/// `grid_report` given the smallest and largest nearest-neighbour distance (a distributed
/// run's ranks each know their own nodes').
pub fn grid_report_spaced<const D: usize>(
    ld: &LoadedDeck,
    body: &Body<D>,
    (min_spacing, max_spacing): (f64, f64),
) -> GridReport {
    let thickness = ld.deck.thickness.unwrap_or(1.0);
    let mut in_layer = vec![false; body.len()];
    for layer in &ld.deck.boundary_layers {
        for i in body.node_set(&layer.name).expect("a layer is a node set") {
            in_layer[i as usize] = true;
        }
    }
    let per_area = if D == 2 { 1.0 / thickness } else { 1.0 };
    let measure_of = |layers: bool| -> f64 {
        (body.volumes.iter().zip(&in_layer))
            .filter(|(_, &l)| l == layers)
            .map(|(v, _)| v)
            .sum()
    };
    GridReport {
        nodes: body.len(),
        min_spacing,
        max_spacing,
        measure: measure_of(false) * per_area,
        layers: (!ld.deck.boundary_layers.is_empty()).then(|| {
            let nodes = in_layer.iter().filter(|&&l| l).count();
            (nodes, measure_of(true) * per_area)
        }),
        shape_measure: deck_shape(ld).and_then(|s| shape_measure(s, D)),
    }
}

/// Area (2D) or volume (3D) of a bounded shape by midpoint sampling of its bounding box.
pub fn shape_measure(shape: &Shape, dim: usize) -> Option<f64> {
    let (lo, hi) = shape.bounding_box()?;
    let n = if dim == 2 { SAMPLES_2D } else { SAMPLES_3D };
    let h: Vec<f64> = (0..dim).map(|a| (hi[a] - lo[a]) / n as f64).collect();
    let rows = if dim == 2 { n } else { n * n };
    let inside: usize = (0..rows)
        .into_par_iter()
        .map(|r| {
            let mut p = [0.0; 3];
            p[1] = lo[1] + ((r % n) as f64 + 0.5) * h[1];
            if dim == 3 {
                p[2] = lo[2] + ((r / n) as f64 + 0.5) * h[2];
            }
            (0..n)
                .filter(|&k| {
                    p[0] = lo[0] + (k as f64 + 0.5) * h[0];
                    shape.contains(&p[..dim])
                })
                .count()
        })
        .sum();
    Some(inside as f64 * h.iter().product::<f64>())
}

/// Why `peridyn grid` wrote no grid.
#[derive(Debug, thiserror::Error)]
pub enum GridError {
    #[error("{0}")]
    Deck(#[from] DeckError),
    #[error("writing the grid: {0}")]
    Io(#[from] std::io::Error),
}

/// `peridyn grid`: builds the deck's grid and writes `grid.vtu` and (2D) `grid.png` into
/// `out`.
pub fn write_grid(ld: &LoadedDeck, out: &Path) -> Result<GridReport, GridError> {
    match ld.deck.dimension {
        2 => write_grid_dim::<2>(ld, out),
        _ => write_grid_dim::<3>(ld, out),
    }
}

fn write_grid_dim<const D: usize>(ld: &LoadedDeck, out: &Path) -> Result<GridReport, GridError> {
    let model = build_model::<D>(ld)?;
    let body = &model.body;
    let report = grid_report(ld, body, &model.bonds);
    std::fs::create_dir_all(out)?;
    if let Some(text) = &model.pores {
        crate::atomic_file::write_atomic(&out.join("pores.txt"), text.as_bytes())?;
    }
    let points: Vec<[f64; 3]> = body
        .positions
        .iter()
        .map(|p| std::array::from_fn(|k| if k < D { p[k] } else { 0.0 }))
        .collect();
    let blocks: Vec<i32> = model.material_of.iter().map(|&b| b as i32).collect();
    // λ of the deck's surface correction; 1 where there is none.
    let surface_factors = match ld.deck.discretization.surface_correction() {
        SurfaceCorrection::None => vec![1.0; body.len()],
        _ => build_constitution(ld, &model)?
            .surface
            .map(|s| s.factors)
            .unwrap_or_else(|| vec![1.0; body.len()]),
    };
    write_vtu(
        &out.join("grid.vtu"),
        &points,
        &[
            Field {
                name: "volume",
                data: FieldData::Scalar(&body.volumes),
            },
            Field {
                name: "cell_size",
                data: FieldData::Scalar(&body.cell_sizes),
            },
            Field {
                name: "horizon",
                data: FieldData::Scalar(&body.horizons),
            },
            Field {
                name: "block",
                data: FieldData::Int(&blocks),
            },
            Field {
                name: "surface_factor",
                data: FieldData::Scalar(&surface_factors),
            },
        ],
    )?;
    if D == 2 {
        let outline: Vec<[[f64; 2]; 2]> = deck_shape(ld)
            .and_then(|s| boundary_segments(s, report.min_spacing).ok())
            .unwrap_or_default()
            .into_iter()
            .map(|s| [s.a, s.b])
            .collect();
        let xy: Vec<[f64; 2]> = body.positions.iter().map(|p| [p[0], p[1]]).collect();
        // Each node a square of 60 % of its cell: the gaps show where the nodes are.
        let squares: Vec<f64> = body.cell_sizes.iter().map(|c| 0.6 * c).collect();
        let (lo, hi) = body
            .cell_sizes
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &c| (a.min(c), b.max(c)));
        let title = format!("{}: {} nodes", ld.deck.title, body.len());
        write_scalar_map_png(
            &out.join("grid.png"),
            &xy,
            &squares,
            &body.cell_sizes,
            &MapStyle {
                title: &title,
                label: "cell size (m)",
                vmin: lo,
                vmax: if hi > lo { hi } else { lo * 1.01 + 1e-12 },
                width_px: 1600,
                outline: &outline,
                fill_gaps: false,
                axis_names: ["x", "y"],
            },
        )
        .map_err(|e| GridError::Io(std::io::Error::other(e.to_string())))?;
    }
    Ok(report)
}
