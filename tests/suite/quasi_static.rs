//! The quasi-static solver (adaptive dynamic relaxation in load steps, seed 001 Appendix B):
//! equilibrium against Hooke's law and against a damped explicit run, the energy balance,
//! splitting of load steps that break too many bonds, and a clear error when it cannot
//! converge.

use super::common;

use peridyn::bonds::PartialVolume;
use peridyn::damage::Damage;
use peridyn::deck::build::solver_settings;
use peridyn::deck::LoadedDeck;
use peridyn::loading::{BoundaryCondition, Kinematic, Loading, TimeFunction};
use peridyn::material::correspondence::ZeroEnergyControl;
use peridyn::material::{Dimensionality, Material, MicromodulusProfile, Pmb};
use peridyn::math::Vector;
use peridyn::run::{drive, drive_quasi_static, RunError};
use peridyn::solver::coarse_space::CoarseSpace;
use peridyn::solver::{AdrMass, EquilibriumMethod, QuasiStatic, QuasiStaticSettings, Simulation};
use peridyn::study::table::Table;
use std::path::Path;

/// A 2D plane-stress PMB plate 20 mm × 40 mm (Δx = 0.5 mm, δ = 3Δx) between two grip layers
/// of three rows; the top grip is pulled up by `pull` (m) over the run, the bottom one held
/// in y; the pull ramps up over `ramp` (load time or seconds); `extra` goes into the
/// discretization table.
fn plate_deck(pull: f64, ramp: f64, solver: &str, extra: &str) -> LoadedDeck {
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.02, 0.04] }}
spacing = 0.5e-3
horizon_ratio = 3.0
{extra}

[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
critical_stretch = 1.0

[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, 0.0385], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.0015] }}

