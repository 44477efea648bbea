//! Plate with a central hole under uniaxial tension, linear elastic, plane stress, against
//! Kirsch's solution (Kirsch 1898; e.g. Timoshenko & Goodier §35), on the three grids of
//! seed 000 §3 — the uniform lattice (zig-zag hole boundary), a global boundary-fitted mesh
//! and the near-boundary non-uniform grid (NB-NUG) — each with the energy surface correction,
//! solved by the quasi-static solver.
//!
//! Kirsch, remote stress σ along y, θ measured from the load axis, κ = (3 − ν)/(1 + ν),
//! μ = E/(2(1 + ν)):
//!   u_r = σ/(4μ) [r((κ − 1)/2 + cos 2θ) + (R²/r)(1 + (1 + κ) cos 2θ) − (R⁴/r³) cos 2θ]
//!   u_θ = σ/(4μ) [(1 − κ) R²/r − r − R⁴/r³] sin 2θ
//! At the hole edge σ_rr = 0 and the hoop stress is E ε_θθ = σ (1 − 2 cos 2θ): 3σ across the
//! load axis. A finite plate is not Kirsch's infinite one, so its outer layer of width 2δ
//! (fictitious nodes, seed 001 §2.9) is displaced as Kirsch's field: what remains is the
//! discretization of the plate and its hole. The hoop stress across the load axis is read from
//! the displacements (a PD node's own stress is truncated at a surface): E ∂u_y/∂y fitted over
//! the nodes within 1.5 cells of the hole edge and 2.5 cells of the axis, there σ_xx = σ_rr
//! ≈ 0. Two plates: a coarse one with all three grids, and seed 000 §4.1's own at two
//! refinements, where the lattice's staircase and NB-NUG's fitted edge part.

use peridyn::deck::build::{build_constitution, build_model, solver_settings, MaterialChoice};
use peridyn::deck::LoadedDeck;
use peridyn::loading::{BoundaryCondition, Kinematic, TimeFunction};
use peridyn::math::Vector;
use peridyn::run::{drive_quasi_static, prepare};
use std::path::Path;

const E: f64 = 1e9;
const NU: f64 = 1.0 / 3.0; // plane-stress PMB
const SIGMA: f64 = 1e6; // Pa
const R: f64 = 4e-3;
/// The plate's side (m), its cell size (m) and δ over the cell size.
#[derive(Debug, Clone, Copy)]
struct Plate {
    w: f64,
    h: f64,
    m: f64,
}

/// Kirsch's displacement (m) at x relative to the hole centre, load along y.
fn kirsch(x: &Vector<2>) -> Vector<2> {
    let r = x.norm();
    // θ from the load axis (y).
    let theta = x[0].atan2(x[1]);
    let mu = E / (2.0 * (1.0 + NU));
    let kappa = (3.0 - NU) / (1.0 + NU);
    let (c2, s2) = ((2.0 * theta).cos(), (2.0 * theta).sin());
    let k = SIGMA / (4.0 * mu);
    let ur = k
        * (r * ((kappa - 1.0) / 2.0 + c2) + R * R / r * (1.0 + (1.0 + kappa) * c2)
            - R.powi(4) / r.powi(3) * c2);
    let ut = k * ((1.0 - kappa) * R * R / r - r - R.powi(4) / r.powi(3)) * s2;
    // Radial unit vector (sin θ, cos θ) and hoop unit vector (cos θ, −sin θ) in (x, y).
    let (st, ct) = (theta.sin(), theta.cos());
    Vector::<2>::new(ur * st + ut * ct, ur * ct - ut * st)
}

