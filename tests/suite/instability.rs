//! A run that goes unstable stops with a diagnosis (step, node, quantity) and keeps every
//! output written so far.

use peridyn::bonds::PartialVolume;
use peridyn::deck::schema::OutputDeck;
use peridyn::loading::Loading;
use peridyn::material::{Dimensionality, MicromodulusProfile, Pmb};
use peridyn::observe::history::History;
use peridyn::observe::snapshots::Snapshots;
use peridyn::observe::Observer;
use peridyn::run::{drive, RunError};
use peridyn::solver::{Simulation, StepError};

/// A 20 mm square PMB plate (Δx = 1 mm, δ = 3Δx, no damage) stepped at `factor` × the
/// stable time step estimate, its nodes moving at ±`speed` in x alternately (the highest mode).
fn vibrating_plate(factor: f64, speed: f64) -> Simulation<2, Pmb> {
    let dx = 1e-3;
    let shape = peridyn::geometry::Shape::Rectangle {
        min: [0.0; 2],
        max: [0.02, 0.02],
    };
    let cloud = peridyn::discretize::lattice::lattice(&shape, 2, dx, 1e-3).unwrap();
    let body = peridyn::body::Body::<2>::from_cloud(cloud, 3.0 * dx, 1e-3);
    let bonds = peridyn::bonds::search::build_bonds(&body, PartialVolume::Hhb, &[]);
    let pmb = Pmb::calibrated(
        70e9,
        2500.0,
        Dimensionality::PlaneStress,
        MicromodulusProfile::Constant,
        3.0 * dx,
        1e-3,
    );
    let mut sim = Simulation::new(
        body,
        bonds,
        pmb,
        peridyn::damage::CriticalStretch::never(),
        PartialVolume::Hhb,
        Loading::default(),
        Some(1.0),
        1.0,
    )
    .unwrap();
    sim.dt = factor * sim.dt_stable;
    for (i, v) in sim.state.v.iter_mut().enumerate() {
        v[0] = if i % 2 == 0 { speed } else { -speed };
    }
    sim
}

#[test]
fn blow_up_is_diagnosed_and_outputs_survive() {
    // Five times the stable step (the deck layer refuses this; the library lets a user try).
    let mut sim = vibrating_plate(5.0, 1.0);
    let out = std::env::temp_dir().join(format!("peridyn-unstable-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let no_maps = OutputDeck {
        png: false,
        ..OutputDeck::default()
    };
    let mut observers: Vec<Box<dyn Observer<2>>> = vec![
        // Every step: the energy check stops this run within its first ten steps.
        Box::new(History::new::<2>(&out.join("history.csv"), 1, &[])),
        Box::new(Snapshots::new(out.clone(), 50, &no_maps, "unstable").unwrap()),
    ];
    let result = drive(&mut sim, 2000, &mut observers);
    for o in observers.iter_mut() {
        o.finish().unwrap();
    }
    let err = result.expect_err("a time step 5× the stable one must blow up");
    match &err {
        RunError::Step(StepError::Unstable {
            step,
            node,
            quantity,
            ..
        }) => {
            println!("stopped at step {step}, node {node}, {quantity}");
            assert!(*step > 0 && *step < 2000 && *node < sim.body.len());
        }
        other => panic!("expected an instability diagnosis, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("unstable at step") && msg.contains("of node"),
        "{msg}"
    );
    let history = std::fs::read_to_string(out.join("history.csv")).unwrap();
    assert!(
        history.lines().count() > 2,
        "history rows written before the blow-up are kept"
    );
    assert!(out.join("fields").join("step_00000000.vtu").exists());
    std::fs::remove_dir_all(&out).ok();
}

/// Energy from nowhere stops a run long before it overflows: a plate vibrating slightly at
/// twice the stable time step estimate (conservative: 1.5× still runs) grows exponentially; the run stops when its kinetic energy passes
/// ten times the energy it was given, with every value still finite.
#[test]
fn energy_blow_up_stops_the_run_before_any_value_overflows() {
    let mut sim = vibrating_plate(2.0, 1e-3);
    let err = drive(&mut sim, 100_000, &mut []).expect_err("twice the stable step must blow up");
    let msg = err.to_string();
    println!("{msg}");
    match &err {
        RunError::Step(StepError::Unstable {
            quantity, value, ..
        }) => {
            assert!(quantity.contains("kinetic energy"), "{msg}");
            assert!(value.is_finite(), "{msg}");
        }
        other => panic!("expected an energy diagnosis, got {other:?}"),
    }
    assert!(
        sim.check_finite().is_ok(),
        "the guard came after values overflowed"
    );
}

/// Correspondence under heavy damage outruns the intact body's stable step (docs/models.md,
/// "Time step and energy under heavy damage"): the 3D bar of the determinism tests breaking on
/// a tiny G0 is stopped by the guard, every value still finite, and the message says where to
/// look. Measured: stopped at step 20 (kinetic energy past ten times the energy put in).
#[test]
fn correspondence_under_heavy_damage_is_stopped_with_its_hint() {
    use crate::determinism::{bar_3d_sim, bar_elasticity, bar_energy, BAR_DELTA};
    use peridyn::material::correspondence::ZeroEnergyControl;
    let material = peridyn::material::Correspondence::new(
        bar_elasticity(),
        peridyn::material::Influence::Constant,
        ZeroEnergyControl::Wan { coefficient: 1.0 },
        BAR_DELTA,
        1000.0,
        1.0,
    );
    let mut sim = bar_3d_sim(material, bar_energy());
    let err = drive(&mut sim, 400, &mut []).expect_err("this bar goes unstable at safety 0.8");
    let msg = err.to_string();
    println!("{msg}");
    match &err {
        RunError::Step(StepError::Unstable { step, value, .. }) => {
            assert!(*step < 400 && value.is_finite(), "{msg}");
        }
        other => panic!("expected an instability diagnosis, got {other:?}"),
    }
    assert!(msg.contains("docs/models.md"), "{msg}");
    assert!(
        sim.check_finite().is_ok(),
        "values overflowed before the guard"
    );
}
