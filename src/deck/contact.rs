//! `[contact]` and `[[impactors]]`: their checks and their defaults, which come from the
//! material's stiffness and the grid (documented in docs/deck.md); their deck types are in
//! `contact_schema`.

pub use super::contact_schema::{ContactDeck, ImpactorDeck, ImpactorShapeDeck};
use super::schema::{Deck, SolverDeck};
use super::DeckIssue;
use crate::material::Elasticity;
use crate::math::{vector_from_slice, Vector};
use crate::solver::contact::{ContactSettings, NodeContact};
use crate::solver::impactor::{Impactor, ImpactorShape, Impactors, Motion};

/// Default contact radius r_c over the grid spacing (LAMMPS `pair peri`: 0.9 × the reference
/// distance of nearest neighbours).
pub const RADIUS_FACTOR: f64 = 0.9;
/// Default contact spring constant over the PMB micromodulus (LAMMPS `pair peri/pmb`: 15 c).
pub const STIFFNESS_FACTOR: f64 = 15.0;
/// Default Verlet skin over the grid spacing. A thin skin rebuilds the list often (a 90 000-node
/// plate moving at 10 m/s: 0.1 Δx costs 18% of a PMB step, 0.3 Δx 7%); the nearest lattice
/// neighbours it adds are bonded and skipped on their status byte.
pub const SKIN_FACTOR: f64 = 0.3;

fn positive(out: &mut Vec<DeckIssue>, path: &str, value: Option<f64>, what: &str) {
    if let Some(v) = value {
        if !(v.is_finite() && v > 0.0) {
            out.push(DeckIssue::new(
                path,
                format!("{what} must be a positive finite number, found {v}"),
            ));
        }
    }
}

fn vector(out: &mut Vec<DeckIssue>, path: &str, v: &[f64], d: usize) {
    if v.len() != d {
        out.push(DeckIssue::new(
            path,
            format!("expected {d} components in a {d}D deck, found {}", v.len()),
        ));
    } else if v.iter().any(|x| !x.is_finite()) {
        out.push(DeckIssue::new(path, "expected finite numbers"));
    }
}

/// The checks of `[contact]` and `[[impactors]]`.
pub fn validate(out: &mut Vec<DeckIssue>, deck: &Deck) {
    let d = deck.dimension;
    if let Some(c) = &deck.contact {
        positive(out, "contact.radius", c.radius, "the contact radius (m)");
        positive(
            out,
            "contact.stiffness_factor",
            c.stiffness_factor,
            "the stiffness factor",
        );
        positive(out, "contact.skin", c.skin, "the skin (m)");
    }
    // Any stage's solver counts: contact and impactors are on for the whole run.
    let solvers = || std::iter::once(&deck.solver).chain(deck.stages.iter().map(|s| &s.solver));
    let quasi_static = solvers().any(|s| matches!(s, SolverDeck::QuasiStatic { .. }));
    if quasi_static && deck.contact.is_some() {
        out.push(DeckIssue::new(
            "contact",
            "contact acts in explicit dynamics only; remove [contact] or use the explicit solver in every stage",
        ));
    }
    let adaptive = solvers().any(|s| {
        matches!(
            s,
            SolverDeck::Explicit {
                adaptive: Some(_),
                ..
            }
        )
    });
    for (k, im) in deck.impactors.iter().enumerate() {
        let p = format!("impactors[{k}]");
        let at = |key: &str| format!("{p}.{key}");
        if im.name.is_empty() || !im.name.chars().all(|c| c.is_alphanumeric() || c == '_') {
            out.push(DeckIssue::new(
                &at("name"),
                format!(
                    "expected a name of letters, digits and '_' (it names history columns), found {:?}",
                    im.name
                ),
            ));
        }
        if deck.impactors[..k].iter().any(|o| o.name == im.name) {
            out.push(DeckIssue::new(
                &at("name"),
                format!("impactor {:?} is defined twice", im.name),
            ));
        }
        let round = im.shape != ImpactorShapeDeck::Plane;
        let (needed, unwanted): (&[&str], &[&str]) = if round {
            (&["centre", "radius"], &["point", "normal", "extent"])
        } else {
            (&["point", "normal"], &["centre", "radius"])
        };
        let given = |key: &str| match key {
            "centre" => im.centre.is_some(),
            "radius" => im.radius.is_some(),
            "point" => im.point.is_some(),
            "normal" => im.normal.is_some(),
            _ => im.extent.is_some(),
        };
        let shape = match im.shape {
            ImpactorShapeDeck::Plane => "plane",
            ImpactorShapeDeck::Sphere => "sphere",
            ImpactorShapeDeck::Cylinder => "cylinder",
        };
        for key in needed.iter().filter(|k| !given(k)) {
            out.push(DeckIssue::new(
                &p,
                format!("a {shape} impactor needs `{key}`"),
            ));
        }
        for key in unwanted.iter().filter(|k| given(k)) {
            out.push(DeckIssue::new(
                &at(key),
                format!("a {shape} impactor has no `{key}`"),
            ));
        }
        positive(out, &at("radius"), im.radius, "the radius (m)");
        positive(out, &at("extent"), im.extent, "the extent (m)");
        positive(out, &at("mass"), im.mass, "the mass (kg)");
        positive(
            out,
            &at("stiffness"),
            im.stiffness,
            "the penalty constant K (N/m²)",
        );
        for (key, v) in [("centre", &im.centre), ("point", &im.point)] {
            if let Some(v) = v {
                vector(out, &at(key), v, d);
            }
        }
        if let Some(n) = &im.normal {
            vector(out, &at("normal"), n, d);
            if n.len() == d && n.iter().all(|x| *x == 0.0) {
                out.push(DeckIssue::new(&at("normal"), "the normal must not be zero"));
            }
        }
        vector(out, &at("velocity"), &im.velocity, d);
        if quasi_static {
            out.push(DeckIssue::new(
                &p,
                "impactors act in explicit dynamics only; remove them or use the explicit solver in every stage",
            ));
        }
        if adaptive {
            out.push(DeckIssue::new(
                &p,
                "impactors do not run with solver.adaptive (a rejected step would not roll the impactor back); use a fixed time step",
            ));
        }
    }
}