fn deck(grid: &str, plate: Plate) -> LoadedDeck {
    let Plate { w: side, m, .. } = plate;
    let c = side / 2.0;
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3

[discretization]
{grid}
shape = {{ type = "difference", base = {{ type = "rectangle", min = [0.0, 0.0], max = [{side:e}, {side:e}] }}, subtract = [{{ type = "disk", center = [{c:e}, {c:e}], radius = {R:e} }}] }}
horizon_ratio = {m:e}
surface_correction = "energy"

[material]
type = "pmb"
density = 1000.0
youngs_modulus = {E:e}
critical_stretch = 1.0
[solver]
type = "quasi_static"
load_steps = 1
tolerance = 1e-8
"#,
    );
    LoadedDeck::from_str(&text, Path::new("kirsch.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Relative L2 error of the displacement field; the hoop stress (in σ) next to the hole
/// across the load axis, computed and Kirsch's sampled the same way; the largest bond stretch
/// near the hole (in σ/E); the node count.
fn errors(grid: &str, plate: Plate) -> (f64, f64, f64, f64, usize) {
    let Plate {
        w: side, h: cell, ..
    } = plate;
    let ld = deck(grid, plate);
    let model = build_model::<2>(&ld).unwrap();
    let c = build_constitution(&ld, &model).unwrap();
    let (material, rest) = c.split();
    let MaterialChoice::Pmb(pmb) = material else {
        panic!("a PMB deck")
    };
    let mut model = model;
    let centre = Vector::<2>::new(side / 2.0, side / 2.0);
    let layer = 2.0 * model.horizon;
    for i in 0..model.body.len() {
        let x = model.body.positions[i];
        if x.iter().any(|&c| c < layer || c > side - layer) {
            let u = kirsch(&(x - centre));
            for k in 0..2 {
                model.loading.conditions.push(BoundaryCondition {
                    set: "outer layer".into(),
                    nodes: vec![i as u32],
                    kind: Kinematic::Displacement,
                    component: k,
                    value: u[k],
                    time: TimeFunction::Ramp { duration: 1.0 },
                    offsets: Vec::new(),
                });
            }
        }
    }
    let (mut sim, report) = prepare(&ld, model, pmb, rest).unwrap();
    let qs = solver_settings(&ld.deck).quasi_static.unwrap();
    drive_quasi_static(&mut sim, qs, report.steps, &mut []).unwrap();
    let n = sim.body.len();
    let rel: Vec<Vector<2>> = (0..n).map(|i| sim.body.positions[i] - centre).collect();
    let exact: Vec<Vector<2>> = rel.iter().map(kirsch).collect();
    let (err, norm) = (0..n).fold((0.0, 0.0), |(e, m), i| {
        (
            e + (sim.state.u[i] - exact[i]).norm_squared(),
            m + exact[i].norm_squared(),
        )
    });
    let field_error = (err / norm).sqrt();
    // ∂u_y/∂y by least squares over the nodes next to the hole across the load axis, both
    // sides, for the computed and for Kirsch's field sampled at the same nodes.
    let near: Vec<usize> = (0..n)
        .filter(|&i| rel[i].norm() < R + 1.5 * cell && rel[i][1].abs() < 2.5 * cell)
        .collect();
    let slope = |u: &dyn Fn(usize) -> f64| {
        let m = near.len() as f64;
        let ym = near.iter().map(|&i| rel[i][1]).sum::<f64>() / m;
        let um = near.iter().map(|&i| u(i)).sum::<f64>() / m;
        let sxy: f64 = near.iter().map(|&i| (rel[i][1] - ym) * (u(i) - um)).sum();
        let sxx: f64 = near.iter().map(|&i| (rel[i][1] - ym).powi(2)).sum();
        sxy / sxx
    };
    // The largest bond stretch around the hole, where a crack would start, in σ/E.
    let mut stretch: f64 = 0.0;
    for i in (0..n).filter(|&i| rel[i].norm() < R + 2.0 * cell) {
        for b in sim.bonds.family(i) {
            let j = sim.bonds.neighbors[b] as usize;
            let l = sim.bonds.ref_lengths[b];
            let len = (sim.state.current[j] - sim.state.current[i]).norm();
            stretch = stretch.max((len - l) / l * E / SIGMA);
        }
    }
    // Every bond with an end within two cells of the hole edge: its stretch against the one
    // Kirsch's field gives the same bond (in σ/E), the measure a failure law reads.
    let kirsch_stretch = |i: usize, j: usize, l: f64| {
        let xi = sim.body.positions[j] - sim.body.positions[i] + exact[j] - exact[i];
        (xi.norm() - l) / l * E / SIGMA
    };
    let (mut worst, mut sq, mut count) = (0.0f64, 0.0, 0usize);
    for i in (0..n).filter(|&i| rel[i].norm() < R + 2.0 * cell) {
        for b in sim.bonds.family(i) {
            let j = sim.bonds.neighbors[b] as usize;
            let l = sim.bonds.ref_lengths[b];
            let s_pd = ((sim.state.current[j] - sim.state.current[i]).norm() - l) / l * E / SIGMA;
            let s_k = kirsch_stretch(i, j, l);
            worst = worst.max((s_pd - s_k).abs());
            sq += (s_pd - s_k).powi(2);
            count += 1;
        }
    }
    println!(
        "  bonds near the hole: {count}, their stretch against Kirsch's: largest error {worst:.3}, RMS {:.3} σ/E",
        (sq / count as f64).sqrt()
    );
    let hoop = E * slope(&|i| sim.state.u[i][1]) / SIGMA;
    let hoop_kirsch = E * slope(&|i| exact[i][1]) / SIGMA;
    (field_error, hoop, hoop_kirsch, stretch, n)
}

#[test]
fn plate_with_a_hole_against_kirsch_on_three_grids() {
    let plate = Plate {
        w: 0.04,
        h: 0.4e-3,
        m: 3.0,
    };
    let h = plate.h;
    for (name, grid) in [
        ("lattice", format!("type = \"lattice\"\nspacing = {h:e}")),
        ("free mesh", format!("type = \"free_mesh\"\nsize = {h:e}")),
        ("NB-NUG", format!("type = \"nbnug\"\nsize = {h:e}")),
    ] {
        let (field, hoop, hoop_kirsch, stretch, nodes) = errors(&grid, plate);
        println!(
            "{name:10} {nodes} nodes: displacement L2 error {:.3} %, hoop stress next to the hole {hoop:.3} σ (Kirsch at the same nodes {hoop_kirsch:.3} σ, {:+.1} %), largest bond stretch {stretch:.3} σ/E (Kirsch's peak strain 3)",
            100.0 * field,
            100.0 * (hoop / hoop_kirsch - 1.0)
        );
        // δ = 3Δx = 0.3 R: the field is within the discretization error of the PMB operator
        // (a few % in stiffness at m = 3, less in displacement with the outer field given);
        // the stress concentration is smoothed over δ, so the hoop stress of the first nodes
        // falls short of Kirsch's, by less than the fraction of the peak lost within δ/2 of
        // the edge (Kirsch: σ_θθ(R + δ/2)/σ_θθ(R) = 0.745 across the load axis).
        assert!(field < 0.015, "{name}: displacement error {field}");
        let shortfall = 1.0 - hoop / hoop_kirsch;
        assert!(
            (0.0..0.255).contains(&shortfall),
            "{name}: hoop stress {hoop} vs {hoop_kirsch}"
        );
        // No grid puts a spurious concentration above Kirsch's peak strain.
        assert!(stretch < 3.0, "{name}: largest stretch {stretch} σ/E");
    }
}

/// Seed 000 §4.1's plate (20 mm square, R = 4 mm, δ = 4Δx, the paper's m) at R/Δx = 20 and
/// 40 (the paper's is 80). Next to the hole across the load axis the lattice's hoop stress
/// does not approach Kirsch's as the cells shrink, while NB-NUG's does: where the hole's
/// staircase meets the first column of nodes changes with Δx, a fitted boundary does not.
/// The displacement field does not tell the grids apart (both within 1.3 %, the lattice
/// slightly ahead): the staircase is felt in the first layer of nodes, where cracks start.
#[test]
fn seed000_plate_hoop_stress_on_nbnug_converges_to_kirsch_while_the_lattice_does_not() {
    let mut shortfalls = Vec::new();
    for cells_per_radius in [20.0, 40.0] {
        let plate = Plate {
            w: 0.02,
            h: R / cells_per_radius,
            m: 4.0,
        };
        let h = plate.h;
        let mut row = Vec::new();
        for (name, grid) in [
            ("lattice", format!("type = \"lattice\"\nspacing = {h:e}")),
            ("NB-NUG", format!("type = \"nbnug\"\nsize = {h:e}")),
        ] {
            let (field, hoop, hoop_kirsch, stretch, nodes) = errors(&grid, plate);
            let shortfall = 1.0 - hoop / hoop_kirsch;
            println!(
                "R/Δx = {cells_per_radius}, {name:8} {nodes} nodes: displacement L2 error {:.3} %, hoop stress next to the hole {hoop:.3} σ vs Kirsch's {hoop_kirsch:.3} σ ({:+.1} %), largest bond stretch {stretch:.3} σ/E",
                100.0 * field,
                -100.0 * shortfall
            );
            assert!(field < 0.015, "{name}: displacement error {field}");
            row.push(shortfall);
        }
        shortfalls.push(row);
    }
    let (coarse, fine) = (&shortfalls[0], &shortfalls[1]);
    // Measured: lattice 5.5 % → 11.3 %, NB-NUG 7.8 % → 5.5 %.
    assert!(
        fine[1] < 0.8 * coarse[1],
        "NB-NUG's hoop stress approaches Kirsch's: {coarse:?} → {fine:?}"
    );
    assert!(
        fine[0] > 0.8 * coarse[0],
        "the lattice's does not: {coarse:?} → {fine:?}"
    );
    assert!(
        fine[1] < 0.6 * fine[0],
        "at R/Δx = 40 NB-NUG is closer to Kirsch than the lattice by 40 %: {fine:?}"
    );
}
