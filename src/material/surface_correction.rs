//! Surface correction of bond-based PMB: a node near a free surface misses part of its family
//! and is too soft. Each node gets a factor λ_i and a bond's micromodulus is scaled by
//! ½(λ_i + λ_j) (seed 000, Eq. 11). The engine's pair weight of a PMB bond is
//! ½(c_i φ_ij μ_ij + c_j φ_ji μ_ji), so scaling each node's c_i by λ_i gives exactly that
//! factor on uniform grids (and the half-by-half form, still the gradient of the discrete
//! energy, on non-uniform ones).
//!
//! Three ways to compute λ, all from the uniaxial strain ε_xx = ε of seed 000 §2.5 (the
//! energy methods) with w_ij node i's half of the bond energy and W0 the energy density of a
//! node with a full neighbourhood:
//! - **energy** (Madenci & Oterkus 2014; Le & Bobaru 2018): λ_i = W0 / Σ_j w_ij, once.
//! - **energy_iterated** (seed 000 §2.5, literally): W_i = Σ_j ½ (λ_i + λ_j) w_ij and
//!   λ_i ← λ_i W0 / W_i until no factor changes by more than 1e-7 of itself. Erratum: the fixed
//!   point of this iteration (W_i = W0 at every node, a linear system for λ) oscillates across
//!   a band of δ next to an edge normal to the strain. On a rectangle with δ = 3Δx or 4Δx it
//!   ranges from 0.1 or 0.03 to 4.4 or 4.7, and with δ = 3.5Δx it has negative factors, so the
//!   iteration drives them to zero and never settles (it is refused then). The one-pass
//!   `energy` factor is the default energy method for this reason (docs/deck.md).
//! - **volume** (Le & Bobaru 2018, "volume method"): λ_i = V_H / (V_i + Σ_j φ_ij V_j), the
//!   horizon's volume over the part of it that the node and its family cover.
//!
//! The paper takes W0 from a bulk node of a very fine grid (δ/Δx = 25); here it is the
//! continuum value that such a grid approaches, the classical ½ ε:C:ε of the model's own
//! elasticity (equal to the PD energy of a homogeneous strain by the calibration of c, seed 001
//! Eq. 6). As in the paper, the bulk factor therefore also absorbs the quadrature error of the
//! grid. The stretch is the small-strain one, s = ε n_x², so λ does not depend on ε.
//!
//! Bonds cut by a pre-crack count as intact here: a pre-crack is a crack, not a free surface
//! of the reference body. The critical stretch is not scaled (seed 000 scales the force only).

use super::{BondGeom, Pmb};
use crate::body::Body;
use crate::bonds::{Bonds, Quadrature};
use crate::solver::ranks::Share;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The paper's convergence tolerance: the largest relative change of any λ (seed 000 §2.5).
pub const TOLERANCE: f64 = 1e-7;
/// Iterations allowed before the energy method gives up.
pub const MAX_ITERATIONS: usize = 5000;
/// Strain of the fictitious uniaxial load (seed 000 §2.5: 0.01 %). With the small-strain
/// stretch it only sets the scale of W.
const STRAIN: f64 = 1e-4;

/// Which surface correction a deck asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceCorrection {
    /// No correction (seeds 001, 002 and the engine's version-1 decks).
    #[default]
    None,
    /// Energy ratio W0 / W_i, one pass (Madenci & Oterkus 2014).
    Energy,
    /// Energy factors iterated with the bond average, as seed 000 §2.5 writes it.
    EnergyIterated,
    /// Horizon volume over family volume (Le & Bobaru 2018).
    Volume,
}

/// The factors of a body and how they were found.
#[derive(Debug, Clone)]
pub struct SurfaceFactors {
    /// λ_i per node.
    pub factors: Vec<f64>,
    pub report: SurfaceReport,
}

/// What `check` and `resolved.toml` say about the correction.
#[derive(Debug, Clone, Serialize)]
pub struct SurfaceReport {
    pub method: SurfaceCorrection,
    pub min: f64,
    pub max: f64,
    /// Fixed-point iterations (energy method; 1 for the volume method).
    pub iterations: usize,
}

impl std::fmt::Display for SurfaceReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let method = match self.method {
            SurfaceCorrection::None => "none",
            SurfaceCorrection::Energy => "energy method",
            SurfaceCorrection::EnergyIterated => "energy method, iterated",
            SurfaceCorrection::Volume => "volume method",
        };
        write!(
            f,
            "surface correction ({method}): λ from {:.4} to {:.4} ({} iteration{})",
            self.min,
            self.max,
            self.iterations,
            if self.iterations == 1 { "" } else { "s" }
        )
    }
}

