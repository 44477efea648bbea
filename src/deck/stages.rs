//! The stages of a run: the deck's own (its top-level solver, boundary conditions, loads and
//! no-fail sets) and each `[[stages]]` entry after it, with what the entry leaves out taken
//! from the stage before (seed 000 "S + D", seed 002's preload then release).

use super::schema::{BoundaryDeck, Deck, LoadDeck, SolverDeck};
use super::solver_settings::{settings_of, SolverSettings};
use super::DeckIssue;
use crate::body::Body;
use crate::loading::{BoundaryCondition, Load, Loading};
use crate::math::{vector_from_slice, Vector};
use std::collections::BTreeMap;

/// One stage, built: what the run switches to when the stage starts.
#[derive(Debug, Clone)]
pub struct StagePlan<const D: usize> {
    /// The deck's name for it, or its number (1 is the deck's own stage).
    pub name: String,
    pub settings: SolverSettings,
    pub loading: Loading<D>,
    /// Per node: its bonds never break in this stage.
    pub no_fail: Vec<bool>,
    /// Steps between history rows in this stage.
    pub history_interval: u64,
}

/// The volume of each node set a traction of the deck (any stage) is spread over, summed over
/// the whole body: a distributed run's part holds only some of a set's nodes, but every rank
/// must spread the same force density.
pub fn traction_volumes<const D: usize>(deck: &Deck, body: &Body<D>) -> BTreeMap<String, f64> {
    let stage_loads = deck.stages.iter().filter_map(|s| s.loads.as_ref());
    std::iter::once(&deck.loads)
        .chain(stage_loads)
        .flatten()
        .filter_map(|load| match load {
            LoadDeck::Traction { set, .. } => Some(set),
            LoadDeck::BodyForce { .. } => None,
        })
        .map(|set| {
            let nodes = body.node_set(set).expect("validated set name");
            let volume: f64 = nodes.iter().map(|&i| body.volumes[i as usize]).sum();
            (set.clone(), volume)
        })
        .collect()
}

/// The boundary conditions and loads of a stage, on the body's nodes (set names validated;
/// `traction_volumes` from the whole body).
pub fn loading<const D: usize>(
    body: &Body<D>,
    conditions: &[BoundaryDeck],
    loads: &[LoadDeck],
    solver: &SolverDeck,
    traction_volumes: &BTreeMap<String, f64>,
) -> Loading<D> {
    let mut loading = Loading::<D>::default();
    for bc in conditions {
        let nodes = body.node_set(&bc.set).expect("validated set name");
        let offsets = match &bc.gradient {
            Some(g) => {
                let origin = bc
                    .origin
                    .as_deref()
                    .map_or(Vector::<D>::zeros(), vector_from_slice);
                BoundaryCondition::gradient_offsets(body, &nodes, &vector_from_slice(g), &origin)
            }
            None => Vec::new(),
        };
        loading.conditions.push(BoundaryCondition {
            set: bc.set.clone(),
            nodes,
            kind: bc.kind,
            component: bc.component.index(),
            value: bc.value,
            time: bc.time.clone(),
            offsets,
        });
    }
    for load in loads {
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
            density *= area / traction_volumes[set];
        }
        loading.loads.push(Load {
            set: set.clone(),
            nodes,
            density,
            time: time.clone(),
        });
    }
    if let SolverDeck::Explicit { damping, .. } = solver {
        loading.damping = *damping;
    }
    loading
}

/// Per node: whether it belongs to one of the named sets.
pub fn no_fail_mask<const D: usize>(body: &Body<D>, sets: &[String]) -> Vec<bool> {
    let mut mask = vec![false; body.len()];
    for name in sets {
        for i in body.node_set(name).expect("validated set name") {
            mask[i as usize] = true;
        }
    }
    mask
}

