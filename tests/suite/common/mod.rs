//! Builders shared by the verification tests.
#![allow(dead_code)]

use peridyn::body::Body;
use peridyn::bonds::{search::build_bonds, Bonds, PartialVolume};
use peridyn::damage::Damage;
use peridyn::deck::build::{build_constitution, build_model, MaterialChoice};
use peridyn::deck::LoadedDeck;
use peridyn::discretize::lattice::lattice;
use peridyn::geometry::Shape;
use peridyn::loading::Loading;
use peridyn::material::correspondence::ZeroEnergyControl;
use peridyn::material::{
    Correspondence, Dimensionality, Elasticity, Influence, Lps, Material, MicromodulusProfile, Pmb,
};
use peridyn::math::Vector;
use peridyn::run::{prepare, ModelReport, RunError};
use peridyn::solver::Simulation;

pub const THICKNESS: f64 = 1e-3;

/// A square (2D) or cube (3D) lattice of `n` cells per side, spacing `dx`, horizon ratio `m`.
pub fn lattice_body<const D: usize>(
    n: usize,
    dx: f64,
    m: f64,
    rule: PartialVolume,
) -> (Body<D>, Bonds) {
    let side = n as f64 * dx;
    let shape = Shape::cube(D, side);
    let cloud = lattice(&shape, D, dx, THICKNESS).unwrap();
    let body = Body::<D>::from_cloud(cloud, m * dx, THICKNESS);
    let bonds = build_bonds(&body, rule, &[]);
    (body, bonds)
}

/// The node closest to the centre of the body.
pub fn centre_node<const D: usize>(body: &Body<D>) -> usize {
    let mut c = peridyn::math::Vector::<D>::zeros();
    for p in &body.positions {
        c += p;
    }
    c /= body.len() as f64;
    (0..body.len())
        .min_by(|&a, &b| {
            (body.positions[a] - c)
                .norm()
                .partial_cmp(&(body.positions[b] - c).norm())
                .unwrap()
        })
        .unwrap()
}

pub fn pmb(dim: Dimensionality, e: f64, horizon: f64, profile: MicromodulusProfile) -> Pmb {
    Pmb::calibrated(e, 2000.0, dim, profile, horizon, THICKNESS)
}

pub fn lps(dim: Dimensionality, e: f64, nu: f64, horizon: f64) -> Lps {
    Lps::new(
        Elasticity {
            youngs_modulus: e,
            poisson_ratio: nu,
            dimensionality: dim,
        },
        Influence::Constant,
        horizon,
        2000.0,
        THICKNESS,
    )
}

/// Correspondence material (constant influence function, ρ = 2000 kg/m³).
pub fn correspondence(
    dim: Dimensionality,
    e: f64,
    nu: f64,
    horizon: f64,
    control: ZeroEnergyControl,
) -> Correspondence {
    Correspondence::new(
        Elasticity {
            youngs_modulus: e,
            poisson_ratio: nu,
            dimensionality: dim,
        },
        Influence::Constant,
        control,
        horizon,
        2000.0,
        THICKNESS,
    )
}

/// A simulation at rest with no loads, dt = 0.8 × the stable estimate.
pub fn simulation<const D: usize, M: Material<D>>(
    body: Body<D>,
    bonds: Bonds,
    material: M,
    damage: impl Into<Damage>,
    rule: PartialVolume,
) -> Simulation<D, M> {
    Simulation::new(
        body,
        bonds,
        material,
        damage,
        rule,
        Loading::default(),
        None,
        0.8,
    )
    .expect("the test model sets up")
}

/// Strain tensor padded to 3×3 from a D×D array.
pub fn strain3(e: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    *e
}

/// A lattice over `shape` (spacing `dx`) whose nodes with x < `split` have horizon `m_left·dx`
/// and the others `m_right·dx` (dual-horizon PD); bonds built for those horizons.
pub fn two_horizon_body<const D: usize>(
    shape: &Shape,
    dx: f64,
    m_left: f64,
    m_right: f64,
    split: f64,
    rule: PartialVolume,
) -> (Body<D>, Bonds) {
    let cloud = lattice(shape, D, dx, THICKNESS).unwrap();
    let mut body = Body::<D>::from_cloud(cloud, m_left * dx, THICKNESS);
    for i in 0..body.len() {
        if body.positions[i][0] >= split {
            body.horizons[i] = m_right * dx;
        }
    }
    let bonds = build_bonds(&body, rule, &[]);
    (body, bonds)
}

/// Sets every node's displacement to `f(i, x)` and evaluates the forces.
pub fn displace<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    f: impl Fn(usize, &Vector<D>) -> Vector<D>,
) {
    let body = sim.body.clone();
    for i in 0..body.len() {
        sim.state
            .set_displacement(&body, i, f(i, &body.positions[i]));
    }
    sim.engine.compute(&sim.body, &sim.bonds, &mut sim.state);
}

/// The largest nodal force density.
pub fn max_force<const D: usize, M: Material<D>>(sim: &Simulation<D, M>) -> f64 {
    sim.state.force.iter().map(|f| f.norm()).fold(0.0, f64::max)
}

/// A 2D deck of one PMB material built into its simulation and report, not run.
pub fn pmb_deck_simulation(ld: &LoadedDeck) -> Result<(Simulation<2, Pmb>, ModelReport), RunError> {
    pmb_deck_simulation_in::<2>(ld)
}

/// A 2D deck of one LPS material built into its simulation and report, not run.
pub fn lps_deck_simulation(
    ld: &LoadedDeck,
) -> Result<(Simulation<2, peridyn::material::Lps>, ModelReport), RunError> {
    let model = build_model::<2>(ld)?;
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    let MaterialChoice::Lps(lps) = material else {
        panic!("a deck of one LPS material")
    };
    prepare(ld, model, lps, rest)
}

/// `pmb_deck_simulation` in dimension D.
pub fn pmb_deck_simulation_in<const D: usize>(
    ld: &LoadedDeck,
) -> Result<(Simulation<D, Pmb>, ModelReport), RunError> {
    let model = build_model::<D>(ld)?;
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    let MaterialChoice::Pmb(pmb) = material else {
        panic!("a deck of one PMB material")
    };
    prepare(ld, model, pmb, rest)
}
