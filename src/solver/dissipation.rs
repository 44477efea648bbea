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
//! (and, for softening laws, the history) of the last evaluation and compares.

use crate::bonds::Bonds;
use crate::state::State;
use rayon::prelude::*;
use std::ops::Range;

/// The damage record of the previous evaluation.
#[derive(Debug, Default)]
pub struct DissipationTracker {
    status: Vec<u8>,
    history: Vec<f64>,
    /// The law's history sets partial factors μ (softening): history changes count.
    partial: bool,
}

impl DissipationTracker {
    pub fn new(partial: bool) -> Self {
        DissipationTracker {
            partial,
            ..Default::default()
        }
    }

    /// Remembers the damage record before an evaluation (reusing the buffers).
    pub fn remember<const D: usize>(&mut self, state: &State<D>) {
        self.status.clone_from(&state.status);
        if self.partial {
            self.history.clone_from(&state.history);
        }
    }

    /// Σ_i V_i (W_i before − W_i after) over the nodes whose bonds changed since `remember`.
    /// `energy(i, status, history)` is W_i at the current positions with that damage record;
    /// `factors(i, j, history, status)` the law's (μ_ij, μ_ji). Summed per node chunk in a
    /// fixed order: the same bits for any number of threads.
    #[allow(clippy::too_many_arguments)]
    pub fn released<const D: usize>(
        &self,
        chunks: &[Range<usize>],
        bonds: &Bonds,
        volumes: &[f64],
        state: &State<D>,
        history_words: usize,
        damage_changed: bool,
        factors: impl Fn(usize, usize, &[f64], u8) -> (f64, f64) + Sync,
        energy: impl Fn(usize, (&[u8], &[f64])) -> f64 + Sync,
    ) -> f64 {
        if !damage_changed && !self.partial {
            return 0.0;
        }
        let hw = history_words;
        let old = (&self.status[..], &self.history[..]);
        let old_history = if self.partial { old.1 } else { &state.history[..] };
        let new = (&state.status[..], &state.history[..]);
        let changed = |i: usize| {
            bonds.family(i).any(|b| {
                if old.0[b] != new.0[b] {
                    return true;
                }
                let (h0, h1) = (&old_history[b * hw..(b + 1) * hw], &new.1[b * hw..(b + 1) * hw]);
                self.partial && h0 != h1 && {
                    let j = bonds.neighbors[b] as usize;
                    factors(i, j, h0, old.0[b]) != factors(i, j, h1, new.0[b])
                }
            })
        };
        let per_chunk: Vec<f64> = chunks
            .par_iter()
            .map(|nodes| {
                nodes
                    .clone()
                    .filter(|&i| changed(i))
                    .fold(0.0, |acc, i| {
                        let before = energy(i, (old.0, old_history));
                        let after = energy(i, new);
                        acc + (before - after) * volumes[i]
                    })
            })
            .collect();
        per_chunk.iter().sum()
    }
}
