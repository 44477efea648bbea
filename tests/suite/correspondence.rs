//! Verification of the correspondence model (seed 004, Eqs. 6–15): patch tests in the bulk,
//! objectivity, zero-energy-mode control (static and dynamic), and nodes whose shape tensor
//! is singular.

use super::common;

use common::*;
use peridyn::body::Body;
use peridyn::bonds::search::build_bonds;
use peridyn::bonds::PartialVolume;
use peridyn::damage::CriticalStretch;
use peridyn::discretize::NodeCloud;
use peridyn::loading::Loading;
use peridyn::material::correspondence::ZeroEnergyControl;
use peridyn::material::{Correspondence, Dimensionality, Elasticity, Material};
use peridyn::math::{inverse, Matrix, Vector};
use peridyn::solver::Simulation;
use peridyn::state::BROKEN;

const DX: f64 = 1e-3;
const E: f64 = 70e9;
const WAN: ZeroEnergyControl = ZeroEnergyControl::Wan { coefficient: 1.0 };
const SILLING: ZeroEnergyControl = ZeroEnergyControl::Silling { coefficient: 1.0 };

/// The dimensionalities every patch test covers.
const DIMENSIONALITIES: [Dimensionality; 3] = [
    Dimensionality::PlaneStress,
    Dimensionality::PlaneStrain,
    Dimensionality::ThreeD,
];

