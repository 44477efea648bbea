//! Deck → model: body, bonds, loading, material and solver settings.

use super::schema::*;
use super::validate::dimensionality;
use super::{DeckError, DeckIssue, LoadedDeck};
use crate::body::Body;
use crate::bonds::{search::build_bonds, Bonds, PartialVolume};
use crate::discretize::{lattice::lattice, NodeCloud};
use crate::geometry::point_cloud::read_point_cloud;
use crate::loading::{BoundaryCondition, InitialVelocity, Load, Loading};
use crate::material::{Dimensionality, Elasticity, Lps, Pmb};
use crate::math::{vector_from_slice, Vector};

/// The discretized body with its families and loading.
pub struct Model<const D: usize> {
    pub body: Body<D>,
    pub bonds: Bonds,
    pub loading: Loading<D>,
    pub rule: PartialVolume,
    /// Horizon δ (m).
    pub horizon: f64,
    /// Smallest cell size Δx (m).
    pub spacing: f64,
    pub dimensionality: Dimensionality,
    /// (name, initial velocity) pairs still to apply to the state.
    pub initial_velocities: Vec<InitialVelocity<D>>,
}

/// The material of a deck, calibrated.
#[derive(Debug, Clone)]
pub enum MaterialChoice {
    Pmb(Pmb),
    Lps(Lps),
}

/// Solver settings of an explicit run.
#[derive(Debug, Clone, Copy)]
pub struct ExplicitSettings {
    pub steps: Option<u64>,
    pub end_time: Option<f64>,
    pub dt: Option<f64>,
    pub safety_factor: f64,
}

/// Builds the body, bonds and loading of a validated deck.
pub fn build_model<const D: usize>(ld: &LoadedDeck) -> Result<Model<D>, DeckError> {
    let deck = &ld.deck;
    let dimensionality = dimensionality(deck).expect("validated deck");
    let thickness = deck.thickness.unwrap_or(1.0);
    let (cloud, horizon, rule) = match &deck.discretization {
        Discretization::Lattice {
            shape,
            spacing,
            horizon,
            horizon_ratio,
            partial_volume,
        } => {
            let h = horizon.unwrap_or_else(|| horizon_ratio.unwrap_or(3.0) * spacing);
            let cloud = lattice(shape, D, *spacing, thickness)
                .map_err(|e| ld.locate(vec![DeckIssue::new("discretization.shape", e)]))?;
            (cloud, h, *partial_volume)
        }
        Discretization::PointCloud {
            file,
            horizon,
            partial_volume,
        } => {
            let path = ld.base_dir().join(file);
            let pc = read_point_cloud(&path, D).map_err(|e| {
                ld.locate(vec![DeckIssue::new("discretization.file", e.to_string())])
            })?;
            let cell_sizes = pc
                .volumes
                .iter()
                .map(|&v| if D == 2 { v.sqrt() } else { v.cbrt() })
                .collect();
            let volumes = pc
                .volumes
                .iter()
                .map(|&v| if D == 2 { v * thickness } else { v })
                .collect();
            (
                NodeCloud {
                    positions: pc.positions,
                    volumes,
                    cell_sizes,
                    blocks: pc.blocks,
                },
                *horizon,
                *partial_volume,
            )
        }
    };
    if cloud.is_empty() {
        let at = if matches!(deck.discretization, Discretization::Lattice { .. }) {
            "discretization.shape"
        } else {
            "discretization"
        };
        return Err(ld.locate(vec![DeckIssue::new(
            at,
            "the discretization produced no nodes; check the shape and spacing",
        )]));
    }
    let mut body = Body::<D>::from_cloud(cloud, horizon, thickness);
    let spacing = body.min_cell_size();
    if horizon < spacing {
        return Err(ld.locate(vec![DeckIssue::new("discretization.horizon", format!("horizon {horizon} m is smaller than the smallest cell {spacing} m; expected δ/Δx ≥ 1, typically 3 to 4"))]));
    }
    for b in &deck.blocks {
        body.assign_block(b.id, &b.region);
    }
    let mut issues = Vec::new();
    for (k, set) in deck.node_sets.iter().enumerate() {
        if body.add_node_set(&set.name, &set.region) == 0 {
            issues.push(DeckIssue::new(
                &format!("node_sets[{k}].region"),
                format!(
                    "node set {:?} selects no nodes; check its region against the body",
                    set.name
                ),
            ));
        }
    }
    if !issues.is_empty() {
        return Err(ld.locate(issues));
    }
    for name in &deck.no_fail {
        let nodes = body.node_set(name).expect("validated set name");
        body.mark_no_fail(&nodes);
    }
    let bonds = build_bonds(&body, rule, &deck.precracks);

    let mut loading = Loading::<D>::default();
    for bc in &deck.boundary_conditions {
        loading.conditions.push(BoundaryCondition {
            set: bc.set.clone(),
            nodes: body.node_set(&bc.set).expect("validated set name"),
            kind: bc.kind,
            component: bc.component.index(),
            value: bc.value,
            time: bc.time.clone(),
        });
    }
    for load in &deck.loads {
        let (set, value, time, area) = match load {
            LoadDeck::BodyForce { set, value, time } => (set, value, time, None),
            LoadDeck::Traction {
                set,
                value,
                time,
                area,
            } => (set, value, time, Some(*area)),
        };
        let nodes = body.node_set(set).expect("validated set name");
        let mut density = vector_from_slice::<D>(value);
        if let Some(area) = area {
            // Traction T over area A is the force T·A spread over the set's volume.
            let volume: f64 = nodes.iter().map(|&i| body.volumes[i as usize]).sum();
            density *= area / volume;
        }
        loading.loads.push(Load {
            set: set.clone(),
            nodes,
            density,
            time: time.clone(),
        });
    }
    let SolverDeck::Explicit { damping, .. } = &deck.solver;
    loading.damping = *damping;
    let initial_velocities = deck
        .initial_velocities
        .iter()
        .map(|iv| InitialVelocity {
            nodes: body.node_set(&iv.set).expect("validated set name"),
            value: vector_from_slice::<D>(&iv.value),
            gradient: iv
                .gradient
                .as_ref()
                .map_or(nalgebra::SMatrix::zeros(), |g| {
                    nalgebra::SMatrix::from_fn(|a, b| g[a][b])
                }),
            origin: iv
                .origin
                .as_ref()
                .map_or(Vector::zeros(), |o| vector_from_slice::<D>(o)),
        })
        .collect();
    Ok(Model {
        body,
        bonds,
        loading,
        rule,
        horizon,
        spacing,
        dimensionality,
        initial_velocities,
    })
}

