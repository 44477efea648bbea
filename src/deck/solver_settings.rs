//! What a `[solver]` table (the deck's or a stage's) asks of a run: `SolverSettings`, and the
//! steps between history rows.

use super::schema::{
    AdaptiveDtDeck, AdrDampingDeck, Deck, PreconditionerDeck, QuasiStaticMethod, SolverDeck,
};
use crate::solver::{AdaptiveDtSettings, AdrDamping, EquilibriumMethod, QuasiStaticSettings};

/// Solver settings of a run.
#[derive(Debug, Clone)]
pub struct SolverSettings {
    pub steps: Option<u64>,
    pub end_time: Option<f64>,
    /// The time step (explicit) or the load increment in pseudo-time (quasi-static).
    pub dt: Option<f64>,
    pub safety_factor: f64,
    /// Present for a quasi-static run.
    pub quasi_static: Option<QuasiStaticSettings>,
    /// Present for an explicit run with an adaptive time step.
    pub adaptive: Option<AdaptiveDtDeck>,
}

impl AdaptiveDtDeck {
    /// The controller's settings for an initial time step `dt`.
    pub fn settings(&self, dt: f64) -> AdaptiveDtSettings {
        AdaptiveDtSettings {
            max_broken_per_node: self.max_broken_per_node,
            stable_broken_per_node: self.stable_broken_per_node,
            stable_steps: self.stable_steps,
            reduce: self.reduce,
            raise: self.raise,
            min_dt: self.min_dt.unwrap_or(dt / 5.0),
            max_dt: self.max_dt.unwrap_or(dt),
        }
    }
}

impl Deck {
    /// Steps between history rows: the deck's, or 10 for explicit dynamics and 1 (every load
    /// step) for a quasi-static run.
    pub fn history_interval(&self) -> u64 {
        self.stage_history_interval(0)
    }

    /// Steps between history rows in stage `index` (0: the deck's own): the stage's, else
    /// `[output]`'s, else 10 for explicit dynamics and 1 (every load step) for quasi-static.
    pub fn stage_history_interval(&self, index: usize) -> u64 {
        let (own, solver) = match index.checked_sub(1) {
            None => (None, &self.solver),
            Some(k) => (self.stages[k].history_interval, &self.stages[k].solver),
        };
        own.or(self.output.history_interval)
            .unwrap_or(match solver {
                SolverDeck::Explicit { .. } => 10,
                SolverDeck::QuasiStatic { .. } => 1,
            })
    }
}

/// The solver settings of a deck (of its own stage, the first).
pub fn solver_settings(deck: &Deck) -> SolverSettings {
    settings_of(&deck.solver)
}

/// The settings of one `[solver]` table.
pub fn settings_of(solver: &SolverDeck) -> SolverSettings {
    match solver {
        SolverDeck::Explicit {
            steps,
            end_time,
            dt,
            safety_factor,
            adaptive,
            ..
        } => SolverSettings {
            steps: *steps,
            end_time: *end_time,
            dt: *dt,
            safety_factor: *safety_factor,
            quasi_static: None,
            adaptive: adaptive.clone(),
        },
        SolverDeck::QuasiStatic {
            load_steps,
            end_time,
            method,
            adr_damping,
            preconditioner,
            tolerance,
            max_iterations,
            mass_factor,
            max_equilibria,
            max_broken_bonds,
            max_splits,
            stop_when_stored_below,
        } => SolverSettings {
            steps: Some(*load_steps),
            end_time: Some(*end_time),
            dt: Some(end_time / *load_steps as f64),
            safety_factor: 1.0,
            quasi_static: Some(QuasiStaticSettings {
                method: match method {
                    QuasiStaticMethod::Adr => EquilibriumMethod::Adr,
                    QuasiStaticMethod::Ncg => EquilibriumMethod::Ncg,
                },
                damping: match adr_damping {
                    AdrDampingDeck::Local => AdrDamping::Local,
                    AdrDampingDeck::Increment => AdrDamping::Increment,
                },
                two_level: *preconditioner == PreconditionerDeck::TwoLevel,
                tolerance: *tolerance,
                max_iterations: *max_iterations,
                mass_factor: *mass_factor,
                max_equilibria: *max_equilibria,
                max_broken_per_step: *max_broken_bonds,
                max_splits: *max_splits,
                stop_when_stored_below: *stop_when_stored_below,
                ..QuasiStaticSettings::default()
            }),
            adaptive: None,
        },
    }
}