/// The iterated energy method did not settle.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotConverged {
    #[error(
        "the iterated energy surface correction did not converge in {iterations} iterations: \
         the largest relative change of a factor is still {change:.3e} (node at {position:?}), \
         tolerance {TOLERANCE:e}"
    )]
    Slow {
        iterations: usize,
        change: f64,
        position: Vec<f64>,
    },
    #[error(
        "the iterated energy surface correction has no positive solution on this grid: the \
         factor of the node at {position:?} fell to {value:.2e} after {iterations} iterations \
         (seed 000's iteration oscillates near edges normal to x, docs/deck.md); use \
         surface_correction = \"energy\""
    )]
    Vanishing {
        iterations: usize,
        value: f64,
        position: Vec<f64>,
    },
}

/// A factor this small means the iteration is heading for a fixed point at or below zero.
const VANISHING: f64 = 1e-3;

/// Computes λ for every node of a PMB body; `None` when no correction is asked for. On a rank
/// of a distributed run (`share`), the owned nodes' factors are the one process's, bit for bit
/// (a ghost's one-pass factor is replaced by its owner's later, `Material::share_constants`).
pub fn surface_factors<const D: usize>(
    method: SurfaceCorrection,
    body: &Body<D>,
    bonds: &Bonds,
    quad: &Quadrature,
    pmb: &Pmb,
    share: Option<&Share>,
) -> Result<Option<SurfaceFactors>, NotConverged> {
    let (factors, iterations) = match method {
        SurfaceCorrection::None => return Ok(None),
        SurfaceCorrection::Volume => (volume_factors(body, bonds, quad), 1),
        SurfaceCorrection::Energy => (energy_ratio(body, bonds, quad, pmb), 1),
        SurfaceCorrection::EnergyIterated => energy_factors(body, bonds, quad, pmb, share)?,
    };
    let (min, max) = factors
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    Ok(Some(SurfaceFactors {
        factors,
        report: SurfaceReport {
            method,
            min,
            max,
            iterations,
        },
    }))
}

/// The same material with each node's micromodulus scaled by its factor.
pub fn corrected(mut pmb: Pmb, factors: &[f64]) -> Pmb {
    pmb.c0 = crate::per_node::PerNode::from_values(
        factors
            .iter()
            .enumerate()
            .map(|(i, &l)| l * pmb.c0.at(i))
            .collect(),
    );
    pmb
}

/// λ_i = V_H / (V_i + Σ_j φ_ij V_j).
fn volume_factors<const D: usize>(body: &Body<D>, bonds: &Bonds, quad: &Quadrature) -> Vec<f64> {
    let thickness = if D == 2 { body.thickness } else { 1.0 };
    (0..body.len())
        .into_par_iter()
        .map(|i| {
            let h = body.horizons[i];
            let full = match D {
                2 => std::f64::consts::PI * h * h * thickness,
                _ => 4.0 / 3.0 * std::f64::consts::PI * h * h * h,
            };
            let covered = bonds.family(i).fold(body.volumes[i], |acc, b| {
                let j = bonds.neighbors[b] as usize;
                acc + quad.phi_pair(b, i, j, bonds.ref_lengths[b]).0 * body.volumes[j]
            });
            full / covered
        })
        .collect()
}

/// Node i's half of the energy of bond b under ε_xx = ε (small-strain stretch ε n_x²).
fn half_energy<const D: usize>(
    body: &Body<D>,
    bonds: &Bonds,
    quad: &Quadrature,
    pmb: &Pmb,
    i: usize,
    b: usize,
) -> f64 {
    use super::Material;
    let j = bonds.neighbors[b] as usize;
    let l = bonds.ref_lengths[b];
    let n_x = (body.positions[j][0] - body.positions[i][0]) / l;
    let (phi_ij, phi_ji) = quad.phi_pair(b, i, j, l);
    let mut g = BondGeom::<D>::intact(l, l * (1.0 + STRAIN * n_x * n_x), phi_ij, body.volumes[j]);
    g.phi_ji = phi_ji;
    <Pmb as Material<D>>::bond_energy(pmb, i, &g, &())
}

/// Energy density of the full neighbourhood under ε_xx = ε.
fn reference_energy<const D: usize>(pmb: &Pmb) -> f64 {
    let mut strain = [[0.0; 3]; 3];
    strain[0][0] = STRAIN;
    pmb.elasticity.energy_density(&strain, D)
}