[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "y"
value = 0.0
[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "y"
value = {pull:e}
time = {{ type = "ramp", duration = {ramp:e} }}

{solver}
"#
    );
    LoadedDeck::from_str(&text, Path::new("plate.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Builds a PMB deck and runs it to the end (no observers).
fn solve(ld: &LoadedDeck) -> Result<Simulation<2, Pmb>, RunError> {
    let (mut sim, report) = common::pmb_deck_simulation(ld)?;
    match solver_settings(&ld.deck).quasi_static {
        Some(qs) => drive_quasi_static(&mut sim, qs, report.steps, &mut [])?,
        None => drive(&mut sim, report.steps, &mut [])?,
    }
    Ok(sim)
}

/// Patch test of the relaxation: a square plate (40 × 40 cells of 0.5 mm, δ = 3Δx) whose
/// outer layer of width 2δ is displaced as the homogeneous field u = ε x (fictitious nodes,
/// seed 001 §2.9); every free node and every node it is bonded to has a full family, so the
/// exact discrete equilibrium is that field. Returns the largest error of the free nodes
/// relative to the largest displacement.
fn patch_error<M: Material<2>>(material: M, eps: [[f64; 2]; 2]) -> f64 {
    patch_error_with(material, eps, EquilibriumMethod::Adr).0
}

/// `patch_error` with the given method; also the iterations (ADR) or force evaluations (NCG).
fn patch_error_with<M: Material<2>>(
    material: M,
    eps: [[f64; 2]; 2],
    method: EquilibriumMethod,
) -> (f64, u64) {
    let settings = QuasiStaticSettings {
        method,
        tolerance: 1e-10,
        ..Default::default()
    };
    let (error, iterations, _) = patch_error_settings(material, eps, settings);
    (error, iterations)
}

/// `patch_error_with` with the given settings; also the measured largest eigenvalue of λ⁻¹K
/// for Gershgorin's masses (0 when not measured).
fn patch_error_settings<M: Material<2>>(
    material: M,
    eps: [[f64; 2]; 2],
    settings: QuasiStaticSettings,
) -> (f64, u64, f64) {
    let (dx, m) = (0.5e-3, 3.0);
    let (body, bonds) = common::lattice_body::<2>(40, dx, m, PartialVolume::Hhb);
    let (side, layer) = (40.0 * dx, 2.0 * m * dx);
    let field = |x: &Vector<2>| {
        Vector::<2>::new(
            eps[0][0] * x[0] + eps[0][1] * x[1],
            eps[1][0] * x[0] + eps[1][1] * x[1],
        )
    };
    let in_layer = |x: &Vector<2>| x.iter().any(|&c| c < layer || c > side - layer);
    let mut loading = Loading::<2>::default();
    for i in 0..body.len() {
        let x = body.positions[i];
        if in_layer(&x) {
            for k in 0..2 {
                loading.conditions.push(BoundaryCondition {
                    set: format!("node {i}"),
                    nodes: vec![i as u32],
                    kind: Kinematic::Displacement,
                    component: k,
                    value: field(&x)[k],
                    time: TimeFunction::Ramp { duration: 1.0 },
                    offsets: Vec::new(),
                });
            }
        }
    }
    let mut sim = Simulation::new(
        body,
        bonds,
        material,
        Damage::none(),
        PartialVolume::Hhb,
        loading,
        Some(1.0),
        1.0,
    )
    .unwrap();
    let method = settings.method;
    let mut solver = QuasiStatic::new(&sim, settings, 1.0);
    let report = solver.advance(&mut sim, 1.0).unwrap();
    let scale = (0..sim.body.len())
        .map(|i| field(&sim.body.positions[i]).norm())
        .fold(0.0, f64::max);
    let error = (0..sim.body.len())
        .filter(|&i| !in_layer(&sim.body.positions[i]))
        .map(|i| (sim.state.u[i] - field(&sim.body.positions[i])).norm())
        .fold(0.0, f64::max);
    println!(
        "{method:?}: {} iterations, residual {:.2e}: largest error {:.3e} of the largest displacement",
        report.iterations,
        report.residual,
        error / scale
    );
    // The residual of the state left, computed again: within the tolerance.
    assert!(solver.residual(&sim).0 <= 1e-10);
    (error / scale, report.iterations, solver.spectral_radius)
}

#[test]
fn relaxation_reproduces_a_homogeneous_deformation_exactly() {
    let (e, h) = (1e9, 1.5e-3);
    let plane = Dimensionality::PlaneStress;
    // Uniaxial stress along y (ν = 1/3 for PMB), a pure shear and a biaxial stretch.
    let uniaxial = [[-1e-4 / 3.0, 0.0], [0.0, 1e-4]];
    let shear = [[0.0, 1e-4], [1e-4, 0.0]];
    let biaxial = [[2e-4, 0.0], [0.0, 1e-4]];
    for eps in [uniaxial, shear, biaxial] {
        let profile = MicromodulusProfile::Constant;
        assert!(patch_error(common::pmb(plane, e, h, profile), eps) < 1e-6);
        assert!(patch_error(common::lps(plane, e, 0.3, h), eps) < 1e-6);
    }
    let control = ZeroEnergyControl::Wan { coefficient: 1.0 };
    assert!(patch_error(common::correspondence(plane, e, 0.3, h, control), biaxial) < 1e-6);
}

#[test]
fn conjugate_gradients_reproduce_a_homogeneous_deformation_exactly() {
    let (e, h) = (1e9, 1.5e-3);
    let plane = Dimensionality::PlaneStress;
    let biaxial = [[2e-4, 0.0], [0.0, 1e-4]];
    let shear = [[0.0, 1e-4], [1e-4, 0.0]];
    for eps in [biaxial, shear] {
        let pmb = || common::pmb(plane, e, h, MicromodulusProfile::Constant);
        let (error, evaluations) = patch_error_with(pmb(), eps, EquilibriumMethod::Ncg);
        let (_, adr) = patch_error_with(pmb(), eps, EquilibriumMethod::Adr);
        println!("NCG {evaluations} force evaluations, ADR {adr}");
        assert!(error < 1e-6);
        let lps = common::lps(plane, e, 0.3, h);
        assert!(patch_error_with(lps, eps, EquilibriumMethod::Ncg).0 < 1e-6);
    }
}

/// ADR's spectral masses (the default) reach the exact equilibrium as Gershgorin's do, in
/// fewer iterations: the measured largest eigenvalue ρ of λ⁻¹K (Gershgorin's λ) lies below
/// Gershgorin's bound 4, so the masses shrink by 1.5 ρ/4 and every frequency grows by the
/// square root of its inverse. (A relaxation that failed with them would fall back to
/// Gershgorin's masses and take at least as many iterations as they do.)
#[test]
fn spectral_masses_reach_the_same_equilibrium_in_fewer_iterations() {
    let (e, h) = (1e9, 1.5e-3);
    let plane = Dimensionality::PlaneStress;
    let biaxial = [[2e-4, 0.0], [0.0, 1e-4]];
    let with = |mass: AdrMass| QuasiStaticSettings {
        tolerance: 1e-10,
        mass,
        ..Default::default()
    };
    let pmb = || common::pmb(plane, e, h, MicromodulusProfile::Constant);
    let lps = || common::lps(plane, e, 0.3, h);
    for (name, gershgorin, spectral) in [
        (
            "PMB",
            patch_error_settings(pmb(), biaxial, with(AdrMass::Gershgorin)),
            patch_error_settings(pmb(), biaxial, with(AdrMass::Spectral)),
        ),
        (
            "LPS",
            patch_error_settings(lps(), biaxial, with(AdrMass::Gershgorin)),
            patch_error_settings(lps(), biaxial, with(AdrMass::Spectral)),
        ),
    ] {
        println!(
            "{name}: Gershgorin {} iterations, spectral {} (ρ = {:.3})",
            gershgorin.1, spectral.1, spectral.2
        );
        assert!(gershgorin.0 < 1e-6 && spectral.0 < 1e-6);
        assert_eq!(gershgorin.2, 0.0);
        assert!(spectral.2 > 0.1 && spectral.2 < 4.0, "ρ = {}", spectral.2);
        assert!(
            (spectral.1 as f64) < 0.85 * gershgorin.1 as f64,
            "{name}: {} against {}",
            spectral.1,
            gershgorin.1
        );
    }
}

/// A notched PMB strip 16 mm × 8 mm (δ = 3Δx, a 5 mm notch at mid-height) whose grip layers
/// are pulled apart by ±1 µm in one quasi-static load step, relaxed by ADR with `damping`.
fn notched_strip(spacing: f64, damping: &str) -> Simulation<2, Pmb> {
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
no_fail = ["all"]
[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.016, 0.008] }}
spacing = {spacing:e}
horizon_ratio = 3.0
[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
fracture_energy = 100.0
[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, 0.0074], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.0006] }}
[[precracks]]
type = "segment"
start = [-0.001, 0.004]
end = [0.004, 0.004]
[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "y"
value = 1e-6
[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "y"
value = -1e-6
[solver]
type = "quasi_static"
load_steps = 1
tolerance = 1e-8
adr_damping = "{damping}"
"#
    );
    let ld = LoadedDeck::from_str(&text, Path::new("strip.toml")).unwrap_or_else(|e| panic!("{e}"));
    solve(&ld).unwrap()
}

