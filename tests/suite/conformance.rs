//! Conformance suite run over every model: zero force in the reference state, momentum
//! balance, rigid-motion invariance, and forces equal to minus the energy gradient.
//! Adding a model means adding a line to `for_every_model!`.

use super::common;

use common::*;
use peridyn::body::Body;
use peridyn::bonds::PartialVolume;
use peridyn::damage::CriticalStretch;
use peridyn::material::correspondence::ZeroEnergyControl;
use peridyn::material::mixed::BlockMaterial;
use peridyn::material::{Dimensionality, Material, MicromodulusProfile, Mixed};
use peridyn::math::Vector;
use peridyn::solver::Simulation;

/// A deterministic pseudo-random number in [-1, 1) (no RNG dependency; fixed sequence).
fn noise(k: usize) -> f64 {
    let x = (k as u64)
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn sim_of<const D: usize, M: Material<D>>(material: M) -> Simulation<D, M> {
    let (body, bonds) =
        lattice_body::<D>(if D == 2 { 12 } else { 7 }, 1e-3, 3.0, PartialVolume::Hhb);
    simulation(
        body,
        bonds,
        material,
        CriticalStretch::never(),
        PartialVolume::Hhb,
    )
}

/// Lattices for models that are made for their body.
enum Layout {
    /// Horizons changing 2:1 across the middle: δ = 3Δx for x < L/2, 6Δx beyond (dual-horizon
    /// PD).
    TwoHorizons,
    /// One horizon (3Δx); the material tells the blocks apart by position.
    OneHorizon,
}

fn sim_on<const D: usize, M: Material<D>>(
    layout: Layout,
    make: impl FnOnce(&Body<D>) -> M,
) -> Simulation<D, M> {
    let (n, dx) = (if D == 2 { 12 } else { 7 }, 1e-3);
    let (body, bonds) = match layout {
        Layout::TwoHorizons => two_horizon_body::<D>(
            &peridyn::geometry::Shape::cube(D, n as f64 * dx),
            dx,
            3.0,
            6.0,
            0.5 * n as f64 * dx,
            PartialVolume::Hhb,
        ),
        Layout::OneHorizon => lattice_body::<D>(n, dx, 3.0, PartialVolume::Hhb),
    };
    let material = make(&body);
    simulation(
        body,
        bonds,
        material,
        CriticalStretch::never(),
        PartialVolume::Hhb,
    )
}

/// PMB for x < 6Δx, LPS beyond (`Mixed`: each half of a bond from its own node's material).
fn pmb_lps<const D: usize>(body: &Body<D>, dim: Dimensionality) -> Mixed {
    Mixed {
        materials: vec![
            BlockMaterial::Pmb(pmb(dim, 70e9, 3e-3, MicromodulusProfile::Constant)),
            BlockMaterial::Lps(lps(dim, 200e9, 0.3, 3e-3)),
        ],
        material_of: body
            .positions
            .iter()
            .map(|p| (p[0] >= 6e-3) as u16)
            .collect(),
    }
}

fn check_model<const D: usize, M: Material<D>>(name: &str, material: M) {
    check_sim(name, sim_of::<D, M>(material));
}

fn check_sim<const D: usize, M: Material<D>>(name: &str, mut sim: Simulation<D, M>) {
    // Reference state: exactly zero force.
    assert_eq!(max_force(&sim), 0.0, "{name}: force in the reference state");

    // Random small deformation: momentum balance Σ V f = 0 to round-off.
    let amp = 1e-6;
    displace(&mut sim, |i, _| {
        Vector::<D>::from_fn(|k, _| amp * noise(D * i + k))
    });
    let scale = max_force(&sim);
    assert!(scale > 0.0);
    let total: Vector<D> = (0..sim.body.len())
        .map(|i| sim.state.force[i] * sim.body.volumes[i])
        .fold(Vector::zeros(), |a, b| a + b);
    let per_node = scale * sim.body.volumes[0];
    assert!(
        total.norm() < 1e-10 * per_node * sim.body.len() as f64,
        "{name}: net internal force {total:?} (scale {per_node})"
    );

    // Energy–force consistency: V_i f_i = −∂E/∂u_i by central differences.
    for (i, k) in [(sim.body.len() / 2, 0), (3, D - 1), (sim.body.len() - 5, 1)] {
        let fd = {
            let h = 1e-9;
            let base = sim.state.u.clone();
            let energy_at = |sim: &mut Simulation<D, M>, du: f64| {
                let body = sim.body.clone();
                let mut u = base[i];
                u[k] += du;
                sim.state.set_displacement(&body, i, u);
                sim.engine.compute(&sim.body, &sim.bonds, &mut sim.state);
                sim.strain_energy()
            };
            let ep = energy_at(&mut sim, h);
            let em = energy_at(&mut sim, -h);
            let body = sim.body.clone();
            sim.state.set_displacement(&body, i, base[i]);
            sim.engine.compute(&sim.body, &sim.bonds, &mut sim.state);
            -(ep - em) / (2.0 * h)
        };
        let f = sim.state.force[i][k] * sim.body.volumes[i];
        assert!(
            (fd - f).abs() < 1e-4 * per_node.max(f.abs()),
            "{name}: node {i} comp {k}: −dE/du = {fd}, V f = {f}"
        );
    }

    // Rigid motion: a finite rotation plus translation gives no force (beyond round-off).
    let angle: f64 = 0.3;
    displace(&mut sim, |_, x| {
        let mut y = *x;
        let (c, s) = (angle.cos(), angle.sin());
        y[0] = c * x[0] - s * x[1] + 0.01;
        y[1] = s * x[0] + c * x[1] - 0.02;
        y - x
    });
    let rigid = max_force(&sim);
    assert!(
        rigid < 1e-6 * scale,
        "{name}: force under rigid motion {rigid} vs {scale} under strain {amp}"
    );
    println!("{name}: ok (strain-force scale {scale:.3e}, rigid-motion force {rigid:.3e})");
}

/// Wan et al.'s zero-energy-mode control with the paper's coefficient.
const WAN: ZeroEnergyControl = ZeroEnergyControl::Wan { coefficient: 1.0 };

/// Models on the uniform lattice, then models made for their body (a `Layout` and a closure
/// of the body).
macro_rules! for_every_model {
    (
        $($name:literal => $d:literal, $material:expr;)*
        made for the body:
        $($b_name:literal => $b_d:literal, $layout:ident, $b_material:expr;)*
    ) => {
        #[test]
        fn every_model_conforms() {
            $( check_model::<$d, _>($name, $material); )*
            $( check_sim($b_name, sim_on::<$b_d, _>(Layout::$layout, $b_material)); )*
        }
    };
}

for_every_model! {
    "pmb plane stress" => 2, pmb(Dimensionality::PlaneStress, 70e9, 3e-3, MicromodulusProfile::Constant);
    "pmb plane strain conical" => 2, pmb(Dimensionality::PlaneStrain, 70e9, 3e-3, MicromodulusProfile::Conical);
    "pmb 3D" => 3, pmb(Dimensionality::ThreeD, 70e9, 3e-3, MicromodulusProfile::Constant);
    "lps plane stress" => 2, lps(Dimensionality::PlaneStress, 70e9, 0.3, 3e-3);
    "lps plane strain" => 2, lps(Dimensionality::PlaneStrain, 70e9, 0.45, 3e-3);
    "lps 3D" => 3, lps(Dimensionality::ThreeD, 70e9, 0.2, 3e-3);
    "correspondence plane stress wan" => 2, correspondence(Dimensionality::PlaneStress, 70e9, 0.3, 3e-3, WAN);
    "correspondence plane strain wan" => 2, correspondence(Dimensionality::PlaneStrain, 70e9, 0.45, 3e-3, WAN);
    "correspondence 3D wan" => 3, correspondence(Dimensionality::ThreeD, 70e9, 0.2, 3e-3, WAN);
    "correspondence plane stress no control" => 2, correspondence(Dimensionality::PlaneStress, 70e9, 0.3, 3e-3, ZeroEnergyControl::None);
    "correspondence plane stress silling" => 2, correspondence(Dimensionality::PlaneStress, 70e9, 0.3, 3e-3, ZeroEnergyControl::Silling { coefficient: 1.0 });
    "correspondence 3D silling" => 3, correspondence(Dimensionality::ThreeD, 70e9, 0.2, 3e-3, ZeroEnergyControl::Silling { coefficient: 1.0 });
    made for the body:
    "pmb dual horizon 2:1 plane stress" => 2, TwoHorizons, |b: &Body<2>| {
        pmb(Dimensionality::PlaneStress, 70e9, 3e-3, MicromodulusProfile::Constant).with_horizons(&b.horizons)
    };
    "pmb dual horizon 2:1 3D conical" => 3, TwoHorizons, |b: &Body<3>| {
        pmb(Dimensionality::ThreeD, 70e9, 3e-3, MicromodulusProfile::Conical).with_horizons(&b.horizons)
    };
    "lps dual horizon 2:1 plane strain" => 2, TwoHorizons, |b: &Body<2>| {
        lps(Dimensionality::PlaneStrain, 70e9, 0.3, 3e-3).with_horizons(&b.horizons)
    };
    "lps dual horizon 2:1 3D" => 3, TwoHorizons, |b: &Body<3>| {
        lps(Dimensionality::ThreeD, 70e9, 0.2, 3e-3).with_horizons(&b.horizons)
    };
    "correspondence dual horizon 2:1 plane stress" => 2, TwoHorizons, |b: &Body<2>| {
        correspondence(Dimensionality::PlaneStress, 70e9, 0.3, 3e-3, WAN).with_horizons(&b.horizons)
    };
    "correspondence dual horizon 2:1 3D" => 3, TwoHorizons, |b: &Body<3>| {
        correspondence(Dimensionality::ThreeD, 70e9, 0.2, 3e-3, WAN).with_horizons(&b.horizons)
    };
    "mixed pmb | lps plane stress" => 2, OneHorizon, |b: &Body<2>| pmb_lps(b, Dimensionality::PlaneStress);
    "mixed pmb | lps 3D" => 3, OneHorizon, |b: &Body<3>| pmb_lps(b, Dimensionality::ThreeD);
    "mixed central pmb | lps plane stress" => 2, OneHorizon, |b: &Body<2>| {
        pmb_lps(b, Dimensionality::PlaneStress).into_central().unwrap()
    };
    "mixed central pmb | lps 3D" => 3, OneHorizon, |b: &Body<3>| {
        pmb_lps(b, Dimensionality::ThreeD).into_central().unwrap()
    };
}
