//! Throughput benchmark of the force loop plus integration for every model and damage law,
//! 2D and 3D, at δ/Δx = 3, single- and multi-threaded, best of three repetitions.
//! `peridyn bench` prints the table; `--cases` picks rows. The quasi-static cases (issue 7)
//! time one elastic load step of a plate in tension to equilibrium with each method.

use crate::body::Body;
use crate::bonds::{search::build_bonds, Bonds, PartialVolume};
use crate::damage::mixed::BlockLaw;
use crate::damage::softening::{Shape as SofteningShape, SofteningParameters};
use crate::damage::{CriticalEnergy, CriticalStretch, Damage, MixedDamage, PerNode, Softening};
use crate::discretize::lattice::lattice;
use crate::geometry::Shape;
use crate::loading::{BoundaryCondition, Kinematic, Loading, TimeFunction};
use crate::material::correspondence::ZeroEnergyControl;
use crate::material::mixed::BlockMaterial;
use crate::material::{
    Correspondence, Dimensionality, Elasticity, Influence, Lps, Material, MicromodulusProfile,
    Mixed, Pmb,
};
use crate::math::Vector;
use crate::solver::{EquilibriumMethod, QuasiStatic, QuasiStaticSettings, Simulation};
use std::time::Instant;

/// One measured case.
#[derive(Debug, Clone)]
pub struct BenchResult {
    pub case: String,
    pub threads: usize,
    pub nodes: usize,
    pub bonds_per_node: f64,
    pub node_steps_per_second: f64,
    pub bond_evaluations_per_second: f64,
    pub bytes_per_bond: f64,
}

/// The cases, in table order: model, damage law, dimension (and "-nopv": no partial-volume
/// band, the ~122 bonds per node of δ/Δx = 3 that other codes quote; "-dh": the right half
/// with a 2δ horizon; "-mixed": PMB left, LPS right; "-contact": node–node contact with the
/// deck's defaults, "-idle" with no node near another, "-dense" every bond broken and the
/// block compressed so every node touches its nearest neighbours, else a crack across the
/// block whose faces are pressed together, `arrange`; "-fragments": the dense arrangement
/// without contact, the baseline that isolates the contact pass's own cost; "-corrected": the
/// energy surface correction, a micromodulus per node).
pub const CASES: [&str; 24] = [
    "pmb-2d",
    "pmb-corrected-2d",
    "lps-2d",
    "correspondence-2d",
    "pmb-bilinear-2d",
    "pmb-energy-2d",
    "lps-energy-2d",
    "correspondence-energy-2d",
    "pmb-dh-2d",
    "mixed-2d",
    "pmb-3d",
    "pmb-corrected-3d",
    "lps-3d",
    "correspondence-3d",
    "pmb-bilinear-3d",
    "pmb-energy-3d",
    "lps-energy-3d",
    "correspondence-energy-3d",
    "pmb-3d-nopv",
    "mixed-3d",
    "pmb-contact-idle-2d",
    "pmb-contact-2d",
    "pmb-contact-dense-2d",
    "pmb-fragments-2d",
];

const E: f64 = 70e9;
const RHO: f64 = 2500.0;
const DX: f64 = 1e-3;
const THICKNESS: f64 = 1e-3;

/// A lattice block with about `target_bonds` directed bonds at δ/Δx = 3; with `dual`, the
/// nodes right of the middle get a horizon twice as large.
fn block<const D: usize>(target_bonds: usize, rule: PartialVolume, dual: bool) -> (Body<D>, Bonds) {
    let per_node = if D == 3 { 122.0 } else { 28.0 } * if dual { 2.5 } else { 1.0 };
    let nodes = (target_bonds as f64 / per_node).max(1000.0);
    let side = nodes.powf(1.0 / D as f64).ceil() * DX;
    let shape = Shape::cube(D, side);
    let cloud = lattice(&shape, D, DX, THICKNESS).expect("benchmark lattice");
    let mut body = Body::<D>::from_cloud(cloud, 3.0 * DX, THICKNESS);
    if dual {
        for i in 0..body.len() {
            if body.positions[i][0] > 0.5 * side {
                body.horizons[i] = 6.0 * DX;
            }
        }
    }
    let bonds = build_bonds(&body, rule, &[]);
    (body, bonds)
}