/// ADR's damping from the Rayleigh quotient of the last increment (`adr_damping =
/// "increment"`) reaches the equilibrium the local estimate of Kilic & Madenci reaches, and
/// on a fine grid in far fewer iterations: the local estimate is weighted by the displacements,
/// so it follows the solution's shape, whose frequency lies above the slowest mode's, and the
/// slow modes are overdamped. Measured first (iterations, local / increment): 80 × 40 nodes
/// 362 / 345, 160 × 80 nodes 4373 / 674 (320 × 160: 22 696 / 1299). The bounds: the
/// increment's count grows at most 2.5× per halving of Δx (measured 1.95) while the
/// local one grows more than fourfold (12), and on the finer grid it takes under a third
/// (0.15).
#[test]
fn damping_from_the_increment_relaxes_a_fine_grid_in_fewer_iterations() {
    let mut counts = Vec::new();
    for spacing in [2e-4, 1e-4] {
        let local = notched_strip(spacing, "local");
        let increment = notched_strip(spacing, "increment");
        let largest = local.state.u.iter().map(|u| u.norm()).fold(0.0, f64::max);
        let apart = (0..local.state.u.len())
            .map(|i| (local.state.u[i] - increment.state.u[i]).norm())
            .fold(0.0, f64::max);
        let (l, i) = (local.state.iterations, increment.state.iterations);
        println!("Δx = {spacing:e}: local {l}, increment {i} iterations, fields apart by {:.2e} of the largest displacement", apart / largest);
        assert!(apart < 1e-6 * largest, "{apart:e}");
        counts.push((l as f64, i as f64));
    }
    let [(l1, i1), (l2, i2)] = counts[..] else {
        unreachable!()
    };
    assert!(i2 < 2.5 * i1 && l2 > 4.0 * l1, "{counts:?}");
    assert!(i2 < 0.33 * l2, "{counts:?}");
}

