//! Intermediately homogenized PD (IH-PD, seed 001 §4.2): a porous quasi-brittle material as
//! its solid phase with a random fraction of bonds broken before loading.

use super::BROKEN;
use crate::bonds::Bonds;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Porosity φ, critical porosity φc and the seed of the pre-broken bonds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Porosity {
    pub porosity: f64,
    pub critical: f64,
    pub seed: u64,
}

impl Porosity {
    /// Solid-phase property from the measured effective one (seed 001, Eq. 18):
    /// M_sp = M_eff / (1 − φ/φc)², for E, G0 and σu alike.
    pub fn solid_phase(&self, effective: f64) -> f64 {
        effective / (1.0 - self.porosity / self.critical).powi(2)
    }

    /// Breaks a fraction φ of the bonds whose both ends satisfy `member`, each physical bond
    /// with probability φ, drawn from a ChaCha8 stream seeded with `seed` in a fixed order
    /// (node i ascending, then its family, bonds with j > i): the same seed gives the same
    /// bonds on any machine and thread count. Returns the number of physical bonds broken.
    pub fn prebreak(
        &self,
        bonds: &Bonds,
        member: impl Fn(usize) -> bool,
        status: &mut [u8],
    ) -> usize {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut broken = 0;
        for i in 0..bonds.nodes() {
            if !member(i) {
                continue;
            }
            for b in bonds.family(i) {
                let j = bonds.neighbors[b] as usize;
                if j <= i || !member(j) {
                    continue;
                }
                if rng.random::<f64>() < self.porosity {
                    let r = bonds.reverse(i, b).expect("families are symmetric");
                    status[b] = BROKEN;
                    status[r] = BROKEN;
                    broken += 1;
                }
            }
        }
        broken
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed001_solid_phase_values() {
        // Seed 001 §2.7: φ/φc = 1 %, E = 192 GPa → E_sp = 195.9 GPa.
        let p = Porosity {
            porosity: 0.01,
            critical: 1.0,
            seed: 1,
        };
        assert!((p.solid_phase(192e9) / 195.90e9 - 1.0).abs() < 1e-4);
    }
}
