//! The deck types of `[contact]` and `[[impactors]]` (their checks and defaults: `contact`).

use serde::{Deserialize, Serialize};

/// Node–node contact between nodes that no intact bond joins.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactDeck {
    /// Contact radius r_c (m); default 0.9 Δx.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Spring constant c_s as a multiple of the PMB micromodulus c of the body's E and ν;
    /// default 15.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_factor: Option<f64>,
    /// Verlet skin of the candidate list (m); default 0.3 Δx.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skin: Option<f64>,
}

/// An impactor's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ImpactorShapeDeck {
    Plane,
    Sphere,
    Cylinder,
}

/// A rigid impactor.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImpactorDeck {
    /// Names its history columns, `impactor_<name>_…`.
    pub name: String,
    pub shape: ImpactorShapeDeck,
    /// Sphere and cylinder: centre (a point of the axis) (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centre: Option<Vec<f64>>,
    /// Sphere and cylinder: radius (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Plane: a point of the plane (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point: Option<Vec<f64>>,
    /// Plane: its normal, pointing out of the impactor towards the body (normalised).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<Vec<f64>>,
    /// Plane: only nodes within this distance of `point` along the plane (a flat punch) (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extent: Option<f64>,
    /// Velocity (m/s): prescribed, or the initial one of a free impactor.
    pub velocity: Vec<f64>,
    /// Mass (kg): a free rigid body; absent: the velocity is prescribed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// Penalty constant K (N/m²) of F = K p²; default E V̄/Δx³.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<f64>,
}
