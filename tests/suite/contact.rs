//! Contact: node–node repulsion between nodes no intact bond joins, and rigid impactors
//! (`solver::contact`, `solver::impactor`). Two blocks that collide neither interpenetrate
//! nor lose momentum and rebound as an elastic collision says; a free rigid disk bouncing off
//! a plate conserves the total energy; a prescribed impactor's booked work is the energy in
//! the body; and the results do not depend on the thread count.

use crate::common::{pmb_deck_simulation, pmb_deck_simulation_in};
use peridyn::deck::LoadedDeck;
use peridyn::material::Pmb;
use peridyn::math::Vector;
use peridyn::run::{run, RunOptions};
use peridyn::solver::{Fields, Simulation};
use std::path::Path;

const SPACING: f64 = 0.5e-3;
const DENSITY: f64 = 1000.0;

/// Two 10 mm × 5 mm PMB blocks (plane stress, E = 1 GPa, no damage) side by side, cut apart
/// by a precrack at x = 10 mm (one spacing between the facing rows, more than r_c = 0.9 Δx),
/// moving towards each other at ±`speed`.
fn blocks_deck(speed: f64, steps: u64) -> LoadedDeck {
    let text = format!(
        r#"
version = 1
dimension = 2
plane = "stress"
thickness = 1e-3

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.02, 0.005] }}
spacing = {SPACING:e}
horizon_ratio = 3.0

[material]
type = "pmb"
density = {DENSITY:e}
youngs_modulus = 1e9
critical_stretch = 10.0

[[node_sets]]
name = "left"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [0.01, 1.0] }}

[[node_sets]]
name = "right"
region = {{ type = "rectangle", min = [0.01, -1.0], max = [1.0, 1.0] }}

[[precracks]]
type = "segment"
start = [0.01, -0.001]
end = [0.01, 0.006]

[[initial_velocities]]
set = "left"
value = [{speed:e}, 0.0]

[[initial_velocities]]
set = "right"
value = [{neg:e}, 0.0]

[contact]

