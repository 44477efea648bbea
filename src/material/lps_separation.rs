//! The critical stretch of an LPS material from its fracture energy.
//!
//! For a bond-based material the energy to break every bond across a plane is a sum of
//! independent bond energies (seed 001, Eqs. 7–8). For the LPS it is not: a bond's force
//! depends on the dilatation of both its ends, which changes as their other bonds break.
//! We therefore compute, by quadrature of the continuum equations, the work W(s0) to pull a
//! body apart through a plane — its two halves moving rigidly apart, each bond breaking once
//! its stretch exceeds s0 — and choose s0 so that W = G0. Under small strains W is
//! homogeneous of degree 2 in s0, so one evaluation at s0 = 1 suffices: s0 = sqrt(G0/W(1)).
//!
//! The body: the plane x = 0, a point at depth z (left), a bond ξ crossing the plane when
//! ξ_x > z, opening d: extension e = d ξ_x/|ξ|; the bond breaks (irreversibly, d grows) when
//! e/|ξ| > s0. θ(z) = (c_θ/m) ∫ ω |ξ| e dV over intact crossing bonds, the scalar force state
//! t(θ) of `Lps::scalar_state`, the force per unit area across the plane
//! F(d) = ∫_0^δ dz ∫ (t_i + t_j) ξ_x/|ξ| dV, and W = ∫ F dd. In 2D every integral is per unit
//! thickness.

/// Quadrature points per coordinate (depth, normal and transverse bond components).
const N: usize = 64;
/// Openings d / (s0 δ) sampled on a log scale, and their range.
const OPENINGS: usize = 160;
const D_MIN: f64 = 1e-3;
const D_MAX: f64 = 1e3;

/// What the separation integral needs from an ordinary state-based law.
pub struct ScalarLaw<'a> {
    pub dim: usize,
    pub horizon: f64,
    /// θ = theta_factor/m Σ ω|ξ|e dV.
    pub theta_factor: f64,
    /// The scalar force state of a node with 1/m, θ, ω, e and |ξ|.
    pub state: &'a dyn Fn(f64, f64, f64, f64, f64) -> f64,
    /// ω(|ξ|).
    pub omega: &'a dyn Fn(f64) -> f64,
}

/// One crossing bond of the quadrature, from a point at depth z.
struct Bond {
    /// Depth of the far end on the other side, ξ_x − z.
    far: f64,
    len: f64,
    cos: f64,
    omega: f64,
    /// Quadrature weight (dz dV).
    weight: f64,
    /// Opening at which it breaks, per unit s0: |ξ|²/ξ_x.
    breaks_at: f64,
}