/// λ_i = W0 / Σ_j w_ij: the first sweep of seed 000's iteration, from λ = 1.
fn energy_ratio<const D: usize>(
    body: &Body<D>,
    bonds: &Bonds,
    quad: &Quadrature,
    pmb: &Pmb,
) -> Vec<f64> {
    energy_sweep(body, bonds, quad, pmb, &vec![1.0; body.len()])
}

/// One sweep of seed 000 §2.5: λ_i W0 / Σ_j ½(λ_i + λ_j) w_ij for every node (a node without
/// bonds keeps its factor: it carries no energy to correct).
fn energy_sweep<const D: usize>(
    body: &Body<D>,
    bonds: &Bonds,
    quad: &Quadrature,
    pmb: &Pmb,
    lambda: &[f64],
) -> Vec<f64> {
    let w0 = reference_energy::<D>(pmb);
    (0..body.len())
        .into_par_iter()
        .map(|i| {
            let w: f64 = bonds.family(i).fold(0.0, |acc, b| {
                let j = bonds.neighbors[b] as usize;
                acc + 0.5 * (lambda[i] + lambda[j]) * half_energy(body, bonds, quad, pmb, i, b)
            });
            if w > 0.0 {
                lambda[i] * w0 / w
            } else {
                lambda[i]
            }
        })
        .collect()
}

/// Seed 000 §2.5: Jacobi sweeps (deterministic for any thread count) until the largest
/// relative change of a factor is below [`TOLERANCE`]. A rank iterates its owned nodes and its
/// ghosts take their owners' factors after each sweep (the next sweep reads them); the largest
/// change and a vanishing factor are the whole body's, so every rank stops at the same sweep.
fn energy_factors<const D: usize>(
    body: &Body<D>,
    bonds: &Bonds,
    quad: &Quadrature,
    pmb: &Pmb,
    share: Option<&Share>,
) -> Result<(Vec<f64>, usize), NotConverged> {
    let owned = share.map_or(body.len(), |s| s.owned);
    let mut lambda = vec![1.0; body.len()];
    for iteration in 1..=MAX_ITERATIONS {
        let mut next = energy_sweep(body, bonds, quad, pmb, &lambda);
        if let Some(s) = share {
            s.halo.exchange_values(&*s.ranks, &mut next);
        }
        let (node, local_change) = next[..owned]
            .iter()
            .zip(&lambda)
            .map(|(a, b)| ((a - b) / b).abs())
            .enumerate()
            .fold(
                (0, 0.0),
                |best, (k, c)| if c > best.1 { (k, c) } else { best },
            );
        let change = share.map_or(local_change, |s| s.ranks.max_f64(local_change));
        let vanishing = next[..owned].iter().position(|&l| l < VANISHING);
        if let Some((value, position)) =
            first_over_ranks(share, body, vanishing.map(|k| (k, next[k])))
        {
            return Err(NotConverged::Vanishing {
                iterations: iteration,
                value,
                position,
            });
        }
        lambda = next;
        if change < TOLERANCE {
            return Ok((lambda, iteration));
        }
        if iteration == MAX_ITERATIONS {
            let mine = (local_change == change).then_some((node, change));
            let (change, position) =
                first_over_ranks(share, body, mine).expect("some rank has the largest change");
            return Err(NotConverged::Slow {
                iterations: iteration,
                change,
                position,
            });
        }
    }
    unreachable!("the loop returns on its last iteration")
}

/// The value and position of the first node in global order that some rank names (`local`:
/// one of its owned nodes and a value), on every rank; every rank calls it.
fn first_over_ranks<const D: usize>(
    share: Option<&Share>,
    body: &Body<D>,
    local: Option<(usize, f64)>,
) -> Option<(f64, Vec<f64>)> {
    let mine = local.map(|(k, value)| (value, body.positions[k].as_slice().to_vec()));
    let Some(s) = share else {
        return mine;
    };
    // [named?, value, position]: the ranks own consecutive parts of the global order.
    let mut words = vec![0.0; 2 + D];
    if let Some((value, position)) = &mine {
        words[0] = 1.0;
        words[1] = *value;
        words[2..].copy_from_slice(position);
    }
    s.ranks
        .all_gather(&words)
        .chunks_exact(2 + D)
        .find(|w| w[0] == 1.0)
        .map(|w| (w[1], w[2..].to_vec()))
}