/// A deterministic pseudo-random number in [-1, 1) (no RNG dependency; fixed sequence).
fn noise(k: usize) -> f64 {
    let x = (k as u64)
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn elasticity(dim: Dimensionality, nu: f64) -> Elasticity {
    Elasticity {
        youngs_modulus: E,
        poisson_ratio: nu,
        dimensionality: dim,
    }
}

// ---------------------------------------------------------------------------------------
// a. Patch tests
// ---------------------------------------------------------------------------------------

/// Strain states probed: uniaxial, pure shear, biaxial, and in 3D a general state.
fn strains(dim: usize) -> Vec<[[f64; 3]; 3]> {
    let e = 1e-6;
    let mut out = vec![
        [[e, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0; 3]],
        [[0.0, e, 0.0], [e, 0.0, 0.0], [0.0; 3]],
        [[e, 0.0, 0.0], [0.0, 0.4 * e, 0.0], [0.0; 3]],
    ];
    if dim == 3 {
        out.push([
            [0.3 * e, 0.7 * e, 0.2 * e],
            [0.7 * e, -0.5 * e, -0.4 * e],
            [0.2 * e, -0.4 * e, e],
        ]);
    }
    out
}

fn to_matrix<const D: usize>(a: &[[f64; 3]; 3]) -> Matrix<D> {
    Matrix::<D>::from_fn(|r, c| a[r][c])
}

fn to_array<const D: usize>(m: &Matrix<D>) -> [[f64; 3]; 3] {
    let mut a = [[0.0; 3]; 3];
    for r in 0..D {
        for c in 0..D {
            a[r][c] = m[(r, c)];
        }
    }
    a
}

/// max_ab |a_ab − b_ab| / max_ab |b_ab|.
fn rel_error<const D: usize>(a: &Matrix<D>, b: &Matrix<D>) -> f64 {
    (a - b).amax() / b.amax()
}

/// Errors of one homogeneous deformation y = Q (I + ε) x at a bulk node.
struct PatchErrors {
    /// Stress at the centre node against Hooke's law σ = C:ε (the linear theory).
    stress_vs_hooke: f64,
    /// Energy density at the centre node against ½ ε:C:ε.
    energy_vs_classical: f64,
    /// Stress against the model's own finite-strain law at F = Q(I + ε) (St. Venant–Kirchhoff:
    /// P = F C:E, E the Green–Lagrange strain), at the centre node...
    stress_vs_law: f64,
    /// ...and the worst over every node of the body, surface included.
    stress_vs_law_all_nodes: f64,
    /// Energy density against ½ E:C:E at the centre node.
    energy_vs_law: f64,
}

/// Applies y = Q (I + ε) x on a lattice of horizon ratio 3 and compares stress and energy
/// density at the centre node.
fn patch<const D: usize>(
    dim: Dimensionality,
    nu: f64,
    control: ZeroEnergyControl,
    strain: &[[f64; 3]; 3],
    rotation: Matrix<D>,
) -> PatchErrors {
    let m: f64 = 3.0;
    let n = (2.0 * m).ceil() as usize * 2 + 3;
    let (body, bonds) = lattice_body::<D>(n, DX, m, PartialVolume::Hhb);
    let centre = centre_node(&body);
    let material = correspondence(dim, E, nu, m * DX, control);
    let mut sim = simulation(
        body,
        bonds,
        material,
        CriticalStretch::never(),
        PartialVolume::Hhb,
    );
    let eps = to_matrix::<D>(strain);
    let id = Matrix::<D>::identity();
    let f = rotation * (id + eps);
    displace(&mut sim, |_, x| f * x - x);

    let el = elasticity(dim, nu);
    let hooke = to_matrix::<D>(&el.stress(strain, D));
    let green = (f.transpose() * f - id) * 0.5;
    let law = f * to_matrix::<D>(&el.stress(&to_array(&green), D));
    let stress_at = |i: usize| {
        to_matrix::<D>(&{
            let s = sim.engine.stress(&sim.body, &sim.bonds, &sim.state, i);
            let mut a = [[0.0; 3]; 3];
            for r in 0..D {
                a[r][..D].copy_from_slice(&s[r]);
            }
            a
        })
    };
    let w = sim.engine.energy_density(&sim.body, &sim.bonds, &sim.state);
    let stress = stress_at(centre);
    PatchErrors {
        stress_vs_hooke: rel_error(&stress, &(rotation * hooke)),
        energy_vs_classical: w[centre] / el.energy_density(strain, D) - 1.0,
        stress_vs_law: rel_error(&stress, &law),
        stress_vs_law_all_nodes: (0..sim.body.len())
            .map(|i| rel_error(&stress_at(i), &law))
            .fold(0.0, f64::max),
        energy_vs_law: w[centre] / el.energy_density(&to_array(&green), D) - 1.0,
    }
}

/// A homogeneous deformation is reproduced exactly: F = (Σ ω Y⊗ξ w) K⁻¹ = I + ε at every node
/// whose shape tensor is invertible, bulk or surface, so stress and energy density are those
/// of the model's finite-strain law (P = F C:E, W = ½ E:C:E) to round-off, and differ from
/// the linear theory (Hooke, ½ ε:C:ε) only by that law's geometric nonlinearity, O(|ε|).
///
/// Against the linear theory (|ε| = 1e-6): the nonlinearity is largest for the shear,
/// where P − C:ε has diagonal entries (λ + 3μ) ε², i.e. (λ + 3μ)/(2μ) |ε| of the shear stress:
/// 6.0e-6 at ν = 0.45 in plane strain and 3D (λ = 9μ), 2.3e-6 in plane stress; uniaxial
/// strain gives 1.5e-6 (stress) and 1.0e-6 (energy). Asserted: 1e-5 = 10 |ε| (the brief's bar
/// is 2 %; the model is exact, so anything above the nonlinearity would be a bug).
///
/// Against the finite-strain law: the round-off of the relative displacements η = Y − ξ,
/// ε_machine |x| / |η| ≈ 2e-16 × 2e-2 m / 1e-9 m ≈ 4e-9 per bond at worst; measured worst
/// 7.7e-10 at the centre node, 3.7e-9 over all nodes (a surface node, shear at ν = 0.45),
/// 2.9e-10 for the energy density. Asserted: 1e-8, at the centre node and every node.
#[test]
fn homogeneous_deformation_gives_hooke_stress_and_classical_energy() {
    let bound_linear = 10.0 * 1e-6;
    let bound_law = 1e-8;
    let mut worst = [0.0f64; 4];
    for dim in DIMENSIONALITIES {
        for nu in [0.2, 0.35, 0.45] {
            for (k, strain) in strains(dim.dim()).iter().enumerate() {
                for (control, cname) in [
                    (WAN, "Wan"),
                    (ZeroEnergyControl::None, "none"),
                    (SILLING, "Silling"),
                ] {
                    let e = if dim.dim() == 2 {
                        patch::<2>(dim, nu, control, strain, Matrix::identity())
                    } else {
                        patch::<3>(dim, nu, control, strain, Matrix::identity())
                    };
                    println!(
                        "{:12} ν = {nu:4} strain {k} control {cname:7}: stress vs Hooke {:.2e}, energy vs classical {:+.2e}; vs the finite-strain law: stress {:.2e} (all nodes {:.2e}), energy {:+.2e}",
                        dim.describe(),
                        e.stress_vs_hooke,
                        e.energy_vs_classical,
                        e.stress_vs_law,
                        e.stress_vs_law_all_nodes,
                        e.energy_vs_law
                    );
                    let tag = format!("{} ν = {nu} strain {k} {cname}", dim.describe());
                    assert!(
                        e.stress_vs_hooke < bound_linear,
                        "{tag}: stress error {}",
                        e.stress_vs_hooke
                    );
                    assert!(
                        e.energy_vs_classical.abs() < bound_linear,
                        "{tag}: energy error {}",
                        e.energy_vs_classical
                    );
                    assert!(
                        e.stress_vs_law < bound_law && e.stress_vs_law_all_nodes < bound_law,
                        "{tag}: stress vs law {} (all nodes {})",
                        e.stress_vs_law,
                        e.stress_vs_law_all_nodes
                    );
                    assert!(
                        e.energy_vs_law.abs() < bound_law,
                        "{tag}: energy vs law {}",
                        e.energy_vs_law
                    );
                    for (w, v) in worst.iter_mut().zip([
                        e.stress_vs_hooke,
                        e.energy_vs_classical.abs(),
                        e.stress_vs_law_all_nodes,
                        e.energy_vs_law.abs(),
                    ]) {
                        *w = w.max(v);
                    }
                }
            }
        }
    }
    println!(
        "worst: stress vs Hooke {:.2e}, energy vs classical {:.2e}, stress vs law (all nodes) {:.2e}, energy vs law {:.2e}",
        worst[0], worst[1], worst[2], worst[3]
    );
}

/// Objectivity: a finite rotation Q superposed on a strained state rotates the first
/// Piola–Kirchhoff stress (P → Q P) and leaves the energy density unchanged. With the
/// paper's Eq. 9 read literally (C:E taken as the Cauchy stress, P = J (C:E) F⁻ᵀ) the stress
/// of the rotated state is J (C:E) Q F⁻ᵀ instead: wrong by O(|Q − I|), 41 % here (measured
/// before the fix).
///
/// Measured: 1.3e-13 to 3.2e-13 at the centre node, 1.6e-12 at worst over all nodes (stress),
/// 2.3e-13 (energy). Asserted: 1e-9 (round-off; the 1e-8 of the patch test came from 1e-9 m
/// relative displacements, here they are ~3e-4 m).
#[test]
fn superposed_rotation_rotates_the_stress() {
    let angle: f64 = 0.3;
    let (c, s) = (angle.cos(), angle.sin());
    let strain = [
        [1e-3, 0.3e-3, 0.0],
        [0.3e-3, -0.5e-3, 0.0],
        [0.0, 0.0, 0.2e-3],
    ];
    for dim in DIMENSIONALITIES {
        let e = if dim.dim() == 2 {
            patch::<2>(dim, 0.3, WAN, &strain, Matrix::<2>::new(c, -s, s, c))
        } else {
            patch::<3>(
                dim,
                0.3,
                WAN,
                &strain,
                Matrix::<3>::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
            )
        };
        println!(
            "{:12} rotated by {angle} rad: stress vs Q·P(law) {:.2e} (all nodes {:.2e}), energy vs ½E:C:E {:+.2e}, stress vs Q·Hooke {:.2e}",
            dim.describe(),
            e.stress_vs_law,
            e.stress_vs_law_all_nodes,
            e.energy_vs_law,
            e.stress_vs_hooke
        );
        assert!(
            e.stress_vs_law_all_nodes < 1e-9,
            "{}: the rotated stress is not Q P: error {}",
            dim.describe(),
            e.stress_vs_law_all_nodes
        );
        assert!(e.energy_vs_law.abs() < 1e-9);
    }
}

// ---------------------------------------------------------------------------------------
// b. Zero-energy modes, static
// ---------------------------------------------------------------------------------------

/// A 2D plate of n × n nodes, δ = 3Δx, plane stress ν = 0.3.
fn plate<M: Material<2>>(n: usize, material: M) -> Simulation<2, M> {
    let (body, bonds) = lattice_body::<2>(n, DX, 3.0, PartialVolume::Hhb);
    simulation(
        body,
        bonds,
        material,
        CriticalStretch::never(),
        PartialVolume::Hhb,
    )
}

fn plate_material(control: ZeroEnergyControl) -> Correspondence {
    correspondence(Dimensionality::PlaneStress, E, 0.3, 3.0 * DX, control)
}

/// A pseudo-random displacement field of amplitude `amp` with its least-squares affine part
/// (u ≈ a + G x over all nodes, equal volumes) removed: zero mean displacement and zero mean
/// strain.
fn random_field_without_affine_part(body: &Body<2>, amp: f64) -> Vec<Vector<2>> {
    let raw: Vec<Vector<2>> = (0..body.len())
        .map(|i| Vector::<2>::new(amp * noise(2 * i), amp * noise(2 * i + 1)))
        .collect();
    let basis = |x: &Vector<2>| Vector::<3>::new(1.0, x[0] / DX, x[1] / DX);
    let mut normal = Matrix::<3>::zeros();
    for x in &body.positions {
        normal += basis(x) * basis(x).transpose();
    }
    let normal_inv = inverse(&normal).expect("nodes span the plane");
    let mut out = raw.clone();
    for k in 0..2 {
        let mut rhs = Vector::<3>::zeros();
        for (x, u) in body.positions.iter().zip(&raw) {
            rhs += basis(x) * u[k];
        }
        let coef = normal_inv * rhs;
        for (x, u) in body.positions.iter().zip(out.iter_mut()) {
            u[k] -= coef.dot(&basis(x));
        }
    }
    out
}

/// The work −Σ V f·u the internal forces do against a displacement field u: u·K u for the
/// linearised stiffness K, i.e. twice the energy the field stores; a zero-energy mode has
/// none.
fn restoring_work<M: Material<2>>(sim: &mut Simulation<2, M>, field: &[Vector<2>]) -> f64 {
    displace(sim, |i, _| field[i]);
    -(0..sim.body.len())
        .map(|i| sim.body.volumes[i] * sim.state.force[i].dot(&field[i]))
        .sum::<f64>()
}

/// A field with zero mean strain but random at the node scale (amplitude 1e-9 m, Δx = 1e-3 m,
/// least-squares affine part removed): the bare correspondence model sees only its non-local
/// average F, which such a field barely changes, so it resists it far less than Wan's
/// stabilised model or a model without zero-energy modes (LPS, same E and ν).
///
/// Measure: the work −Σ V f·u (twice the energy the field stores in the linearised model);
/// also printed: the RMS force ratio. Measured (24 × 24 plate, δ = 3Δx, plane stress
/// ν = 0.3): none/Wan = 0.048, none/LPS = 0.085, Wan/LPS = 1.79, Silling/LPS = 2.47.
/// Asserted: none/Wan < 0.1 (the unstabilised model keeps less than a tenth of the stabilised
/// stiffness against the rough field), Wan/LPS > 0.5 and Silling/LPS > 0.5 (the stabilised
/// models resist it at least like a model without zero-energy modes, to a factor 2).
#[test]
fn random_field_with_zero_mean_strain_meets_no_resistance_without_control() {
    let n = 24;
    let field = random_field_without_affine_part(&plate(n, plate_material(WAN)).body, 1e-9);
    // (work, RMS force density) of each control.
    let response = |control| {
        let mut sim = plate(n, plate_material(control));
        let work = restoring_work(&mut sim, &field);
        let rms = (sim
            .state
            .force
            .iter()
            .map(|f| f.norm_squared())
            .sum::<f64>()
            / sim.body.len() as f64)
            .sqrt();
        (work, rms)
    };
    let ((none, f_none), (wan, f_wan), (silling, _)) = (
        response(ZeroEnergyControl::None),
        response(WAN),
        response(SILLING),
    );
    let lps_work = restoring_work(
        &mut plate(n, lps(Dimensionality::PlaneStress, E, 0.3, 3.0 * DX)),
        &field,
    );
    println!(
        "random field, zero mean strain: −Σ V f·u = {none:.3e} J (none), {wan:.3e} J (Wan), {silling:.3e} J (Silling), {lps_work:.3e} J (LPS)"
    );
    println!(
        "  work ratios: none/Wan = {:.4}, none/LPS = {:.4}, Wan/LPS = {:.3}, Silling/LPS = {:.3}; RMS force none/Wan = {:.4}",
        none / wan,
        none / lps_work,
        wan / lps_work,
        silling / lps_work,
        f_none / f_wan
    );
    assert!(none > 0.0, "the bare model is not unstable: {none}");
    assert!(none / wan < 0.1, "none/Wan = {}", none / wan);
    assert!(wan / lps_work > 0.5, "Wan/LPS = {}", wan / lps_work);
    assert!(
        silling / lps_work > 0.5,
        "Silling/LPS = {}",
        silling / lps_work
    );
}

/// The checkerboard u = a (−1)^(i+j) (1, 1) is an exact zero-energy mode in the bulk: every
/// bond ξ has a partner −ξ with the same displacement, so F = I wherever the family is full,
/// and nodes 2δ inside the plate (whose neighbours all have full families) feel no force
/// at all without control. Asserted: their largest force is below 1e-10 of Wan's (round-off).
#[test]
fn checkerboard_is_a_zero_energy_mode_without_control() {
    let n = 24;
    let body = plate(n, plate_material(WAN)).body;
    let amp = 1e-9;
    let field: Vec<Vector<2>> = body
        .positions
        .iter()
        .map(|x| {
            let parity = ((x[0] / DX - 0.5).round() + (x[1] / DX - 0.5).round()) as i64 % 2;
            Vector::<2>::new(1.0, 1.0) * if parity == 0 { amp } else { -amp }
        })
        .collect();
    let side = n as f64 * DX;
    let inner = |x: &Vector<2>| (0..2).all(|k| x[k] > 6.0 * DX && x[k] < side - 6.0 * DX);
    let interior_force = |control| {
        let mut sim = plate(n, plate_material(control));
        displace(&mut sim, |i, _| field[i]);
        (0..sim.body.len())
            .filter(|&i| inner(&sim.body.positions[i]))
            .map(|i| sim.state.force[i].norm())
            .fold(0.0, f64::max)
    };
    let (none, wan, silling) = (
        interior_force(ZeroEnergyControl::None),
        interior_force(WAN),
        interior_force(SILLING),
    );
    println!(
        "checkerboard, nodes 2δ inside: max |f| = {none:.3e} (none), {wan:.3e} (Wan), {silling:.3e} (Silling) N/m³; none/Wan = {:.2e}",
        none / wan
    );
    assert!(none < 1e-10 * wan, "none/Wan = {}", none / wan);
    assert!(silling > 0.1 * wan, "Silling/Wan = {}", silling / wan);
}

// ---------------------------------------------------------------------------------------
// c. Zero-energy modes, dynamic
// ---------------------------------------------------------------------------------------

/// Roughness of a displacement field: RMS over nodes with four nearest neighbours of
/// |u_i − mean of u over them|, relative to `scale`. A smooth field of wavelength λ gives
/// ≈ (πΔx/λ)² / 4 · |u|; a checkerboard 2|u|.
fn roughness<M: Material<2>>(sim: &Simulation<2, M>, scale: f64) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for i in 0..sim.body.len() {
        let near: Vec<usize> = sim
            .bonds
            .family(i)
            .filter(|&b| (sim.bonds.ref_lengths[b] - DX).abs() < 1e-6 * DX)
            .map(|b| sim.bonds.neighbors[b] as usize)
            .collect();
        if near.len() == 4 {
            let mean = near
                .iter()
                .fold(Vector::<2>::zeros(), |a, &j| a + sim.state.u[j])
                / 4.0;
            sum += (sim.state.u[i] - mean).norm_squared();
            count += 1;
        }
    }
    (sum / count as f64).sqrt() / scale
}