/// A crack run through the notched plate in load steps: the reaction after every committed
/// step, the bond halves broken by then, and the force evaluations (ADR iterations or NCG
/// evaluations) of the whole run.
fn crack_run(settings: QuasiStaticSettings, load_steps: u64) -> (Vec<(f64, u64)>, u64) {
    let ld = notched_deck(load_steps);
    let (mut sim, _) = common::pmb_deck_simulation(&ld).unwrap();
    let nominal = 1.0 / load_steps as f64;
    let mut solver = QuasiStatic::new(&sim, settings, nominal);
    let top = sim.body.node_set("top").unwrap();
    let mut curve = Vec::new();
    for k in 1..=load_steps {
        let target = k as f64 * nominal;
        while sim.state.time < target {
            let report = solver.advance(&mut sim, target).unwrap();
            assert!(report.residual <= solver.settings.tolerance);
            curve.push((sim.reaction(&top)[1], sim.state.broken));
        }
    }
    (curve, solver.iterations)
}

/// A solver continued from a checkpoint's memory scales Gershgorin's masses by the spectral
/// radius the memory keeps instead of measuring it again (which needs a fresh copy of the
/// bonds' state beside a paused step's work records): it spends no force evaluation on it
/// and takes the next load step exactly as the solver that measured it.
#[test]
fn a_continued_solver_keeps_the_measured_spectrum() {
    let ld = notched_deck(4);
    let (mut sim, _) = common::pmb_deck_simulation(&ld).unwrap();
    let mut solver = QuasiStatic::new(&sim, QuasiStaticSettings::default(), 0.25);
    solver.advance(&mut sim, 0.25).unwrap();
    let (rho, measured) = (solver.spectral_radius, solver.setup_evaluations);
    assert!(
        rho > 0.1 && rho < 4.0 && measured > 0,
        "ρ = {rho}, {measured} evaluations"
    );
    let memory = solver.memory();
    assert_eq!(memory.spectrum, Some((rho, measured)));
    let mut continued = QuasiStatic::new(&sim, QuasiStaticSettings::default(), 0.25);
    continued.resume(memory);
    assert_eq!(continued.setup_evaluations, measured);
    let mut sim_continued = common::pmb_deck_simulation(&ld).unwrap().0;
    sim_continued.state = sim.state.clone();
    let whole = solver.advance(&mut sim, 0.5).unwrap();
    let resumed = continued.advance(&mut sim_continued, 0.5).unwrap();
    assert_eq!(continued.setup_evaluations, measured, "measured again");
    assert_eq!(continued.spectral_radius, rho);
    assert_eq!(resumed.iterations, whole.iterations);
    assert!(sim_continued.state.u == sim.state.u);
}

/// The faster relaxations (ADR's spectral masses, NCG's shorter line search) trace the same
/// fracture as the previous ones (Gershgorin's masses, the line search to 10⁻⁶): the same
/// committed steps, the same bond halves broken after each, and reactions that differ by
/// no more than the tolerance's effect (the equilibria differ within the relative residual
/// 10⁻⁶ of the deck's default tolerance), in fewer force evaluations.
#[test]
fn faster_relaxations_trace_the_same_fracture() {
    let (before, after) = (
        QuasiStaticSettings {
            mass: AdrMass::Gershgorin,
            ..notched_settings()
        },
        notched_settings(),
    );
    let ncg = |exact| QuasiStaticSettings {
        method: EquilibriumMethod::Ncg,
        exact_line_search: exact,
        ..notched_settings()
    };
    for (name, before, after) in [("ADR", before, after), ("NCG", ncg(true), ncg(false))] {
        let (old_work, new_work) = assert_same_fracture(name, before, after);
        assert!(new_work < old_work);
    }
}

/// Runs the notched plate with `before` and `after` and asserts the same fracture: the same
/// committed steps, the same bond halves broken after each, reactions within 10⁻⁴ of the
/// peak; returns both runs' force evaluations.
fn assert_same_fracture(
    name: &str,
    before: QuasiStaticSettings,
    after: QuasiStaticSettings,
) -> (u64, u64) {
    let ((old, old_work), (new, new_work)) = (crack_run(before, 10), crack_run(after, 10));
    let peak = old.iter().map(|p| p.0).fold(0.0, f64::max);
    let worst = old
        .iter()
        .zip(&new)
        .map(|(a, b)| (a.0 - b.0).abs())
        .fold(0.0, f64::max);
    println!(
        "{name}: {} committed steps, {} bond halves broken, peak {peak:.5} N, largest reaction difference {worst:.2e} N; {old_work} → {new_work} force evaluations",
        old.len(),
        old.last().unwrap().1,
    );
    assert!(old.last().unwrap().1 > 0, "the crack grows");
    assert_eq!(old.len(), new.len());
    for (a, b) in old.iter().zip(&new) {
        assert_eq!(a.1, b.1, "bond halves broken: {old:?} against {new:?}");
    }
    assert!(worst <= 1e-4 * peak, "{worst} of {peak}");
    (old_work, new_work)
}

