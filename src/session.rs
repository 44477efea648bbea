//! A simulation driven from another program (the Python package): built from a deck as `run`
//! builds it, advanced a few steps at a time with the guards of `peridyn run`'s explicit loop,
//! its node data read in place, its history kept in memory with the columns of `history.csv`,
//! loads changed between steps, snapshots and checkpoints written when asked.
//!
//! Every deck `run` runs steps here, through `run`'s own stage loop (`run::stages::Course`):
//! a step is one committed step of it — an explicit step (of the adaptive dt's size with
//! `[solver.adaptive]`), or a quasi-static load step (each committed piece of one split
//! because it broke too many bonds) — and a staged deck's steps cross its stages as `run`'s do.

use crate::checkpoint::Origin;
use crate::deck::build::{build_constitution, build_model, MaterialChoice};
use crate::deck::solver_settings::{solver_settings, SolverSettings};
use crate::deck::stages::{stage_name, StagePlan};
use crate::deck::LoadedDeck;
use crate::loading::{BoundaryCondition, Kinematic, Loading, TimeFunction};
use crate::material::Material;
use crate::math::Vector;
use crate::observe::history::History;
use crate::observe::snapshots::Snapshots;
use crate::observe::{Observer, StageStart, StepView};
use crate::run::observers::history;
use crate::run::resolved::resolved_deck;
use crate::run::stages::{Course, Position, Watch};
use crate::run::{prepare, ModelReport, RunError};
use crate::solver::{Fields, Simulation};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
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
    /// To the end of the deck's last stage.
    End,
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
    fn done(&self) -> bool;
    fn stage(&self) -> (usize, &str);
    fn advance(&mut self, target: Target, deadline: Instant) -> Result<bool, RunError>;
    fn vectors(&self, which: NodeVectors) -> &[f64];
    fn volumes(&self) -> &[f64];
    fn blocks(&self) -> &[u32];
    fn node_sets(&self) -> Vec<(String, Vec<u32>)>;
    fn damage(&self) -> Vec<f64>;
    fn energy_density(&self) -> Vec<f64>;
    fn energies(&self) -> Energies;
    fn history(&self) -> (Vec<String>, Vec<Vec<f64>>);
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
    /// from step 0.
    pub fn new(ld: &LoadedDeck, threads: Option<usize>) -> Result<Self, RunError> {
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
    /// Time step (s) of the next step: the adaptive controller's next try with
    /// `[solver.adaptive]`, the load increment (pseudo-time) of a quasi-static stage.
    pub fn dt(&self) -> f64 {
        self.driver.dt()
    }
    /// The deck's steps (a staged deck's: the sum of its stages'; with an adaptive time
    /// step, the estimate from its first dt). `done` says when the run is over.
    pub fn steps(&self) -> u64 {
        self.report.steps
    }
    /// Whether the deck's last step is done.
    pub fn done(&self) -> bool {
        self.driver.done()
    }
    /// The stage of the last step (0: the deck's own) and its name (the deck's, or its
    /// number from 1).
    pub fn stage(&self) -> (usize, &str) {
        self.driver.stage()
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
    /// `history_interval` steps, each stage's last step and the deck's last step), copied.
    pub fn history(&self) -> (Vec<String>, Vec<Vec<f64>>) {
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

    /// Continues from a checkpoint written by this deck (by a session or by `peridyn run`),
    /// in the stage it was written in, as `peridyn run --restart` does.
    pub fn load_checkpoint(&mut self, path: &Path) -> Result<(), RunError> {
        self.on_pool(|d| d.load_checkpoint(path))
    }
}

fn build_dim<const D: usize>(ld: &LoadedDeck) -> Result<(Box<dyn Driver>, ModelReport), RunError> {
    let mut model = build_model::<D>(ld)?;
    let plans = std::mem::take(&mut model.stages);
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    Ok(match material {
        MaterialChoice::Pmb(m) => Stepper::boxed(ld, plans, prepare(ld, model, m, rest)?)?,
        MaterialChoice::Lps(m) => Stepper::boxed(ld, plans, prepare(ld, model, m, rest)?)?,
        MaterialChoice::Correspondence(m) => {
            Stepper::boxed(ld, plans, prepare(ld, model, m, rest)?)?
        }
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => Stepper::boxed(ld, plans, prepare(ld, model, m, rest)?)?,
            Err(m) => Stepper::boxed(ld, plans, prepare(ld, model, m, rest)?)?,
        },
    })
}

struct Stepper<const D: usize, M: Material<D>> {
    sim: Simulation<D, M>,
    /// The history, held in memory (its empty path is never written), lent to each call's
    /// watch.
    history: Arc<Mutex<History>>,
    /// `run`'s stages and where the run is in them.
    course: Course<D>,
    at: Position<D>,
    /// What a checkpoint's run starts again from.
    start: Start<D>,
    /// Each stage's name.
    names: Vec<String>,
    origin: Origin,
    output: crate::deck::schema::OutputDeck,
    title: String,
    snapshots: Option<(PathBuf, Snapshots)>,
}

/// The run as built: a checkpoint is continued from it as `peridyn run --restart` continues
/// one from a freshly built run.
struct Start<const D: usize> {
    first: SolverSettings,
    plans: Vec<StagePlan<D>>,
    report: ModelReport,
    dt: f64,
    no_fail: Vec<bool>,
    loading: Loading<D>,
    /// The first stage's steps between history rows.
    history_interval: u64,
}

impl<const D: usize> Start<D> {
    fn staged(&self) -> bool {
        !self.plans.is_empty()
    }
}

/// The session's history as one of a run's observers: in memory, nothing to finish.
struct Shared(Arc<Mutex<History>>);

fn locked(h: &Mutex<History>) -> MutexGuard<'_, History> {
    h.lock().unwrap_or_else(|p| p.into_inner())
}

