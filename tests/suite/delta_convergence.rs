//! Seed 001's central result (§3.3, §3.4, Figs. 5, 12): quasi-static crack nucleation at a
//! hole. With PMB the critical stretch s0 = √(4πG0/(9Eδ)) grows as δ shrinks and nothing ties
//! the model to a tensile strength, so the peak load keeps rising; with the bilinear law the
//! peak-force stretch s1 = 2σu/(3E) does not depend on δ and the peak load converges.
//!
//! The plate of seed 001 §3.1 (50 mm square, hole of d = 20 mm, E = 192 GPa, G0 = 83 kJ/m²,
//! plane stress, 0.5 mm thick, fictitious layers of width δ) at reduced resolution: a
//! lattice at m = δ/Δx = 3 and δ = 5, 3, 2.5 mm (968 to 3512 nodes; the paper: FE-centroid
//! grids at m = 5, δ = 3 to 0.375 mm). The quasi-brittle σu = 0.576 GPa of Table 1.

use super::common;

use peridyn::deck::build::solver_settings;
use peridyn::deck::LoadedDeck;
use peridyn::solver::QuasiStatic;
use std::path::Path;
use std::time::Instant;

/// The horizons, coarsest first (δ/Δx = 3: 30, 50, 60 cells across the plate).
const DELTAS: [f64; 3] = [5e-3, 3e-3, 2.5e-3];
/// Pull of each layer over the nominal load steps: 5 µm per step, halved up to 5 times when
/// a step breaks more than 20 bonds (adaptive load stepping).
const STEP: f64 = 5e-6;
/// Largest pull of each law: past the bilinear peak (70–85 µm here) until the load falls
/// below 80 % of it, and past the PMB peak (90–120 µm).
const BILINEAR_PULL: f64 = 1.6e-4;
const PMB_PULL: f64 = 2.0e-4;
/// Least rise of the PMB peak from one horizon to the next finer one, and over all three.
const MARGIN: f64 = 1.05;
const OVERALL: f64 = 1.25;

/// Plate side L and hole radius (seed 001 §3.1: W = 50 mm, d ≈ 20 mm from Appendix D).
const SIDE: f64 = 0.05;
const RADIUS: f64 = 0.01;
const THICKNESS: f64 = 0.5e-3;