/// What the defaults derive from.
pub struct Scales {
    /// Grid spacing Δx (m).
    pub spacing: f64,
    /// Horizon δ (m).
    pub horizon: f64,
    /// Mean node volume (m³).
    pub volume: f64,
    /// 2D thickness (m; 1 in 3D).
    pub thickness: f64,
    pub elasticity: Elasticity,
}

/// PMB micromodulus of the body's elasticity: c = 18K/(πδ⁴) in 3D (Silling & Askari 2005,
/// Eq. (15)) and c = 12κ/(π t δ³) in 2D with κ the in-plane bulk modulus (9E/(π t δ³) in
/// plane stress at ν = 1/3, 48E/(5π t δ³) in plane strain at ν = 1/4, Ha & Bobaru 2010).
pub fn micromodulus(dim: usize, s: &Scales) -> f64 {
    let pi = std::f64::consts::PI;
    if dim == 3 {
        18.0 * s.elasticity.bulk() / (pi * s.horizon.powi(4))
    } else {
        12.0 * s.elasticity.in_plane_bulk() / (pi * s.thickness * s.horizon.powi(3))
    }
}

/// Node–node contact as the deck sets it, `None` without `[contact]`.
pub fn node_contact<const D: usize>(deck: &Deck, s: &Scales) -> Option<NodeContact<D>> {
    let c = deck.contact.as_ref()?;
    Some(NodeContact::new(ContactSettings {
        radius: c.radius.unwrap_or(RADIUS_FACTOR * s.spacing),
        stiffness: c.stiffness_factor.unwrap_or(STIFFNESS_FACTOR) * micromodulus(D, s),
        horizon: s.horizon,
        skin: c.skin.unwrap_or(SKIN_FACTOR * s.spacing),
    }))
}

/// Default penalty constant K = E V̄/Δx³: at a depth of Δx/2 the tangent stiffness 2Kp equals
/// E A/Δx, the axial stiffness of one node's column (A = V̄/Δx its cross-section).
pub fn default_penalty(s: &Scales) -> f64 {
    s.elasticity.youngs_modulus * s.volume / s.spacing.powi(3)
}

/// The deck's impactors.
pub fn impactors<const D: usize>(deck: &Deck, s: &Scales) -> Impactors<D> {
    let list = deck
        .impactors
        .iter()
        .map(|im| {
            let shape = match im.shape {
                ImpactorShapeDeck::Plane => {
                    let n: Vector<D> = vector_from_slice(im.normal.as_deref().unwrap_or(&[]));
                    ImpactorShape::Plane {
                        normal: n.normalize(),
                        extent: im.extent,
                    }
                }
                ImpactorShapeDeck::Sphere => ImpactorShape::Sphere {
                    radius: im.radius.unwrap_or(0.0),
                },
                ImpactorShapeDeck::Cylinder => ImpactorShape::Cylinder {
                    radius: im.radius.unwrap_or(0.0),
                },
            };
            let at = im.centre.as_deref().or(im.point.as_deref()).unwrap_or(&[]);
            Impactor::new(
                im.name.clone(),
                shape,
                im.mass
                    .map_or(Motion::Prescribed, |mass| Motion::Free { mass }),
                im.stiffness.unwrap_or_else(|| default_penalty(s)),
                vector_from_slice(at),
                vector_from_slice(&im.velocity),
            )
        })
        .collect();
    Impactors { list }
}