fn rms_displacement<M: Material<2>>(sim: &Simulation<2, M>) -> f64 {
    (sim.state.u.iter().map(|u| u.norm_squared()).sum::<f64>() / sim.body.len() as f64).sqrt()
}

/// Free vibration of a free 20 × 20 plate (δ = 3Δx) from the smooth displacement
/// u = a (cos πx/L, cos πy/L), no damage, 1000 steps at 0.8 × the stable step. Returns the
/// largest roughness over the run, relative to the initial RMS |u| (fixed, so that passing
/// through zero displacement does not inflate it), or infinity if the run went unstable, and
/// the first step (of those sampled, every 20) at which it exceeded `bound`.
fn peak_roughness(control: ZeroEnergyControl, bound: f64) -> (f64, f64, Option<u64>) {
    let n = 20;
    let mut sim = plate(n, plate_material(control));
    let side = n as f64 * DX;
    let pi = std::f64::consts::PI;
    let body = sim.body.clone();
    for i in 0..body.len() {
        let x = body.positions[i];
        let u = Vector::<2>::new((pi * x[0] / side).cos(), (pi * x[1] / side).cos()) * 1e-6;
        sim.state.set_displacement(&body, i, u);
    }
    sim.refresh_forces().expect("forces at the initial state");
    let scale = rms_displacement(&sim);
    let initial = roughness(&sim, scale);
    let (mut peak, mut first_above): (f64, Option<u64>) = (initial, None);
    for step in 1..=1000 {
        if sim.step().is_err() || sim.check_finite().is_err() {
            return (initial, f64::INFINITY, first_above.or(Some(step)));
        }
        if step % 20 == 0 {
            let r = roughness(&sim, scale);
            let r = if r.is_finite() { r } else { f64::INFINITY };
            if r > bound && first_above.is_none() {
                first_above = Some(step);
            }
            peak = peak.max(r);
        }
    }
    (initial, peak, first_above)
}

