//! Failure rules on a fracturing run: no-fail sets never damage, pre-cracks open, breakage
//! is symmetric (bond i→j breaks exactly when j→i does), broken bonds stay broken.

use peridyn::deck::build::{build_constitution, build_model, MaterialChoice};
use peridyn::deck::LoadedDeck;
use peridyn::run::prepare;
use peridyn::state::{BROKEN, INTACT};
use std::path::Path;

const DECK: &str = r#"
version = 1
dimension = 2
plane = "stress"
thickness = 1e-3
no_fail = ["top", "bottom", "island"]

[discretization]
type = "lattice"
shape = { type = "rectangle", min = [0.0, 0.0], max = [0.02, 0.01] }
spacing = 2.5e-4
horizon_ratio = 3.0

[material]
type = "pmb"
density = 2440.0
youngs_modulus = 72e9
fracture_energy = 3.8

[[node_sets]]
name = "top"
region = { type = "rectangle", min = [-1.0, 0.00925], max = [1.0, 1.0] }

[[node_sets]]
name = "bottom"
region = { type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.00075] }

[[node_sets]]
name = "island"
region = { type = "disk", center = [0.012, 0.005], radius = 0.001 }

[[precracks]]
type = "segment"
start = [-0.001, 0.005]
end = [0.005, 0.005]

[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "y"
value = 0.5

[[boundary_conditions]]
set = "bottom"
kind = "velocity"
component = "y"
value = -0.5

[solver]
type = "explicit"
end_time = 12e-6
"#;

#[test]
fn no_fail_precrack_and_symmetric_breakage() {
    let ld = LoadedDeck::from_str(DECK, Path::new("fracture_rules.toml")).unwrap();
    let model = build_model::<2>(&ld).unwrap();
    let (MaterialChoice::Pmb(pmb), rest) = build_constitution(&ld, &model).unwrap().split() else {
        panic!("pmb expected")
    };
    let (mut sim, report) = prepare(&ld, model, pmb, rest).unwrap();

    // The pre-crack filter: no bond crosses the segment.
    let crack = peridyn::bonds::Precrack::Segment {
        start: [-0.001, 0.005],
        end: [0.005, 0.005],
    };
    for i in 0..sim.body.len() {
        for b in sim.bonds.family(i) {
            let j = sim.bonds.neighbors[b] as usize;
            assert!(!crack.cuts(
                sim.body.positions[i].as_slice(),
                sim.body.positions[j].as_slice()
            ));
        }
    }

    let dx = 2.5e-4;
    let near = |sim: &peridyn::solver::Simulation<2, peridyn::material::Pmb>, x: f64, y: f64| {
        let p = peridyn::math::Vector::<2>::new(x, y);
        (0..sim.body.len())
            .min_by(|&a, &b| {
                (sim.body.positions[a] - p)
                    .norm()
                    .partial_cmp(&(sim.body.positions[b] - p).norm())
                    .unwrap()
            })
            .unwrap()
    };
    let opening = |sim: &peridyn::solver::Simulation<2, peridyn::material::Pmb>, x: f64| {
        sim.state.u[near(sim, x, 0.005 + dx / 2.0)][1]
            - sim.state.u[near(sim, x, 0.005 - dx / 2.0)][1]
    };
    let mut checked_opening = false;
    let mut previously_broken = vec![false; sim.state.status.len()];
    for step in 1..=report.steps {
        sim.step().unwrap();
        // When the first bonds break (at the notch tip), the pre-crack faces must have opened
        // more than two rows of the intact ligament on the far right have separated (×5 here;
        // the bar is ×3 because stress waves, not a static field, load the plate).
        if !checked_opening && sim.state.broken > 0 {
            let (mouth, ligament) = (opening(&sim, dx / 2.0), opening(&sim, 0.02 - dx / 2.0));
            println!("first breakage at step {step}: opening at the crack mouth {mouth:.3e} m, across two rows of the far ligament {ligament:.3e} m");
            assert!(
                mouth > 0.0 && mouth > 3.0 * ligament.abs(),
                "pre-crack did not open: mouth {mouth}, ligament {ligament}"
            );
            checked_opening = true;
        }
        if step % 20 == 0 || step == report.steps {
            for (b, &s) in sim.state.status.iter().enumerate() {
                assert!(
                    !(previously_broken[b] && s == INTACT),
                    "bond {b} healed at step {step}"
                );
                previously_broken[b] = s != INTACT;
            }
        }
    }
    assert!(
        sim.state.broken > 0,
        "the test must break bonds to prove anything"
    );

    let damage = sim.engine.damage(&sim.body, &sim.bonds, &sim.state);
    for name in ["top", "bottom", "island"] {
        for &i in &sim.body.node_sets[name] {
            assert_eq!(
                damage[i as usize], 0.0,
                "no-fail node {i} of {name} is damaged"
            );
        }
    }
    // Symmetric breakage: each entry's own half is its reverse's other half, and with one
    // law for both ends the two halves break together.
    use peridyn::state::{OTHER_BROKEN, OWN_BROKEN};
    for i in 0..sim.body.len() {
        for b in sim.bonds.family(i) {
            let r = sim.bonds.reverse(i, b).expect("families are symmetric");
            let (s, t) = (sim.state.status[b], sim.state.status[r]);
            assert_eq!(
                (s & OWN_BROKEN != 0, s & OTHER_BROKEN != 0),
                (t & OTHER_BROKEN != 0, t & OWN_BROKEN != 0),
                "bond {i}→{} and its reverse disagree",
                sim.bonds.neighbors[b]
            );
            assert!(s == 0 || s == BROKEN, "one half broken alone: {s}");
        }
    }
    assert!(checked_opening);
}
