//! A simulation driven from another program (the Python package): built from a deck as `run`
//! builds it, advanced a few steps at a time with the guards of `peridyn run`'s explicit loop,
//! its node data read in place, its history kept in memory with the columns of `history.csv`,
//! loads changed between steps, snapshots and checkpoints written when asked.
//!
//! One explicit stage at a fixed time step: a quasi-static, adaptive or staged deck runs
//! through `run::run` instead (its drivers live inside `run`).

use crate::checkpoint::{DriverState, Origin};
use crate::deck::build::{build_constitution, build_model, MaterialChoice};
use crate::deck::solver_settings::solver_settings;
use crate::deck::{DeckIssue, LoadedDeck};
use crate::loading::{BoundaryCondition, Kinematic, TimeFunction};
use crate::material::Material;
use crate::math::Vector;
use crate::observe::history::History;
use crate::observe::snapshots::Snapshots;
use crate::observe::{Observer, StepView};
use crate::run::observers::opening_nodes;
use crate::run::resolved::resolved_deck;
use crate::run::stages::energy_given;
use crate::run::{prepare, ModelReport, RunError};
use crate::solver::{Fields, Simulation};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Per-node vectors a session lends (D values per node, node after node).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeVectors {
    /// Reference positions x (m).
    Positions,
    /// Displacement u (m).
    Displacement,
    /// Velocity v (m/s).
    Velocity,
    /// Internal force density of the last evaluation (N/m³).
    Force,
}

/// How far `Session::advance` goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// Until the step count reaches this.
    Step(u64),
    /// Until the time reaches this (s), within a billionth of a step.
    Time(f64),
}

/// What a session reports besides the node data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Energies {
    pub kinetic: f64,
    pub strain: f64,
    pub external_work: f64,
    pub damage_dissipation: f64,
    /// Broken bonds (each counted once).
    pub broken_bonds: u64,
}

/// The material-specific half of a session, behind one object-safe interface.
trait Driver: Send {
    fn dimension(&self) -> usize;
    fn nodes(&self) -> usize;
    fn time(&self) -> f64;
    fn step(&self) -> u64;
    fn dt(&self) -> f64;
    fn advance(&mut self, target: Target, deadline: Instant) -> Result<bool, RunError>;
    fn vectors(&self, which: NodeVectors) -> &[f64];
    fn volumes(&self) -> &[f64];
    fn blocks(&self) -> &[u32];
    fn node_sets(&self) -> Vec<(String, Vec<u32>)>;
    fn damage(&self) -> Vec<f64>;
    fn energy_density(&self) -> Vec<f64>;
    fn energies(&self) -> Energies;
    fn history(&self) -> (&[String], &[Vec<f64>]);
    fn prescribe(
        &mut self,
        set: &str,
        kind: Kinematic,
        component: usize,
        value: f64,
    ) -> Result<(), String>;
    fn release(&mut self, set: &str, component: Option<usize>) -> Result<usize, String>;
    fn write_nodes(
        &mut self,
        which: NodeVectors,
        nodes: Option<&[u32]>,
        values: &[f64],
    ) -> Result<(), RunError>;
    fn snapshot(&mut self, dir: &Path) -> Result<PathBuf, RunError>;
    fn save_checkpoint(&self, path: &Path) -> Result<(), RunError>;
    fn load_checkpoint(&mut self, path: &Path) -> Result<(), RunError>;
}

/// A built simulation and the threads it steps on.
pub struct Session {
    driver: Box<dyn Driver>,
    pool: Option<rayon::ThreadPool>,
    /// The model as built (`check`'s numbers).
    pub report: ModelReport,
}

