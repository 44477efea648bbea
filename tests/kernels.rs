//! The vector kernels compute what the generic loop computes: same forces up to the order of
//! summation, the same bonds broken.

mod common;

use common::*;
use peridyn::bonds::PartialVolume;
use peridyn::damage::CriticalStretch;
use peridyn::material::{Dimensionality, Material, MicromodulusProfile};
use peridyn::math::Vector;

fn noise(k: usize) -> f64 {
    let x = (k as u64)
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// Runs the same deformed, partly failing state through the vector kernel and the generic loop.
fn compare<M: Material<3> + Clone>(name: &str, material: M, rule: PartialVolume) {
    let mut runs = Vec::new();
    for vector in [true, false] {
        let (body, bonds) = lattice_body::<3>(9, 1e-3, 3.0, rule);
        let mut sim = simulation(
            body,
            bonds,
            material.clone(),
            CriticalStretch::new(1e-3),
            rule,
        );
        sim.engine.vector_kernels = vector;
        let body = sim.body.clone();
        for i in 0..body.len() {
            // A stretch field large enough to break some bonds (s0 = 1e-3 below).
            let u = Vector::<3>::from_fn(|k, _| {
                2e-3 * body.positions[i][k] * (1.0 + 0.5 * noise(3 * i + k))
            });
            sim.state.set_displacement(&body, i, u);
        }
        sim.refresh_forces().unwrap();
        sim.refresh_forces().unwrap(); // a second pass sees the bonds broken by the first
        runs.push((sim.state.force.clone(), sim.state.status.clone()));
    }
    let (fv, sv) = &runs[0];
    let (fg, sg) = &runs[1];
    assert_eq!(sv, sg, "{name}: broken bonds differ");
    assert!(
        sv.iter().any(|&s| s != 0),
        "{name}: the test must break bonds"
    );
    let scale = fg.iter().map(|f| f.norm()).fold(0.0, f64::max);
    let diff = fv
        .iter()
        .zip(fg)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    println!(
        "{name}: max force difference {:.2e} of {scale:.3e}",
        diff / scale
    );
    assert!(
        diff < 1e-12 * scale,
        "{name}: vector and generic forces differ by {diff} (scale {scale})"
    );
}

#[test]
fn vector_kernels_match_the_generic_loop() {
    let dim = Dimensionality::ThreeD;
    for rule in [PartialVolume::Hhb, PartialVolume::None] {
        compare(
            "pmb",
            pmb(dim, 70e9, 3e-3, MicromodulusProfile::Constant),
            rule,
        );
        compare(
            "pmb conical",
            pmb(dim, 70e9, 3e-3, MicromodulusProfile::Conical),
            rule,
        );
        compare("lps", lps(dim, 70e9, 0.3, 3e-3), rule);
    }
}

#[test]
fn correspondence_kernels_match_the_generic_loop() {
    use peridyn::material::correspondence::ZeroEnergyControl;
    use peridyn::material::Influence;
    let dim = Dimensionality::ThreeD;
    for rule in [PartialVolume::Hhb, PartialVolume::None] {
        for (name, control) in [
            (
                "correspondence wan",
                ZeroEnergyControl::Wan { coefficient: 1.0 },
            ),
            (
                "correspondence silling",
                ZeroEnergyControl::Silling { coefficient: 0.5 },
            ),
            ("correspondence bare", ZeroEnergyControl::None),
        ] {
            let mut m = correspondence(dim, 70e9, 0.25, 3e-3, control);
            compare(name, m.clone(), rule);
            m.influence = Influence::Inverse;
            compare(&format!("{name} inverse ω"), m, rule);
        }
    }
}