fn measure<const D: usize, M: Material<D>>(
    case: &str,
    model: (Body<D>, Bonds, PartialVolume),
    material: M,
    damage: Damage,
    steps: u64,
    threads: usize,
) -> BenchResult {
    measure_with(case, model, (material, damage), steps, threads, |_| {})
}

/// `measure`, with `setup` run on the simulation before the warm-up step.
fn measure_with<const D: usize, M: Material<D>>(
    case: &str,
    (body, bonds, rule): (Body<D>, Bonds, PartialVolume),
    (material, damage): (M, Damage),
    steps: u64,
    threads: usize,
    setup: impl FnOnce(&mut Simulation<D, M>) + Send,
) -> BenchResult {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        let history = damage.bytes_per_bond(crate::solver::bond_force::<D, M>());
        let mut sim = Simulation::new(
            body,
            bonds,
            material,
            damage,
            rule,
            Loading::default(),
            None,
            0.8,
        )
        .expect("benchmark model");
        // A small deterministic velocity field so the loop does real work.
        for (i, v) in sim.state.v.iter_mut().enumerate() {
            v[0] = 1e-3 * ((i % 7) as f64 - 3.0);
        }
        setup(&mut sim);
        sim.step().expect("warm-up step");
        // Best of three repetitions: the machine's noise only ever slows a run down.
        let secs = (0..3)
            .map(|_| {
                let started = Instant::now();
                for _ in 0..steps {
                    sim.step().expect("bench step");
                }
                started.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        let n = sim.body.len();
        let nb = sim.bonds.len();
        let evals = if M::NEEDS_PREPASS { 2 } else { 1 } as f64;
        BenchResult {
            case: case.to_string(),
            threads,
            nodes: n,
            bonds_per_node: nb as f64 / n as f64,
            node_steps_per_second: n as f64 * steps as f64 / secs,
            bond_evaluations_per_second: evals * nb as f64 * steps as f64 / secs,
            bytes_per_bond: (Bonds::BYTES_PER_BOND + sim.engine.quad.bytes_per_bond() + history)
                as f64,
        }
    })
}

fn dim_of<const D: usize>() -> Dimensionality {
    if D == 2 {
        Dimensionality::PlaneStress
    } else {
        Dimensionality::ThreeD
    }
}

fn pmb<const D: usize>() -> Pmb {
    let dim = dim_of::<D>();
    Pmb::calibrated(
        E,
        RHO,
        dim,
        MicromodulusProfile::Constant,
        3.0 * DX,
        THICKNESS,
    )
}

fn elasticity<const D: usize>() -> Elasticity {
    Elasticity {
        youngs_modulus: E,
        poisson_ratio: 0.3,
        dimensionality: dim_of::<D>(),
    }
}

fn lps<const D: usize>() -> Lps {
    Lps::new(
        elasticity::<D>(),
        Influence::Constant,
        3.0 * DX,
        RHO,
        THICKNESS,
    )
}

fn correspondence<const D: usize>() -> Correspondence {
    Correspondence::new(
        elasticity::<D>(),
        Influence::Constant,
        ZeroEnergyControl::Wan { coefficient: 1.0 },
        3.0 * DX,
        RHO,
        THICKNESS,
    )
}

/// Damage laws with thresholds no bond reaches (the cost of the law, not of fracture).
fn stretch() -> Damage {
    CriticalStretch::new(1.0).into()
}
fn energy() -> Damage {
    CriticalEnergy {
        wc: PerNode::Uniform(f64::MAX),
        tension_only: false,
    }
    .into()
}
fn bilinear() -> Damage {
    Softening::uniform(
        SofteningShape::Bilinear,
        SofteningParameters::bilinear(1e-6, 1.0).expect("bench parameters"),
    )
    .into()
}

