//! The vector kernels compute what the generic loop computes: same forces up to the order of
//! summation, the same bonds broken.

mod common;

use common::*;
use peridyn::bonds::PartialVolume;
use peridyn::damage::softening::{Shape, SofteningParameters};
use peridyn::damage::{CriticalStretch, Damage, Softening};
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
    compare_with(name, material, CriticalStretch::new(1e-3).into(), rule);
}

/// One run of `compare_with`: forces, status bytes and history after two evaluations.
type Run = (Vec<Vector<3>>, Vec<u8>, Vec<f64>);

/// The same as `compare` under any damage law; also compares the bond histories, and checks
/// that the vector run is bitwise the same on 1 and 2 threads.
fn compare_with<M: Material<3> + Clone>(
    name: &str,
    material: M,
    damage: Damage,
    rule: PartialVolume,
) {
    let mut runs: Vec<Run> = Vec::new();
    for (vector, threads) in [(true, 1), (true, 2), (false, 1)] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        runs.push(pool.install(|| run(&material, damage.clone(), rule, vector)));
    }
    let (fv, sv, hv) = &runs[0];
    assert!(
        runs[1].0 == *fv
            && runs[1].1 == *sv
            && runs[1]
                .2
                .iter()
                .map(|h| h.to_bits())
                .eq(hv.iter().map(|h| h.to_bits())),
        "{name}: the vector kernel differs between 1 and 2 threads"
    );
    let (fg, sg, hg) = &runs[2];
    let hscale = hg.iter().fold(0.0f64, |m, h| m.max(h.abs()));
    let hdiff = hv
        .iter()
        .zip(hg)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        hdiff <= 1e-12 * hscale,
        "{name}: histories differ by {hdiff} (scale {hscale})"
    );
    check((name, fv, sv), (fg, sg));
}

fn run<M: Material<3> + Clone>(
    material: &M,
    damage: Damage,
    rule: PartialVolume,
    vector: bool,
) -> Run {
    {
        let (body, bonds) = lattice_body::<3>(9, 1e-3, 3.0, rule);
        let mut sim = simulation(body, bonds, material.clone(), damage, rule);
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
        (
            sim.state.force.clone(),
            sim.state.status.clone(),
            sim.state.history.clone(),
        )
    }
}

/// Same bonds broken, forces within round-off.
fn check((name, fv, sv): (&str, &[Vector<3>], &[u8]), (fg, sg): (&[Vector<3>], &[u8])) {
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

#[test]
fn softening_kernel_matches_the_generic_loop() {
    let dim = Dimensionality::ThreeD;
    // The stretch field of `run` (2e-3 ± 1e-3) softens bonds past s1 and breaks some.
    let bilinear = SofteningParameters::bilinear(1.2e-3, 2.6e-3).unwrap();
    let trilinear = SofteningParameters::trilinear(bilinear, 0.25, 1.5).unwrap();
    for rule in [PartialVolume::Hhb, PartialVolume::None] {
        for (label, law) in [
            ("bilinear", Softening::uniform(Shape::Bilinear, bilinear)),
            (
                "trilinear",
                Softening::uniform(Shape::Trilinear { beta: 0.25 }, trilinear),
            ),
        ] {
            for profile in [MicromodulusProfile::Constant, MicromodulusProfile::Conical] {
                compare_with(
                    &format!("pmb {label} {profile:?}"),
                    pmb(dim, 70e9, 3e-3, profile),
                    law.clone().into(),
                    rule,
                );
            }
        }
    }
}
