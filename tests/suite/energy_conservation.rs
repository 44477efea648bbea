//! Verification: a free elastic body integrated by velocity Verlet at the default time step
//! (`dt = None`, safety factor 0.8) conserves energy and linear momentum.
//!
//! For a linear system M ẍ = −K x, velocity Verlet conserves exactly the shadow energy
//!   H̃ = ½ vᵀM v + ½ xᵀK x − (dt²/8) xᵀK M⁻¹K x = E − (dt²/8) Σ_i V_i |f_i|² / ρ,
//! (f_i the force density, V_i the volume, E = kinetic + strain energy at the integer steps).
//! Hence
//!  * E has no secular drift: the running mean of E is constant (asserted: < 0.1% change
//!    between the first and last 10% of the samples);
//!  * E oscillates above H̃ by exactly (dt²/8) Σ V |f|²/ρ, a quantity we compute at each sample:
//!    the maximum instantaneous deviation of E from its running mean is bounded by the
//!    largest value of this term (plus a small allowance for the geometric nonlinearity of the
//!    bonds, relative order of the strain, ~1e-4);
//!  * H̃ itself is constant to that nonlinearity: asserted to 1e-4 relative.
//!
//! Linear momentum Σ ρ V v is conserved to round-off because pairwise forces are equal and
//! opposite (PMB: symmetrised φ; LPS: dual force state weighted by φ_ij and φ_ji).

use peridyn::body::Body;
use peridyn::bonds::search::build_bonds;
use peridyn::bonds::PartialVolume;
use peridyn::damage::CriticalStretch;
use peridyn::discretize::lattice::lattice;
use peridyn::geometry::Shape;
use peridyn::loading::Loading;
use peridyn::material::{
    Dimensionality, Elasticity, Influence, Lps, Material, MicromodulusProfile, Pmb,
};
use peridyn::math::Vector;
use peridyn::solver::Simulation;
use std::f64::consts::PI;
use std::time::Instant;

const DX: f64 = 1.0e-3;
const RHO: f64 = 1000.0;
const E: f64 = 1.0e9;
const STEPS: usize = 10_000;
const SAMPLE_EVERY: usize = 20;