impl<const D: usize> Observer<D> for Shared {
    fn wants(&self, step: u64, last: bool) -> bool {
        Observer::<D>::wants(&*locked(&self.0), step, last)
    }
    fn observe(&mut self, view: &StepView<D>) -> std::io::Result<()> {
        locked(&self.0).observe(view)
    }
    fn begin_stage(&mut self, stage: &StageStart) {
        Observer::<D>::begin_stage(&mut *locked(&self.0), stage)
    }
}

impl<const D: usize, M: Material<D> + 'static> Stepper<D, M> {
    fn boxed(
        ld: &LoadedDeck,
        plans: Vec<StagePlan<D>>,
        (sim, report): (Simulation<D, M>, ModelReport),
    ) -> Result<(Box<dyn Driver>, ModelReport), RunError>
    where
        Simulation<D, M>: Send,
    {
        let deck = &ld.deck;
        let staged = !plans.is_empty();
        let history = history::<D>(deck, &sim.body, staged, Path::new(""));
        let start = Start {
            first: solver_settings(deck),
            plans,
            report: report.clone(),
            dt: sim.dt,
            no_fail: sim.body.no_fail.clone(),
            loading: sim.loading.clone(),
            history_interval: match deck.history_interval() {
                0 => u64::MAX,
                k => k,
            },
        };
        let mut stepper = Stepper {
            course: Course::new(start.first.clone(), &report, start.plans.clone()),
            at: Position::new(None, staged),
            names: (0..=start.plans.len())
                .map(|k| stage_name(deck, k))
                .collect(),
            start,
            sim,
            history: Arc::new(Mutex::new(history)),
            origin: Origin::new(&resolved_deck(ld)?, &ld.file),
            output: deck.output.clone(),
            title: ld.title(),
            snapshots: None,
        };
        // The first stage starts: step 0 joins the history.
        stepper.watched(|course, sim, watch| course.start(sim, watch))?;
        Ok((Box::new(stepper), report))
    }
}

impl<const D: usize, M: Material<D>> Stepper<D, M> {
    /// Runs `f` on the course with a watch whose one observer is the history, at the
    /// position the last call left.
    fn watched<T>(
        &mut self,
        f: impl FnOnce(&mut Course<D>, &mut Simulation<D, M>, &mut Watch<D>) -> Result<T, RunError>,
    ) -> Result<T, RunError> {
        let mut observers: Vec<Box<dyn Observer<D>>> = vec![Box::new(Shared(self.history.clone()))];
        let mut watch = Watch::at(&mut observers, std::mem::take(&mut self.at));
        let result = f(&mut self.course, &mut self.sim, &mut watch);
        self.at = watch.position();
        result
    }
}

fn reached<const D: usize, M: Material<D>>(
    course: &Course<D>,
    sim: &Simulation<D, M>,
    target: Target,
) -> bool {
    match target {
        Target::Step(n) => sim.state.step >= n,
        Target::Time(t) => t - sim.state.time <= 1e-9 * sim.dt,
        Target::End => course.done(sim),
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
    fn done(&self) -> bool {
        self.course.done(&self.sim)
    }
    fn stage(&self) -> (usize, &str) {
        let k = self.at.stage();
        (k, &self.names[k])
    }

    /// `run`'s own steps, guards and stage changes, one committed step at a time (the
    /// guards count from the run's start, so pieces check what one call does).
    fn advance(&mut self, target: Target, deadline: Instant) -> Result<bool, RunError> {
        self.watched(|course, sim, watch| {
            while !reached(course, sim, target) {
                if !course.advance(sim, watch)? || Instant::now() >= deadline {
                    break;
                }
            }
            Ok(())
        })?;
        Ok(reached(&self.course, &self.sim, target) || self.course.done(&self.sim))
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
    fn history(&self) -> (Vec<String>, Vec<Vec<f64>>) {
        let h = locked(&self.history);
        (h.header().to_vec(), h.rows().to_vec())
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
            offsets: Vec::new(),
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
        self.course.rebase(&self.sim);
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
        let driver = self.course.driver_state(&self.sim, &self.at);
        crate::checkpoint::write(path, &self.origin, &self.sim.state, &driver)?;
        Ok(())
    }

    fn load_checkpoint(&mut self, path: &Path) -> Result<(), RunError> {
        // Restored into a copy first: a refused checkpoint leaves the simulation as it was.
        let mut state = self.sim.state.clone();
        let driver = crate::checkpoint::restore(path, &self.origin, &mut state)?;
        // Into the arrays already there, which the views read.
        self.sim.state.clone_from(&state);
        self.sim.impactors.restore(&driver.impactors);
        // The run as built, continued in the checkpoint's stage as `run --restart` does;
        // an unstaged deck keeps the conditions Python prescribed.
        let s = &self.start;
        self.sim.dt = s.dt;
        self.sim.body.no_fail.clone_from(&s.no_fail);
        if s.staged() {
            self.sim.replace_loading(s.loading.clone());
            // The history's stage column and interval back at the first stage's.
            let first = StageStart {
                index: 0,
                history_interval: s.history_interval,
            };
            Observer::<D>::begin_stage(&mut *locked(&self.history), &first);
        }
        self.course = Course::new(s.first.clone(), &s.report, s.plans.clone());
        self.at = Position::new(Some(driver), s.staged());
        self.watched(|course, sim, watch| course.start(sim, watch))
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