/// With Wan's control the field stays smooth (its roughness stays near that of the initial
/// cosine, 0.006); without control hourglass modes grow to a good part of the motion itself.
///
/// Measured: peak over 1000 steps 0.011 with Wan, 0.008 with Silling's control, 0.43
/// without (see the printout for the first step above the bound; no blow-up: the modes have
/// no stiffness, they do not grow exponentially). Asserted: Wan below 0.1 throughout (about
/// ten times its measured peak, twenty times the smooth initial field's level) and Silling
/// likewise, none above
/// 0.1 at some point (or unstable).
#[test]
fn smooth_vibration_stays_smooth_only_with_control() {
    let bound = 0.1;
    let (initial, wan, _) = peak_roughness(WAN, bound);
    let (_, none, none_above) = peak_roughness(ZeroEnergyControl::None, bound);
    let (_, silling, _) = peak_roughness(SILLING, bound);
    println!(
        "roughness (RMS |u − nearest-neighbour mean| / initial RMS |u|): initial {initial:.4}; peak over 1000 steps: Wan {wan:.4}, Silling {silling:.4}, none {none:.4} (above {bound} from step {none_above:?})"
    );
    assert!(wan < bound, "Wan: peak roughness {wan}");
    assert!(silling < bound, "Silling: peak roughness {silling}");
    assert!(
        none > bound,
        "no control: peak roughness {none} stays below {bound}"
    );
}

