//! Patch tests: a homogeneous deformation must give the classical strain energy density
//! (bond-based PMB, whose ν is fixed) and the classical stress (LPS, any ν) at a bulk node.

use super::common;

use common::*;
use peridyn::bonds::{PartialVolume, Quadrature};
use peridyn::damage::CriticalStretch;
use peridyn::material::surface_correction::{corrected, surface_factors, SurfaceCorrection};
use peridyn::material::{Dimensionality, Elasticity, Material, MicromodulusProfile};
use peridyn::math::Vector;
use peridyn::solver::Simulation;

/// The dimensionalities every test covers.
const DIMENSIONALITIES: [(Dimensionality, &str); 3] = [
    (Dimensionality::PlaneStress, "plane stress"),
    (Dimensionality::PlaneStrain, "plane strain"),
    (Dimensionality::ThreeD, "3D"),
];

/// Strain states probed: uniaxial, pure shear, biaxial.
fn strains(dim: usize) -> Vec<[[f64; 3]; 3]> {
    let e = 1e-6;
    let mut out = vec![
        [[e, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0; 3]],
        [[0.0, e, 0.0], [e, 0.0, 0.0], [0.0; 3]],
        [[e, 0.0, 0.0], [0.0, 0.4 * e, 0.0], [0.0; 3]],
    ];
    if dim == 3 {
        out.push([
            [0.3 * e, 0.0, 0.2 * e],
            [0.0, -0.5 * e, 0.0],
            [0.2 * e, 0.0, e],
        ]);
    }
    out
}

/// Applies u = ε x to every node (bonds built with partial-volume `rule`), evaluates forces,
/// and returns the simulation with its centre node.
fn deformed<const D: usize, M: Material<D>>(
    m: f64,
    n: usize,
    material: M,
    strain: &[[f64; 3]; 3],
    rule: PartialVolume,
) -> (Simulation<D, M>, usize) {
    let dx = 1e-3;
    let (body, bonds) = lattice_body::<D>(n, dx, m, rule);
    let centre = centre_node(&body);
    let mut sim = simulation(body, bonds, material, CriticalStretch::never(), rule);
    for i in 0..sim.body.len() {
        let x = sim.body.positions[i];
        let u = Vector::<D>::from_fn(|a, _| (0..D).map(|b| strain[a][b] * x[b]).sum());
        sim.state.set_displacement(&sim.body.clone(), i, u);
    }
    sim.engine.compute(&sim.body, &sim.bonds, &mut sim.state);
    (sim, centre)
}

fn energy_error<const D: usize>(
    dim: Dimensionality,
    m: f64,
    strain: &[[f64; 3]; 3],
    rule: PartialVolume,
) -> f64 {
    let h = m * 1e-3;
    let material = pmb(dim, 70e9, h, MicromodulusProfile::Constant);
    let el = Material::<D>::elasticity(&material);
    let n = (2.0 * m).ceil() as usize * 2 + 3;
    let (sim, c) = deformed::<D, _>(m, n, material, strain, rule);
    let w = sim.engine.energy_density(&sim.body, &sim.bonds, &sim.state)[c];
    let classical = el.energy_density(strain, D);
    w / classical - 1.0
}

#[test]
fn pmb_bulk_energy_density_matches_classical() {
    for (dim, name) in DIMENSIONALITIES {
        for m in [3.0, 4.0, 5.0, 6.0] {
            for (k, strain) in strains(dim.dim()).iter().enumerate() {
                let err = if dim.dim() == 2 {
                    energy_error::<2>(dim, m, strain, PartialVolume::Hhb)
                } else {
                    energy_error::<3>(dim, m, strain, PartialVolume::Hhb)
                };
                println!(
                    "PMB {name:12} δ/Δx = {m}: strain state {k}: W_PD/W_classical − 1 = {err:+.4}"
                );
                // 2D meets 2% from δ/Δx = 4. In 3D the HHB rule (seed 000, Eq. 12) over-counts the
                // outer shell, where the ξ³ weight is largest: +2.7% at δ/Δx = 4, +2.3% at 5, within
                // 2% only from 6 (see docs/verification.md). This asserts the 2% bar where it holds.
                let holds_from = if dim.dim() == 2 { 4.0 } else { 6.0 };
                if m >= holds_from {
                    assert!(
                        err.abs() < 0.02,
                        "{name} δ/Δx = {m}, strain {k}: energy error {err}"
                    );
                }
            }
        }
    }
}