/// One case in dimension D.
fn case<const D: usize>(name: &str, target: usize, steps: u64, threads: usize) -> BenchResult {
    let rule = if name.ends_with("nopv") {
        PartialVolume::None
    } else {
        PartialVolume::Hhb
    };
    let (body, bonds) = block::<D>(target, rule, name.contains("-dh"));
    let model = (body, bonds, rule);
    match name.split('-').next().unwrap_or_default() {
        "lps" if name.contains("energy") => {
            measure(name, model, lps::<D>(), energy(), steps, threads)
        }
        "lps" => measure(name, model, lps::<D>(), stretch(), steps, threads),
        "correspondence" if name.contains("energy") => {
            measure(name, model, correspondence::<D>(), energy(), steps, threads)
        }
        "correspondence" => measure(
            name,
            model,
            correspondence::<D>(),
            stretch(),
            steps,
            threads,
        ),
        "mixed" => {
            let side = model.0.positions.iter().map(|p| p[0]).fold(0.0, f64::max);
            let of: Vec<u16> = (0..model.0.len())
                .map(|i| (model.0.positions[i][0] > 0.5 * side) as u16)
                .collect();
            let mixed = Mixed {
                materials: vec![
                    BlockMaterial::Pmb(pmb::<D>()),
                    BlockMaterial::Lps(lps::<D>()),
                ],
                material_of: of.clone(),
            };
            let laws = MixedDamage {
                laws: vec![
                    BlockLaw::CriticalStretch(CriticalStretch::new(1.0)),
                    BlockLaw::CriticalStretch(CriticalStretch::new(1.0)),
                ],
                law_of: of,
            };
            let mixed = mixed.into_central().expect("PMB and LPS blocks");
            measure(name, model, mixed, laws.into(), steps, threads)
        }
        _ if name.contains("-contact") || name.contains("-fragments") => {
            let touching = if name.contains("idle") {
                Touching::Nothing
            } else if name.contains("dense") || name.contains("fragments") {
                Touching::Everything
            } else {
                Touching::PressedCut
            };
            let setup = |sim: &mut Simulation<D, Pmb>| {
                if name.contains("-contact") {
                    enable_contact(sim);
                }
                arrange(sim, touching);
            };
            measure_with(name, model, (pmb::<D>(), stretch()), steps, threads, setup)
        }
        _ if name.contains("-corrected") => {
            use crate::material::surface_correction::{
                corrected, surface_factors, SurfaceCorrection,
            };
            let (body, bonds, rule) = &model;
            let quad = crate::bonds::Quadrature::for_body(*rule, body, bonds);
            let method = SurfaceCorrection::Energy;
            let factors = surface_factors(method, body, bonds, &quad, &pmb::<D>(), None)
                .expect("one-pass factors")
                .expect("a method");
            let m = corrected(pmb::<D>(), &factors.factors);
            measure(name, model, m, stretch(), steps, threads)
        }
        _ => {
            let horizons = model.0.horizons.clone();
            let m = pmb::<D>().with_horizons(&horizons);
            let d = if name.contains("bilinear") {
                bilinear()
            } else if name.contains("energy") {
                energy()
            } else {
                stretch()
            };
            measure(name, model, m, d, steps, threads)
        }
    }
}

/// What touches in a contact case.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Touching {
    /// The intact block at rest: no node within r_c of another.
    Nothing,
    /// The block cut across its middle (every bond crossing y = mid broken) and its upper half
    /// moved down by 0.2Δx, a rigid shift: the rows facing each other across the cut are 0.8Δx
    /// apart, within r_c, while no bond is strained (a closed crack's faces).
    PressedCut,
    /// Every bond broken (a heap of fragments) and the block compressed by 20 % about its
    /// centre: each node is 0.8Δx from its 2D nearest neighbours (in contact) and 1.13Δx from
    /// its diagonal ones (candidates within r_c + skin, not in contact). The outer three rows
    /// are held at rest (a confined heap, in equilibrium inside): a free heap would burst, and
    /// its list be rebuilt at every step, which measures the burst, not contact.
    Everything,
}

/// Turns on node–node contact with the deck's defaults (r_c = 0.9Δx, c_s = 15c, skin 0.3Δx).
fn enable_contact<const D: usize>(sim: &mut Simulation<D, Pmb>) {
    use crate::deck::contact::{micromodulus, Scales, RADIUS_FACTOR, SKIN_FACTOR};
    use crate::solver::contact::{ContactSettings, NodeContact};
    let scales = Scales {
        spacing: DX,
        horizon: 3.0 * DX,
        volume: sim.body.total_volume() / sim.body.len() as f64,
        thickness: sim.body.thickness,
        elasticity: elasticity::<D>(),
    };
    sim.contact = Some(NodeContact::new(ContactSettings {
        radius: RADIUS_FACTOR * DX,
        stiffness: crate::deck::contact::STIFFNESS_FACTOR * micromodulus(D, &scales),
        horizon: 3.0 * DX,
        skin: SKIN_FACTOR * DX,
    }));
}

