//! The energy needed to break every bond across a plane equals G0 (seed 001, Eqs. 7–8):
//! the sum of the micropotentials at the critical stretch over all bonds crossing a plane,
//! per unit area, using the code's own families, partial volumes and calibration.

use super::common;

use common::*;
use peridyn::bonds::PartialVolume;
use peridyn::damage::CriticalStretch;
use peridyn::material::{BondGeom, Dimensionality, Material, MicromodulusProfile};

/// Energy per unit area to break every bond crossing the plane x_{D−1} = mid, counted for bonds
/// whose midpoint lies in the central window (away from the lateral surfaces).
fn separation_energy<const D: usize>(
    dim: Dimensionality,
    m: f64,
    profile: MicromodulusProfile,
) -> f64 {
    let (g0, e, dx) = (300.0, 3e9, 1e-3);
    let h = m * dx;
    let material = pmb(dim, e, h, profile);
    let c = material.c0_paper;
    let s0 = peridyn::material::Pmb::critical_stretch_from_g0(g0, c, dim, profile, h);
    let n = (6.0 * m) as usize + 2;
    let (body, bonds) = lattice_body::<D>(n, dx, m, PartialVolume::Hhb);
    let sim = simulation(
        body,
        bonds,
        material,
        CriticalStretch::never(),
        PartialVolume::Hhb,
    );
    let side = n as f64 * dx;
    let mid = 0.5 * side;
    // Window: the central square (or interval) of the plane, one third of the side wide.
    let (lo, hi) = (side / 3.0, 2.0 * side / 3.0);
    let mut energy = 0.0;
    for i in 0..sim.body.len() {
        let xi = sim.body.positions[i];
        for b in sim.bonds.family(i) {
            let j = sim.bonds.neighbors[b] as usize;
            let xj = sim.body.positions[j];
            if (xi[D - 1] - mid) * (xj[D - 1] - mid) >= 0.0 {
                continue;
            }
            let centre = (xi + xj) * 0.5;
            if (0..D - 1).any(|k| centre[k] < lo || centre[k] >= hi) {
                continue;
            }
            let l = sim.bonds.ref_lengths[b];
            let phi = sim.engine.quad.phi_pair(b, i, j, l).0;
            let g = BondGeom::<D>::intact(l, l * (1.0 + s0), phi, sim.body.volumes[j]);
            // bond_energy is node i's half of the pair micropotential, per unit volume of i.
            energy +=
                sim.body.volumes[i] * Material::<D>::bond_energy(&sim.engine.material, i, &g, &());
        }
    }
    let area = (hi - lo).powi(D as i32 - 1) * if D == 2 { THICKNESS } else { 1.0 };
    energy / area / g0
}

#[test]
fn pmb_separation_energy_equals_g0() {
    for (dim, name) in [
        (Dimensionality::PlaneStress, "plane stress"),
        (Dimensionality::PlaneStrain, "plane strain"),
        (Dimensionality::ThreeD, "3D"),
    ] {
        for profile in [MicromodulusProfile::Constant, MicromodulusProfile::Conical] {
            for m in [3.0, 4.0, 5.0] {
                let ratio = if dim.dim() == 2 {
                    separation_energy::<2>(dim, m, profile)
                } else {
                    separation_energy::<3>(dim, m, profile)
                };
                println!("PMB {name:12} {profile:?} δ/Δx = {m}: G_PD/G0 = {ratio:.4}");
                // The conical profile converges more slowly (its weight peaks at 3δ/4 and vanishes
                // at δ, where the partial-volume cells sit); it is reported, asserted for the
                // constant profile the papers calibrate.
                if m >= 4.0 && profile == MicromodulusProfile::Constant {
                    assert!(
                        (ratio - 1.0).abs() < 0.03,
                        "{name} {profile:?} δ/Δx = {m}: G_PD/G0 = {ratio}"
                    );
                }
            }
        }
    }
}
