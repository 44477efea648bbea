//! Good decks: the shipped examples build (study files: every run's deck), point clouds and CSG shapes give the bodies they
//! describe, traction loads apply their total force, and `resolved.toml` runs again.

use peridyn::deck::build::build_model;
use peridyn::deck::LoadedDeck;
use peridyn::run::{check, run, RunOptions};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn shipped_examples_build() {
    let decks = ["examples", "bench/lammps"]
        .into_iter()
        .flat_map(|dir| std::fs::read_dir(root().join(dir)).unwrap());
    for entry in decks {
        let path = entry.unwrap().path();
        if path.to_string_lossy().ends_with("_study.toml") {
            // A parameter study: valid, and every run's deck builds.
            let ls = peridyn::deck::study::LoadedStudy::from_file(&path)
                .unwrap_or_else(|e| panic!("{e}"));
            let runs = peridyn::study_run::plan_study(&ls, Some(1))
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(runs.len() > 1, "{}", path.display());
        } else if path.extension().is_some_and(|e| e == "toml") {
            let ld = LoadedDeck::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
            let report = check(&ld, Some(1)).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            // The Gmsh example is a small mesh (432 elements); the lattices are finer.
            let min_nodes = if path.ends_with("gmsh_plate.toml") {
                400
            } else {
                1000
            };
            // A quasi-static deck's dt is its load increment in pseudo-time.
            let stable = report.solver != "explicit" || report.dt <= report.dt_stable;
            assert!(
                report.nodes > min_nodes && report.steps > 0 && stable,
                "{}",
                path.display()
            );
        }
    }
}