impl Session {
    /// Builds the deck's model on `threads` worker threads (`None`: all cores), ready to step
    /// from step 0. Refuses decks that are not one explicit stage at a fixed time step.
    pub fn new(ld: &LoadedDeck, threads: Option<usize>) -> Result<Self, RunError> {
        let settings = solver_settings(&ld.deck);
        let refuse = |key: &str, what: &str| {
            RunError::Deck(ld.locate(vec![DeckIssue::new(
                key,
                format!("{what}: a simulation stepped from Python is one explicit stage at a fixed time step; run this deck whole with peridyn.run(deck, out_dir)"),
            )]))
        };
        if settings.quasi_static.is_some() {
            return Err(refuse("solver.type", "a quasi-static deck"));
        }
        if settings.adaptive.is_some() {
            return Err(refuse("solver.adaptive", "an adaptive time step"));
        }
        if !ld.deck.stages.is_empty() {
            return Err(refuse("stages", "a staged deck"));
        }
        let pool = match threads {
            None => None,
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| RunError::Threads(e.to_string()))?,
            ),
        };
        let build = || match ld.deck.dimension {
            2 => build_dim::<2>(ld),
            _ => build_dim::<3>(ld),
        };
        let (driver, report) = match &pool {
            Some(p) => p.install(build),
            None => build(),
        }?;
        Ok(Session {
            driver,
            pool,
            report,
        })
    }

    fn on_pool<T: Send>(&mut self, f: impl FnOnce(&mut dyn Driver) -> T + Send) -> T {
        let driver = &mut *self.driver;
        match &self.pool {
            Some(p) => p.install(|| f(driver)),
            None => f(driver),
        }
    }

    /// Steps towards `target` until it is reached or `deadline` has passed (at least one
    /// step when one is due); true when the target is reached. Between calls the caller may
    /// look for an interrupt: the state is always that of a whole step.
    pub fn advance(&mut self, target: Target, deadline: Instant) -> Result<bool, RunError> {
        self.on_pool(|d| d.advance(target, deadline))
    }

    pub fn dimension(&self) -> usize {
        self.driver.dimension()
    }
    pub fn nodes(&self) -> usize {
        self.driver.nodes()
    }
    /// Simulation time (s).
    pub fn time(&self) -> f64 {
        self.driver.time()
    }
    /// Steps taken.
    pub fn step(&self) -> u64 {
        self.driver.step()
    }
    /// Time step (s).
    pub fn dt(&self) -> f64 {
        self.driver.dt()
    }
    /// The deck's steps: `Target::Step(session.steps())` is the end of the run.
    pub fn steps(&self) -> u64 {
        self.report.steps
    }

    /// Per-node vectors in place: `nodes × dimension` values, node after node. The buffer
    /// stays where it is for the session's life (stepping writes into it).
    pub fn vectors(&self, which: NodeVectors) -> &[f64] {
        self.driver.vectors(which)
    }
    /// Node volumes (m³; in 2D area × thickness), in place.
    pub fn volumes(&self) -> &[f64] {
        self.driver.volumes()
    }
    /// Block (material region) of each node, in place.
    pub fn blocks(&self) -> &[u32] {
        self.driver.blocks()
    }
    /// Named node sets and their node indices.
    pub fn node_sets(&self) -> Vec<(String, Vec<u32>)> {
        self.driver.node_sets()
    }
    /// Damage index per node, computed now.
    pub fn damage(&mut self) -> Vec<f64> {
        self.on_pool(|d| d.damage())
    }
    /// Strain energy density per node (J/m³), computed now.
    pub fn energy_density(&mut self) -> Vec<f64> {
        self.on_pool(|d| d.energy_density())
    }
    pub fn energies(&mut self) -> Energies {
        self.on_pool(|d| d.energies())
    }
    /// The history so far: the columns of `history.csv` and its rows (step 0, every
    /// `history_interval` steps and the deck's last step).
    pub fn history(&self) -> (&[String], &[Vec<f64>]) {
        self.driver.history()
    }

    /// Prescribes `value` (m or m/s, constant in time) on `component` of a node set from the
    /// next step on, in place of any condition the deck or an earlier call put there.
    pub fn prescribe(
        &mut self,
        set: &str,
        kind: Kinematic,
        component: usize,
        value: f64,
    ) -> Result<(), String> {
        self.driver.prescribe(set, kind, component, value)
    }

    /// Frees a node set's `component` (every component for `None`) of prescribed conditions;
    /// returns how many were removed.
    pub fn release(&mut self, set: &str, component: Option<usize>) -> Result<usize, String> {
        self.driver.release(set, component)
    }

    /// Writes displacements or velocities (`nodes.len() × dimension` values, or every node's
    /// for `None`); forces are evaluated again after displacements change.
    pub fn write_nodes(
        &mut self,
        which: NodeVectors,
        nodes: Option<&[u32]>,
        values: &[f64],
    ) -> Result<(), RunError> {
        self.on_pool(|d| d.write_nodes(which, nodes, values))
    }

    /// Writes the current fields as `dir/fields/step_N.vtu` (in the series `dir/fields.pvd`)
    /// with the maps the deck's `[output]` asks for; returns the VTU file.
    pub fn snapshot(&mut self, dir: &Path) -> Result<PathBuf, RunError> {
        self.on_pool(|d| d.snapshot(dir))
    }

    /// Writes a checkpoint of the current state (the format of `checkpoint.bin`).
    pub fn save_checkpoint(&self, path: &Path) -> Result<(), RunError> {
        self.driver.save_checkpoint(path)
    }

    /// Continues from a checkpoint written by this deck (by a session or by `peridyn run`).
    pub fn load_checkpoint(&mut self, path: &Path) -> Result<(), RunError> {
        self.on_pool(|d| d.load_checkpoint(path))
    }
}