/// Largest |E(t)/E(0) − 1| of the total energy (kinetic + strain) of a free 16 × 16 plate
/// (δ = 3Δx) released from a rough displacement field (the zero-mean-strain random field of
/// amplitude 1e-9 m), over `steps` steps at `safety` × the stable step, sampled every 50.
/// The field excites the highest frequencies, whose energy velocity Verlet measures with an
/// error ~(ω Δt / 2)²: a small step keeps that below the effect sought.
fn energy_drift(control: ZeroEnergyControl, safety: f64, steps: u64) -> f64 {
    let mut sim = plate(16, plate_material(control));
    sim.dt = safety * sim.dt_stable;
    let field = random_field_without_affine_part(&sim.body, 1e-9);
    let body = sim.body.clone();
    for (i, u) in field.iter().enumerate() {
        sim.state.set_displacement(&body, i, *u);
    }
    sim.refresh_forces().expect("forces at the initial state");
    let e0 = sim.strain_energy() + sim.kinetic_energy();
    let mut drift: f64 = 0.0;
    for step in 1..=steps {
        if sim.step().is_err() || sim.check_finite().is_err() {
            return f64::INFINITY;
        }
        if step % 50 == 0 {
            let e = sim.strain_energy() + sim.kinetic_energy();
            drift = drift.max((e / e0 - 1.0).abs());
        }
    }
    drift
}