/// Conjugate gradients with the coarse grid's correction (`preconditioner = "two_level"`)
/// trace the fracture of Jacobi's: the same committed steps and bond halves broken after
/// each, reactions within the tolerance's effect, in fewer force evaluations (measured on
/// this 800-node plate: 21 074 → 9 462; the gain grows with the plate's width in nodes).
#[test]
fn a_coarse_grid_correction_traces_the_same_fracture_in_fewer_evaluations() {
    let ncg = |two_level| QuasiStaticSettings {
        method: EquilibriumMethod::Ncg,
        two_level,
        ..notched_settings()
    };
    let (old_work, new_work) = assert_same_fracture("two-level NCG", ncg(false), ncg(true));
    assert!(2 * new_work < old_work, "{old_work} → {new_work}");
}

/// A crack that cuts the body in two leaves each side's coarse cells to move apart: the
/// two-level preconditioner's correction of a residual on one side is exactly zero on the
/// other (no unbroken bond joins them, so no stiffness does). A cell that straddled the cut
/// and moved as one would carry the residual across it.
#[test]
fn a_coarse_correction_does_not_cross_a_cut() {
    let ld = plate_deck(
        1e-6,
        1.0,
        "[solver]\ntype = \"quasi_static\"\nload_steps = 1",
        "",
    );
    let (mut sim, _) = common::pmb_deck_simulation(&ld).unwrap();
    // Cut between the node rows at y = 19.75 and 20.25 mm, inside a row of cells (about
    // 1.5 mm high from y = 0.25 mm) and away from the grips.
    let cut = 0.02;
    let above = |i: usize| sim.body.positions[i][1] > cut;
    let mut crossing = 0;
    for i in 0..sim.body.len() {
        for b in sim.bonds.family(i) {
            if above(i) != above(sim.bonds.neighbors[b] as usize) {
                sim.state.status[b] = peridyn::state::BROKEN;
                crossing += 1;
            }
        }
    }
    assert!(crossing > 0);
    let mut coarse = CoarseSpace::new(&sim);
    coarse.update(&sim);
    let r: Vec<Vector<2>> = (0..sim.body.len())
        .map(|i| {
            if above(i) {
                Vector::<2>::new(1.0, 0.5)
            } else {
                Vector::<2>::zeros()
            }
        })
        .collect();
    let mut s = vec![Vector::<2>::zeros(); r.len()];
    coarse.correct(None, &r, &mut s);
    let top_moved = (0..r.len())
        .filter(|&i| above(i) && s[i] != Vector::<2>::zeros())
        .count();
    let across = (0..r.len())
        .filter(|&i| !above(i) && s[i] != Vector::<2>::zeros())
        .count();
    assert!(top_moved > 0, "the side loaded is corrected");
    assert_eq!(
        across, 0,
        "{across} nodes below the cut moved by a residual above it"
    );
}

/// The notched deck's solver settings.
fn notched_settings() -> QuasiStaticSettings {
    solver_settings(&notched_deck(10).deck)
        .quasi_static
        .unwrap()
}

/// `peridyn check` estimates a quasi-static run from its first two load steps, and the
/// estimate of an elastic run is what the run takes: the iterations within a factor 1.5.
#[test]
fn check_estimates_the_iterations_of_an_elastic_quasi_static_run() {
    let ld = plate_deck(
        4e-6,
        1.0,
        "[solver]\ntype = \"quasi_static\"\nload_steps = 4\ntolerance = 1e-6",
        "",
    );
    let (report, time) = peridyn::run::check_timed(&ld, Some(1)).unwrap();
    let time = time.expect("a quasi-static run is timed");
    let basis = time.quasi_static.expect("with its basis");
    assert_eq!(time.steps, 4);
    let estimated = basis.first + 3.0 * basis.later;
    let shown = time.to_string();
    println!("{shown}");
    assert!(shown.contains("4 load steps"), "{shown}");
    assert!(basis.seconds_per_iteration > 0.0);
    let (mut sim, _) = common::pmb_deck_simulation(&ld).unwrap();
    let settings = solver_settings(&ld.deck).quasi_static.unwrap();
    let mut solver = QuasiStatic::new(&sim, settings, report.dt);
    for k in 1..=4 {
        solver.advance(&mut sim, k as f64 * report.dt).unwrap();
    }
    let taken = solver.iterations as f64;
    println!("estimated {estimated:.0} iterations, taken {taken:.0}");
    assert!(estimated < 1.5 * taken && taken < 1.5 * estimated);
}