fn build_dim<const D: usize>(ld: &LoadedDeck) -> Result<(Box<dyn Driver>, ModelReport), RunError> {
    let model = build_model::<D>(ld)?;
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    Ok(match material {
        MaterialChoice::Pmb(m) => Stepper::boxed(ld, prepare(ld, model, m, rest)?)?,
        MaterialChoice::Lps(m) => Stepper::boxed(ld, prepare(ld, model, m, rest)?)?,
        MaterialChoice::Correspondence(m) => Stepper::boxed(ld, prepare(ld, model, m, rest)?)?,
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => Stepper::boxed(ld, prepare(ld, model, m, rest)?)?,
            Err(m) => Stepper::boxed(ld, prepare(ld, model, m, rest)?)?,
        },
    })
}

struct Stepper<const D: usize, M: Material<D>> {
    sim: Simulation<D, M>,
    history: History,
    /// The deck's steps (the run's last step is always recorded).
    steps: u64,
    /// The energy given to the run, which `check_energy` measures blow-ups against.
    given: (f64, f64),
    origin: Origin,
    output: crate::deck::schema::OutputDeck,
    title: String,
    snapshots: Option<(PathBuf, Snapshots)>,
}

impl<const D: usize, M: Material<D> + 'static> Stepper<D, M> {
    fn boxed(
        ld: &LoadedDeck,
        (sim, report): (Simulation<D, M>, ModelReport),
    ) -> Result<(Box<dyn Driver>, ModelReport), RunError>
    where
        Simulation<D, M>: Send,
    {
        let deck = &ld.deck;
        let sets: Vec<(String, Vec<u32>)> = sim
            .body
            .node_sets
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        let every = match deck.history_interval() {
            0 => u64::MAX,
            k => k,
        };
        // Held in memory only: an empty path is never written.
        let mut history = History::new::<D>(Path::new(""), every, &sets)
            .with_openings(&opening_nodes(&sim.body, &deck.output.openings));
        if deck.contact.is_some() || !deck.impactors.is_empty() {
            let names: Vec<String> = deck.impactors.iter().map(|i| i.name.clone()).collect();
            history = history.with_contact::<D>(&names);
        }
        let title = ld.title();
        let mut stepper = Stepper {
            given: energy_given(&sim),
            sim,
            history,
            steps: report.steps,
            origin: Origin::new(&resolved_deck(ld)?, &ld.file),
            output: deck.output.clone(),
            title,
            snapshots: None,
        };
        stepper.record()?;
        Ok((Box::new(stepper), report))
    }
}

impl<const D: usize, M: Material<D>> Stepper<D, M> {
    /// Adds the history row of the step just committed, when it is due.
    fn record(&mut self) -> Result<(), RunError> {
        let step = self.sim.state.step;
        let last = step == self.steps;
        if Observer::<D>::wants(&self.history, step, last) {
            let view = StepView::new(&self.sim as &dyn Fields<D>, last);
            Observer::<D>::observe(&mut self.history, &view)?;
        }
        Ok(())
    }

