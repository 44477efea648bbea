//! Fictitious boundary layers (seed 001 §2.9): `[[boundary_layers]]` adds the rows of nodes a
//! user would otherwise draw by hand, and a load through them acts on the body's face.

use super::common;

use peridyn::deck::build::{build_model, solver_settings};
use peridyn::deck::LoadedDeck;
use peridyn::grid::grid_report;
use peridyn::run::drive_quasi_static;
use std::path::Path;

/// δ = 1.5 mm on a 0.5 mm lattice; the plate is 10 mm × `length`.
const HORIZON: f64 = 1.5e-3;

/// A PMB plate pulled apart in y by ±`pull` on two grips. `layers`: the grips are
/// `[[boundary_layers]]` outside the plate; otherwise node sets, either drawn by hand outside
/// an extended shape (`outside`) or the plate's own end strips of width δ.
fn plate(pull: f64, length: f64, grips: Grips) -> LoadedDeck {
    let (y0, y1) = match grips {
        Grips::HandDrawn => (-HORIZON, length + HORIZON),
        _ => (0.0, length),
    };
    let (no_fail, sets) = match grips {
        Grips::Layers => (
            "",
            r#"
[[boundary_layers]]
name = "top"
side = "+y"
[[boundary_layers]]
name = "bottom"
side = "-y""#
                .to_string(),
        ),
        Grips::HandDrawn | Grips::Inside => {
            let (below, above) = match grips {
                Grips::HandDrawn => (0.0, length),
                _ => (HORIZON, length - HORIZON),
            };
            (
                r#"no_fail = ["top", "bottom"]"#,
                format!(
                    r#"
[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, {above:e}], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, {below:e}] }}"#
                ),
            )
        }
    };
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
{no_fail}

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, {y0:e}], max = [0.01, {y1:e}] }}
spacing = 0.5e-3
horizon = {HORIZON:e}

