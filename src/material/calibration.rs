//! Classical elastic constants and the dimensional settings shared by every model.

pub use crate::dimensionality::Dimensionality;

/// Isotropic linear elasticity (E, ν) with the derived moduli a model needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elasticity {
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
    pub dimensionality: Dimensionality,
}

impl Elasticity {
    /// Bulk modulus K = E / (3(1 − 2ν)).
    pub fn bulk(&self) -> f64 {
        self.youngs_modulus / (3.0 * (1.0 - 2.0 * self.poisson_ratio))
    }
    /// Shear modulus μ = E / (2(1 + ν)).
    pub fn shear(&self) -> f64 {
        self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))
    }
    /// Lamé's first parameter λ = K − 2μ/3.
    pub fn lame(&self) -> f64 {
        self.bulk() - 2.0 * self.shear() / 3.0
    }
    /// In-plane bulk modulus κ such that W = κ/2 (tr ε)² + μ ε_d:ε_d in the plane:
    /// K in 3D, λ + μ in plane strain, E/(2(1 − ν)) in plane stress.
    pub fn in_plane_bulk(&self) -> f64 {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        match self.dimensionality {
            Dimensionality::ThreeD => self.bulk(),
            Dimensionality::PlaneStrain => self.lame() + self.shear(),
            Dimensionality::PlaneStress => e / (2.0 * (1.0 - nu)),
        }
    }
    /// P-wave (constrained) modulus: λ + 2μ in 3D and plane strain, E/(1 − ν²) in plane stress.
    pub fn p_wave_modulus(&self) -> f64 {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        match self.dimensionality {
            Dimensionality::PlaneStress => e / (1.0 - nu * nu),
            _ => self.lame() + 2.0 * self.shear(),
        }
    }
    /// Classical strain energy density ½ ε:C:ε of a small strain (D×D, symmetric part used),
    /// under the model's plane condition.
    #[allow(clippy::needless_range_loop)] // ε_ab and ε_ba are both read
    pub fn energy_density(&self, strain: &[[f64; 3]; 3], dim: usize) -> f64 {
        let mu = self.shear();
        let kappa = self.in_plane_bulk();
        let tr: f64 = (0..dim).map(|k| strain[k][k]).sum();
        let mut dev2 = 0.0;
        for a in 0..dim {
            for b in 0..dim {
                let e = 0.5 * (strain[a][b] + strain[b][a])
                    - if a == b { tr / dim as f64 } else { 0.0 };
                dev2 += e * e;
            }
        }
        0.5 * kappa * tr * tr + mu * dev2
    }
    /// Classical stress of a small strain under the model's plane condition.
    pub fn stress(&self, strain: &[[f64; 3]; 3], dim: usize) -> [[f64; 3]; 3] {
        let mu = self.shear();
        let kappa = self.in_plane_bulk();
        let tr: f64 = (0..dim).map(|k| strain[k][k]).sum();
        let mut s = [[0.0; 3]; 3];
        for a in 0..dim {
            for b in 0..dim {
                let e = 0.5 * (strain[a][b] + strain[b][a]);
                s[a][b] = 2.0 * mu * e
                    + if a == b {
                        (kappa - 2.0 * mu / dim as f64) * tr
                    } else {
                        0.0
                    };
            }
        }
        s
    }
}

/// Linearised bond stiffness C = c/|ξ| (N/m⁷) of the bond-based material with the same
/// P-wave modulus M, for the stable time step of state-based models: c = 18K'/(πδ⁴) with
/// K' = M/1.8 in 3D; c = 12κ'/(πδ³ t) with κ' = 2M/3 in 2D (seed 001 Eq. 6 rewritten).
pub fn equivalent_bond_stiffness(
    elasticity: &Elasticity,
    horizon: f64,
    thickness: f64,
    ref_len: f64,
) -> f64 {
    let m = elasticity.p_wave_modulus();
    let c = match elasticity.dimensionality {
        Dimensionality::ThreeD => 18.0 * (m / 1.8) / (std::f64::consts::PI * horizon.powi(4)),
        _ => 12.0 * (2.0 * m / 3.0) / (std::f64::consts::PI * horizon.powi(3) * thickness),
    };
    c / ref_len
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_stress_uniaxial_stress_is_e_times_strain() {
        let el = Elasticity {
            youngs_modulus: 2.0,
            poisson_ratio: 0.3,
            dimensionality: Dimensionality::PlaneStress,
        };
        let (ex, ey) = (1e-3, -0.3e-3);
        let s = el.stress(&[[ex, 0.0, 0.0], [0.0, ey, 0.0], [0.0; 3]], 2);
        assert!((s[0][0] - 2.0 * ex).abs() < 1e-15 && s[1][1].abs() < 1e-15);
    }

    #[test]
    fn three_d_uniaxial_stress_is_e_times_strain() {
        let el = Elasticity {
            youngs_modulus: 2.0,
            poisson_ratio: 0.25,
            dimensionality: Dimensionality::ThreeD,
        };
        let (ex, et) = (1e-3, -0.25e-3);
        let s = el.stress(&[[ex, 0.0, 0.0], [0.0, et, 0.0], [0.0, 0.0, et]], 3);
        assert!((s[0][0] - 2.0 * ex).abs() < 1e-15 && s[1][1].abs() < 1e-15);
    }
}