/// The plate with a central hole at horizon `delta` (m = δ/Δx = 3, lattice), between two
/// fictitious layers of width δ above and below it (seed 001 §2.9) pulled apart in y by
/// `pull` each over the run; `damage` is the material's damage line.
fn plate(delta: f64, damage: &str, pull: f64, load_steps: u64, max_broken: u64) -> LoadedDeck {
    let dx = delta / 3.0;
    let (l, r, c) = (SIDE, RADIUS, SIDE / 2.0);
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = {THICKNESS:e}
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = {{ type = "difference", base = {{ type = "rectangle", min = [0.0, {lo:e}], max = [{l:e}, {hi:e}] }}, subtract = [{{ type = "disk", center = [{c:e}, {c:e}], radius = {r:e} }}] }}
spacing = {dx:e}
horizon_ratio = 3.0

[material]
type = "pmb"
density = 8000.0
youngs_modulus = 192e9
fracture_energy = 83e3
{damage}

[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, {l:e}], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.0] }}

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
value = {neg:e}
time = {{ type = "ramp", duration = 1.0 }}
[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "x"
value = 0.0
[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "x"
value = 0.0

[solver]
type = "quasi_static"
load_steps = {load_steps}
tolerance = 1e-4
max_broken_bonds = {max_broken}
max_splits = 5
"#,
        lo = -delta,
        hi = l + delta,
        neg = -pull,
    );
    LoadedDeck::from_str(&text, Path::new("plate_hole.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// What one run measured.
struct Curve {
    peak: f64,
    /// Pull of each layer at the peak (m).
    at: f64,
    /// The smallest load after the peak.
    after: f64,
    steps: u64,
    iterations: u64,
    seconds: f64,
}

/// Loads the plate step by step until the load has fallen below `drop` of its peak (or the
/// last load step); returns the peak reaction of the top layer (N) and what it took.
fn load_curve(ld: &LoadedDeck, pull: f64, drop: f64) -> Curve {
    let started = Instant::now();
    let (mut sim, report) = common::pmb_deck_simulation(ld).unwrap();
    let settings = solver_settings(&ld.deck).quasi_static.unwrap();
    let n = report.steps;
    let nominal = 1.0 / n as f64;
    let mut solver = QuasiStatic::new(&sim, settings, nominal);
    let top = sim.body.node_set("top").unwrap().to_vec();
    let (mut peak, mut at, mut after, mut steps) = (0.0f64, 0.0, f64::INFINITY, 0);
    'load: for k in 1..=n {
        let target = k as f64 * nominal;
        while sim.state.time < target {
            solver.advance(&mut sim, target).unwrap();
            steps += 1;
            let load = sim.reaction(&top)[1];
            if load > peak {
                (peak, at, after) = (load, sim.state.time * pull, f64::INFINITY);
            } else {
                after = after.min(load);
            }
            if after < drop * peak {
                break 'load;
            }
        }
    }
    Curve {
        peak,
        at,
        after,
        steps,
        iterations: solver.iterations,
        seconds: started.elapsed().as_secs_f64(),
    }
}

/// The peak loads of one law at the three horizons, each run stopped once its load has
/// fallen below 80 % of its peak or at `pull`.
fn peaks(law: &str, damage: &str, pull: f64) -> Vec<Curve> {
    let steps = (pull / STEP).round() as u64;
    DELTAS
        .iter()
        .map(|&delta| {
            let c = load_curve(&plate(delta, damage, pull, steps, 20), pull, 0.8);
            println!(
                "{law:<8} δ = {:.3} mm: peak {:7.1} N at a pull of {:5.1} µm per side, lowest load after it {:7.1} N ({:.0} %), {} load steps, {} ADR iterations, {:.1} s",
                delta * 1e3,
                c.peak,
                c.at * 1e6,
                c.after,
                100.0 * c.after / c.peak,
                c.steps,
                c.iterations,
                c.seconds
            );
            c
        })
        .collect()
}

#[test]
fn bilinear_peak_load_converges_while_pmb_keeps_rising() {
    let started = Instant::now();
    let bilinear = peaks(
        "bilinear",
        "damage = { type = \"bilinear\", tensile_strength = 0.576e9 }",
        BILINEAR_PULL,
    );
    let pmb = peaks("PMB", "", PMB_PULL);
    let p: Vec<f64> = bilinear.iter().map(|c| c.peak).collect();
    let q: Vec<f64> = pmb.iter().map(|c| c.peak).collect();
    let change = (p[1] - p[2]).abs() / p[2];
    // Seed 001 Appendix D (Peterson's K_t for d/W = 0.4): first yield at the hole edge at
    // σu (W − d) t / K_t = 3.86 kN; the net section carries at most σu (W − d) t = 8.64 kN.
    println!(
        "bilinear peak change between the two finest horizons {:.2} %; PMB peak ratios {:.3}, {:.3} (s0 ∝ δ^-1/2: {:.3}, {:.3}); {:.1} s in all",
        100.0 * change,
        q[1] / q[0],
        q[2] / q[1],
        (DELTAS[0] / DELTAS[1]).sqrt(),
        (DELTAS[1] / DELTAS[2]).sqrt(),
        started.elapsed().as_secs_f64()
    );
    assert!(change < 0.05, "bilinear peaks {p:?}");
    // Between a first bond at σu and the net-section limit.
    assert!(p.iter().all(|&x| (3.86e3..8.64e3).contains(&x)), "{p:?}");
    // The bilinear curve has a post-peak branch: the load falls below 80 % of its peak.
    for c in &bilinear {
        assert!(
            c.after < 0.8 * c.peak,
            "no post-peak branch: {:?}",
            (c.peak, c.after)
        );
    }
    // PMB: each finer horizon carries a larger peak, by more than the 5 % within which the
    // bilinear peak is asserted converged, so the two laws are told apart at these horizons;
    // over the factor 2 in δ the rise is far beyond it. s0 ∝ δ^-1/2 predicts +29 %, +10 % and
    // +41 % overall. Not every horizon follows the trend this closely on a lattice: the
    // zig-zag hole outline moves single peaks by several per cent (δ = 3.33 mm, R/Δx = 9,
    // gave 20.6 kN, 10 % above the δ^-1/2 line through these three).
    assert!(
        q[1] > MARGIN * q[0] && q[2] > MARGIN * q[1],
        "PMB peaks {q:?}"
    );
    assert!(q[2] > OVERALL * q[0], "PMB peaks {q:?}");
}
