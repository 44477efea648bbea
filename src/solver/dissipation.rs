//! The energy dissipated by damage, booked where it happens.
//!
//! When an evaluation breaks or softens bonds, the body loses the strain energy those bonds
//! held: E_diss grows by E_strain(y, d_before) − E_strain(y, d_after), both at the
//! configuration y of the evaluation. For a bond-based law this is the bond's energy at the
//! moment it breaks (seed 002 §4.2.2 counts the dissipated energy so) and, for a softening
//! bond unloading along the secant, the area between its loading curve and the secant
//! (seed 001 §4.1); for a state-based model it is the drop of the node energies, which the
//! bond's family shares. With it the energy balance W_ext = E_kin + E_strain + D_visc + E_diss
//! closes up to time-integration error, a check that no other quantity provides.
//!
//! Only the nodes whose family changed are re-evaluated: the tracker keeps the status bytes
//! of the last evaluation and compares. A softening bond's dissipation depends on its largest
//! stretch alone (it unloads along the secant), so the engine sums it from the history when
//! asked (`ForceEngine::dissipated_energy`) instead of following it step by step: a softening
//! bond that breaks has already lost its force and releases nothing here.

use crate::bonds::Bonds;
use crate::state::State;
use rayon::prelude::*;
use std::ops::Range;

/// The bond status of the previous evaluation.
#[derive(Debug, Default)]
pub struct DissipationTracker {
    status: Vec<u8>,
}

impl DissipationTracker {
    /// Remembers the bond status before an evaluation (reusing the buffer).
    pub fn remember<const D: usize>(&mut self, state: &State<D>) {
        self.status.clone_from(&state.status);
    }

    /// Per node chunk that broke a half, in chunk order: Σ_i V_i (W_i before − W_i after)
    /// over its nodes whose bond status changed since
    /// `remember`. `energy(i, status)` is W_i at the booking's positions with that status.
    /// Chunks whose nodes broke no own half (`broke_in_chunk`) are skipped: a node's energy
    /// depends on its own halves only (an entry's other-half bit changes nothing in W_i). The
    /// caller sums the chunks in order: the same bits for any number of threads (and ranks).
    pub fn released<const D: usize>(
        &self,
        chunks: &[Range<usize>],
        broke_in_chunk: &[u64],
        bonds: &Bonds,
        volumes: &[f64],
        state: &State<D>,
        energy: impl Fn(usize, &[u8]) -> f64 + Sync,
    ) -> Vec<f64> {
        let (old, new) = (&self.status[..], &state.status[..]);
        let per_chunk: Vec<f64> = chunks
            .par_iter()
            .zip(broke_in_chunk)
            .filter(|(_, &broke)| broke > 0)
            .map(|(nodes, _)| {
                nodes
                    .clone()
                    .filter(|&i| bonds.family(i).any(|b| old[b] != new[b]))
                    .fold(0.0, |acc, i| {
                        acc + (energy(i, old) - energy(i, new)) * volumes[i]
                    })
            })
            .collect();
        per_chunk
    }
}