/// Calibrates the deck's material for a horizon δ.
pub fn build_material(deck: &Deck, horizon: f64) -> MaterialChoice {
    let dim = dimensionality(deck).expect("validated deck");
    let thickness = deck.thickness.unwrap_or(1.0);
    match &deck.material {
        MaterialDeck::Pmb {
            density,
            youngs_modulus,
            micromodulus,
            fracture_energy,
            critical_stretch,
            profile,
            ..
        } => {
            let c0 = micromodulus.unwrap_or_else(|| {
                Pmb::micromodulus(youngs_modulus.unwrap_or(0.0), dim, *profile, horizon)
            });
            let s0 = match (fracture_energy, critical_stretch) {
                (_, Some(s)) => *s,
                (Some(g), None) => Pmb::critical_stretch_from_g0(*g, c0, dim, *profile, horizon),
                (None, None) => f64::INFINITY,
            };
            MaterialChoice::Pmb(Pmb::new(
                c0, s0, *density, dim, *profile, horizon, thickness,
            ))
        }
        MaterialDeck::Lps {
            density,
            youngs_modulus,
            poisson_ratio,
            fracture_energy,
            critical_stretch,
            influence,
        } => {
            let el = Elasticity {
                youngs_modulus: *youngs_modulus,
                poisson_ratio: *poisson_ratio,
                dimensionality: dim,
            };
            let s0 = match (fracture_energy, critical_stretch) {
                (_, Some(s)) => *s,
                (Some(g), None) => Lps::critical_stretch_from_g0(*g, &el, horizon),
                (None, None) => f64::INFINITY,
            };
            MaterialChoice::Lps(Lps::new(el, *influence, horizon, s0, *density, thickness))
        }
    }
}

/// The solver settings of a deck.
pub fn explicit_settings(deck: &Deck) -> ExplicitSettings {
    let SolverDeck::Explicit {
        steps,
        end_time,
        dt,
        safety_factor,
        ..
    } = &deck.solver;
    ExplicitSettings {
        steps: *steps,
        end_time: *end_time,
        dt: *dt,
        safety_factor: *safety_factor,
    }
}
