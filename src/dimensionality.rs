//! Whether a body is 3D or, in 2D, plane stress or plane strain: a setting of the body that
//! the models' constants and the damage laws' calibrations depend on (below both, so that
//! `damage` does not import `material` for it; `material::Dimensionality` re-exports it).

use serde::{Deserialize, Serialize};

/// How a body's dimension enters the constitutive constants.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dimensionality {
    ThreeD,
    PlaneStress,
    PlaneStrain,
}

impl Dimensionality {
    /// Plain name for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Dimensionality::ThreeD => "3D",
            Dimensionality::PlaneStress => "plane stress",
            Dimensionality::PlaneStrain => "plane strain",
        }
    }

    pub fn dim(self) -> usize {
        match self {
            Dimensionality::ThreeD => 3,
            _ => 2,
        }
    }
}
