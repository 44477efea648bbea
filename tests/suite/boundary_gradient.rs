//! Boundary conditions whose value varies linearly over the set (`gradient`, `origin`; seed 004
//! Eq. 2's load introduced unevenly, u_x = −v₀ t + m_l (y − h/2) t): each node of the set gets
//! (value + g · (x − origin)) · f(t) at its reference position x, for velocities and
//! displacements alike, and a condition without a gradient is unchanged.

use peridyn::deck::LoadedDeck;
use peridyn::session::{NodeVectors, Session, Target};
use std::path::Path;
use std::time::{Duration, Instant};

const DECK: &str = r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3

[discretization]
type = "lattice"
shape = { type = "rectangle", min = [0.0, 0.0], max = [4e-3, 2e-3] }
spacing = 0.25e-3
horizon_ratio = 3.0

[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
fracture_energy = 100.0

[[node_sets]]
name = "left"
region = { type = "rectangle", min = [-1.0, -1.0], max = [0.3e-3, 1.0] }

[[node_sets]]
name = "right"
region = { type = "rectangle", min = [3.7e-3, -1.0], max = [1.0, 1.0] }

# Pushed at 1 m/s, faster at the top: v_x = −1 − 400 (y − 1 mm) m/s.
[[boundary_conditions]]
set = "right"
kind = "velocity"
component = "x"
value = -1.0
gradient = [0.0, -400.0]
origin = [0.0, 1e-3]

# Sheared: u_y = 0.01 x, ramped over 1 µs (no origin: about x = 0).
[[boundary_conditions]]
set = "left"
kind = "displacement"
component = "y"
value = 0.0
gradient = [0.01, 0.0]
time = { type = "ramp", duration = 1e-6 }

# Held in x as before: no gradient.
[[boundary_conditions]]
set = "left"
kind = "displacement"
component = "x"
value = 0.0

[solver]
type = "explicit"
end_time = 0.5e-6
"#;

#[test]
fn each_node_of_the_set_gets_the_value_of_the_gradient_at_its_position() {
    let ld = LoadedDeck::from_str(DECK, Path::new("gradient.toml")).expect("a valid deck");
    let mut s = Session::new(&ld, Some(1)).expect("built");
    s.advance(Target::End, Instant::now() + Duration::from_secs(60))
        .expect("ran");
    let t = s.time();
    let ramp = t / 1e-6;
    let x = s.vectors(NodeVectors::Positions).to_vec();
    let u = s.vectors(NodeVectors::Displacement).to_vec();
    let v = s.vectors(NodeVectors::Velocity).to_vec();
    let sets = s.node_sets();
    let set = |name: &str| sets.iter().find(|(n, _)| n == name).unwrap().1.clone();
    let (right, left) = (set("right"), set("left"));
    assert!(right.len() >= 8 && left.len() >= 8);
    let mut speeds = Vec::new();
    for &i in &right {
        let i = i as usize;
        let expected = -1.0 - 400.0 * (x[2 * i + 1] - 1e-3);
        assert!(
            (v[2 * i] - expected).abs() <= 1e-12,
            "v_x {} at y = {}",
            v[2 * i],
            x[2 * i + 1]
        );
        speeds.push(v[2 * i]);
    }
    // The top is pushed faster than the bottom: the gradient is felt, not averaged away.
    let (lo, hi) = speeds
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &s| (a.min(s), b.max(s)));
    assert!(hi - lo > 0.5, "speeds from {lo} to {hi} m/s");
    for &i in &left {
        let i = i as usize;
        let expected = 0.01 * x[2 * i] * ramp;
        assert!(
            (u[2 * i + 1] - expected).abs() <= 1e-18,
            "u_y {} at x = {}",
            u[2 * i + 1],
            x[2 * i]
        );
        assert_eq!(u[2 * i], 0.0, "held in x");
    }
}
