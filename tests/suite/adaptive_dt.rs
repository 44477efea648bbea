//! The adaptive explicit time step (seed 004 §5): on a run where a fixed dt lets a node lose
//! more than N_b^m bonds in one step, the adaptive run never commits such a step, and a
//! rejected step leaves no trace (the retry is bitwise the step a run with the smaller dt takes).

use super::common;
use peridyn::deck::build::solver_settings;
use peridyn::deck::LoadedDeck;
use peridyn::material::Pmb;
use peridyn::solver::adaptive_dt::most_broken_at_a_node;
use peridyn::solver::{AdaptiveDt, Simulation};
use std::path::Path;

/// A notched 8 mm × 4 mm PMB plate (Δx = 0.1 mm, δ = 3Δx) whose grips are pulled apart at
/// `speed` m/s each, with `[solver.adaptive]` (N_b^m = 4, t_min = dt/1000).
fn deck(speed: f64) -> LoadedDeck {
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.008, 0.004] }}
spacing = 0.1e-3
horizon_ratio = 3.0

[material]
type = "pmb"
density = 1180.0
youngs_modulus = 3.09e9
fracture_energy = 300.0

[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, 0.0037], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.0003] }}

[[precracks]]
type = "segment"
start = [-0.001, 0.002]
end = [0.002, 0.002]

[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "y"
value = {speed:e}
[[boundary_conditions]]
set = "bottom"
kind = "velocity"
component = "y"
value = {neg:e}

[solver]
type = "explicit"
steps = 1500

[solver.adaptive]
max_broken_per_node = 4
min_dt = 1e-12
"#,
        neg = -speed
    );
    LoadedDeck::from_str(&text, Path::new("adaptive.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn simulation(ld: &LoadedDeck) -> Simulation<2, Pmb> {
    common::pmb_deck_simulation(ld).unwrap().0
}

#[test]
fn adaptive_steps_keep_every_node_below_the_limit_and_roll_back_exactly() {
    let ld = deck(20.0);
    let settings = solver_settings(&ld.deck)
        .adaptive
        .expect("the deck asks for it");
    // Fixed dt: some step lets a node lose more than 4 bonds.
    let mut fixed = simulation(&ld);
    let dt0 = fixed.dt;
    let mut worst_fixed = 0;
    for _ in 0..1500 {
        let before = fixed.state.status.clone();
        fixed.step().unwrap();
        worst_fixed = worst_fixed.max(most_broken_at_a_node(
            &fixed.bonds,
            &before,
            &fixed.state.status,
        ));
    }
    println!(
        "fixed dt {dt0:.3e} s: a node lost up to {worst_fixed} bonds in one step, {} broken",
        fixed.state.broken / 2
    );
    assert!(worst_fixed > 4, "the case must break bursts");

    // Adaptive over the same time: no committed step breaks more than 4 at a node.
    let mut adaptive = simulation(&ld);
    let mut controller = AdaptiveDt::new(settings.settings(dt0));
    let end = 1500.0 * dt0;
    let (mut first_rejection, mut steps, mut smallest) = (None, 0u64, dt0);
    while end - adaptive.state.time > 1e-9 * dt0 {
        adaptive.dt = adaptive.dt.min(end - adaptive.state.time);
        let before = adaptive.state.status.clone();
        let report = controller.step(&mut adaptive).unwrap();
        steps += 1;
        let most = most_broken_at_a_node(&adaptive.bonds, &before, &adaptive.state.status);
        assert_eq!(most, report.most_broken_at_a_node);
        assert!(most <= 4, "step {steps}: a node lost {most} bonds");
        smallest = smallest.min(adaptive.state.dt);
        if report.rejected > 0 && first_rejection.is_none() {
            first_rejection = Some((steps, adaptive.state.clone()));
        }
    }
    println!(
        "adaptive: {steps} steps, {} rejected, smallest dt {smallest:.3e} s, {} bonds broken",
        controller.rejected,
        adaptive.state.broken / 2
    );
    let (k, committed) = first_rejection.expect("some step was rejected");
    assert!(adaptive.state.dt > 0.0 && smallest < dt0);

    // Until its first rejection the adaptive run is the fixed one (dt starts at its ceiling);
    // the rejected step, retried, equals the step a run takes with the smaller dt directly.
    let mut direct = simulation(&ld);
    for _ in 1..k {
        direct.step().unwrap();
    }
    direct.dt = committed.dt;
    direct.step().unwrap();
    let d = &direct.state;
    assert_eq!(d.time.to_bits(), committed.time.to_bits());
    assert_eq!(d.step, committed.step);
    assert!(d.u.iter().zip(&committed.u).all(|(a, b)| a == b));
    assert!(d.v.iter().zip(&committed.v).all(|(a, b)| a == b));
    assert!(d.force.iter().zip(&committed.force).all(|(a, b)| a == b));
    assert_eq!(d.status, committed.status);
    assert_eq!(d.history, committed.history);
    assert_eq!(d.broken, committed.broken);
    assert_eq!(d.external_work.to_bits(), committed.external_work.to_bits());
    println!(
        "first rejection at step {k}: the retry is bitwise the direct step of dt {:.3e} s",
        committed.dt
    );
}