#[test]
fn relaxation_agrees_with_the_long_time_limit_of_damped_dynamics() {
    let pull = 4e-6;
    let quasi = solve(&plate_deck(
        pull,
        1.0,
        "[solver]\ntype = \"quasi_static\"\nload_steps = 1\ntolerance = 1e-9",
        "",
    ))
    .unwrap();
    // The same plate, loaded over 50 µs and held, with viscous damping near the lowest mode's
    // critical value, run to rest.
    let explicit = solve(&plate_deck(
        pull,
        50e-6,
        "[solver]\ntype = \"explicit\"\nend_time = 1.5e-3\ndamping = 3e4",
        "",
    ))
    .unwrap();
    let scale = pull;
    let top = explicit.body.node_set("top").unwrap();
    assert!((explicit.state.u[top[0] as usize][1] - pull).abs() < 1e-12 * pull);
    let worst = (0..quasi.body.len())
        .map(|i| (quasi.state.u[i] - explicit.state.u[i]).norm())
        .fold(0.0, f64::max);
    println!(
        "largest difference {worst:.3e} m ({:.3} % of the pull)",
        100.0 * worst / scale
    );
    assert!(worst < 0.01 * scale);
    // Between two equilibria the external work is the strain energy: no kinetic energy, no
    // dissipation. The trapezoidal work of one step is exact for a linear response; the
    // model's geometric nonlinearity at a strain of 1e-4 leaves ~1e-5.
    let (w, es) = (quasi.state.external_work, quasi.strain_energy());
    println!("external work {w:.6e} J, strain energy {es:.6e} J");
    assert!(es > 0.0 && (w - es).abs() < 1e-4 * es);
    assert_eq!(quasi.kinetic_energy(), 0.0);
}

#[test]
fn a_relaxation_that_cannot_converge_names_the_step_and_the_node() {
    let ld = plate_deck(
        4e-6,
        1.0,
        "[solver]\ntype = \"quasi_static\"\nload_steps = 3\nmax_iterations = 5",
        "",
    );
    let err = solve(&ld)
        .err()
        .expect("5 iterations are not enough")
        .to_string();
    println!("{err}");
    assert!(err.contains("did not converge in load step 1"), "{err}");
    assert!(
        err.contains("after 5 ADR iterations") && err.contains("node"),
        "{err}"
    );
}

/// A notched 10 mm × 5 mm PMB plate (Δx = 0.25 mm, δ = 3Δx, s0 = 1e-3) pulled apart by its
/// grip layers over `load_steps`, splitting a step that breaks more than 40 bonds.
fn notched_deck(load_steps: u64) -> LoadedDeck {
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.01, 0.005] }}
spacing = 0.25e-3
horizon_ratio = 3.0

[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
critical_stretch = 1e-3

[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, 0.00425], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.00075] }}

[[precracks]]
type = "segment"
start = [-0.001, 0.0025]
end = [0.003, 0.0025]