    fn reached(&self, target: Target) -> bool {
        match target {
            Target::Step(n) => self.sim.state.step >= n,
            Target::Time(t) => t - self.sim.state.time <= 1e-9 * self.sim.dt,
        }
    }
}

impl<const D: usize, M: Material<D>> Driver for Stepper<D, M>
where
    Simulation<D, M>: Send,
{
    fn dimension(&self) -> usize {
        D
    }
    fn nodes(&self) -> usize {
        self.sim.body.len()
    }
    fn time(&self) -> f64 {
        self.sim.state.time
    }
    fn step(&self) -> u64 {
        self.sim.state.step
    }
    fn dt(&self) -> f64 {
        self.sim.dt
    }

    /// `run::explicit_loop`'s steps and guards: the finiteness check every 100 steps and the
    /// energy check (a pass over the bonds) every 10, by the run's step count, so pieces
    /// check what one call does and a loop of single steps pays for no extra pass.
    fn advance(&mut self, target: Target, deadline: Instant) -> Result<bool, RunError> {
        while !self.reached(target) {
            self.sim.step()?;
            let k = self.sim.state.step;
            if k.is_multiple_of(100) || k == self.steps {
                self.sim.check_finite()?;
            }
            if k.is_multiple_of(10) || k == self.steps {
                self.sim.check_energy(self.given)?;
            }
            self.record()?;
            if Instant::now() >= deadline {
                break;
            }
        }
        Ok(self.reached(target))
    }

    fn vectors(&self, which: NodeVectors) -> &[f64] {
        let v = match which {
            NodeVectors::Positions => &self.sim.body.positions,
            NodeVectors::Displacement => &self.sim.state.u,
            NodeVectors::Velocity => &self.sim.state.v,
            NodeVectors::Force => &self.sim.state.force,
        };
        flat(v)
    }
    fn volumes(&self) -> &[f64] {
        &self.sim.body.volumes
    }
    fn blocks(&self) -> &[u32] {
        &self.sim.body.blocks
    }
    fn node_sets(&self) -> Vec<(String, Vec<u32>)> {
        self.sim
            .body
            .node_sets
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect()
    }
    fn damage(&self) -> Vec<f64> {
        Fields::damage(&self.sim)
    }
    fn energy_density(&self) -> Vec<f64> {
        Fields::energy_density(&self.sim)
    }
    fn energies(&self) -> Energies {
        Energies {
            kinetic: self.sim.kinetic_energy(),
            strain: self.sim.strain_energy(),
            external_work: self.sim.state.external_work,
            damage_dissipation: Fields::damage_dissipation(&self.sim),
            broken_bonds: self.sim.state.broken / 2,
        }
    }
    fn history(&self) -> (&[String], &[Vec<f64>]) {
        (self.history.header(), self.history.rows())
    }

    fn prescribe(
        &mut self,
        set: &str,
        kind: Kinematic,
        component: usize,
        value: f64,
    ) -> Result<(), String> {
        let nodes = self.set_nodes(set)?;
        if component >= D {
            return Err(format!(
                "component {component} does not exist in {D}D (0 to {})",
                D - 1
            ));
        }
        if !value.is_finite() {
            return Err(format!("the value to prescribe is {value}, not a number"));
        }
        let mut loading = self.sim.loading.clone();
        loading
            .conditions
            .retain(|c| !(c.set == set && c.component == component));
        loading.conditions.push(BoundaryCondition {
            set: set.to_string(),
            nodes,
            kind,
            component,
            value,
            time: TimeFunction::Constant,
        });
        // Applied by the next step as the deck's own conditions are (velocities at its half
        // step and end, displacements before its force evaluation).
        self.sim.replace_loading(loading);
        Ok(())
    }

    fn release(&mut self, set: &str, component: Option<usize>) -> Result<usize, String> {
        self.set_nodes(set)?;
        let mut loading = self.sim.loading.clone();
        let before = loading.conditions.len();
        loading
            .conditions
            .retain(|c| !(c.set == set && component.is_none_or(|k| k == c.component)));
        let removed = before - loading.conditions.len();
        self.sim.replace_loading(loading);
        Ok(removed)
    }

    fn write_nodes(
        &mut self,
        which: NodeVectors,
        nodes: Option<&[u32]>,
        values: &[f64],
    ) -> Result<(), RunError> {
        let n = self.sim.body.len();
        let count = nodes.map_or(n, |s| s.len());
        let invalid =
            |m: String| RunError::Io(std::io::Error::new(std::io::ErrorKind::InvalidInput, m));
        if values.len() != count * D {
            return Err(invalid(format!(
                "{} values given for {count} nodes × {D} components",
                values.len()
            )));
        }
        if let Some(&bad) = nodes.and_then(|s| s.iter().find(|&&i| i as usize >= n)) {
            return Err(invalid(format!(
                "node {bad} does not exist (the model has {n} nodes)"
            )));
        }
        if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
            return Err(invalid(format!("the values hold {bad}")));
        }
        for k in 0..count {
            let i = nodes.map_or(k, |s| s[k] as usize);
            let value = Vector::<D>::from_column_slice(&values[k * D..(k + 1) * D]);
            match which {
                NodeVectors::Displacement => {
                    self.sim.state.set_displacement(&self.sim.body, i, value)
                }
                NodeVectors::Velocity => self.sim.state.v[i] = value,
                _ => {
                    return Err(invalid(
                        "only displacements and velocities can be written".into(),
                    ))
                }
            }
        }
        if which == NodeVectors::Displacement {
            self.sim.refresh_forces()?;
        }
        // The energy put in by hand is the run's to keep.
        self.given = energy_given(&self.sim);
        Ok(())
    }

    fn snapshot(&mut self, dir: &Path) -> Result<PathBuf, RunError> {
        if self.snapshots.as_ref().is_none_or(|(d, _)| d != dir) {
            let s = Snapshots::new(dir.to_path_buf(), u64::MAX, &self.output, &self.title)?;
            self.snapshots = Some((dir.to_path_buf(), s));
        }
        let Some((_, snapshots)) = &mut self.snapshots else {
            unreachable!("set just above")
        };
        let view = StepView::new(&self.sim as &dyn Fields<D>, false);
        Observer::<D>::observe(snapshots, &view)?;
        Observer::<D>::finish(snapshots)?;
        Ok(dir
            .join("fields")
            .join(format!("step_{:08}.vtu", self.sim.state.step)))
    }

    fn save_checkpoint(&self, path: &Path) -> Result<(), RunError> {
        let driver = DriverState {
            next_dt: self.sim.dt,
            impactors: self.sim.impactors.states(),
            ..DriverState::default()
        };
        crate::checkpoint::write(path, &self.origin, &self.sim.state, &driver)?;
        Ok(())
    }

    fn load_checkpoint(&mut self, path: &Path) -> Result<(), RunError> {
        // Restored into a copy first: a refused checkpoint leaves the simulation as it was.
        let mut state = self.sim.state.clone();
        let driver = crate::checkpoint::restore(path, &self.origin, &mut state)?;
        if driver.stage != 0 {
            return Err(RunError::Io(std::io::Error::other(format!(
                "{} was written in stage {} of a staged run",
                path.display(),
                driver.stage
            ))));
        }
        // Into the arrays already there, which the views read.
        self.sim.state.clone_from(&state);
        self.sim.impactors.restore(&driver.impactors);
        self.given = energy_given(&self.sim);
        Ok(())
    }
}

impl<const D: usize, M: Material<D>> Stepper<D, M> {
    fn set_nodes(&self, set: &str) -> Result<Vec<u32>, String> {
        self.sim.body.node_sets.get(set).cloned().ok_or_else(|| {
            let names: Vec<&str> = self.sim.body.node_sets.keys().map(|k| k.as_str()).collect();
            format!(
                "no node set `{set}` (the deck has: {})",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            )
        })
    }
}

/// Vectors of D f64 as their D·n numbers.
fn flat<const D: usize>(v: &[Vector<D>]) -> &[f64] {
    // SAFETY: a `Vector<D>` is nalgebra's `#[repr(C)]` array storage of D f64, so a slice of
    // n of them is n·D contiguous, aligned f64.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<f64>(), v.len() * D) }
}