/// The no-fail flags of each `[[stages]]` entry (the sets it names, or the stage before's),
/// per node of `body`.
pub fn stage_no_fail<const D: usize>(deck: &Deck, body: &Body<D>) -> Vec<Vec<bool>> {
    let mut no_fail = &deck.no_fail;
    deck.stages
        .iter()
        .map(|stage| {
            no_fail = stage.no_fail.as_ref().unwrap_or(no_fail);
            no_fail_mask(body, no_fail)
        })
        .collect()
}

/// The `[[stages]]` entries of a deck, built in order (the deck's own stage is the model's),
/// with their no-fail flags (`stage_no_fail`, per node of `body`).
pub fn further_stages<const D: usize>(
    deck: &Deck,
    body: &Body<D>,
    no_fail: Vec<Vec<bool>>,
    traction_volumes: &BTreeMap<String, f64>,
) -> Vec<StagePlan<D>> {
    let (mut conditions, mut loads) = (&deck.boundary_conditions, &deck.loads);
    deck.stages
        .iter()
        .zip(no_fail)
        .enumerate()
        .map(|(k, (stage, no_fail))| {
            conditions = stage.boundary_conditions.as_ref().unwrap_or(conditions);
            loads = stage.loads.as_ref().unwrap_or(loads);
            StagePlan {
                name: stage_name(deck, k + 1),
                settings: settings_of(&stage.solver),
                loading: loading(body, conditions, loads, &stage.solver, traction_volumes),
                no_fail,
                history_interval: deck.stage_history_interval(k + 1),
            }
        })
        .collect()
}

/// The name of stage `index` (0: the deck's own): its `name`, or its number from 1.
pub fn stage_name(deck: &Deck, index: usize) -> String {
    match index.checked_sub(1).map(|k| &deck.stages[k].name) {
        Some(name) if !name.is_empty() => name.clone(),
        _ => (index + 1).to_string(),
    }
}

/// What one stage will do: its solver, steps, time step (or load increment) and duration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StageReport {
    pub name: String,
    /// "explicit" or "quasi-static".
    pub solver: String,
    /// Steps, or load steps.
    pub steps: u64,
    /// Time step (s), or the load increment.
    pub dt: f64,
    /// How far the clock moves in the stage: steps × dt, or the adaptive run's end time.
    pub duration: f64,
}

impl StageReport {
    /// The stage's solver with `dt_stable`, the stable time step of the body; `at` is where
    /// its `[solver]` table is, for the error of a too large dt.
    pub fn new(
        name: String,
        settings: &SolverSettings,
        dt_stable: f64,
        at: &str,
    ) -> Result<Self, DeckIssue> {
        if settings.quasi_static.is_some() {
            let steps = settings.steps.expect("a quasi-static run has load steps");
            let dt = settings
                .dt
                .expect("a quasi-static run has a load increment");
            return Ok(StageReport {
                name,
                solver: "quasi-static".into(),
                steps,
                dt,
                duration: steps as f64 * dt,
            });
        }
        let dt = match settings.dt {
            Some(dt) if dt > dt_stable => {
                return Err(DeckIssue::new(
                    &format!("{at}solver.dt"),
                    format!("dt = {dt:.4e} s exceeds the stable time step {dt_stable:.4e} s (Silling–Askari estimate); lower dt or remove it to use safety_factor × the estimate"),
                ))
            }
            Some(dt) => dt,
            None => settings.safety_factor * dt_stable,
        };
        let steps = settings
            .steps
            .unwrap_or_else(|| (settings.end_time.unwrap_or(0.0) / dt).ceil() as u64);
        let duration = match (&settings.adaptive, settings.end_time) {
            (Some(_), Some(end)) => end,
            _ => steps as f64 * dt,
        };
        Ok(StageReport {
            name,
            solver: "explicit".into(),
            steps,
            dt,
            duration,
        })
    }
}

impl std::fmt::Display for StageReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = if self.solver == "explicit" {
            "steps of dt"
        } else {
            "load steps of"
        };
        write!(
            f,
            "stage {:<10} {}: {} {what} {:.4e}, lasting {:.4e}",
            self.name, self.solver, self.steps, self.dt, self.duration
        )
    }
}