[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
critical_stretch = 0.01
{sets}

[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "y"
value = {pull:e}
time = {{ type = "ramp", duration = 1.0 }}
[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "y"
value = {minus:e}
time = {{ type = "ramp", duration = 1.0 }}

[solver]
type = "quasi_static"
load_steps = 1
method = "ncg"
tolerance = 1e-8
"#,
        minus = -pull
    );
    LoadedDeck::from_str(&text, Path::new("plate.toml")).unwrap_or_else(|e| panic!("{e}"))
}

#[derive(Clone, Copy, PartialEq)]
enum Grips {
    Layers,
    HandDrawn,
    Inside,
}

/// The layers are the nodes a user would draw: the same positions, volumes, sets and no-fail
/// flags as grips drawn by hand outside an extended shape.
#[test]
fn layers_are_the_hand_drawn_grips() {
    let by_deck = build_model::<2>(&plate(1e-6, 0.04, Grips::Layers))
        .unwrap()
        .body;
    let by_hand = build_model::<2>(&plate(1e-6, 0.04, Grips::HandDrawn))
        .unwrap()
        .body;
    assert_eq!(by_deck.len(), by_hand.len());
    let key = |b: &peridyn::body::Body<2>, i: usize| {
        let p = b.positions[i];
        ((p[1] * 1e9).round() as i64, (p[0] * 1e9).round() as i64)
    };
    let summary = |b: &peridyn::body::Body<2>| {
        let top = b.node_set("top").unwrap();
        let bottom = b.node_set("bottom").unwrap();
        let mut rows: Vec<_> = (0..b.len())
            .map(|i| {
                let set = if top.contains(&(i as u32)) {
                    1
                } else if bottom.contains(&(i as u32)) {
                    -1
                } else {
                    0
                };
                (
                    key(b, i),
                    (b.volumes[i] * 1e15).round() as i64,
                    set,
                    b.no_fail[i],
                )
            })
            .collect();
        rows.sort_unstable();
        rows
    };
    let rows = summary(&by_deck);
    assert_eq!(rows, summary(&by_hand));
    // Three rows of 20 in each layer (δ/Δx = 3), and they hold.
    let held = rows.iter().filter(|r| r.3).count();
    assert_eq!(held, 2 * 3 * 20);
    assert!(rows.iter().all(|r| r.3 == (r.2 != 0)));
    // `peridyn check` counts the layers apart from the plate.
    let ld = plate(1e-6, 0.04, Grips::Layers);
    let model = build_model::<2>(&ld).unwrap();
    let report = grid_report(&ld, &model.body, &model.bonds);
    let (nodes, measure) = report.layers.unwrap();
    assert_eq!(nodes, 120);
    assert!((measure - 2.0 * 0.01 * HORIZON).abs() < 1e-15);
    assert!((report.measure - 0.01 * 0.04).abs() < 1e-15);
}

/// On a free mesh the layer tiles the face's width in cells of the mesh size and lies a
/// horizon deep; the body's nodes next to it have full families.
#[test]
fn a_free_mesh_gets_layers_too() {
    let text = toml::to_string(&plate(1e-6, 0.04, Grips::Layers).deck)
        .unwrap()
        .replace("type = \"lattice\"", "type = \"free_mesh\"")
        .replace("spacing = 0.0005", "size = 0.0005");
    let ld = LoadedDeck::from_str(&text, Path::new("mesh.toml"))
        .unwrap_or_else(|e| panic!("{e}\n{text}"));
    let body = build_model::<2>(&ld).unwrap().body;
    let top = body.node_set("top").unwrap();
    assert_eq!(top.len(), 3 * 20);
    let area: f64 = top.iter().map(|&i| body.volumes[i as usize]).sum::<f64>() / 1e-3;
    assert!((area - 0.01 * HORIZON).abs() < 1e-12 * 0.01);
    for &i in &top {
        let p = body.positions[i as usize];
        assert!(p[1] > 0.04 && p[1] < 0.04 + HORIZON && body.no_fail[i as usize]);
    }
}

/// The mean strain of the plate's middle half along the pull, from a least-squares fit of
/// u_y against y, over the strain a local boundary condition gives, 2·pull / L.
fn middle_strain_ratio(length: f64, grips: Grips) -> f64 {
    let pull = 2e-6;
    let ld = plate(pull, length, grips);
    let (mut sim, report) = common::pmb_deck_simulation(&ld).unwrap();
    let qs = solver_settings(&ld.deck).quasi_static.unwrap();
    drive_quasi_static(&mut sim, qs, report.steps, &mut []).unwrap();
    let (mut n, mut sy, mut su, mut syy, mut syu) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..sim.body.len() {
        let y = sim.body.positions[i][1];
        if (y - 0.5 * length).abs() < 0.25 * length {
            let u = sim.state.u[i][1];
            n += 1.0;
            sy += y;
            su += u;
            syy += y * y;
            syu += y * u;
        }
    }
    let slope = (n * syu - sy * su) / (n * syy - sy * sy);
    slope / (2.0 * pull / length)
}

/// Pulled through its layers, the plate strains as a bar whose ends move by the prescribed
/// displacement: the load acts on the faces (seed 001 §2.9). Grips inside the body shorten
/// the gauge to L − 2δ. What is left is the end zone of a nonlocal body at a rigid grip, a
/// horizon deep, so its share falls as δ/L.
#[test]
fn a_plate_pulled_by_its_layers_strains_over_its_whole_length() {
    let mut deviations = Vec::new();
    for length in [0.04, 0.08] {
        let layers = middle_strain_ratio(length, Grips::Layers);
        let inside = middle_strain_ratio(length, Grips::Inside);
        let gauge = length / (length - 2.0 * HORIZON);
        println!(
            "L = {:.0} mm: middle strain / (2 pull / L): layers {layers:.4}, grips inside {inside:.4}; their ratio {:.4} against L/(L − 2δ) = {gauge:.4}",
            length * 1e3,
            inside / layers
        );
        assert!((inside / layers / gauge - 1.0).abs() < 0.005);
        assert!((layers - 1.0).abs() < 0.03, "layers: {layers}");
        deviations.push((layers - 1.0).abs());
    }
    assert!(deviations[1] < 0.6 * deviations[0], "{deviations:?}");
}

/// Clear errors: a z face in 2D, a name taken twice, a mesh from a file without a spacing.
#[test]
fn bad_layers_are_refused_with_their_keys() {
    let text = plate(1e-6, 0.04, Grips::Layers);
    let deck_text = toml::to_string(&text.deck).unwrap();
    let with = |from: &str, to: &str| {
        let changed = deck_text.replacen(from, to, 1);
        assert_ne!(changed, deck_text, "{from:?} not in the deck");
        LoadedDeck::from_str(&changed, Path::new("bad.toml"))
            .map(|_| ())
            .unwrap_err()
            .to_string()
    };
    let z = with("side = \"+y\"", "side = \"+z\"");
    assert!(
        z.contains("boundary_layers[0].side") && z.contains("no z faces"),
        "{z}"
    );
    let twice = with("name = \"bottom\"", "name = \"top\"");
    assert!(twice.contains("boundary_layers[1].name"), "{twice}");
    let face = with("side = \"-y\"", "side = \"+y\"");
    assert!(face.contains("one layer per face"), "{face}");
    let width = with("side = \"-y\"", "side = \"-y\"\nwidth = -1.0");
    assert!(width.contains("boundary_layers[1].width"), "{width}");
}