/// Every control derives from an energy (see the conformance suite): a free plate released
/// from a rough field keeps its total energy, up to velocity Verlet's bounded O((ω Δt)²)
/// fluctuation, ≲ (0.2)² = 4 % at 0.2 × the stable step. Measured over 5000 steps (1000
/// stable steps of physical time): see the printout (about 1 %). Asserted: 5 %.
///
/// This is the test the earlier bond-projected hourglass force G c (z·M)/|ξ| M failed: it has
/// no potential, and a free plate under it gained energy exponentially (E/E0 ≈ 25 after 8000
/// stable steps at 0.5 Δt_stable), which is why Silling's control is his 2017 form G c_s ω z.
#[test]
fn every_control_keeps_the_energy_of_a_rough_field() {
    for (control, name) in [
        (WAN, "Wan"),
        (SILLING, "Silling"),
        (ZeroEnergyControl::None, "none"),
    ] {
        let drift = energy_drift(control, 0.2, 5000);
        println!("{name}: max |E/E0 − 1| over 5000 steps at 0.2 Δt_stable = {drift:.2e}");
        assert!(drift < 0.05, "{name}: energy drift {drift}");
    }
}

// ---------------------------------------------------------------------------------------
// d. Nodes whose shape tensor is singular
// ---------------------------------------------------------------------------------------