/// Arranges the block as `touching` says and computes the forces there.
fn arrange<const D: usize>(sim: &mut Simulation<D, Pmb>, touching: Touching) {
    match touching {
        Touching::Nothing => {}
        Touching::PressedCut => {
            let top = sim.body.positions.iter().map(|p| p[1]).fold(0.0, f64::max);
            let mid = 0.5 * (top + 0.5 * DX);
            let above = |i: usize| sim.body.positions[i][1] > mid;
            for i in 0..sim.body.len() {
                for b in sim.bonds.family(i) {
                    if above(i) != above(sim.bonds.neighbors[b] as usize) {
                        sim.state.status[b] = crate::state::BROKEN;
                    }
                }
            }
            for i in (0..sim.body.len()).filter(|&i| above(i)) {
                sim.state.u[i][1] -= 0.2 * DX;
                sim.state.current[i] = sim.body.positions[i] + sim.state.u[i];
            }
        }
        Touching::Everything => {
            sim.state.status.fill(crate::state::BROKEN);
            let n = sim.body.len() as f64;
            let centre = sim
                .body
                .positions
                .iter()
                .fold(Vector::<D>::zeros(), |c, p| c + p)
                / n;
            for i in 0..sim.body.len() {
                sim.state.u[i] = (centre - sim.body.positions[i]) * 0.2;
                sim.state.current[i] = sim.body.positions[i] + sim.state.u[i];
            }
            let (lo, hi) = sim.body.positions.iter().fold(
                (
                    Vector::<D>::repeat(f64::INFINITY),
                    Vector::<D>::repeat(f64::NEG_INFINITY),
                ),
                |(lo, hi), p| (lo.inf(p), hi.sup(p)),
            );
            let border: Vec<u32> = (0..sim.body.len())
                .filter(|&i| {
                    let p = sim.body.positions[i];
                    (0..D).any(|k| p[k] < lo[k] + 2.5 * DX || p[k] > hi[k] - 2.5 * DX)
                })
                .map(|i| i as u32)
                .collect();
            for i in &border {
                sim.state.v[*i as usize] = Vector::<D>::zeros();
            }
            for component in 0..D {
                sim.loading.conditions.push(BoundaryCondition {
                    set: "border".into(),
                    nodes: border.clone(),
                    kind: Kinematic::Velocity,
                    component,
                    value: 0.0,
                    time: TimeFunction::Constant,
                    offsets: Vec::new(),
                });
            }
        }
    }
    sim.refresh_forces().expect("contact forces");
}