[solver]
type = "explicit"
steps = {steps}
safety_factor = 0.5
"#,
        neg = -speed
    );
    LoadedDeck::from_str(&text, Path::new("blocks.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn momentum(sim: &Simulation<2, Pmb>, nodes: &[u32]) -> Vector<2> {
    nodes.iter().fold(Vector::zeros(), |p, &i| {
        let i = i as usize;
        p + sim.state.v[i] * (sim.densities[i] * sim.body.volumes[i])
    })
}

fn mass(sim: &Simulation<2, Pmb>, nodes: &[u32]) -> f64 {
    nodes
        .iter()
        .map(|&i| sim.densities[i as usize] * sim.body.volumes[i as usize])
        .sum()
}

/// The smallest distance between a node of `a` and one of `b`.
fn min_distance(sim: &Simulation<2, Pmb>, a: &[u32], b: &[u32]) -> f64 {
    let y = &sim.state.current;
    let mut best = f64::INFINITY;
    for &i in a {
        for &j in b {
            best = best.min((y[i as usize] - y[j as usize]).norm());
        }
    }
    best
}

/// Total energy with contact: kinetic + strain + contact (node pairs and penalty) + the free
/// impactors' kinetic energy, minus the external work.
fn total_energy(sim: &Simulation<2, Pmb>) -> f64 {
    sim.kinetic_energy()
        + sim.strain_energy()
        + Fields::contact_energy(sim)
        + Fields::impactor_kinetic_energy(sim)
        - sim.state.external_work
}

#[test]
fn colliding_blocks_rebound_without_interpenetrating() {
    let speed = 5.0;
    let ld = blocks_deck(speed, 1);
    let (mut sim, _) = pmb_deck_simulation(&ld).unwrap();
    let left = sim.body.node_set("left").unwrap();
    let right = sim.body.node_set("right").unwrap();
    let (m_left, m_right) = (mass(&sim, &left), mass(&sim, &right));
    let p_scale = m_left * speed;
    let rc = sim.contact.as_ref().unwrap().settings.radius;
    let e0 = total_energy(&sim);
    let mut closest = f64::INFINITY;
    let mut max_p = 0.0f64;
    let mut max_drift = 0.0f64;
    let mut touched_at = None;
    let mut apart_at = None;
    let mut steps = 0;
    // Step until the blocks have been apart (no contact energy) for 10 µs after touching.
    while steps < 4000 {
        sim.step().unwrap();
        steps += 1;
        closest = closest.min(min_distance(&sim, &left, &right));
        let p = momentum(&sim, &left) + momentum(&sim, &right);
        max_p = max_p.max(p.norm());
        max_drift = max_drift.max((total_energy(&sim) - e0).abs());
        let ec = Fields::contact_energy(&sim);
        match (touched_at, apart_at) {
            (None, _) if ec > 0.0 => touched_at = Some(sim.state.time),
            (Some(_), None) if ec == 0.0 => apart_at = Some(sim.state.time),
            (Some(_), Some(_)) if ec > 0.0 => apart_at = None,
            _ => {}
        }
        if apart_at.is_some_and(|t| sim.state.time > t + 10e-6) {
            break;
        }
    }
    let (t0, t1) = (
        touched_at.unwrap(),
        apart_at.expect("the blocks separate again"),
    );
    let v_left = momentum(&sim, &left)[0] / m_left;
    let v_right = momentum(&sim, &right)[0] / m_right;
    // Coefficient of restitution: relative speed after over before.
    let restitution = (v_right - v_left) / (2.0 * speed);
    let contact_time = t1 - t0;
    let e_kin = sim.kinetic_energy();
    let e_start = 2.0 * 0.5 * m_left * speed * speed;
    println!(
        "{steps} steps, dt {:.3e} s; contact from {t0:.3e} to {t1:.3e} s ({contact_time:.3e} s); \
         closest pair {:.3} r_c; rebound {v_left:.4} / {v_right:.4} m/s (restitution {restitution:.4}); \
         |P| max {:.2e} of m v; energy drift {:.2e} of the initial; rigid-body share of the \
         kinetic energy after {:.4}; list rebuilds {}",
        sim.dt,
        closest / rc,
        max_p / p_scale,
        max_drift / e_start,
        (0.5 * m_left * v_left * v_left + 0.5 * m_right * v_right * v_right) / e_kin,
        sim.contact.as_ref().unwrap().rebuilds
    );
    assert!(
        closest > 0.5 * rc,
        "nodes came within {:.3} r_c",
        closest / rc
    );
    assert!(
        max_p < 1e-12 * p_scale,
        "momentum {max_p:e} (m v = {p_scale:e})"
    );
    assert!(
        max_drift < 0.01 * e_start,
        "energy drift {max_drift:e} of {e_start:e}"
    );
    // Rebound: momentum says v_left = −v_right; an elastic collision of equal bars exchanges
    // the velocities (restitution 1) after a contact of 2L/c. Part of the energy stays in the
    // blocks as vibration (2D waves, lattice dispersion), so the rigid-body restitution is
    // below 1.
    assert!((v_left + v_right).abs() < 1e-9 * speed);
    assert!(
        (0.8..=1.0).contains(&restitution),
        "restitution {restitution}"
    );
}

/// A 10 mm × 4 mm PMB plate (plane stress, E = 1 GPa, no damage, free) and a `[[impactors]]`
/// entry given as TOML.
fn plate_deck(impactor: &str, steps: u64) -> LoadedDeck {
    let text = format!(
        r#"
version = 1
dimension = 2
plane = "stress"
thickness = 1e-3

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.01, 0.004] }}
spacing = {SPACING:e}
horizon_ratio = 3.0

[material]
type = "pmb"
density = {DENSITY:e}
youngs_modulus = 1e9
critical_stretch = 10.0

[[impactors]]
{impactor}

[solver]
type = "explicit"
steps = {steps}
safety_factor = 0.5