fn cloud_2d(points: &[[f64; 2]]) -> NodeCloud {
    NodeCloud {
        positions: points.iter().map(|p| [p[0], p[1], 0.0]).collect(),
        volumes: vec![DX * DX * THICKNESS; points.len()],
        cell_sizes: vec![DX; points.len()],
        blocks: vec![0; points.len()],
    }
}

/// `Simulation::new` on this body must fail naming `node` (by index, position and bond
/// count), and produce no NaN on the way.
fn expect_singular_error<const D: usize>(body: Body<D>, node_at: &[f64]) {
    let bonds = build_bonds(&body, PartialVolume::Hhb, &[]);
    let node = (0..body.len())
        .find(|&i| {
            body.positions[i]
                .iter()
                .zip(node_at)
                .all(|(a, b)| (a - b).abs() < 1e-12)
        })
        .expect("the node is in the body");
    let position: Vec<f64> = body.positions[node].iter().cloned().collect();
    let count = bonds.family(node).len();
    let dim = if D == 2 {
        Dimensionality::PlaneStress
    } else {
        Dimensionality::ThreeD
    };
    for control in [WAN, ZeroEnergyControl::None, SILLING] {
        let material = correspondence(dim, E, 0.3, 3.0 * DX, control);
        let result = Simulation::new(
            body.clone(),
            bonds.clone(),
            material,
            CriticalStretch::never(),
            PartialVolume::Hhb,
            Loading::default(),
            None,
            0.8,
        );
        let message = match result {
            Ok(_) => panic!("node {node} at {position:?} with {count} bonds was accepted"),
            Err(e) => e.to_string(),
        };
        println!("{message}");
        assert!(
            message.contains(&format!("node {node} at x = {position:?}")),
            "the message does not name node {node} at {position:?}: {message}"
        );
        assert!(
            message.contains(&format!("singular with {count} bonds")),
            "the message does not give the {count} bonds: {message}"
        );
        assert!(!message.contains("NaN"), "{message}");
    }
}