[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "y"
value = 0.0
[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "y"
value = 1e-5
time = {{ type = "ramp", duration = 1.0 }}

[solver]
type = "quasi_static"
load_steps = {load_steps}
max_broken_bonds = 40
max_splits = 6
"#
    );
    LoadedDeck::from_str(&text, Path::new("notched.toml")).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn split_load_steps_trace_the_fracture_and_fix_the_peak_load() {
    let mut peaks = Vec::new();
    for load_steps in [10, 40] {
        let ld = notched_deck(load_steps);
        let (mut sim, _) = common::pmb_deck_simulation(&ld).unwrap();
        let settings = solver_settings(&ld.deck).quasi_static.unwrap();
        let nominal = 1.0 / load_steps as f64;
        let mut solver = QuasiStatic::new(&sim, settings, nominal);
        let top = sim.body.node_set("top").unwrap();
        let (mut peak, mut committed, mut split) = (0.0f64, 0, 0);
        for k in 1..=load_steps {
            let target = k as f64 * nominal;
            while sim.state.time < target {
                let broken_before = sim.state.broken;
                let report = solver.advance(&mut sim, target).unwrap();
                committed += 1;
                assert_eq!(sim.state.broken - broken_before, report.broken);
                // A step broke at most 40 bond halves, or was already halved 6 times.
                assert!(
                    report.broken <= 40 || sim.state.dt <= nominal / 64.0 * 1.000001,
                    "{} halves broken in a step of {}",
                    report.broken,
                    sim.state.dt
                );
                if sim.state.dt < nominal * 0.99 {
                    split += 1;
                }
                peak = peak.max(sim.reaction(&top)[1]);
            }
        }
        let final_load = sim.reaction(&top)[1];
        println!(
            "{load_steps} load steps: {committed} committed ({split} split), peak {peak:.4} N, final {final_load:.4} N, {} bonds broken, energy balance {:.3e} J of {:.3e} J work",
            sim.state.broken / 2,
            sim.strain_energy() - sim.state.external_work,
            sim.state.external_work
        );
        assert!(split > 0, "the crack forces split steps");
        // The plate is cut through: the load has dropped to nothing.
        assert!(final_load < 0.02 * peak);
        // The crack dissipated energy: strain energy below the work done.
        assert!(sim.strain_energy() < 0.5 * sim.state.external_work);
        peaks.push(peak);
    }
    let change = (peaks[0] - peaks[1]).abs() / peaks[1];
    println!(
        "peak load change between 10 and 40 load steps: {:.2} %",
        100.0 * change
    );
    assert!(change < 0.05);
}

/// The notched plate of `notched_deck(10)`, pulled twice as far, run whole and with
/// `stop_when_stored_below`: the stopped run ends at the first load step whose equilibrium stores less than 1 % of the work
/// done (the step that cuts the plate: its load falls to nothing), and its history is the
/// whole run's up to there, bit for bit (the stop changes when the run ends, not its path).
#[test]
fn a_run_that_breaks_through_stops_at_the_step_that_cut_it() {
    let run_into = |name: &str, stop: &str| {
        let mut ld = notched_deck(10);
        ld.src = ld
            .src
            .replace("max_splits = 6\n", &format!("max_splits = 6\n{stop}\n"))
            .replace("value = 1e-5", "value = 2e-5");
        ld.deck = LoadedDeck::from_str(&ld.src, Path::new("notched.toml"))
            .unwrap()
            .deck;
        ld.file = std::path::PathBuf::from("notched.toml");
        let out = std::env::temp_dir().join(format!("peridyn-{name}-{}", std::process::id()));
        let options = peridyn::run::RunOptions {
            out_dir: out.clone(),
            threads: None,
            quiet: true,
        };
        let summary = peridyn::run::run(&ld, &options).unwrap();
        let history = std::fs::read_to_string(out.join("history.csv")).unwrap();
        std::fs::remove_dir_all(&out).ok();
        (summary.notes, history)
    };
    let (_, whole) = run_into("whole", "");
    let (notes, stopped) = run_into("stopped", "stop_when_stored_below = 0.01");
    let table = |text: &str| Table::parse(text).unwrap();
    let (whole_rows, stopped_rows) = (table(&whole).rows, table(&stopped).rows);
    let column = |name: &str| table(&whole).column(name).unwrap();
    let (stored, work, load) = (
        column("strain_energy"),
        column("external_work"),
        column("reaction_top_y"),
    );
    let n = stopped_rows.len();
    assert!(
        n < whole_rows.len(),
        "the stop ended the run early ({n} rows)"
    );
    assert!(
        whole.starts_with(&stopped),
        "the stopped history is the whole run's beginning"
    );
    let kept = |r: &Vec<f64>| r[stored] / r[work];
    assert!(kept(&stopped_rows[n - 1]) < 0.01);
    assert!(stopped_rows[1..n - 1].iter().all(|r| kept(r) >= 0.01));
    // The step that stopped it cut the plate: its load fell from the peak to nothing.
    let peak = stopped_rows.iter().map(|r| r[load]).fold(0.0, f64::max);
    let last = stopped_rows[n - 1][load];
    println!("stopped after {n} rows of {}: load {last:.4e} N of a {peak:.4} N peak, {:.2e} of the work stored", whole_rows.len(), kept(&stopped_rows[n - 1]));
    assert!(last < 0.02 * peak);
    assert!(
        notes.iter().any(|n| n.contains("stopped at load time")),
        "{notes:?}"
    );
}

#[test]
fn a_run_records_openings_and_draws_its_history() {
    // Probes in one column of the two grip layers: the opening is the pull.
    let pull = 4e-6;
    let mut ld = plate_deck(
        pull,
        1.0,
        "[solver]\ntype = \"quasi_static\"\nload_steps = 2\ntolerance = 1e-9\n\n[output]\nsnapshots = 0\npng = false\n[[output.openings]]\nname = \"grips\"\nbetween = [[0.01025, 0.00075], [0.01025, 0.03925]]",
        "",
    );
    ld.file = std::path::PathBuf::from("plate.toml");
    let out = std::env::temp_dir().join(format!("peridyn-openings-{}", std::process::id()));
    let summary = peridyn::run::run(
        &ld,
        &peridyn::run::RunOptions {
            out_dir: out.clone(),
            threads: None,
            quiet: true,
        },
    )
    .unwrap();
    let table = peridyn::plot::history_plots::HistoryTable::read(&out.join("history.csv")).unwrap();
    // The summary names the fictitious masses the relaxations used and their iterations,
    // as many as the history's rows add up to.
    let iterations: f64 = table.column("iterations").unwrap().iter().sum();
    let note = "quasi-static: ADR with the spectral masses (Gershgorin's × ";
    let solver = summary.notes.iter().find(|n| n.starts_with(note));
    assert!(
        solver.is_some_and(|n| n.ends_with(&format!(", {iterations} iterations"))),
        "{:?}",
        summary.notes
    );
    let opening = table.column("opening_grips").expect("an opening column");
    let last = *opening.last().unwrap();
    println!("opening of the grips {last:.6e} m for a pull of {pull:e} m");
    assert!((last - pull).abs() < 1e-3 * pull);
    assert_eq!(opening[0], 0.0);
    for plot in [
        "energies",
        "load_displacement_top",
        "load_displacement_bottom",
        "openings",
        "time_step",
        "broken_bonds",
    ] {
        assert!(
            out.join("plots").join(format!("{plot}.png")).exists(),
            "{plot}"
        );
    }
    std::fs::remove_dir_all(&out).ok();
}

/// The work each bond of an LPS plate with the critical-energy law (too tough to break) has
/// recorded after one quasi-static load step that moves its bottom grip layer to `bottom` and
/// its top one to `top` (m, in y); the equilibrium tolerance is tight (1e-9).
fn preload_works(bottom: f64, top: f64, method: &str) -> Vec<f64> {
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.01, 0.005] }}
spacing = 0.25e-3
horizon_ratio = 3.0

