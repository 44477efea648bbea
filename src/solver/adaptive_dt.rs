//! Adaptive explicit time step (seed 004 §5, Fig. 13; Willberg et al. 2022): count the bonds
//! each node loses in a step; when some node loses more than N_b^m, the step is undone exactly
//! and retried with dt·t_reduce (never below t_min); after more than `stable_steps` steps since
//! the last change in which every node lost at most N_b^s, dt grows by t_raise (never above
//! t_max nor the stable time step). Defaults are those of the authors' Peridigm code
//! (N_b^m = 4, N_b^s = 1, step_d = 4, t_reduce = 0.5, t_raise = 1.2, t_max = the initial dt,
//! t_min = the initial dt / 5).
//!
//! The whole `State` is saved before each step into a buffer kept between steps (no
//! allocation), so a rejected step leaves no trace: bond status, damage history, energies and
//! counters are as they were, and the retry is bitwise the step a run with the smaller dt
//! would have taken.

use super::{Simulation, StepError};
use crate::bonds::Bonds;
use crate::material::Material;
use crate::state::{State, OWN_BROKEN};
use rayon::prelude::*;

/// Parameters of the adaptive time step.
#[derive(Debug, Clone, Copy)]
pub struct AdaptiveDtSettings {
    /// N_b^m: a node losing more bonds than this in one step rejects the step.
    pub max_broken_per_node: u32,
    /// N_b^s: a step in which every node loses at most this many is quiet.
    pub stable_broken_per_node: u32,
    /// step_d: steps since the last change before dt may grow.
    pub stable_steps: u64,
    /// t_reduce, in (0, 1).
    pub reduce: f64,
    /// t_raise, > 1.
    pub raise: f64,
    /// t_min (s).
    pub min_dt: f64,
    /// t_max (s), at most the stable time step.
    pub max_dt: f64,
}

impl AdaptiveDtSettings {
    /// The defaults of the authors' code for an initial time step `dt`.
    pub fn defaults(dt: f64) -> Self {
        AdaptiveDtSettings {
            max_broken_per_node: 4,
            stable_broken_per_node: 1,
            stable_steps: 4,
            reduce: 0.5,
            raise: 1.2,
            min_dt: dt / 5.0,
            max_dt: dt,
        }
    }
}

/// What one committed step took.
#[derive(Debug, Clone, Copy, Default)]
pub struct AdaptiveReport {
    /// Attempts rejected before the step was committed.
    pub rejected: u32,
    /// The largest number of bonds a node lost in the committed step.
    pub most_broken_at_a_node: u32,
}

/// The controller: the settings, the saved state and the quiet-step count.
pub struct AdaptiveDt<const D: usize> {
    pub settings: AdaptiveDtSettings,
    saved: Option<State<D>>,
    /// Committed steps since dt last changed.
    since_change: u64,
    /// Steps rejected over the run.
    pub rejected: u64,
}

impl<const D: usize> AdaptiveDt<D> {
    pub fn new(settings: AdaptiveDtSettings) -> Self {
        AdaptiveDt {
            settings,
            saved: None,
            since_change: 0,
            rejected: 0,
        }
    }

    /// A controller continuing a run (from a checkpoint) that had taken `since_change` steps
    /// since dt last changed and rejected `rejected`.
    pub fn resumed(settings: AdaptiveDtSettings, since_change: u64, rejected: u64) -> Self {
        AdaptiveDt {
            since_change,
            rejected,
            ..Self::new(settings)
        }
    }

    /// Committed steps since dt last changed (what a checkpoint keeps).
    pub fn since_change(&self) -> u64 {
        self.since_change
    }

    /// Commits one velocity-Verlet step, retrying it with smaller time steps while a node loses
    /// more than N_b^m bonds (and dt·t_reduce ≥ t_min); then raises dt for the next step if
    /// the run has been quiet long enough. `sim.dt` is the step to try; on return it is the
    /// step to try next, and `sim.state.dt` the one committed.
    pub fn step<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
    ) -> Result<AdaptiveReport, StepError> {
        let s = &self.settings;
        let mut report = AdaptiveReport::default();
        loop {
            match &mut self.saved {
                Some(saved) => saved.clone_from(&sim.state),
                None => self.saved = Some(sim.state.clone()),
            }
            let saved = self.saved.as_ref().expect("just saved");
            let broken = sim.step()?;
            // `broken` is every rank's; so is the largest count (a maximum of integers,
            // exact in any order), and every rank takes the same decision.
            let most = if broken == 0 {
                0
            } else {
                let most = most_broken_at_a_node(&sim.bonds, &saved.status, &sim.state.status);
                match &sim.share {
                    None => most,
                    Some(s) => s.ranks.max_f64(most as f64) as u32,
                }
            };
            if most > s.max_broken_per_node && sim.dt * s.reduce >= s.min_dt {
                sim.state.clone_from(saved);
                sim.counters.steps -= 1;
                sim.counters.bonds_broken -= broken;
                sim.dt *= s.reduce;
                self.since_change = 0;
                self.rejected += 1;
                report.rejected += 1;
                continue;
            }
            report.most_broken_at_a_node = most;
            self.since_change += 1;
            let quiet = most <= s.stable_broken_per_node;
            let ceiling = s.max_dt.min(sim.dt_stable);
            if quiet && self.since_change > s.stable_steps && sim.dt * s.raise <= ceiling {
                sim.dt *= s.raise;
                self.since_change = 0;
            }
            return Ok(report);
        }
    }
}

/// The largest number of own bond halves a node lost between two status arrays.
pub fn most_broken_at_a_node(bonds: &Bonds, before: &[u8], after: &[u8]) -> u32 {
    (0..bonds.offsets.len() - 1)
        .into_par_iter()
        .with_min_len(1024)
        .map(|i| {
            bonds
                .family(i)
                .filter(|&b| before[b] & OWN_BROKEN == 0 && after[b] & OWN_BROKEN != 0)
                .count() as u32
        })
        .max()
        .unwrap_or(0)
}