/// Runs the chosen cases (all when `only` is empty) and prints a table; returns the results.
pub fn run_benchmarks(
    target_bonds: usize,
    steps: u64,
    threads: &[usize],
    only: &[String],
) -> Result<Vec<BenchResult>, String> {
    if only.iter().any(|c| c == "list") {
        for case in CASES.iter().chain(&SOLVER_CASES).chain(&GRID_CASES) {
            println!("{case}");
        }
        return Ok(Vec::new());
    }
    if let Some(bad) = only.iter().find(|c| {
        let c = c.as_str();
        !CASES.contains(&c) && !SOLVER_CASES.contains(&c) && !GRID_CASES.contains(&c)
    }) {
        return Err(format!(
            "unknown benchmark case {bad:?}; cases: {}, {}, {}",
            CASES.join(", "),
            SOLVER_CASES.join(", "),
            GRID_CASES.join(", ")
        ));
    }
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let threads: Vec<usize> = if threads.is_empty() {
        if cores > 1 {
            vec![1, cores]
        } else {
            vec![1]
        }
    } else {
        threads.to_vec()
    };
    let mut results = Vec::new();
    let wanted = |c: &str| only.is_empty() || only.iter().any(|o| o == c);
    let forces: Vec<&str> = CASES.into_iter().filter(|c| wanted(c)).collect();
    if !forces.is_empty() {
        println!(
            "{:<26} {:>7} {:>9} {:>10} {:>16} {:>18} {:>10}",
            "case", "threads", "nodes", "bonds/node", "node-steps/s", "bond-evals/s", "bytes/bond"
        );
        for &t in &threads {
            for &name in &forces {
                let r = if name.ends_with("2d") {
                    case::<2>(name, target_bonds, steps, t)
                } else {
                    case::<3>(name, target_bonds, steps, t)
                };
                println!(
                    "{:<26} {:>7} {:>9} {:>10.1} {:>16.3e} {:>18.3e} {:>10.0}",
                    r.case,
                    r.threads,
                    r.nodes,
                    r.bonds_per_node,
                    r.node_steps_per_second,
                    r.bond_evaluations_per_second,
                    r.bytes_per_bond
                );
                results.push(r);
            }
        }
    }
    // Opt-in: a relaxation at the default size takes tens of seconds, three times over.
    let solvers: Vec<&str> = SOLVER_CASES
        .into_iter()
        .filter(|c| only.iter().any(|o| o == c))
        .collect();
    if !solvers.is_empty() {
        println!(
            "\n{:<10} {:>7} {:>9} {:>10} {:>11} {:>9} {:>13} {:>18}",
            "solver",
            "threads",
            "nodes",
            "bonds/node",
            "iterations",
            "seconds",
            "iterations/s",
            "node-iterations/s"
        );
        for &t in &threads {
            for &name in &solvers {
                let r = solver_case(name, target_bonds, t);
                println!(
                    "{:<10} {:>7} {:>9} {:>10.1} {:>11} {:>9.3} {:>13.1} {:>18.3e}",
                    r.case,
                    r.threads,
                    r.nodes,
                    r.bonds_per_node,
                    r.iterations,
                    r.seconds,
                    r.iterations as f64 / r.seconds,
                    r.nodes as f64 * r.iterations as f64 / r.seconds
                );
            }
        }
    }
    let grids: Vec<&str> = GRID_CASES
        .into_iter()
        .filter(|c| only.is_empty() || only.iter().any(|o| o == c))
        .collect();
    if !grids.is_empty() {
        println!(
            "\n{:<20} {:>9} {:>12} {:>12} {:>14} {:>14} {:>12}",
            "grid", "nodes", "generate s", "bonds s", "100 steps s", "MB grid+bonds", "gen/100 st"
        );
        for name in grids {
            let g = grid_case(name);
            println!(
                "{:<20} {:>9} {:>12.3} {:>12.3} {:>14.2} {:>14.0} {:>12.3}",
                g.case,
                g.nodes,
                g.generate_seconds,
                g.bonds_seconds,
                g.hundred_steps_seconds,
                g.bytes as f64 / 1e6,
                g.generate_seconds / g.hundred_steps_seconds
            );
        }
    }
    Ok(results)
}

/// Quasi-static equilibrium cases (issue 7): one elastic load step of a square PMB plate
/// (plane stress, δ = 3Δx, the size of the force cases) whose top three rows are pulled up by
/// a strain of 1e-4 over the bottom three, held, relaxed to the default relative residual 1e-6
/// by adaptive dynamic relaxation or nonlinear conjugate gradients. Measured only when named
/// in `--cases`.
pub const SOLVER_CASES: [&str; 2] = ["adr-2d", "ncg-2d"];

/// One measured equilibrium: iterations (ADR) or force evaluations (NCG) to converge, and the
/// best of three wall times of the whole load step.
#[derive(Debug, Clone)]
pub struct SolverBench {
    pub case: String,
    pub threads: usize,
    pub nodes: usize,
    pub bonds_per_node: f64,
    pub iterations: u64,
    pub seconds: f64,
}