const POINT_CLOUD: &str = r#"
version = 1
dimension = 2
plane = "stress"
thickness = 2e-3
[discretization]
type = "point_cloud"
file = "data/good_cloud.txt"
horizon = 0.75e-3
[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
[solver]
type = "explicit"
steps = 1
"#;

#[test]
fn point_cloud_gives_its_nodes_areas_and_cell_sizes() {
    let ld = LoadedDeck::from_str(POINT_CLOUD, &root().join("tests/decks/deck.toml")).unwrap();
    let model = build_model::<2>(&ld).unwrap();
    assert_eq!(model.body.len(), 32);
    for i in 0..32 {
        assert!(
            (model.body.volumes[i] - 6.25e-8 * 2e-3).abs() < 1e-24,
            "volume = area × thickness"
        );
        assert!(
            (model.body.cell_sizes[i] - 0.25e-3).abs() < 1e-15,
            "r_j = sqrt(area)"
        );
    }
    assert!((model.spacing - 0.25e-3).abs() < 1e-15);
}

const PLATE_WITH_HOLE: &str = r#"
version = 1
dimension = 2
plane = "strain"
thickness = 1e-3
[discretization]
type = "lattice"
shape = { type = "difference", base = { type = "rectangle", min = [0.0, 0.0], max = [0.04, 0.02] }, subtract = [{ type = "disk", center = [0.02, 0.01], radius = 0.005 }] }
spacing = 0.25e-3
horizon_ratio = 3.0
[material]
type = "lps"
density = 1000.0
youngs_modulus = 1e9
poisson_ratio = 0.3
[[node_sets]]
name = "right"
region = { type = "rectangle", min = [0.039, -1.0], max = [1.0, 1.0] }
[[loads]]
type = "traction"
set = "right"
value = [2e6, 0.0]
area = 2e-5
[solver]
type = "explicit"
steps = 3
[output]
snapshots = 1
png = false
"#;

#[test]
fn csg_plate_with_hole_has_the_right_area_and_traction_the_right_force() {
    let ld = LoadedDeck::from_str(PLATE_WITH_HOLE, Path::new("plate.toml")).unwrap();
    let model = build_model::<2>(&ld).unwrap();
    let area: f64 = model.body.volumes.iter().sum::<f64>() / 1e-3;
    let exact = 0.04 * 0.02 - std::f64::consts::PI * 0.005f64.powi(2);
    assert!(
        (area / exact - 1.0).abs() < 0.01,
        "lattice area {area} vs {exact}"
    );
    // Traction T over area A: total force T·A spread over the set's volume.
    let load = &model.loading.loads[0];
    let force: f64 = load
        .nodes
        .iter()
        .map(|&i| load.density[0] * model.body.volumes[i as usize])
        .sum();
    assert!(
        (force - 2e6 * 2e-5).abs() < 1e-9 * force,
        "applied force {force} N"
    );
}

#[test]
fn resolved_deck_runs_again_with_the_same_model() {
    let ld = LoadedDeck::from_str(PLATE_WITH_HOLE, Path::new("plate.toml")).unwrap();
    let out = std::env::temp_dir().join(format!("peridyn-resolved-{}", std::process::id()));
    let first = run(
        &ld,
        &RunOptions {
            out_dir: out.clone(),
            threads: Some(1),
            quiet: true,
        },
    )
    .unwrap();
    let resolved =
        LoadedDeck::from_file(&out.join("resolved.toml")).unwrap_or_else(|e| panic!("{e}"));
    let again = check(&resolved, Some(1)).unwrap();
    assert_eq!(again.nodes, first.report.nodes);
    assert_eq!(again.bonds, first.report.bonds);
    assert_eq!(again.dt, first.report.dt);
    let text = std::fs::read_to_string(out.join("resolved.toml")).unwrap();
    for key in [
        "[derived]",
        "critical_stretch",
        "dt_stable",
        "horizon_over_spacing",
        "memory_bytes",
    ] {
        assert!(text.contains(key), "resolved.toml lacks {key}");
    }
    std::fs::remove_dir_all(&out).ok();
}

const VELOCITY_FIELD: &str = r#"
version = 1
dimension = 2
plane = "stress"
thickness = 1e-3
[discretization]
type = "lattice"
shape = { type = "rectangle", min = [0.0, 0.0], max = [0.01, 0.004] }
spacing = 0.5e-3
horizon_ratio = 3.0
[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
[[node_sets]]
name = "top"
region = { type = "rectangle", min = [-1.0, 0.0035], max = [1.0, 1.0] }
[[initial_velocities]]
set = "all"
value = [0.1, 0.0]
gradient = [[0.0, 0.0], [0.0, 500.0]]
origin = [0.0, 0.002]
[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "x"
value = 0.0
[solver]
type = "explicit"
steps = 1
"#;

#[test]
fn initial_velocity_field_is_value_plus_gradient_and_yields_to_constraints() {
    let ld = LoadedDeck::from_str(VELOCITY_FIELD, Path::new("field.toml")).unwrap();
    let model = build_model::<2>(&ld).unwrap();
    let c = peridyn::deck::build::build_constitution(&ld, &model).unwrap();
    let (peridyn::deck::build::MaterialChoice::Pmb(material), rest) = c.split() else {
        unreachable!()
    };
    let (sim, _) = peridyn::run::prepare(&ld, model, material, rest).unwrap();
    let top = &sim.body.node_sets["top"];
    for i in 0..sim.body.len() {
        let x = sim.body.positions[i];
        let vy = 500.0 * (x[1] - 0.002);
        assert!((sim.state.v[i][1] - vy).abs() < 1e-12, "v_y at node {i}");
        let vx = if top.contains(&(i as u32)) { 0.0 } else { 0.1 };
        assert_eq!(sim.state.v[i][0], vx, "v_x at node {i}");
    }
}

/// A 3D LPS deck with a fracture energy, at deck version `version`.
fn lps_deck(version: u32) -> String {
    format!(
        r#"
version = {version}
dimension = 3
[discretization]
type = "lattice"
shape = {{ type = "box", min = [0.0, 0.0, 0.0], max = [0.012, 0.012, 0.012] }}
spacing = 1e-3
horizon_ratio = 3.0
[material]
type = "lps"
density = 2500.0
youngs_modulus = 70e9
poisson_ratio = 0.2
fracture_energy = 100.0
[solver]
type = "explicit"
steps = 1
"#
    )
}

/// Decks keep their results across versions: a version-1 LPS deck keeps the bond-based
/// equivalent s0 = √(5G0/(9Kδ)) it always had (Silling & Askari 2005), and version 2 gets
/// the exact separation calibration, which differs (by about 11 % in 3D).
#[test]
fn version_one_lps_deck_keeps_its_critical_stretch() {
    let s0 = |version| {
        let ld = LoadedDeck::from_str(&lps_deck(version), Path::new("lps.toml")).unwrap();
        check(&ld, Some(1)).unwrap().critical_stretch
    };
    let (e, nu, g0, delta): (f64, f64, f64, f64) = (70e9, 0.2, 100.0, 3e-3);
    let k = e / (3.0 * (1.0 - 2.0 * nu));
    let bond_based = (5.0 * g0 / (9.0 * k * delta)).sqrt();
    let (v1, v2) = (s0(1), s0(2));
    println!("s0: version 1 {v1:.6e} (formula {bond_based:.6e}), version 2 {v2:.6e}");
    assert!(
        (v1 / bond_based - 1.0).abs() < 1e-12,
        "version 1: {v1} vs {bond_based}"
    );
    assert!(
        (v2 / v1 - 1.0).abs() > 0.03,
        "version 2 should be recalibrated: {v2} vs {v1}"
    );
}

/// `peridyn grid`: the nodes and picture of a deck's grid, and statistics that agree with the
/// shape (a lattice plate with a hole: the zig-zag boundary costs less than 0.5 % of the area).
#[test]
fn grid_writes_the_nodes_and_reports_the_spacing_and_area() {
    let ld = LoadedDeck::from_file(&root().join("examples/bilinear_softening.toml")).unwrap();
    let out = std::env::temp_dir().join(format!("peridyn_grid_{}", std::process::id()));
    let report = peridyn::grid::write_grid(&ld, &out).unwrap();
    assert_eq!(report.nodes, 8736);
    for d in [report.min_spacing, report.max_spacing] {
        assert!((d - 5e-4).abs() < 1e-12, "{d}");
    }
    let shape = report.shape_measure.unwrap();
    let exact = 0.05 * 0.05 - std::f64::consts::PI * 0.01 * 0.01;
    assert!(
        (shape - exact).abs() < 1e-3 * exact,
        "sampled {shape} vs {exact}"
    );
    assert!((report.measure - shape).abs() < 5e-3 * shape);
    let vtu = std::fs::read(out.join("grid.vtu")).unwrap();
    let text = String::from_utf8_lossy(&vtu);
    for field in ["volume", "cell_size", "horizon", "block", "surface_factor"] {
        assert!(text.contains(&format!("Name=\"{field}\"")), "{field}");
    }
    assert!(std::fs::metadata(out.join("grid.png")).unwrap().len() > 10_000);
    std::fs::remove_dir_all(&out).unwrap();
}

/// `peridyn check`'s time estimate: a single-stage explicit run gets one, from three timed
/// steps at the deck's time step, for the deck's step count; a staged run gets none (a
/// quasi-static run's estimate: tests/suite/quasi_static.rs).
#[test]
fn check_times_the_steps_of_an_explicit_run_only() {
    let checked = |name: &str| {
        let ld = LoadedDeck::from_file(&root().join("examples").join(name)).unwrap();
        peridyn::run::check_timed(&ld, Some(1)).unwrap_or_else(|e| panic!("{name}: {e}"))
    };
    let (report, time) = checked("dual_horizon.toml");
    let time = time.expect("an explicit run is timed");
    assert_eq!(time.steps, report.steps);
    assert_eq!(time.timed_steps, 3);
    assert!(time.seconds_per_step.is_finite() && time.seconds_per_step > 0.0);
    let shown = time.to_string();
    assert!(
        shown.contains(&format!("{} steps", report.steps)),
        "{shown}"
    );
    let name = "seed002_preload_release.toml";
    let (report, time) = checked(name);
    assert!(time.is_none(), "{name}: {} timed", report.solver);
}

/// A deck relaxed by ADR is estimated with the relaxation's two copies of each directed
/// bond's status and history (measured: docs/performance.md, "Memory"); an explicit deck
/// without them.
#[test]
fn the_memory_estimate_counts_the_relaxations_copies() {
    let path = root().join("validation/seed002/decks/ex_d_monotonic_3d.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("spacing = 80e-6 ", "spacing = 250e-6 ");
    let ld = LoadedDeck::from_str(&text, &path).unwrap_or_else(|e| panic!("{e}"));
    let r = check(&ld, Some(1)).unwrap();
    // LPS under one critical energy: a status byte (and the observers' copy of it) and two
    // work words per directed bond.
    assert_eq!(r.bytes_per_bond, 4 + 8 + 1 + 1 + 16);
    assert_eq!(r.relaxation_bytes_per_bond, 2 * (1 + 16));
    let directed = 2 * r.bonds;
    assert!(r.memory_bytes > directed * (r.bytes_per_bond + r.relaxation_bytes_per_bond));
    let explicit = LoadedDeck::from_file(&root().join("examples/quickstart.toml")).unwrap();
    assert_eq!(
        check(&explicit, Some(1)).unwrap().relaxation_bytes_per_bond,
        0
    );
}
