//! Generated grids from decks: free mesh, NB-NUG, multi-grid lattice, random pores. Each
//! covers its shape (node area within 0.5 % of the shape's), keeps its nodes inside it, and
//! runs through the engine.

use peridyn::deck::build::build_model;
use peridyn::deck::LoadedDeck;
use std::path::Path;

fn deck(discretization: &str) -> String {
    format!(
        r#"
version = 2
title = "grid test"
dimension = 2
plane = "stress"
thickness = 1e-3
[discretization]
{discretization}
[material]
type = "pmb"
density = 1180.0
youngs_modulus = 3.09e9
[solver]
type = "explicit"
steps = 5
"#
    )
}

const PLATE_WITH_HOLE: &str = r#"shape = { type = "difference", base = { type = "rectangle", min = [0.0, 0.0], max = [0.02, 0.01] }, subtract = [{ type = "disk", center = [0.01, 0.005], radius = 0.002 }] }"#;

/// Builds the deck's grid and checks it against the shape.
fn covered(text: &str) -> (usize, Vec<f64>) {
    let ld = LoadedDeck::from_str(text, Path::new("grid.toml")).unwrap_or_else(|e| panic!("{e}"));
    let model = build_model::<2>(&ld).unwrap_or_else(|e| panic!("{e}"));
    let shape = peridyn::grid::deck_shape(&ld).cloned();
    let report = peridyn::grid::grid_report(&ld, &model.body, &model.bonds);
    if let Some(s) = report.shape_measure {
        assert!((report.measure - s).abs() < 5e-3 * s, "{report}");
    }
    if let Some(shape) = &shape {
        for p in &model.body.positions {
            assert!(shape.contains(&[p[0], p[1]]), "node {p:?} outside");
        }
    }
    // Nodes no closer than a fraction of the local spacing.
    assert!(
        report.min_spacing
            > 0.3
                * model
                    .body
                    .cell_sizes
                    .iter()
                    .cloned()
                    .fold(f64::INFINITY, f64::min),
        "{report}"
    );
    let run = peridyn::run::check(&ld, Some(1)).unwrap();
    assert!(run.bonds > 0);
    (model.body.len(), model.body.horizons.clone())
}

#[test]
fn free_mesh_and_nbnug_cover_a_plate_with_a_hole() {
    for (kind, extra) in [
        ("free_mesh", "cells = \"triangles\""),
        ("free_mesh", ""),
        ("nbnug", ""),
        ("nbnug", "padding = 1e-3"),
    ] {
        let text = deck(&format!(
            "type = \"{kind}\"\n{PLATE_WITH_HOLE}\nsize = 2.5e-4\nhorizon_ratio = 3.0\n{extra}"
        ));
        let (n, _) = covered(&text);
        assert!(n > 2000, "{kind} {extra}: {n} nodes");
    }
}

#[test]
fn a_refined_lattice_gets_a_horizon_per_node() {
    let text = deck(&format!(
        "type = \"lattice\"\n{PLATE_WITH_HOLE}\nspacing = 5e-4\nhorizon_ratio = 3.015\nrefine = [{{ region = {{ type = \"rectangle\", min = [0.012, 0.003], max = [0.016, 0.007] }}, levels = 2 }}]"
    ));
    let (_, horizons) = covered(&text);
    let fine = 3.015 * 5e-4 / 4.0;
    assert!(horizons.iter().any(|&h| (h - fine).abs() < 1e-15));
    assert!(horizons.iter().any(|&h| (h - 3.015 * 5e-4).abs() < 1e-15));
}

#[test]
fn pores_are_cut_and_repeat_with_their_seed() {
    let text = |seed: u64| {
        deck(&format!(
            "type = \"nbnug\"\nshape = {{ type = \"rectangle\", min = [0.0, 0.0], max = [0.02, 0.01] }}\nsize = 2.5e-4\nhorizon_ratio = 3.0\npores = {{ count = 4, radius = [7.5e-4, 1.5e-3], clearance = 3e-4, seed = {seed} }}"
        ))
    };
    let build = |seed| {
        let ld = LoadedDeck::from_str(&text(seed), Path::new("pores.toml")).unwrap();
        build_model::<2>(&ld).unwrap().body.positions
    };
    let (a, b, c) = (build(1), build(1), build(2));
    assert_eq!(a, b);
    assert_ne!(a, c);
    let area: f64 = {
        let ld = LoadedDeck::from_str(&text(1), Path::new("pores.toml")).unwrap();
        build_model::<2>(&ld)
            .unwrap()
            .body
            .volumes
            .iter()
            .sum::<f64>()
            / 1e-3
    };
    assert!(area < 0.02 * 0.01 - 4.0 * std::f64::consts::PI * 7.5e-4f64.powi(2) * 0.99);
    // The realisation is recorded (pores.txt): a header, then x y r per pore, inside the plate
    // and within the radius range, so a run can be repeated and inspected.
    let ld = LoadedDeck::from_str(&text(1), Path::new("pores.toml")).unwrap();
    let record = build_model::<2>(&ld).unwrap().pores.expect("a pore record");
    let rows: Vec<Vec<f64>> = record
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4);
    for r in rows {
        assert!(
            (0.0..0.02).contains(&r[0]) && (0.0..0.01).contains(&r[1]),
            "{r:?}"
        );
        assert!((7.5e-4..=1.5e-3).contains(&r[2]), "{r:?}");
    }
}

#[test]
fn bad_grids_are_refused_with_their_key() {
    for (discretization, key, words) in [
        (
            "type = \"nbnug\"\nshape = { type = \"disk\", center = [0.0, 0.0], radius = 1.0 }\nsize = 0.1\nhorizon_ratio = 3.0".to_string(),
            "discretization.shape",
            "rectangle",
        ),
        (
            format!("type = \"free_mesh\"\n{PLATE_WITH_HOLE}\nsize = -1.0\nhorizon = 1e-3"),
            "discretization.size",
            "positive",
        ),
        (
            format!("type = \"lattice\"\n{PLATE_WITH_HOLE}\nspacing = 5e-4\nhorizon_ratio = 3.0\nrefine = [{{ region = {{ type = \"rectangle\", min = [0.0, 0.0], max = [0.01, 0.01] }}, levels = 0 }}]"),
            "discretization.refine[0].levels",
            "1 to 8",
        ),
        (
            "type = \"nbnug\"\nshape = { type = \"difference\", base = { type = \"rectangle\", min = [0.0, 0.0], max = [0.02, 0.01] }, subtract = [{ type = \"disk\", center = [0.001, 0.005], radius = 0.002 }] }\nsize = 2.5e-4\nhorizon_ratio = 3.0".to_string(),
            "discretization.shape",
            "inside the plate",
        ),
        (
            format!("type = \"lattice\"\n{PLATE_WITH_HOLE}\nspacing = 5e-4\nhorizon_ratio = 3.0\npores = {{ count = 2, radius = [2e-3, 1e-3], seed = 1 }}"),
            "discretization.pores.radius",
            "r_min",
        ),
    ] {
        let text = deck(&discretization);
        let err = match LoadedDeck::from_str(&text, Path::new("bad.toml")) {
            Err(e) => e.to_string(),
            Ok(ld) => build_model::<2>(&ld).err().expect("refused").to_string(),
        };
        assert!(err.contains(key) && err.contains(words), "{key}: {err}");
    }
}