/// Measures one quasi-static case on `threads` threads.
pub fn solver_case(name: &str, target_bonds: usize, threads: usize) -> SolverBench {
    let method = if name == "ncg-2d" {
        EquilibriumMethod::Ncg
    } else {
        EquilibriumMethod::Adr
    };
    let (body, bonds) = block::<2>(target_bonds, PartialVolume::Hhb, false);
    let side = body.positions.iter().map(|p| p[1]).fold(0.0, f64::max) + 0.5 * DX;
    let rows = |keep: &dyn Fn(f64) -> bool| -> Vec<u32> {
        (0..body.len() as u32)
            .filter(|&i| keep(body.positions[i as usize][1]))
            .collect()
    };
    let top = rows(&|y| y > side - 3.0 * DX);
    let bottom = rows(&|y| y < 3.0 * DX);
    let condition = |set: &str, nodes: Vec<u32>, value: f64| BoundaryCondition {
        set: set.to_string(),
        nodes,
        kind: Kinematic::Displacement,
        component: 1,
        value,
        time: TimeFunction::Ramp { duration: 1.0 },
        offsets: Vec::new(),
    };
    let loading = Loading::<2> {
        conditions: vec![
            condition("bottom", bottom, 0.0),
            condition("top", top, 1e-4 * side),
        ],
        ..Default::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        let mut sim = Simulation::new(
            body,
            bonds,
            pmb::<2>(),
            Damage::none(),
            PartialVolume::Hhb,
            loading,
            Some(1.0),
            1.0,
        )
        .expect("benchmark model");
        let settings = QuasiStaticSettings {
            method,
            ..Default::default()
        };
        let initial = sim.state.clone();
        let (mut iterations, mut seconds) = (0, f64::INFINITY);
        for _ in 0..3 {
            sim.state = initial.clone();
            let started = Instant::now();
            let mut solver = QuasiStatic::new(&sim, settings.clone(), 1.0);
            let report = solver.advance(&mut sim, 1.0).expect("benchmark relaxation");
            seconds = seconds.min(started.elapsed().as_secs_f64());
            iterations = report.iterations;
        }
        SolverBench {
            case: name.to_string(),
            threads,
            nodes: sim.body.len(),
            bonds_per_node: sim.bonds.len() as f64 / sim.body.len() as f64,
            iterations,
            seconds,
        }
    })
}

/// Grid generation cases (issue 6): 10⁶ nodes of seed 000's NB-NUG around 20 holes, and a
/// 3D lattice with two levels of multi-grid refinement (three cell sizes) in its centre.
pub const GRID_CASES: [&str; 2] = ["grid-nbnug-2d", "grid-multigrid-3d"];

/// One measured grid: generation, bond search, and 100 PMB steps on all cores (5 steps
/// measured, best of three), with the memory of nodes and bonds.
#[derive(Debug, Clone)]
pub struct GridBench {
    pub case: String,
    pub nodes: usize,
    pub generate_seconds: f64,
    pub bonds_seconds: f64,
    pub hundred_steps_seconds: f64,
    pub bytes: usize,
}

fn grid_case(name: &str) -> GridBench {
    let started = Instant::now();
    if name == "grid-nbnug-2d" {
        // A 100 mm square, Δx = 0.1 mm, 5 × 4 holes of R = 2 mm (boxes of 2(R + δ)).
        let size = 1e-4;
        let holes: Vec<Shape> = (0..20)
            .map(|k| Shape::Disk {
                center: [
                    0.01 + 0.02 * (k % 5) as f64,
                    0.0125 + 0.025 * (k / 5) as f64,
                ],
                radius: 2e-3,
            })
            .collect();
        let shape = Shape::Difference {
            base: Box::new(Shape::Rectangle {
                min: [0.0, 0.0],
                max: [0.1, 0.1],
            }),
            subtract: holes,
        };
        let cloud = crate::deck::grids::nbnug_grid(
            &shape,
            size,
            3.0 * size,
            THICKNESS,
            crate::deck::schema::CellKind::QuadDominant,
            &[],
        )
        .expect("benchmark NB-NUG");
        let generate = started.elapsed().as_secs_f64();
        let body = Body::<2>::from_cloud(cloud, 3.0 * size, THICKNESS);
        grid_steps(name, body, generate)
    } else {
        // A 60 mm cube of Δx = 1 mm refined twice (Δx/4) in its central 22 mm cube.
        let shape = Shape::cube(3, 0.06);
        let centre = Shape::Box {
            min: [0.019, 0.019, 0.019],
            max: [0.041, 0.041, 0.041],
        };
        let cloud = crate::discretize::multigrid::multigrid(
            &shape,
            3,
            DX,
            1.0,
            &[crate::discretize::multigrid::Refinement {
                region: centre,
                level: 2,
            }],
        )
        .expect("benchmark multi-grid");
        let generate = started.elapsed().as_secs_f64();
        let mut body = Body::<3>::from_cloud(cloud, 3.0 * DX, 1.0);
        for i in 0..body.len() {
            body.horizons[i] = 3.0 * body.cell_sizes[i];
        }
        grid_steps(name, body, generate)
    }
}