/// With exact partial volumes (the cell–ball overlap) the 2 % bar holds from δ/Δx = 4 in 2D
/// and 3D alike.
#[test]
fn pmb_bulk_energy_density_with_exact_partial_volumes() {
    for (dim, name) in DIMENSIONALITIES {
        for m in [3.0, 4.0, 5.0] {
            for (k, strain) in strains(dim.dim()).iter().enumerate() {
                let err = if dim.dim() == 2 {
                    energy_error::<2>(dim, m, strain, PartialVolume::Exact)
                } else {
                    energy_error::<3>(dim, m, strain, PartialVolume::Exact)
                };
                println!("PMB exact {name:12} δ/Δx = {m}: strain state {k}: W_PD/W_classical − 1 = {err:+.4}");
                if m >= 4.0 {
                    assert!(
                        err.abs() < 0.02,
                        "{name} δ/Δx = {m}, strain {k}: energy error {err} (exact partial volumes)"
                    );
                }
            }
        }
    }
}

#[test]
fn conical_profile_bulk_energy_matches_classical() {
    let m = 4.0;
    let strain = [[1e-6, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0; 3]];
    let h = m * 1e-3;
    let material = pmb(
        Dimensionality::PlaneStress,
        70e9,
        h,
        MicromodulusProfile::Conical,
    );
    let el = Material::<2>::elasticity(&material);
    let (sim, c) = deformed::<2, _>(m, 19, material, &strain, PartialVolume::Hhb);
    let w = sim.engine.energy_density(&sim.body, &sim.bonds, &sim.state)[c];
    let err = w / el.energy_density(&strain, 2) - 1.0;
    println!("PMB conical plane stress δ/Δx = 4: error {err:+.4}");
    assert!(err.abs() < 0.02);
}

fn lps_stress_error<const D: usize>(
    dim: Dimensionality,
    nu: f64,
    m: f64,
    strain: &[[f64; 3]; 3],
) -> f64 {
    let h = m * 1e-3;
    let material = lps(dim, 70e9, nu, h);
    let el = Elasticity {
        youngs_modulus: 70e9,
        poisson_ratio: nu,
        dimensionality: dim,
    };
    let n = (2.0 * m).ceil() as usize * 2 + 3;
    let (sim, c) = deformed::<D, _>(m, n, material, strain, PartialVolume::Hhb);
    let sigma = sim.engine.stress(&sim.body, &sim.bonds, &sim.state, c);
    let hooke = el.stress(strain, D);
    let scale = (0..D)
        .flat_map(|a| (0..D).map(move |b| (a, b)))
        .map(|(a, b)| hooke[a][b].abs())
        .fold(0.0, f64::max);
    (0..D)
        .flat_map(|a| (0..D).map(move |b| (a, b)))
        .map(|(a, b)| (sigma[a][b] - hooke[a][b]).abs() / scale)
        .fold(0.0, f64::max)
}