fn run<const D: usize, M: Material<D>>(
    label: &str,
    n: usize,
    m_ratio: f64,
    make: impl FnOnce(f64) -> M,
) {
    let started = Instant::now();
    let delta = m_ratio * DX;
    let side = n as f64 * DX;
    let shape = if D == 2 {
        Shape::Rectangle {
            min: [0.0, 0.0],
            max: [side, side],
        }
    } else {
        Shape::Box {
            min: [0.0; 3],
            max: [side; 3],
        }
    };
    let cloud = lattice(&shape, D, DX, 1.0).unwrap();
    let body = Body::<D>::from_cloud(cloud, delta, 1.0);
    let bonds = build_bonds(&body, PartialVolume::Hhb, &[]);
    let material = make(delta);
    let c_p = (material.elasticity().p_wave_modulus() / material.density(0)).sqrt();
    let mut sim = Simulation::new(
        body,
        bonds,
        material,
        CriticalStretch::never(),
        PartialVolume::Hhb,
        Loading::<D>::default(),
        None,
        0.8,
    )
    .unwrap();
    assert!((sim.dt / sim.dt_stable - 0.8).abs() < 1e-12);

    // Smooth, non-rigid initial field: a displacement with strain ~1e-4 (a bending/shear-like
    // pattern, different in each component) and a velocity field with a strain rate of the same
    // order plus a uniform drift (so the momentum is non-zero).
    let eps = 1e-4;
    let v0 = eps * c_p;
    for i in 0..sim.body.len() {
        let p = sim.body.positions[i];
        let s: Vec<f64> = (0..D).map(|k| p[k] / side).collect();
        let mut u = Vector::<D>::zeros();
        let mut v = Vector::<D>::zeros();
        for k in 0..D {
            let a = s[k];
            let b = s[(k + 1) % D];
            u[k] = eps * side / PI
                * ((PI * a).sin() * (PI * b).cos() + 0.3 * (2.0 * PI * b).sin() * (k as f64 + 1.0));
            v[k] = v0
                * ((PI * a).cos() * (2.0 * PI * b).sin()
                    + 0.5 * (PI * b).cos()
                    + 0.2 * (k as f64 + 1.0));
        }
        sim.state.set_displacement(&sim.body, i, u);
        sim.state.v[i] = v;
    }
    // Forces consistent with the initial displacement (Simulation::new evaluated them at u = 0).
    sim.engine.compute(&sim.body, &sim.bonds, &mut sim.state);

    let rho = sim.engine.material.density(0);
    let momentum = |sim: &Simulation<D, M>| -> (Vector<D>, f64) {
        let mut p = Vector::<D>::zeros();
        let mut scale = 0.0;
        for i in 0..sim.body.len() {
            p += sim.state.v[i] * (rho * sim.body.volumes[i]);
            scale += rho * sim.body.volumes[i] * sim.state.v[i].norm();
        }
        (p, scale)
    };
    let shadow_term = |sim: &Simulation<D, M>| -> f64 {
        sim.dt * sim.dt / 8.0
            * (0..sim.body.len())
                .map(|i| sim.body.volumes[i] * sim.state.force[i].norm_squared())
                .sum::<f64>()
            / rho
    };

    let (p0, pscale) = momentum(&sim);
    let mut energies = Vec::with_capacity(STEPS / SAMPLE_EVERY + 1);
    let mut shadows = Vec::with_capacity(STEPS / SAMPLE_EVERY + 1);
    let mut max_term: f64 = 0.0;
    let (mut max_dp, mut ke_min, mut ke_max) = (0.0f64, f64::INFINITY, 0.0f64);
    for k in 0..=STEPS {
        if k > 0 {
            sim.step().unwrap();
        }
        if k % SAMPLE_EVERY == 0 {
            let (ke, se) = (sim.kinetic_energy(), sim.strain_energy());
            let term = shadow_term(&sim);
            energies.push(ke + se);
            shadows.push(ke + se - term);
            max_term = max_term.max(term);
            ke_min = ke_min.min(ke);
            ke_max = ke_max.max(ke);
            let (p, _) = momentum(&sim);
            max_dp = max_dp.max((p - p0).norm());
        }
    }
    sim.check_finite().unwrap();
    assert_eq!(sim.state.broken, 0);

    let ns = energies.len();
    let w = ns / 10;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (first, last) = (mean(&energies[..w]), mean(&energies[ns - w..]));
    let total = mean(&energies);
    let drift = (last - first) / total;
    let max_dev = energies
        .iter()
        .map(|e| (e - total).abs())
        .fold(0.0, f64::max)
        / total;
    let bound = max_term / total;
    let shadow_mean = mean(&shadows);
    let shadow_dev = shadows
        .iter()
        .map(|e| (e - shadow_mean).abs())
        .fold(0.0, f64::max)
        / total;
    let shadow_drift = (mean(&shadows[ns - w..]) - mean(&shadows[..w])) / total;
    let dp_rel = max_dp / pscale;
    println!(
        "{label}: {} nodes, {:.1} bonds/node, {STEPS} steps of dt = {:.3e} s (0.8 dt_stable), \
         E = {total:.5e} J (KE between {ke_min:.3e} and {ke_max:.3e}); \
         mean-energy drift {drift:.3e}; max |E - <E>|/<E> = {max_dev:.3e} (Verlet bound (dt²/8)ΣV|f|²/ρ / E = {bound:.3e}); \
         shadow energy max dev {shadow_dev:.3e}, drift {shadow_drift:.3e}; momentum |Δp|/Σρ V|v| = {dp_rel:.2e}, |p0| = {:.4e}; {:.1} s",
        sim.body.len(),
        sim.bonds.bonds_per_node(),
        sim.dt,
        p0.norm(),
        started.elapsed().as_secs_f64()
    );

    // The body really deforms and exchanges kinetic and strain energy.
    assert!(
        ke_max - ke_min > 0.05 * total,
        "{label}: the initial field should exchange energy"
    );
    assert!(
        drift.abs() < 1e-3,
        "{label}: mean energy drift {drift:e} above 0.1%"
    );
    // E − H̃ ∈ [0, max term], so |E − <E>| ≤ max term + (H̃ variation); allowance 1e-4 for the
    // geometric nonlinearity (strain ~1e-4) and for <E> differing from H̃ by the mean of the term.
    assert!(
        max_dev <= bound + 1e-4,
        "{label}: instantaneous energy deviation {max_dev:e} exceeds the Verlet bound {bound:e}"
    );
    assert!(
        shadow_dev < 1e-4,
        "{label}: shadow energy varies by {shadow_dev:e}"
    );
    assert!(
        dp_rel < 1e-12,
        "{label}: momentum changed by {dp_rel:e} of Σ ρV|v|"
    );
}

#[test]
fn pmb_2d_energy_and_momentum() {
    run::<2, _>("PMB 2D plane stress", 30, 3.0, |delta| {
        let dim = Dimensionality::PlaneStress;
        Pmb::calibrated(E, RHO, dim, MicromodulusProfile::Constant, delta, 1.0)
    });
}

#[test]
fn lps_2d_energy_and_momentum() {
    run::<2, _>("LPS 2D plane stress", 30, 3.0, |delta| {
        Lps::new(
            Elasticity {
                youngs_modulus: E,
                poisson_ratio: 0.3,
                dimensionality: Dimensionality::PlaneStress,
            },
            Influence::Constant,
            delta,
            RHO,
            1.0,
        )
    });
}

#[test]
fn pmb_3d_energy_and_momentum() {
    run::<3, _>("PMB 3D", 10, 3.0, |delta| {
        let dim = Dimensionality::ThreeD;
        Pmb::calibrated(E, RHO, dim, MicromodulusProfile::Constant, delta, 1.0)
    });
}
