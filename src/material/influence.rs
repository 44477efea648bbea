//! Influence functions ω(|ξ|) of the state-based models (LPS, correspondence).

use serde::{Deserialize, Serialize};

/// Influence function ω(|ξ|) of a bond of reference length |ξ| in a horizon δ.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Influence {
    /// ω = 1 (Peridigm's default, used by seed 002).
    #[default]
    Constant,
    /// ω = δ/|ξ|.
    Inverse,
    /// ω = exp(−|ξ|²/δ²) (Seleson & Parks 2011).
    Gaussian,
}

impl Influence {
    #[inline(always)]
    pub fn omega(self, ref_len: f64, horizon: f64) -> f64 {
        match self {
            Influence::Constant => 1.0,
            Influence::Inverse => horizon / ref_len,
            Influence::Gaussian => {
                let r = ref_len / horizon;
                (-r * r).exp()
            }
        }
    }
}
