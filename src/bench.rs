//! Throughput benchmark of the force loop plus integration: PMB and LPS, 2D and 3D, at
//! δ/Δx = 3, single- and multi-threaded, best of three repetitions. `peridyn bench` prints
//! the table.

use crate::body::Body;
use crate::bonds::{search::build_bonds, Bonds, PartialVolume};
use crate::damage::CriticalStretch;
use crate::discretize::lattice::lattice;
use crate::geometry::Shape;
use crate::loading::Loading;
use crate::material::{
    Dimensionality, Elasticity, Influence, Lps, Material, MicromodulusProfile, Pmb,
};
use crate::solver::Simulation;
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

/// A lattice block with about `target_bonds` directed bonds at δ/Δx = 3.
fn block<const D: usize>(target_bonds: usize, rule: PartialVolume) -> (Body<D>, Bonds, f64) {
    let dx = 1e-3;
    let per_node = if D == 3 { 122.0 } else { 28.0 };
    let nodes = (target_bonds as f64 / per_node).max(1000.0);
    let side = nodes.powf(1.0 / D as f64).ceil() * dx;
    let shape = Shape::cube(D, side);
    let cloud = lattice(&shape, D, dx, 1e-3).expect("benchmark lattice");
    let body = Body::<D>::from_cloud(cloud, 3.0 * dx, 1e-3);
    let bonds = build_bonds(&body, rule, &[]);
    (body, bonds, 3.0 * dx)
}

fn measure<const D: usize, M: Material<D>>(
    case: &str,
    (body, bonds, rule): (Body<D>, Bonds, PartialVolume),
    material: M,
    steps: u64,
    threads: usize,
) -> BenchResult {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        let mut sim = Simulation::new(
            body,
            bonds,
            material,
            CriticalStretch::never(),
            rule,
            Loading::default(),
            None,
            0.8,
        )
        .expect("benchmark model");
        // A small random-free initial velocity field so the loop does real work.
        for (i, v) in sim.state.v.iter_mut().enumerate() {
            v[0] = 1e-3 * ((i % 7) as f64 - 3.0);
        }
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
            bytes_per_bond: Bonds::BYTES_PER_BOND as f64,
        }
    })
}

fn pmb<const D: usize>(dim: Dimensionality, horizon: f64) -> Pmb {
    Pmb::calibrated(
        70e9,
        2500.0,
        dim,
        MicromodulusProfile::Constant,
        horizon,
        1e-3,
    )
}

fn lps(dim: Dimensionality, horizon: f64) -> Lps {
    Lps::new(
        Elasticity {
            youngs_modulus: 70e9,
            poisson_ratio: 0.3,
            dimensionality: dim,
        },
        Influence::Constant,
        horizon,
        2500.0,
        1e-3,
    )
}

/// Runs every case and prints a table; returns the results.
pub fn run_benchmarks(
    target_bonds: usize,
    steps: u64,
    threads: &[usize],
    only: &[String],
) -> Result<Vec<BenchResult>, String> {
    const CASES: [&str; 5] = ["pmb-2d", "lps-2d", "pmb-3d", "lps-3d", "pmb-3d-nopv"];
    if let Some(bad) = only.iter().find(|c| !CASES.contains(&c.as_str())) {
        return Err(format!(
            "unknown benchmark case {bad:?}; cases: {}",
            CASES.join(", ")
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
    println!(
        "{:<10} {:>7} {:>9} {:>10} {:>16} {:>18} {:>14}",
        "case", "threads", "nodes", "bonds/node", "node-steps/s", "bond-evals/s", "bytes/bond"
    );
    for &t in &threads {
        for case in CASES
            .into_iter()
            .filter(|c| only.is_empty() || only.iter().any(|o| o == c))
        {
            // "-nopv": whole volumes inside δ only (no partial-volume band), the ~122 bonds per
            // node of δ/Δx = 3 that other codes quote.
            let rule = if case.ends_with("nopv") {
                PartialVolume::None
            } else {
                PartialVolume::Hhb
            };
            let r = match case {
                "pmb-2d" => {
                    let (b, bo, h) = block::<2>(target_bonds, rule);
                    measure(
                        case,
                        (b, bo, rule),
                        pmb::<2>(Dimensionality::PlaneStress, h),
                        steps,
                        t,
                    )
                }
                "lps-2d" => {
                    let (b, bo, h) = block::<2>(target_bonds, rule);
                    measure(
                        case,
                        (b, bo, rule),
                        lps(Dimensionality::PlaneStress, h),
                        steps,
                        t,
                    )
                }
                "lps-3d" => {
                    let (b, bo, h) = block::<3>(target_bonds, rule);
                    measure(
                        case,
                        (b, bo, rule),
                        lps(Dimensionality::ThreeD, h),
                        steps,
                        t,
                    )
                }
                _ => {
                    let (b, bo, h) = block::<3>(target_bonds, rule);
                    measure(
                        case,
                        (b, bo, rule),
                        pmb::<3>(Dimensionality::ThreeD, h),
                        steps,
                        t,
                    )
                }
            };
            println!(
                "{:<10} {:>7} {:>9} {:>10.1} {:>16.3e} {:>18.3e} {:>14.0}",
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
    Ok(results)
}