#[test]
fn lps_bulk_stress_matches_hooke() {
    for (dim, name) in DIMENSIONALITIES {
        for nu in [0.2, 0.35, 0.45] {
            for m in [3.0, 4.0] {
                for (k, strain) in strains(dim.dim()).iter().enumerate() {
                    let err = if dim.dim() == 2 {
                        lps_stress_error::<2>(dim, nu, m, strain)
                    } else {
                        lps_stress_error::<3>(dim, nu, m, strain)
                    };
                    println!("LPS {name:12} ν = {nu} δ/Δx = {m}: strain state {k}: max |σ_PD − σ_Hooke| / max|σ| = {err:.4}");
                    if m >= 4.0 {
                        assert!(
                            err < 0.02,
                            "{name} ν = {nu} δ/Δx = {m} strain {k}: stress error {err}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn lps_bulk_energy_matches_classical() {
    for (dim, nu) in [
        (Dimensionality::PlaneStress, 0.35),
        (Dimensionality::PlaneStrain, 0.3),
        (Dimensionality::ThreeD, 0.2),
    ] {
        let m = 4.0;
        for strain in strains(dim.dim()) {
            let h = m * 1e-3;
            let material = lps(dim, 70e9, nu, h);
            let el = Elasticity {
                youngs_modulus: 70e9,
                poisson_ratio: nu,
                dimensionality: dim,
            };
            let (w, classical) = if dim.dim() == 2 {
                let (sim, c) = deformed::<2, _>(m, 19, material, &strain, PartialVolume::Hhb);
                (
                    sim.engine.energy_density(&sim.body, &sim.bonds, &sim.state)[c],
                    el.energy_density(&strain, 2),
                )
            } else {
                let (sim, c) = deformed::<3, _>(m, 19, material, &strain, PartialVolume::Hhb);
                (
                    sim.engine.energy_density(&sim.body, &sim.bonds, &sim.state)[c],
                    el.energy_density(&strain, 3),
                )
            };
            let err = w / classical - 1.0;
            println!("LPS {dim:?} ν = {nu}: energy error {err:+.4}");
            assert!(err.abs() < 0.02, "{dim:?}: energy error {err}");
        }
    }
}

/// Strain energy of the whole body under a homogeneous strain, relative to the classical
/// energy of its volume: W_PD / W_classical − 1, with the PMB material's surface factors from
/// `method` applied.
fn body_energy_error<const D: usize>(
    dim: Dimensionality,
    m: f64,
    n: usize,
    strain: &[[f64; 3]; 3],
    method: SurfaceCorrection,
) -> f64 {
    let h = m * 1e-3;
    let rule = PartialVolume::Hhb;
    let material = pmb(dim, 70e9, h, MicromodulusProfile::Constant);
    let el = Material::<D>::elasticity(&material);
    let (body, bonds) = lattice_body::<D>(n, 1e-3, m, rule);
    let quad = Quadrature::for_body(rule, &body, &bonds);
    let material = match surface_factors(method, &body, &bonds, &quad, &material, None).unwrap() {
        Some(f) => corrected(material, &f.factors),
        None => material,
    };
    let volume: f64 = body.volumes.iter().sum();
    let mut sim = simulation(body, bonds, material, CriticalStretch::never(), rule);
    displace(&mut sim, |_, x| {
        Vector::<D>::from_fn(|a, _| (0..D).map(|b| strain[a][b] * x[b]).sum())
    });
    let energy = sim.engine.strain_energy(&sim.body, &sim.bonds, &sim.state);
    energy / (el.energy_density(strain, D) * volume) - 1.0
}

/// Surface correction (seed 000 §2.5): the factors come from a uniaxial strain along x. For
/// that strain the corrected body stores exactly the classical energy; for the strains it was
/// not computed from (along y, biaxial, shear) it must still remove most of the missing
/// stiffness of the surface layer. A wrong factor (or one applied to the wrong half of a bond)
/// leaves the error where it was.
#[test]
fn surface_correction_restores_the_energy_of_homogeneous_strains() {
    let e = 1e-6;
    // The least gain in |error| each correction must bring (measured: xx ≥ 2.6 for the volume
    // method, yy ≥ 2.4, biaxial ≥ 6.6, shear ≥ 1.66; both methods are scalar per node and
    // tuned to one strain, so shear gains least).
    let cases: [(&str, [[f64; 3]; 3], f64); 4] = [
        ("xx", [[e, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0; 3]], 2.0),
        ("yy", [[0.0, 0.0, 0.0], [0.0, e, 0.0], [0.0; 3]], 2.0),
        ("biaxial", [[e, 0.0, 0.0], [0.0, e, 0.0], [0.0; 3]], 5.0),
        ("shear", [[0.0, e, 0.0], [e, 0.0, 0.0], [0.0; 3]], 1.5),
    ];
    for method in [SurfaceCorrection::Energy, SurfaceCorrection::Volume] {
        for (dim, m, n) in [
            (Dimensionality::PlaneStress, 3.0, 40),
            (Dimensionality::PlaneStress, 3.5, 40),
            (Dimensionality::ThreeD, 3.0, 14),
        ] {
            for (name, strain, gain) in &cases {
                let errors = [SurfaceCorrection::None, method].map(|s| match dim {
                    Dimensionality::ThreeD => body_energy_error::<3>(dim, m, n, strain, s),
                    _ => body_energy_error::<2>(dim, m, n, strain, s),
                });
                println!(
                    "{method:?} {dim:?} δ/Δx = {m}, {name}: W/W_classical − 1 = {:+.4} → {:+.4}",
                    errors[0], errors[1]
                );
                assert!(errors[0] < -0.01, "the uncorrected body is too soft");
                if method == SurfaceCorrection::Energy && *name == "xx" {
                    // Exact up to the engine's finite stretch, which differs from the small-strain
                    // one the factors use by O(ε) = 1e-6 of itself.
                    assert!(errors[1].abs() < 1e-6, "{dim:?} δ/Δx = {m}: {}", errors[1]);
                } else {
                    assert!(
                        errors[1].abs() * gain <= errors[0].abs(),
                        "{method:?} {dim:?} δ/Δx = {m}, {name}: {:+.4} → {:+.4}",
                        errors[0],
                        errors[1]
                    );
                }
            }
        }
    }
}

/// Seed 000's iteration, literally: where it has a positive fixed point (δ = 3Δx) every
/// node's W_i = Σ ½(λ_i + λ_j) w_ij equals W0, so the body stores the classical energy of the
/// uniaxial strain; with δ = 3.5Δx the fixed point has negative factors and the iteration is
/// refused with a message that says why (the erratum in docs/deck.md).
#[test]
fn iterated_surface_correction_converges_or_is_refused() {
    let strain = [[1e-6, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0; 3]];
    let err = body_energy_error::<2>(
        Dimensionality::PlaneStress,
        3.0,
        30,
        &strain,
        SurfaceCorrection::EnergyIterated,
    );
    assert!(err.abs() < 1e-6, "{err}");
    let (body, bonds) = lattice_body::<2>(30, 1e-3, 3.5, PartialVolume::Hhb);
    let material = pmb(
        Dimensionality::PlaneStress,
        70e9,
        3.5e-3,
        MicromodulusProfile::Constant,
    );
    let quad = Quadrature::for_body(PartialVolume::Hhb, &body, &bonds);
    let refused = surface_factors(
        SurfaceCorrection::EnergyIterated,
        &body,
        &bonds,
        &quad,
        &material,
        None,
    )
    .unwrap_err();
    assert!(
        refused.to_string().contains("no positive solution"),
        "{refused}"
    );
}

/// Issue 6's criterion for the surface correction: under the calibration deformation (ε_xx)
/// every node, at the boundary or in the bulk, stores the bulk energy density W0 within 1e-6
/// of itself (ε = 1e-7 keeps the finite-stretch term below that). Plane stress, 3D, and a
/// dual-horizon body (two horizons, each node's micromodulus calibrated to its own).
#[test]
fn corrected_nodes_store_the_bulk_energy_density() {
    fn check<const D: usize>(
        dim: Dimensionality,
        body: peridyn::body::Body<D>,
        bonds: peridyn::bonds::Bonds,
    ) {
        let rule = PartialVolume::Hhb;
        let h0 = body.horizons[0];
        let material =
            pmb(dim, 70e9, h0, MicromodulusProfile::Constant).with_horizons(&body.horizons);
        let quad = Quadrature::for_body(rule, &body, &bonds);
        let f = surface_factors(
            SurfaceCorrection::Energy,
            &body,
            &bonds,
            &quad,
            &material,
            None,
        )
        .unwrap()
        .unwrap();
        let material = corrected(material, &f.factors);
        let el = Material::<D>::elasticity(&material);
        let mut sim = simulation(body, bonds, material, CriticalStretch::never(), rule);
        let e = 1e-7;
        displace(&mut sim, |_, x| {
            Vector::<D>::from_fn(|a, _| if a == 0 { e * x[0] } else { 0.0 })
        });
        let mut strain = [[0.0; 3]; 3];
        strain[0][0] = e;
        let w0 = el.energy_density(&strain, D);
        let w = sim.engine.energy_density(&sim.body, &sim.bonds, &sim.state);
        let worst = w.iter().map(|w| (w / w0 - 1.0).abs()).fold(0.0, f64::max);
        println!(
            "{dim:?}: λ from {:.3} to {:.3}; worst |W_i/W0 − 1| = {worst:.2e}",
            f.report.min, f.report.max
        );
        assert!(
            f.report.max > 1.8,
            "corner and edge nodes need a correction"
        );
        assert!(worst < 1e-6, "{dim:?}: {worst}");
    }
    let (body, bonds) = lattice_body::<2>(30, 1e-3, 3.0, PartialVolume::Hhb);
    check(Dimensionality::PlaneStress, body, bonds);
    let (body, bonds) = lattice_body::<3>(12, 1e-3, 3.0, PartialVolume::Hhb);
    check(Dimensionality::ThreeD, body, bonds);
    let (body, bonds) = two_horizon_body::<2>(
        &peridyn::geometry::Shape::cube(2, 0.03),
        1e-3,
        3.0,
        4.0,
        0.015,
        PartialVolume::Hhb,
    );
    check(Dimensionality::PlaneStress, body, bonds);
}