[output]
snapshots = 2
png = false
history_interval = 10
"#
    );
    LoadedDeck::from_str(&text, Path::new("plate.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// A free disk of radius 2 mm and 5 mg (the plate's mass is 40 mg) dropped at 5 m/s onto the
/// plate's top row of nodes (0.02 mm gap).
const FREE_DISK: &str = r#"name = "disk"
shape = "sphere"
centre = [0.005, 0.00577]
radius = 0.002
velocity = [0.0, -5.0]
mass = 5e-6"#;

#[test]
fn free_disk_bounces_off_a_plate_conserving_energy() {
    let ld = plate_deck(FREE_DISK, 1);
    let (mut sim, _) = pmb_deck_simulation(&ld).unwrap();
    let all: Vec<u32> = (0..sim.body.len() as u32).collect();
    let disk = |sim: &Simulation<2, Pmb>| sim.impactors.list[0].clone();
    let (m_disk, v0) = (5e-6, 5.0);
    let e_start = 0.5 * m_disk * v0 * v0;
    let e0 = total_energy(&sim);
    let (mut max_drift, mut max_p, mut steps, mut touched) = (0.0f64, 0.0f64, 0, false);
    let mut max_penalty = 0.0f64;
    while steps < 6000 {
        sim.step().unwrap();
        steps += 1;
        max_drift = max_drift.max((total_energy(&sim) - e0).abs());
        let d = disk(&sim);
        let p = momentum(&sim, &all) + d.velocity * m_disk;
        max_p = max_p.max((p - Vector::<2>::from([0.0, -m_disk * v0])).norm());
        max_penalty = max_penalty.max(d.energy);
        touched |= d.energy > 0.0;
        // Done once the disk flies up clear of the plate.
        if touched && d.energy == 0.0 && d.velocity[1] > 0.0 {
            break;
        }
    }
    let d = disk(&sim);
    println!(
        "{steps} steps, dt {:.3e} s; disk rebounds at {:.4} m/s (restitution {:.4}); largest \
         penalty energy {:.3} of the impact energy; energy drift {:.2e} of it; momentum error \
         {:.2e} of m v",
        sim.dt,
        d.velocity[1],
        d.velocity[1] / v0,
        max_penalty / e_start,
        max_drift / e_start,
        max_p / (m_disk * v0)
    );
    assert!(touched && d.velocity[1] > 0.0, "the disk bounces back");
    // Velocity Verlet is symplectic: the total energy (plate kinetic + strain + penalty + disk
    // kinetic) oscillates at O(dt²) about its start; 1% of the impact energy bounds it.
    assert!(
        max_drift < 0.01 * e_start,
        "energy drift {max_drift:e} of {e_start:e}"
    );
    // The penalty forces are equal and opposite: momentum of plate and disk together is kept.
    assert!(max_p < 1e-9 * m_disk * v0, "momentum error {max_p:e}");
}

#[test]
fn prescribed_impactor_work_is_the_energy_in_the_body() {
    // A disk of radius 3 mm, 0.01 mm above the top row of nodes, driven into it at 2 m/s.
    let ld = plate_deck(
        r#"name = "punch"
shape = "sphere"
centre = [0.005, 0.00676]
radius = 0.003
velocity = [0.0, -2.0]"#,
        1,
    );
    let (mut sim, _) = pmb_deck_simulation(&ld).unwrap();
    let (mut max_residual, mut max_force) = (0.0f64, 0.0f64);
    for _ in 0..600 {
        sim.step().unwrap();
        max_residual = max_residual.max(total_energy(&sim).abs());
        max_force = max_force.max(sim.impactors.list[0].force[1]);
    }
    let w = sim.state.external_work;
    let im = &sim.impactors.list[0];
    println!(
        "t = {:.3e} s: work {w:.4e} J, kinetic {:.4e}, strain {:.4e}, penalty {:.4e}; largest \
         residual {:.2e} of the work; largest force on the punch {max_force:.4e} N, at the end \
         {:?} N (the free plate flies off), punch at y = {:.5e} m",
        sim.state.time,
        sim.kinetic_energy(),
        sim.strain_energy(),
        im.energy,
        max_residual / w,
        im.force.as_slice(),
        im.position[1]
    );
    assert!(w > 0.0 && max_force > 0.0, "the punch pushes and works");
    assert!(
        im.velocity[1] == -2.0,
        "a prescribed impactor keeps its velocity"
    );
    // W_ext = E_kin + E_strain + E_penalty up to the integrator's O(dt²) error.
    assert!(
        max_residual < 0.01 * w,
        "residual {max_residual:e} of {w:e}"
    );
}

/// Every regular file in `dir` (not recursive), by name, with its bytes.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.file_name().unwrap() != "summary.txt")
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().to_string(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    out.sort();
    out
}

#[test]
fn contact_results_do_not_depend_on_threads() {
    // Colliding blocks with node contact and a free disk dropped onto the left block.
    let mut ld = blocks_deck(5.0, 400);
    let mut impactors = plate_deck(FREE_DISK, 1).deck.impactors;
    impactors[0].centre = Some(vec![0.005, 0.00677]);
    ld.deck.impactors = impactors;
    ld.deck.output.png = false;
    ld.deck.output.snapshots = 2;
    ld.deck.output.history_interval = Some(10);
    let mut outputs = Vec::new();
    for threads in [1, 2] {
        let out = std::env::temp_dir().join(format!(
            "peridyn-contact-threads-{threads}-{}",
            std::process::id()
        ));
        let opts = RunOptions {
            out_dir: out.clone(),
            threads: Some(threads),
            quiet: true,
        };
        run(&ld, &opts).unwrap();
        outputs.push(files(&out));
        std::fs::remove_dir_all(&out).ok();
    }
    let history = String::from_utf8(
        outputs[0]
            .iter()
            .find(|(n, _)| n == "history.csv")
            .unwrap()
            .1
            .clone(),
    )
    .unwrap();
    let header = history.lines().next().unwrap();
    assert!(header.contains("impactor_disk_force_y") && header.contains("contact_energy"));
    let last = history.lines().last().unwrap();
    println!("{header}\n{last}");
    assert_eq!(outputs[0].len(), outputs[1].len());
    for ((n1, b1), (n2, b2)) in outputs[0].iter().zip(&outputs[1]) {
        assert_eq!(n1, n2);
        assert!(b1 == b2, "{n1} differs between 1 and 2 threads");
    }
}

/// A free rigid sphere (radius 1.5 mm, 5 mg, 5 m/s down) dropped onto a 6 × 6 × 2 mm PMB
/// block (E = 1 GPa, 72 mg, no damage, free) 0.02 mm above its top row of nodes: in 3D as
/// in 2D it bounces back, the total energy stays within 1 % of the impact energy (velocity
/// Verlet's O(dt²) oscillation), and block and sphere together keep their momentum.
#[test]
fn free_sphere_bounces_off_a_block_in_3d() {
    let text = format!(
        r#"
version = 2
dimension = 3

[discretization]
type = "lattice"
shape = {{ type = "box", min = [0.0, 0.0, 0.0], max = [0.006, 0.006, 0.002] }}
spacing = {SPACING:e}
horizon_ratio = 3.0

[material]
type = "pmb"
density = {DENSITY:e}
youngs_modulus = 1e9
critical_stretch = 10.0

[[impactors]]
name = "ball"
shape = "sphere"
centre = [0.003, 0.003, 0.00327]
radius = 0.0015
velocity = [0.0, 0.0, -5.0]
mass = 5e-6

[solver]
type = "explicit"
steps = 1
safety_factor = 0.5
"#
    );
    let ld = LoadedDeck::from_str(&text, Path::new("ball.toml")).unwrap_or_else(|e| panic!("{e}"));
    let (mut sim, _) = pmb_deck_simulation_in::<3>(&ld).unwrap();
    let (m_ball, v0) = (5e-6, 5.0);
    let e_start = 0.5 * m_ball * v0 * v0;
    let energy = |sim: &Simulation<3, Pmb>| {
        sim.kinetic_energy()
            + sim.strain_energy()
            + Fields::contact_energy(sim)
            + Fields::impactor_kinetic_energy(sim)
            - sim.state.external_work
    };
    let momentum = |sim: &Simulation<3, Pmb>| {
        (0..sim.body.len()).fold(sim.impactors.list[0].velocity * m_ball, |p, i| {
            p + sim.state.v[i] * (sim.densities[i] * sim.body.volumes[i])
        })
    };
    let (e0, p0) = (energy(&sim), momentum(&sim));
    let (mut max_drift, mut max_p, mut steps, mut touched) = (0.0f64, 0.0f64, 0, false);
    while steps < 8000 {
        sim.step().unwrap();
        steps += 1;
        max_drift = max_drift.max((energy(&sim) - e0).abs());
        max_p = max_p.max((momentum(&sim) - p0).norm());
        let ball = &sim.impactors.list[0];
        touched |= ball.energy > 0.0;
        if touched && ball.energy == 0.0 && ball.velocity[2] > 0.0 {
            break;
        }
    }
    let ball = &sim.impactors.list[0];
    println!(
        "{steps} steps; sphere rebounds at {:.4} m/s (restitution {:.4}); energy drift {:.2e} \
         of the impact energy; momentum error {:.2e} of m v",
        ball.velocity[2],
        ball.velocity[2] / v0,
        max_drift / e_start,
        max_p / (m_ball * v0)
    );
    assert!(touched && ball.velocity[2] > 0.0, "the sphere bounces back");
    assert!(
        max_drift < 0.01 * e_start,
        "energy drift {max_drift:e} of {e_start:e}"
    );
    assert!(max_p < 1e-9 * m_ball * v0, "momentum error {max_p:e}");
}