/// A lone node far from a plate has no bonds: K = 0.
#[test]
fn lone_node_is_refused_by_name() {
    let mut points = Vec::new();
    for iy in 0..8 {
        for ix in 0..8 {
            points.push([(ix as f64 + 0.5) * DX, (iy as f64 + 0.5) * DX]);
        }
    }
    let lone = [0.05, 0.0305];
    points.push(lone);
    let body = Body::<2>::from_cloud(cloud_2d(&points), 3.0 * DX, THICKNESS);
    expect_singular_error(body, &lone);
}

/// A line of nodes in 2D: every K has rank 1. The first node in body order is named.
#[test]
fn line_of_nodes_in_2d_is_refused_by_name() {
    let points: Vec<[f64; 2]> = (0..10).map(|i| [(i as f64 + 0.5) * DX, 0.5 * DX]).collect();
    let body = Body::<2>::from_cloud(cloud_2d(&points), 3.0 * DX, THICKNESS);
    let first: Vec<f64> = body.positions[0].iter().cloned().collect();
    expect_singular_error(body, &first);
}

/// A plate of nodes in 3D: every K has rank 2.
#[test]
fn plane_of_nodes_in_3d_is_refused_by_name() {
    let mut cloud = NodeCloud::default();
    for iy in 0..6 {
        for ix in 0..6 {
            cloud
                .positions
                .push([(ix as f64 + 0.5) * DX, (iy as f64 + 0.5) * DX, 0.5 * DX]);
            cloud.volumes.push(DX * DX * DX);
            cloud.cell_sizes.push(DX);
            cloud.blocks.push(0);
        }
    }
    let body = Body::<3>::from_cloud(cloud, 3.0 * DX, 1.0);
    let first: Vec<f64> = body.positions[0].iter().cloned().collect();
    expect_singular_error(body, &first);
}

/// During a run a node may lose bonds until its K is singular (here: all bonds but those
/// along x, then all): it is detached (no force state of its own), and every force stays
/// finite.
#[test]
fn node_that_loses_its_bonds_is_detached_without_nan() {
    for control in [WAN, ZeroEnergyControl::None, SILLING] {
        let mut sim = plate(12, plate_material(control));
        let c = centre_node(&sim.body);
        let xc = sim.body.positions[c];
        let field = random_field_without_affine_part(&sim.body, 1e-9);
        for keep_along_x in [true, false] {
            for b in sim.bonds.family(c) {
                let j = sim.bonds.neighbors[b] as usize;
                let xi = sim.body.positions[j] - xc;
                if keep_along_x && xi[1].abs() < 1e-9 {
                    continue;
                }
                sim.state.status[b] = BROKEN;
                let back = sim.bonds.reverse(c, b).expect("bonds are symmetric");
                sim.state.status[back] = BROKEN;
            }
            displace(&mut sim, |i, _| field[i]);
            let w = sim.engine.energy_density(&sim.body, &sim.bonds, &sim.state);
            assert!(
                sim.state
                    .force
                    .iter()
                    .all(|f| f.iter().all(|v| v.is_finite())),
                "{control:?}: non-finite force"
            );
            assert!(
                w.iter().all(|v| v.is_finite()),
                "{control:?}: non-finite energy"
            );
            assert!(
                w[c] == 0.0,
                "{control:?}: the detached node has energy {}",
                w[c]
            );
        }
    }
}