[material]
type = "lps"
density = 1000.0
youngs_modulus = 1e9
poisson_ratio = 0.3
fracture_energy = 1e9
damage = {{ type = "critical_energy" }}

[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, 0.00425], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.00075] }}

[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "y"
value = {bottom:e}
time = {{ type = "ramp", duration = 1.0 }}
[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "y"
value = {top:e}
time = {{ type = "ramp", duration = 1.0 }}

[solver]
type = "quasi_static"
method = "{method}"
load_steps = 1
tolerance = 1e-9
"#
    );
    let ld =
        LoadedDeck::from_str(&text, Path::new("preload.toml")).unwrap_or_else(|e| panic!("{e}"));
    let (mut sim, report) = common::lps_deck_simulation(&ld).unwrap();
    let qs = solver_settings(&ld.deck).quasi_static.unwrap();
    drive_quasi_static(&mut sim, qs, report.steps, &mut []).unwrap();
    let words = sim.state.history.len() / sim.bonds.len();
    sim.state.history.iter().step_by(words).copied().collect()
}

/// The work a bond has taken in a quasi-static load step is that of the equilibrium path,
/// not of the relaxation's iterates: holding the bottom grip and moving the top one by 2u
/// gives the same strains as moving both by ∓u (a rigid translation apart), so every bond's
/// work must agree. An LPS bond's force depends on both ends' dilatation, so the work along
/// the relaxation's oscillations (or NCG's trial points) is path-dependent; recorded there it
/// made the one-grip preload break bonds along its grip that the two-grip one did not.
#[test]
fn a_quasi_static_step_records_the_work_of_the_equilibrium_path() {
    let u = 2e-6; // a strain of 8e-4
    for method in ["adr", "ncg"] {
        let one_grip = preload_works(0.0, 2.0 * u, method);
        let two_grips = preload_works(-u, u, method);
        let largest = two_grips.iter().copied().fold(0.0, f64::max);
        assert!(largest > 0.0);
        let differs = one_grip
            .iter()
            .zip(&two_grips)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            differs < 1e-5 * largest,
            "{method}: bond works differ by {:.3e} of the largest",
            differs / largest
        );
    }
}
