//! Random pores (seed 000 §6): N circular (2D) or spherical (3D) pores with radii uniform in
//! [r_min, r_max], centres at least one diameter from the outer boundary and every pair at
//! least r1 + r2 + clearance apart, by rejection sampling from a seeded generator. The same
//! seed gives the same pores on every machine (ChaCha8, explicit seed).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct PoreSpec {
    /// The box the pores go in: `min` and `max` with 2 or 3 entries.
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    pub count: usize,
    pub radius_min: f64,
    pub radius_max: f64,
    /// Smallest gap between two pores' surfaces (m); seed 000 uses 0.3 mm.
    pub clearance: f64,
    pub seed: u64,
}

/// One pore: centre (2 or 3 entries) and radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Pore {
    pub center: Vec<f64>,
    pub radius: f64,
}

/// Rejected draws in a row before giving up.
const ATTEMPTS_PER_PORE: usize = 100_000;

/// Draws the pores; refuses specifications that cannot be met.
pub fn random_pores(spec: &PoreSpec) -> Result<Vec<Pore>, String> {
    let dim = spec.min.len();
    if !(dim == 2 || dim == 3) || spec.max.len() != dim {
        return Err("min and max need 2 or 3 coordinates each".into());
    }
    if !(spec.radius_min > 0.0 && spec.radius_min <= spec.radius_max && spec.radius_max.is_finite())
    {
        return Err(format!(
            "radii must satisfy 0 < radius_min ≤ radius_max, not [{}, {}]",
            spec.radius_min, spec.radius_max
        ));
    }
    if !(spec.clearance >= 0.0 && spec.clearance.is_finite()) {
        return Err(format!("the clearance must be ≥ 0, not {}", spec.clearance));
    }
    // A centre keeps one diameter (of its own pore) from the boundary.
    for a in 0..dim {
        if spec.max[a] - spec.min[a] <= 4.0 * spec.radius_min {
            return Err(format!(
                "the box is {} wide along axis {a}: no pore of radius {} fits one diameter from both sides",
                spec.max[a] - spec.min[a],
                spec.radius_min
            ));
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let mut pores: Vec<Pore> = Vec::with_capacity(spec.count);
    let mut attempts = 0;
    while pores.len() < spec.count {
        attempts += 1;
        if attempts > ATTEMPTS_PER_PORE {
            return Err(format!(
                "placed only {} of {} pores ({attempts} draws in a row found no room): too many or too large pores for the box and clearance",
                pores.len(),
                spec.count
            ));
        }
        let radius = rng.random_range(spec.radius_min..=spec.radius_max);
        let margin = 2.0 * radius;
        if (0..dim).any(|a| spec.max[a] - spec.min[a] <= 2.0 * margin) {
            continue;
        }
        let center: Vec<f64> = (0..dim)
            .map(|a| rng.random_range(spec.min[a] + margin..spec.max[a] - margin))
            .collect();
        let clear = pores.iter().all(|p| {
            let d2: f64 = (0..dim).map(|a| (p.center[a] - center[a]).powi(2)).sum();
            d2.sqrt() >= p.radius + radius + spec.clearance
        });
        if clear {
            pores.push(Pore { center, radius });
            attempts = 0;
        }
    }
    Ok(pores)
}

/// The pores as text, one per line: `x y [z] r` (metres), preceded by a header line
/// starting with `#` that names the specification.
pub fn pores_text(spec: &PoreSpec, pores: &[Pore]) -> String {
    let mut s = format!(
        "# {} pores, radii [{:e}, {:e}] m, clearance {:e} m, seed {}; columns: centre, radius (m)\n",
        pores.len(),
        spec.radius_min,
        spec.radius_max,
        spec.clearance,
        spec.seed
    );
    for p in pores {
        for c in &p.center {
            s += &format!("{c:.17e} ");
        }
        s += &format!("{:.17e}\n", p.radius);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 000 §6: a 50 × 25 mm plate, radii in [0.75, 1.5] mm, clearance 0.3 mm.
    fn seed000(count: usize, seed: u64) -> PoreSpec {
        PoreSpec {
            min: vec![0.0, 0.0],
            max: vec![0.05, 0.025],
            count,
            radius_min: 0.75e-3,
            radius_max: 1.5e-3,
            clearance: 0.3e-3,
            seed,
        }
    }

    #[test]
    fn the_constraints_hold_and_the_seed_repeats() {
        for count in [10, 20, 30] {
            let spec = seed000(count, 7);
            let pores = random_pores(&spec).unwrap();
            assert_eq!(pores.len(), count);
            assert_eq!(pores, random_pores(&spec).unwrap());
            for (k, p) in pores.iter().enumerate() {
                assert!((spec.radius_min..=spec.radius_max).contains(&p.radius));
                for a in 0..2 {
                    assert!(p.center[a] - spec.min[a] >= 2.0 * p.radius);
                    assert!(spec.max[a] - p.center[a] >= 2.0 * p.radius);
                }
                for q in &pores[k + 1..] {
                    let d = (p.center[0] - q.center[0]).hypot(p.center[1] - q.center[1]);
                    assert!(d >= p.radius + q.radius + spec.clearance);
                }
            }
        }
        assert_ne!(random_pores(&seed000(10, 7)), random_pores(&seed000(10, 8)));
    }

    #[test]
    fn spheres_in_3d_and_impossible_requests() {
        let spec = PoreSpec {
            min: vec![0.0; 3],
            max: vec![0.01; 3],
            count: 5,
            radius_min: 5e-4,
            radius_max: 1e-3,
            clearance: 1e-4,
            seed: 1,
        };
        let pores = random_pores(&spec).unwrap();
        assert!(pores.iter().all(|p| p.center.len() == 3));
        let text = pores_text(&spec, &pores);
        assert_eq!(text.lines().count(), 6);
        let crowded = PoreSpec {
            count: 500,
            ..spec.clone()
        };
        assert!(random_pores(&crowded).unwrap_err().contains("placed only"));
        let narrow = PoreSpec {
            max: vec![0.01, 0.01, 0.001],
            ..spec
        };
        assert!(random_pores(&narrow).unwrap_err().contains("axis 2"));
    }
}