/// Bond search and steps of a PMB model (each node's micromodulus at its own horizon).
fn grid_steps<const D: usize>(name: &str, body: Body<D>, generate_seconds: f64) -> GridBench {
    let started = Instant::now();
    let bonds = build_bonds(&body, PartialVolume::Hhb, &[]);
    let bonds_seconds = started.elapsed().as_secs_f64();
    let bytes =
        body.len() * crate::memory::bytes_per_node(D, 0) + bonds.len() * Bonds::BYTES_PER_BOND;
    let h = body.horizons[0];
    let material = Pmb::calibrated(
        E,
        RHO,
        dim_of::<D>(),
        MicromodulusProfile::Constant,
        h,
        THICKNESS,
    )
    .with_horizons(&body.horizons);
    let nodes = body.len();
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let r = measure(
        name,
        (body, bonds, PartialVolume::Hhb),
        material,
        stretch(),
        5,
        cores,
    );
    GridBench {
        case: name.to_string(),
        nodes,
        generate_seconds,
        bonds_seconds,
        hundred_steps_seconds: 100.0 * nodes as f64 / r.node_steps_per_second,
        bytes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn list_names_the_cases_without_measuring() {
        let listed = run_benchmarks(1000, 1, &[1], &["list".to_string()]).unwrap();
        assert!(listed.is_empty());
        let err = run_benchmarks(1000, 1, &[1], &["nope".to_string()]).unwrap_err();
        assert!(err.contains("pmb-3d") && err.contains("ncg-2d"), "{err}");
    }

    /// The pressed cut has its faces in contact and no bond strained; idle, nothing touches;
    /// dense, every node pushes on its four nearest neighbours.
    #[test]
    fn the_contact_cases_press_a_cut_or_touch_nothing_or_everything() {
        for touching in [
            Touching::Nothing,
            Touching::PressedCut,
            Touching::Everything,
        ] {
            let (body, bonds) = block::<2>(30_000, PartialVolume::Hhb, false);
            let loading = Loading::default();
            let rule = PartialVolume::Hhb;
            let mut sim =
                Simulation::new(body, bonds, pmb::<2>(), stretch(), rule, loading, None, 0.8)
                    .unwrap();
            enable_contact(&mut sim);
            arrange(&mut sim, touching);
            let energy = sim.contact.as_ref().unwrap().energy;
            assert_eq!(
                energy > 0.0,
                touching != Touching::Nothing,
                "contact energy {energy}"
            );
            assert!(sim.strain_energy() < 1e-12 * energy.max(1e-30) + 1e-30);
            if touching == Touching::Everything {
                // Every node but the block's edges has 4 neighbours in contact and 8
                // candidates: the energy is that of 2 pairs per node at overlap 0.1Δx.
                let c = sim.contact.as_ref().unwrap();
                let n = sim.body.len();
                assert!(
                    c.candidates() > 7 * n && c.candidates() <= 8 * n,
                    "{}",
                    c.candidates()
                );
                let v = sim.body.volumes[0];
                let overlap = 0.1 * DX;
                let per_pair =
                    0.5 * c.settings.stiffness * v * v * overlap * overlap / c.settings.horizon;
                let pairs = energy / per_pair;
                assert!(
                    pairs > 1.9 * n as f64 && pairs <= 2.0 * n as f64,
                    "{pairs} pairs for {n} nodes"
                );
            }
        }
        let r = case::<2>("pmb-contact-2d", 30_000, 2, 1);
        assert!(r.node_steps_per_second > 0.0);
    }

    #[test]
    fn a_small_plate_relaxes_with_both_methods() {
        for case in SOLVER_CASES {
            let r = solver_case(case, 30_000, 1);
            assert!(
                r.nodes >= 1000 && r.iterations > 0 && r.seconds > 0.0,
                "{r:?}"
            );
        }
    }
}
