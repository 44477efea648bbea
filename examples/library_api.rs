//! Everything a deck says, built from Rust code: a pre-notched plate pulled at its top and
//! bottom edges, run with the standard outputs (history CSV, VTU series, damage PNGs).
//!
//!     cargo run --release --example library_api -- [output-folder]

use peridyn::body::Body;
use peridyn::bonds::{search::build_bonds, PartialVolume, Precrack};
use peridyn::damage::CriticalStretch;
use peridyn::deck::schema::OutputDeck;
use peridyn::discretize::lattice::lattice;
use peridyn::geometry::Shape;
use peridyn::loading::{BoundaryCondition, Kinematic, Loading, TimeFunction};
use peridyn::material::{Dimensionality, MicromodulusProfile, Pmb};
use peridyn::observe::history::History;
use peridyn::observe::progress::Progress;
use peridyn::observe::snapshots::Snapshots;
use peridyn::observe::Observer;
use peridyn::run::drive;
use peridyn::solver::Simulation;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "results/library_api".into()),
    );
    std::fs::create_dir_all(&out)?;

    // Geometry and discretization: a 32 mm × 16 mm plate, Δx = 0.16 mm, δ = 3.5 Δx.
    let (dx, thickness) = (0.16e-3, 0.5e-3);
    let horizon = 3.5 * dx;
    let plate = Shape::Rectangle {
        min: [0.0, 0.0],
        max: [0.032, 0.016],
    };
    let mut body = Body::<2>::from_cloud(lattice(&plate, 2, dx, thickness)?, horizon, thickness);
    body.add_node_set(
        "top",
        &Shape::Rectangle {
            min: [-1.0, 0.016 - 3.0 * dx],
            max: [1.0, 1.0],
        },
    );
    body.add_node_set(
        "bottom",
        &Shape::Rectangle {
            min: [-1.0, -1.0],
            max: [1.0, 3.0 * dx],
        },
    );
    for set in ["top", "bottom"] {
        let nodes = body.node_sets[set].clone();
        body.mark_no_fail(&nodes);
    }

    // Bonds, with a 3 mm notch at mid-height.
    let notch = Precrack::Segment {
        start: [-0.001, 0.008],
        end: [0.003, 0.008],
    };
    let bonds = build_bonds(&body, PartialVolume::Hhb, &[notch]);

    // PMMA as a plane-stress PMB material calibrated from E (seed 001, Eq. 6), breaking at the
    // critical stretch of G0 = 300 J/m² (Eq. 8).
    let dim = Dimensionality::PlaneStress;
    let profile = MicromodulusProfile::Constant;
    let material = Pmb::calibrated(3.09e9, 1180.0, dim, profile, horizon, thickness);
    let s0 = Pmb::critical_stretch_from_g0(300.0, material.c0_paper, dim, profile, horizon);

    // Grips pulled apart at 2.5 m/s, ramped over 1 µs.
    let mut loading = Loading::<2>::default();
    for (set, v) in [("top", 2.5), ("bottom", -2.5)] {
        loading.conditions.push(BoundaryCondition {
            set: set.into(),
            nodes: body.node_sets[set].clone(),
            kind: Kinematic::Velocity,
            component: 1,
            value: v,
            time: TimeFunction::Ramp { duration: 1e-6 },
            offsets: Vec::new(),
        });
    }

    // Velocity Verlet at 0.8 × the Silling–Askari stable step, 40 µs.
    let mut sim = Simulation::new(
        body,
        bonds,
        material,
        CriticalStretch::new(s0),
        PartialVolume::Hhb,
        loading,
        None,
        0.8,
    )?;
    let steps = (40e-6 / sim.dt).ceil() as u64;
    let sets: Vec<(String, Vec<u32>)> = sim
        .body
        .node_sets
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    let mut observers: Vec<Box<dyn Observer<2>>> = vec![
        Box::new(History::new::<2>(&out.join("history.csv"), 20, &sets)),
        Box::new(Snapshots::new(
            out.clone(),
            steps / 4,
            &OutputDeck::default(), // the damage map, as a deck without [output] draws
            "library API example",
        )?),
        Box::new(Progress::new(steps as f64 * sim.dt, false)),
    ];
    let result = drive(&mut sim, steps, &mut observers);
    for o in observers.iter_mut() {
        o.finish()?;
    }
    result?;
    println!(
        "{} nodes, {} steps of {:.3e} s, {} bonds broken; results in {}",
        sim.body.len(),
        steps,
        sim.dt,
        sim.state.broken / 2,
        out.display()
    );
    Ok(())
}