/// W(s0 = 1): the work per unit area to separate the body, in J/m² at unit critical stretch.
pub fn separation_work_at_unit_stretch(law: &ScalarLaw) -> f64 {
    let delta = law.horizon;
    let h = delta / N as f64;
    // Weighted volume m = ∫ ω |ξ|² dV.
    let m: f64 = (0..4 * N)
        .map(|k| {
            let r = (k as f64 + 0.5) * delta / (4 * N) as f64;
            let shell = if law.dim == 3 {
                4.0 * std::f64::consts::PI * r * r
            } else {
                2.0 * std::f64::consts::PI * r
            };
            (law.omega)(r) * r * r * shell * delta / (4 * N) as f64
        })
        .sum();
    let inv_m = 1.0 / m;
    // The crossing bonds of each depth z_k, by midpoint quadrature in (z, ξ_x, transverse).
    let depths: Vec<f64> = (0..N).map(|k| (k as f64 + 0.5) * h).collect();
    let bonds: Vec<Vec<Bond>> = depths
        .iter()
        .map(|&z| {
            let mut out = Vec::new();
            let hx = (delta - z) / N as f64;
            for a in 0..N {
                let xn = z + (a as f64 + 0.5) * hx;
                let reach = (delta * delta - xn * xn).max(0.0).sqrt();
                let hr = reach / N as f64;
                for b in 0..N {
                    let rho = (b as f64 + 0.5) * hr;
                    let len = (xn * xn + rho * rho).sqrt();
                    // 3D: a ring of radius ρ; 2D: both signs of the transverse component.
                    let transverse = if law.dim == 3 {
                        2.0 * std::f64::consts::PI * rho
                    } else {
                        2.0
                    };
                    out.push(Bond {
                        far: xn - z,
                        len,
                        cos: xn / len,
                        omega: (law.omega)(len),
                        weight: h * hx * hr * transverse,
                        breaks_at: len * len / xn,
                    });
                }
            }
            out
        })
        .collect();
    // θ at depth z for opening d (s0 = 1); linear interpolation between depths, 0 beyond δ.
    let theta_at = |thetas: &[f64], z: f64| -> f64 {
        let x = z / h - 0.5;
        if x <= 0.0 {
            return thetas[0];
        }
        let k = x.floor() as usize;
        if k + 1 >= N {
            return if z < delta { thetas[N - 1] } else { 0.0 };
        }
        let f = x - k as f64;
        thetas[k] * (1.0 - f) + thetas[k + 1] * f
    };
    let force = |d: f64| -> f64 {
        let intact = |b: &Bond| d <= b.breaks_at;
        let thetas: Vec<f64> = bonds
            .iter()
            .map(|list| {
                let sum: f64 = list
                    .iter()
                    .filter(|b| intact(b))
                    .map(|b| b.omega * b.len * d * b.cos * b.weight / h)
                    .sum();
                law.theta_factor * inv_m * sum
            })
            .collect();
        bonds
            .iter()
            .enumerate()
            .map(|(k, list)| {
                list.iter()
                    .filter(|b| intact(b))
                    .map(|b| {
                        let e = d * b.cos;
                        let ti = (law.state)(inv_m, thetas[k], b.omega, e, b.len);
                        let tj = (law.state)(inv_m, theta_at(&thetas, b.far), b.omega, e, b.len);
                        (ti + tj) * b.cos * b.weight
                    })
                    .sum::<f64>()
            })
            .sum()
    };
    // W = ∫ F dd on a log scale of d/δ (F is linear below the first break).
    let ds: Vec<f64> = (0..OPENINGS)
        .map(|k| delta * D_MIN * (D_MAX / D_MIN).powf(k as f64 / (OPENINGS - 1) as f64))
        .collect();
    let fs: Vec<f64> = ds.iter().map(|&d| force(d)).collect();
    let mut work = 0.5 * fs[0] * ds[0];
    for k in 1..OPENINGS {
        work += 0.5 * (fs[k - 1] + fs[k]) * (ds[k] - ds[k - 1]);
    }
    work
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bond-based law (t = ½ c s, no dilatation) must give the closed forms of seed 001,
    /// Eqs. 7–8: W = c s0² δ⁴/4 in 2D and π c s0² δ⁵/10 in 3D.
    #[test]
    fn bond_based_law_gives_seed001_eq8() {
        let c = 2.0e20;
        let delta = 3e-3;
        let state = |_: f64, _: f64, _: f64, e: f64, l: f64| 0.5 * c * e / l;
        let omega = |_: f64| 1.0;
        for dim in [2, 3] {
            let law = ScalarLaw {
                dim,
                horizon: delta,
                theta_factor: 0.0,
                state: &state,
                omega: &omega,
            };
            let w = separation_work_at_unit_stretch(&law);
            let exact = if dim == 2 {
                c * delta.powi(4) / 4.0
            } else {
                std::f64::consts::PI * c * delta.powi(5) / 10.0
            };
            println!("{dim}D: W / closed form = {:.5}", w / exact);
            assert!((w / exact - 1.0).abs() < 5e-3, "{dim}D: {}", w / exact);
        }
    }
}
