//! Dispatch-once: the deck's dimension and material pick `run_model::<D, M>()`; everything
//! below is monomorphised. Also `check` (build and report without stepping).

use crate::checkpoint::{CheckpointError, Checkpoints, DriverState, Origin};
use crate::damage::Damage;
use crate::deck::build::{
    build_constitution, build_model, Constitution, MaterialChoice, MaterialReport, Model,
};
use crate::deck::solver_settings::{settings_of, solver_settings, SolverSettings};
use crate::deck::stages::{stage_name, StagePlan, StageReport};
use crate::deck::{DeckError, DeckIssue, LoadedDeck};
use crate::material::surface_correction::SurfaceReport;
use crate::material::{Elasticity, Material};
use crate::math::Vector;
use crate::observe::crack_path::{CrackPath, PathReport, PathSettings};
use crate::observe::crack_surface::{CrackSurface, CrackSurfaceReport, SurfaceSettings};
use crate::observe::crack_tip::{CrackReport, CrackTips};
use crate::observe::history::History;
use crate::observe::progress::Progress;
use crate::observe::resume::ResumedCsv;
use crate::observe::snapshots::Snapshots;
use crate::observe::stage_record::StageRecord;
use crate::observe::{Every, Observer, StageStart, StepView};
use crate::solver::Fields;
use crate::solver::{
    AdaptiveDt, AdaptiveDtSettings, QuasiStatic, QuasiStaticSettings, Simulation, StepError,
};
use serde::Serialize;
use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use std::time::Instant;

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Deck(#[from] DeckError),
    #[error("{0}")]
    Step(#[from] StepError),
    #[error("writing results: {0}")]
    Io(#[from] std::io::Error),
    #[error("{0}")]
    Threads(String),
    #[error("{0}")]
    Checkpoint(#[from] CheckpointError),
    /// The run stopped after this step as `RunControl::stop_after_step` asked.
    #[error("stopped after step {0} as asked (--stop-after-step)")]
    Stopped(u64),
}

/// Options of `peridyn run`.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub out_dir: PathBuf,
    pub threads: Option<usize>,
    /// No progress output.
    pub quiet: bool,
}

/// How a run continues or stops, besides `RunOptions`.
#[derive(Debug, Clone, Default)]
pub struct RunControl {
    /// Continue the run in `RunOptions::out_dir` from its checkpoint.
    pub restart: bool,
    /// Stop after this step as a killed run would (files not finished): for tests of restarts.
    pub stop_after_step: Option<u64>,
}

/// The model as built: what `peridyn check` prints and `resolved.toml` records.
#[derive(Debug, Clone, Serialize)]
pub struct ModelReport {
    pub dimension: usize,
    /// The model(s) in use: "pmb", "lps", "correspondence", or several joined by " + ".
    pub model: String,
    /// The damage law(s) in use.
    pub damage: String,
    pub nodes: usize,
    /// Physical bonds (each counted once).
    pub bonds: usize,
    pub bonds_per_node: f64,
    pub horizon: f64,
    pub spacing: f64,
    pub horizon_over_spacing: f64,
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
    /// PMB micromodulus c0 as the papers write it (2D: per unit thickness) of the first
    /// material; 0 for state-based models.
    pub micromodulus: f64,
    /// Critical stretch of the first material (infinite when its law has none).
    pub critical_stretch: f64,
    pub p_wave_speed: f64,
    /// "explicit" or "quasi-static (adaptive dynamic relaxation)".
    pub solver: String,
    /// Time step (s), or the load increment in pseudo-time of a quasi-static run.
    pub dt: f64,
    pub dt_stable: f64,
    /// Steps, or load steps of a quasi-static run.
    pub steps: u64,
    pub end_time: f64,
    pub memory_bytes: usize,
    pub bytes_per_bond: usize,
    /// Every material as calibrated.
    pub materials: Vec<MaterialReport>,
    pub grid: crate::grid::GridReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface_correction: Option<SurfaceReport>,
    /// A staged run's stages, the deck's own first (then `steps` and `end_time` above are
    /// their sums, the other solver fields the first stage's); empty for a run of one stage.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub stages: Vec<StageReport>,
}

impl std::fmt::Display for ModelReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "model            {} ({}D), damage: {}",
            self.model, self.dimension, self.damage
        )?;
        writeln!(f, "nodes            {}", self.nodes)?;
        writeln!(f, "{}", self.grid)?;
        if let Some(s) = &self.surface_correction {
            writeln!(f, "{s}")?;
        }
        writeln!(
            f,
            "bonds            {} ({:.1} per node, {} B per directed bond)",
            self.bonds, self.bonds_per_node, self.bytes_per_bond
        )?;
        writeln!(
            f,
            "horizon δ        {:.4e} m, δ/Δx = {:.3} (Δx = {:.4e} m)",
            self.horizon, self.horizon_over_spacing, self.spacing
        )?;
        writeln!(
            f,
            "elasticity       E = {:.4e} Pa, ν = {:.4}, P-wave speed {:.1} m/s",
            self.youngs_modulus, self.poisson_ratio, self.p_wave_speed
        )?;
        for m in &self.materials {
            write!(
                f,
                "{:<16} {} ({} nodes): E = {:.4e} Pa, ν = {:.4}, ρ = {} kg/m³",
                m.key, m.model, m.nodes, m.youngs_modulus, m.poisson_ratio, m.density
            )?;
            if let Some(c) = m.micromodulus {
                write!(f, ", c0 = {c:.4e}")?;
            }
            if m.horizon_max > m.horizon_min {
                write!(
                    f,
                    ", δ from {:.4e} to {:.4e} m",
                    m.horizon_min, m.horizon_max
                )?;
            }
            write!(f, "\n                 damage: {}", m.damage)?;
            if let Some(s) = m.critical_stretch {
                write!(f, ", s0 = {s:.5e}")?;
            }
            if let Some(w) = m.critical_energy {
                write!(f, ", w_c = {w:.5e} J/m⁶")?;
            }
            if let (Some(s1), Some(sc)) = (m.peak_stretch, m.breaking_stretch) {
                write!(f, ", s1 = {s1:.5e}")?;
                if let Some(s2) = m.kink_stretch {
                    write!(f, ", s2 = {s2:.5e}")?;
                }
                write!(f, ", breaking stretch {sc:.5e}")?;
            }
            if let Some(n) = m.prebroken_bonds {
                write!(f, ", {n} bonds broken before loading (porosity)")?;
            }
            writeln!(f)?;
            if let Some(note) = &m.note {
                writeln!(f, "                 note: {note}")?;
            }
        }
        if !self.stages.is_empty() {
            for stage in &self.stages {
                writeln!(f, "{stage}")?;
            }
            writeln!(
                f,
                "run              {} steps in {} stages, stable time step {:.4e} s, t_end = {:.4e}",
                self.steps,
                self.stages.len(),
                self.dt_stable,
                self.end_time
            )?;
        } else if self.solver == "explicit" {
            writeln!(
                f,
                "time step        dt = {:.4e} s (stable estimate {:.4e} s, ratio {:.3})",
                self.dt,
                self.dt_stable,
                self.dt / self.dt_stable
            )?;
            writeln!(
                f,
                "run              {} steps, t_end = {:.4e} s",
                self.steps, self.end_time
            )?;
        } else {
            writeln!(
                f,
                "solver           {}: {} load steps of {:.4e} to t = {:.4e}",
                self.solver, self.steps, self.dt, self.end_time
            )?;
        }
        write!(
            f,
            "memory estimate  {:.1} MB",
            self.memory_bytes as f64 / 1e6
        )
    }
}

/// What a finished run reports.
#[derive(Debug, Clone)]
pub struct RunSummary {
    pub report: ModelReport,
    pub wall_seconds: f64,
    pub node_steps_per_second: f64,
    pub broken_bonds: u64,
    pub kinetic_energy: f64,
    pub strain_energy: f64,
    pub external_work: f64,
    pub timers: String,
    pub out_dir: PathBuf,
    /// With `[analysis.crack_tip]`: the Rayleigh speed and each branch's mean crack speed.
    pub crack: Option<CrackReport>,
    /// With `[analysis.crack_path]`: the path, its comparison with the reference, the forks.
    pub crack_path: Option<PathReport>,
    /// With `[analysis.crack_surface]`: the crack area, its cells and E_diss/A.
    pub crack_surface: Option<CrackSurfaceReport>,
}

impl std::fmt::Display for RunSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{}", self.report)?;
        writeln!(
            f,
            "finished         {} steps in {:.2} s wall, {:.3e} node-steps/s",
            self.report.steps, self.wall_seconds, self.node_steps_per_second
        )?;
        writeln!(f, "broken bonds     {}", self.broken_bonds)?;
        writeln!(
            f,
            "energies         kinetic {:.5e} J, strain {:.5e} J, external work {:.5e} J",
            self.kinetic_energy, self.strain_energy, self.external_work
        )?;
        if let Some(c) = &self.crack {
            writeln!(f, "crack            {c}")?;
        }
        if let Some(p) = &self.crack_path {
            writeln!(f, "crack path       {p}")?;
        }
        if let Some(a) = &self.crack_surface {
            writeln!(f, "crack surface    {a}")?;
        }
        writeln!(f, "timers           {}", self.timers)?;
        write!(f, "results in       {}", self.out_dir.display())
    }
}

fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> Result<T, RunError> {
    match threads {
        None => Ok(f()),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| RunError::Threads(e.to_string()))?;
            Ok(pool.install(f))
        }
    }
}

/// Builds the model and reports it, without stepping.
pub fn check(ld: &LoadedDeck, threads: Option<usize>) -> Result<ModelReport, RunError> {
    Ok(checked(ld, threads, false)?.0)
}

/// `check`, and for a single-stage explicit run the time its steps will take, from a few
/// steps of the built model timed on the same threads (`peridyn check`).
pub fn check_timed(
    ld: &LoadedDeck,
    threads: Option<usize>,
) -> Result<(ModelReport, Option<TimeEstimate>), RunError> {
    checked(ld, threads, true)
}

/// What `check_timed` predicts: the stepping alone (the force passes and the integration),
/// without the output, at the deck's time step.
#[derive(Debug, Clone, Copy)]
pub struct TimeEstimate {
    pub seconds_per_step: f64,
    pub steps: u64,
    /// Steps timed, after one untimed (whose one-off work, such as a first contact list,
    /// later steps do not repeat).
    pub timed_steps: u64,
}

impl std::fmt::Display for TimeEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "time estimate    {:.1} s stepping {} steps at {:.3e} s per step ({} steps timed; \
             output and breaking bonds add to it)",
            self.seconds_per_step * self.steps as f64,
            self.steps,
            self.seconds_per_step,
            self.timed_steps
        )
    }
}

/// Steps `check_timed` times after the untimed one.
const TIMED_STEPS: u64 = 3;

fn checked(
    ld: &LoadedDeck,
    threads: Option<usize>,
    time: bool,
) -> Result<(ModelReport, Option<TimeEstimate>), RunError> {
    with_threads(threads, || match ld.deck.dimension {
        2 => check_dim::<2>(ld, time),
        _ => check_dim::<3>(ld, time),
    })?
}

fn check_dim<const D: usize>(
    ld: &LoadedDeck,
    time: bool,
) -> Result<(ModelReport, Option<TimeEstimate>), RunError> {
    let model = build_model::<D>(ld)?;
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    fn timed<const D: usize, M: Material<D>>(
        (mut sim, report): (Simulation<D, M>, ModelReport),
        time: bool,
    ) -> (ModelReport, Option<TimeEstimate>) {
        let estimate = (time && report.solver == "explicit" && report.stages.is_empty())
            .then(|| time_steps(&mut sim, report.steps))
            .flatten();
        (report, estimate)
    }
    Ok(match material {
        MaterialChoice::Pmb(m) => timed(prepare(ld, model, m, rest)?, time),
        MaterialChoice::Lps(m) => timed(prepare(ld, model, m, rest)?, time),
        MaterialChoice::Correspondence(m) => timed(prepare(ld, model, m, rest)?, time),
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => timed(prepare(ld, model, m, rest)?, time),
            Err(m) => timed(prepare(ld, model, m, rest)?, time),
        },
    })
}

/// One untimed step, then `TIMED_STEPS` timed (of a model `check` throws away); `None` for a
/// run of no steps or when a step fails (the run itself will say why).
fn time_steps<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    steps: u64,
) -> Option<TimeEstimate> {
    if steps == 0 || sim.step().is_err() {
        return None;
    }
    let started = Instant::now();
    for _ in 0..TIMED_STEPS {
        sim.step().ok()?;
    }
    Some(TimeEstimate {
        seconds_per_step: started.elapsed().as_secs_f64() / TIMED_STEPS as f64,
        steps,
        timed_steps: TIMED_STEPS,
    })
}

/// Runs a deck, writing results into `opts.out_dir`.
pub fn run(ld: &LoadedDeck, opts: &RunOptions) -> Result<RunSummary, RunError> {
    run_with(ld, opts, &RunControl::default())
}

/// Runs a deck, or continues it from its checkpoint, as `control` says.
pub fn run_with(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
) -> Result<RunSummary, RunError> {
    with_threads(opts.threads, || match ld.deck.dimension {
        2 => run_dim::<2>(ld, opts, control),
        _ => run_dim::<3>(ld, opts, control),
    })?
}

fn run_dim<const D: usize>(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
) -> Result<RunSummary, RunError> {
    let model = build_model::<D>(ld)?;
    let c = build_constitution(ld, &model)?;
    let (material, rest) = c.split();
    match material {
        MaterialChoice::Pmb(m) => run_model(ld, model, m, rest, opts, control),
        MaterialChoice::Lps(m) => run_model(ld, model, m, rest, opts, control),
        MaterialChoice::Correspondence(m) => run_model(ld, model, m, rest, opts, control),
        // PMB and LPS blocks only: the scalar path.
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => run_model(ld, model, m, rest, opts, control),
            Err(m) => run_model(ld, model, m, rest, opts, control),
        },
    }
}

/// A constitution without its material: what `prepare` needs besides it.
pub struct DamageAndReports {
    pub damage: Damage,
    pub reports: Vec<MaterialReport>,
    pub porosity: Vec<(u16, crate::damage::porosity::Porosity)>,
    pub surface: Option<SurfaceReport>,
}

impl Constitution {
    /// The material (to dispatch on) and the rest.
    pub fn split(self) -> (MaterialChoice, DamageAndReports) {
        (
            self.material,
            DamageAndReports {
                damage: self.damage,
                reports: self.reports,
                porosity: self.porosity,
                surface: self.surface.map(|s| s.report),
            },
        )
    }
}

/// Builds the simulation, checks the time step and reports the model.
pub fn prepare<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    model: Model<D>,
    material: M,
    rest: DamageAndReports,
) -> Result<(Simulation<D, M>, ModelReport), RunError> {
    let settings = solver_settings(&ld.deck);
    let started = Instant::now();
    let DamageAndReports {
        damage,
        mut reports,
        porosity,
        surface,
    } = rest;
    let Model {
        body,
        bonds,
        loading,
        rule,
        horizon,
        spacing,
        initial_velocities,
        material_of,
        build_time,
        ..
    } = model;
    let history_bytes = damage.bytes_per_bond(crate::solver::bond_force::<D, M>());
    let grid = crate::grid::grid_report(ld, &body, &bonds);
    let mut sim = Simulation::new(
        body,
        bonds,
        material,
        damage,
        rule,
        loading,
        settings.dt,
        settings.safety_factor,
    )
    .map_err(|e| ld.locate(vec![DeckIssue::new("material", e.to_string())]))?;
    for (k, p) in &porosity {
        let n = p.prebreak(&sim.bonds, |i| material_of[i] == *k, &mut sim.state.status);
        reports[*k as usize].prebroken_bonds = Some(n);
    }
    if !porosity.is_empty() {
        sim.refresh_forces()?;
    }
    if let (Some(dt), None) = (settings.dt, &settings.quasi_static) {
        if dt > sim.dt_stable {
            return Err(ld
                .locate(vec![DeckIssue::new("solver.dt", format!("dt = {dt:.4e} s exceeds the stable time step {:.4e} s (Silling–Askari estimate); lower dt or remove it to use safety_factor × the estimate", sim.dt_stable))])
                .into());
        }
    }
    for iv in &initial_velocities {
        iv.apply(&sim.body, &mut sim.state);
    }
    // Prescribed velocities win over initial ones on constrained components; a quasi-static
    // run has none.
    sim.loading.apply_end_velocities(&mut sim.state, 0.0);
    if settings.quasi_static.is_some() {
        sim.state
            .v
            .iter_mut()
            .for_each(|v| *v = crate::math::Vector::zeros());
    }
    sim.counters.setup = started.elapsed();
    sim.counters.grid = build_time;
    let steps = settings
        .steps
        .unwrap_or_else(|| (settings.end_time.unwrap_or(0.0) / sim.dt).ceil() as u64);
    let el: Elasticity = sim.engine.material.elasticity();
    attach_contact(ld, &mut sim, spacing, horizon, el)?;
    let nodes = sim.body.len();
    let bytes_per_bond =
        crate::bonds::Bonds::BYTES_PER_BOND + sim.engine.quad.bytes_per_bond() + history_bytes;
    let join = |f: fn(&MaterialReport) -> &str| {
        let mut names: Vec<&str> = reports.iter().map(f).collect();
        names.dedup();
        names.join(" + ")
    };
    let first = &reports[0];
    let report = ModelReport {
        dimension: D,
        model: join(|r| &r.model),
        damage: join(|r| &r.damage),
        nodes,
        bonds: sim.bonds.len() / 2,
        bonds_per_node: sim.bonds.bonds_per_node(),
        horizon,
        spacing,
        horizon_over_spacing: horizon / spacing,
        youngs_modulus: el.youngs_modulus,
        poisson_ratio: el.poisson_ratio,
        micromodulus: first.micromodulus.unwrap_or(0.0),
        critical_stretch: first.critical_stretch.unwrap_or(f64::INFINITY),
        p_wave_speed: (el.p_wave_modulus() / sim.densities[0]).sqrt(),
        solver: if settings.quasi_static.is_some() {
            "quasi-static (adaptive dynamic relaxation)".into()
        } else {
            "explicit".into()
        },
        dt: sim.dt,
        dt_stable: sim.dt_stable,
        steps,
        end_time: steps as f64 * sim.dt,
        memory_bytes: nodes
            * crate::memory::bytes_per_node(D, std::mem::size_of::<M::Point>() + M::NODE_BYTES)
            + sim.bonds.len() * bytes_per_bond,
        bytes_per_bond,
        materials: reports,
        grid,
        surface_correction: surface,
        stages: Vec::new(),
    };
    let report = with_stages(ld, report, &settings)?;
    Ok((sim, report))
}

/// A staged deck's report: each stage's, and the totals.
fn with_stages(
    ld: &LoadedDeck,
    mut report: ModelReport,
    first: &SolverSettings,
) -> Result<ModelReport, RunError> {
    let deck = &ld.deck;
    if deck.stages.is_empty() {
        return Ok(report);
    }
    let mut stages = vec![StageReport {
        name: stage_name(deck, 0),
        solver: if first.quasi_static.is_some() {
            "quasi-static".into()
        } else {
            "explicit".into()
        },
        steps: report.steps,
        dt: report.dt,
        duration: match (&first.adaptive, first.end_time) {
            (Some(_), Some(end)) => end,
            _ => report.end_time,
        },
    }];
    for (k, stage) in deck.stages.iter().enumerate() {
        let at = format!("stages[{k}].");
        stages.push(
            StageReport::new(
                stage_name(deck, k + 1),
                &settings_of(&stage.solver),
                report.dt_stable,
                &at,
            )
            .map_err(|issue| ld.locate(vec![issue]))?,
        );
    }
    report.steps = stages.iter().map(|s| s.steps).sum();
    report.end_time = stages.iter().map(|s| s.duration).sum();
    report.stages = stages;
    Ok(report)
}

/// `[contact]` and `[[impactors]]` (`deck::contact`), with the forces at the initial state.
fn attach_contact<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    sim: &mut Simulation<D, M>,
    spacing: f64,
    horizon: f64,
    elasticity: Elasticity,
) -> Result<(), RunError> {
    use crate::deck::contact::{impactors, node_contact, Scales};
    if ld.deck.contact.is_none() && ld.deck.impactors.is_empty() {
        return Ok(());
    }
    let scales = Scales {
        spacing,
        horizon,
        volume: sim.body.total_volume() / sim.body.len().max(1) as f64,
        thickness: sim.body.thickness,
        elasticity,
    };
    sim.contact = node_contact(&ld.deck, &scales);
    sim.impactors = impactors(&ld.deck, &scales);
    sim.refresh_forces()?;
    Ok(())
}

fn run_model<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    mut model: Model<D>,
    material: M,
    rest: DamageAndReports,
    opts: &RunOptions,
    control: &RunControl,
) -> Result<RunSummary, RunError> {
    let pores = model.pores.clone();
    let deck = &ld.deck;
    let out = &opts.out_dir;
    let plans = std::mem::take(&mut model.stages);
    let (mut sim, report) = prepare(ld, model, material, rest)?;
    let resolved = resolved_deck(ld)?;
    let origin = Origin::new(&resolved, &ld.file);
    let checkpoint_path = out.join(crate::checkpoint::FILE_NAME);
    // Checked before anything is written: a refused restart leaves the folder as it was.
    let resume = if control.restart {
        let driver = crate::checkpoint::restore(&checkpoint_path, &origin, &mut sim.state)?;
        sim.impactors.restore(&driver.impactors);
        Some(driver)
    } else {
        None
    };
    std::fs::create_dir_all(out)
        .map_err(|e| crate::atomic_file::with_path(e, "cannot create directory", out))?;
    write_resolved(ld, &resolved, &report, out)?;
    if let Some(text) = pores {
        crate::atomic_file::write_atomic(&out.join("pores.txt"), text.as_bytes())?;
    }

    let sets: Vec<(String, Vec<u32>)> = sim
        .body
        .node_sets
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    let snapshot_every = if deck.output.snapshots == 0 {
        u64::MAX
    } else {
        report.steps.div_ceil(deck.output.snapshots).max(1)
    };
    let history_every = match deck.history_interval() {
        0 => u64::MAX,
        k => k,
    };
    let title = if deck.title.is_empty() {
        ld.file
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default()
    } else {
        deck.title.clone()
    };
    let openings = opening_nodes(&sim.body, &deck.output.openings);
    let staged = !plans.is_empty();
    let impactor_names: Vec<String> = deck.impactors.iter().map(|i| i.name.clone()).collect();
    let history = |path: &std::path::Path| -> Box<dyn Observer<D>> {
        let h = History::new::<D>(path, history_every, &sets).with_openings(&openings);
        let h = match deck.contact.is_some() || !deck.impactors.is_empty() {
            true => h.with_contact::<D>(&impactor_names),
            false => h,
        };
        Box::new(if staged { h.with_stages() } else { h })
    };
    let history_path = out.join("history.csv");
    let (output, step, time) = (&deck.output, sim.state.step, sim.state.time);
    let (history, snapshots) = match resume {
        None => (
            history(&history_path),
            Snapshots::new(out.clone(), snapshot_every, output, &title)?,
        ),
        // The files keep what they held up to the checkpoint's step.
        Some(_) => (
            Box::new(ResumedCsv::new(&history_path, step, history)?) as Box<dyn Observer<D>>,
            Snapshots::resume(out.clone(), time, snapshot_every, output, &title)?,
        ),
    };
    let mut observers: Vec<Box<dyn Observer<D>>> = vec![
        history,
        Box::new(snapshots),
        Box::new(Progress::new(report.end_time, opts.quiet)),
    ];
    if staged {
        // Energies at each stage's end; the profile along the crack's direction (x by default).
        let direction = match deck.analysis.as_ref().and_then(|a| a.crack_tip.as_ref()) {
            Some(tip) => crate::math::vector_from_slice::<D>(&tip.direction),
            None => Vector::<D>::from_fn(|k, _| if k == 0 { 1.0 } else { 0.0 }),
        };
        let bin = sim.body.min_cell_size();
        let record = StageRecord::new(out, direction, bin);
        observers.push(Box::new(match resume {
            Some(_) => record.resume(step)?,
            None => record,
        }));
    }
    let restarting = resume.is_some();
    let analysis = deck.analysis.as_ref();
    let crack = match analysis.and_then(|a| a.crack_tip.as_ref()) {
        Some(tip) => Some(attach_analysis(
            &mut observers,
            crack_tips(deck, tip, &sim, &report, out),
            restarting,
            |o| o.resume(step, &sim.body.positions),
            CrackTips::report,
        )?),
        None => None,
    };
    let path = match analysis.and_then(|a| a.crack_path.as_ref()) {
        Some(p) if D == 2 => Some(attach_analysis(
            &mut observers,
            crack_path(p, &sim.body, out),
            restarting,
            |o| o.resume(step),
            CrackPath::report,
        )?),
        _ => None,
    };
    let surface = match analysis.and_then(|a| a.crack_surface.as_ref()) {
        Some(a) if D == 3 => Some(attach_analysis(
            &mut observers,
            crack_surface(deck, a, &sim, out),
            restarting,
            |o| o.resume(step),
            CrackSurface::report,
        )?),
        _ => None,
    };

    let checkpoints =
        (deck.output.checkpoint || deck.output.checkpoint_interval.is_some()).then(|| {
            Checkpoints {
                path: checkpoint_path,
                origin,
                snapshots: deck.output.checkpoint.then_some(Every(snapshot_every)),
                interval: deck.output.checkpoint_interval,
            }
        });

    let latest_checkpoint = checkpoints
        .as_ref()
        .map(|c| (c.path.clone(), c.origin.clone()));
    let started = Instant::now();
    let settings = solver_settings(deck);
    let mut watch = Watch {
        observers: &mut observers,
        checkpoints,
        stop_after: control.stop_after_step,
        stage: resume.as_ref().map_or(0, |d| d.stage),
        stage_start: resume.as_ref().map_or((0, 0.0), |d| d.stage_start),
        resume,
        final_stage: !staged,
    };
    let result = if staged {
        run_stages(&mut sim, settings, &report, plans, &mut watch)
    } else {
        run_stage(&mut sim, settings, &report, &mut watch)
    };
    // A stop stands for a kill: the files stay as the last flush left them.
    if !matches!(result, Err(RunError::Stopped(_))) {
        for o in observers.iter_mut() {
            o.finish()?;
        }
    }
    if let (Err(RunError::Step(_)), Some(latest)) = (&result, &latest_checkpoint) {
        if let Some(file) = write_last_good(&mut sim, latest, out) {
            eprintln!(
                "peridyn: the last good state (the latest checkpoint, step {}) is in {}",
                sim.state.step,
                file.display()
            );
        }
    }
    result?;
    let wall = started.elapsed().as_secs_f64();
    let c = &sim.counters;
    let summary = RunSummary {
        wall_seconds: wall,
        node_steps_per_second: c.node_steps_per_second(sim.body.len()),
        broken_bonds: sim.state.broken / 2,
        kinetic_energy: sim.kinetic_energy(),
        strain_energy: sim.strain_energy(),
        external_work: sim.state.external_work,
        timers: format!(
            "grid and bonds {:.2} s, setup {:.2} s, force {:.2} s, integrate {:.2} s, observe {:.2} s",
            c.grid.as_secs_f64(),
            c.setup.as_secs_f64(),
            c.force.as_secs_f64(),
            c.integrate.as_secs_f64(),
            c.observe.as_secs_f64()
        ),
        out_dir: out.clone(),
        report,
        crack: crack.and_then(|c| c.borrow().clone()),
        crack_path: path.and_then(|c| c.borrow().clone()),
        crack_surface: surface.and_then(|c| c.borrow().clone()),
    };
    if deck.output.plots {
        crate::plot::history_plots::write_history_plots(out)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
    }
    crate::atomic_file::write_atomic(&out.join("summary.txt"), format!("{summary}\n").as_bytes())?;
    Ok(summary)
}

/// After a diagnosed failure (NaN, energy blow-up, a relaxation that does not converge):
/// writes the latest checkpoint's state, the last good one, as `fields/last_good_step_N.vtu`
/// (not in `fields.pvd`). `None` when there is no checkpoint to read or the file cannot be
/// written: the run's own error is what matters then.
fn write_last_good<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    (path, origin): &(std::path::PathBuf, Origin),
    out: &std::path::Path,
) -> Option<std::path::PathBuf> {
    crate::checkpoint::restore(path, origin, &mut sim.state).ok()?;
    let fields = out.join("fields");
    std::fs::create_dir_all(&fields).ok()?;
    let file = fields.join(format!("last_good_step_{:08}.vtu", sim.state.step));
    let view = StepView::new(&*sim as &dyn Fields<D>, true);
    crate::observe::snapshots::write_fields(&file, &view).ok()?;
    Some(file)
}

/// Each opening's name and the nodes nearest its two points (the lowest index on a tie).
fn opening_nodes<const D: usize>(
    body: &crate::body::Body<D>,
    openings: &[crate::deck::schema::OpeningDeck],
) -> Vec<(String, usize, usize)> {
    let nearest = |p: &[f64]| {
        let p = crate::math::vector_from_slice::<D>(p);
        (0..body.len())
            .min_by(|&a, &b| {
                (body.positions[a] - p)
                    .norm()
                    .total_cmp(&(body.positions[b] - p).norm())
                    .then(a.cmp(&b))
            })
            .unwrap_or(0)
    };
    openings
        .iter()
        .map(|o| {
            (
                o.name.clone(),
                nearest(&o.between[0]),
                nearest(&o.between[1]),
            )
        })
        .collect()
}

/// Adds an analysis observer to the run, first continuing its files from the checkpoint's
/// step when `restarting`, and returns the handle its end-of-run report is read from.
fn attach_analysis<const D: usize, O: Observer<D> + 'static, R>(
    observers: &mut Vec<Box<dyn Observer<D>>>,
    observer: O,
    restarting: bool,
    resume: impl FnOnce(O) -> std::io::Result<O>,
    report: impl Fn(&O) -> Rc<RefCell<Option<R>>>,
) -> std::io::Result<Rc<RefCell<Option<R>>>> {
    let observer = if restarting {
        resume(observer)?
    } else {
        observer
    };
    let handle = report(&observer);
    observers.push(Box::new(observer));
    Ok(handle)
}

/// The crack-tip observer of `[analysis.crack_tip]`. The Rayleigh speed is that of the model's
/// E and ν (`ModelReport`, the first material's) and node 0's density, in plane stress, plane
/// strain or 3D as the deck says. In 3D the front is the damaged nodes within one grid spacing
/// (the smallest cell size) of the tip.
fn crack_tips<const D: usize, M: Material<D>>(
    deck: &crate::deck::Deck,
    tip: &crate::deck::schema::CrackTipDeck,
    sim: &Simulation<D, M>,
    report: &ModelReport,
    out: &std::path::Path,
) -> CrackTips<D> {
    use crate::analysis::{rayleigh_speed, Branch, SearchBox, TipTracker, WaveSetting};
    use crate::deck::schema::Plane;
    use crate::math::Vector;
    let vector = |v: &[f64]| Vector::<D>::from_iterator(v.iter().copied());
    let branches = if tip.branches.is_empty() {
        vec![Branch {
            name: "crack".into(),
            search: None,
        }]
    } else {
        tip.branches
            .iter()
            .map(|b| Branch {
                name: b.name.clone(),
                search: Some(SearchBox::new(vector(&b.min), vector(&b.max))),
            })
            .collect()
    };
    let mut tracker = TipTracker::new(tip.threshold, vector(&tip.direction), branches);
    if D == 3 {
        tracker = tracker.with_front(sim.body.min_cell_size());
    }
    let setting = match (D, deck.plane) {
        (3, _) => WaveSetting::ThreeD,
        (_, Some(Plane::Strain)) => WaveSetting::PlaneStrain,
        _ => WaveSetting::PlaneStress,
    };
    let rayleigh = rayleigh_speed(
        report.youngs_modulus,
        report.poisson_ratio,
        sim.densities[0],
        setting,
    );
    let tips = CrackTips::new(out, tracker, tip.interval, tip.window, rayleigh);
    if D == 2 {
        tips.with_dissipation_rate(sim.body.thickness, deck.material.fracture_energy())
    } else {
        tips
    }
}

/// The crack-path observer of `[analysis.crack_path]`, its lengths defaulting to multiples of
/// the smallest cell size.
fn crack_path<const D: usize>(
    p: &crate::deck::schema::CrackPathDeck,
    body: &crate::body::Body<D>,
    out: &std::path::Path,
) -> CrackPath {
    let h = body.min_cell_size();
    CrackPath::new(
        out,
        PathSettings {
            axis: p.axis.index(),
            threshold: p.threshold,
            bin_width: p.bin_width.unwrap_or(2.0 * h),
            reference: p.reference.iter().map(|q| (q[0], q[1])).collect(),
            samples: p.samples,
            interval: p.interval,
            link: p.link.unwrap_or(3.0 * h),
            fit_bands: p.fit_bands,
        },
    )
}

/// The crack-surface observer of `[analysis.crack_surface]`: the cell side defaults to twice
/// the smallest cell size, and Γ is compared with the deck's `[material]` G0, as the 2D
/// dissipation rate of `[analysis.crack_tip]` is.
fn crack_surface<const D: usize, M: Material<D>>(
    deck: &crate::deck::Deck,
    a: &crate::deck::schema::CrackSurfaceDeck,
    sim: &Simulation<D, M>,
    out: &std::path::Path,
) -> CrackSurface {
    let settings = SurfaceSettings {
        axis: a.axis.index(),
        bin_width: a.bin_width.unwrap_or(2.0 * sim.body.min_cell_size()),
        interval: a.interval,
        g0: deck.material.fracture_energy(),
    };
    CrackSurface::new(out, &sim.body, settings)
}

/// Runs the deck's stages one after the other: each starts from the state the one before
/// left (the clock runs on), with its own boundary conditions, loads, no-fail sets, solver and
/// history interval; a quasi-static stage starts at rest. A run continued from a checkpoint
/// skips the stages finished before it and continues the one it was in.
fn run_stages<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    first: SolverSettings,
    report: &ModelReport,
    plans: Vec<StagePlan<D>>,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let count = plans.len() + 1;
    let resumed_stage = watch.resume.as_ref().map_or(0, |d| d.stage as usize);
    if resumed_stage == 0 {
        watch.final_stage = count == 1;
        run_stage(sim, first, &report.stages[0], watch)?;
    }
    for (k, plan) in plans.into_iter().enumerate() {
        let index = k + 1;
        if index < resumed_stage {
            continue;
        }
        let stage = &report.stages[index];
        sim.body.no_fail = plan.no_fail;
        sim.dt = stage.dt;
        if index == resumed_stage {
            // The checkpoint holds the state the stage's start made and what followed it.
            sim.replace_loading(plan.loading);
        } else {
            if plan.settings.quasi_static.is_some() {
                sim.state.v.iter_mut().for_each(|v| *v = Vector::zeros());
            }
            sim.set_loading(plan.loading)?;
            watch.stage_start = (sim.state.step, sim.state.time);
        }
        watch.stage = index as u64;
        let start = StageStart {
            index,
            history_interval: match plan.history_interval {
                0 => u64::MAX,
                k => k,
            },
        };
        for o in watch.observers.iter_mut() {
            o.begin_stage(&start);
        }
        watch.final_stage = index + 1 == count;
        run_stage(sim, plan.settings, stage, watch)?;
    }
    Ok(())
}

/// One stage with its solver, from `watch.stage_start` (a run continued from a checkpoint is
/// past it): `stage` gives its steps and duration (a `ModelReport` or `StageReport`). A
/// continued run's driver state serves this stage only.
fn run_stage<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: SolverSettings,
    stage: &impl StageLength,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let (step, time) = watch.stage_start;
    match (settings.quasi_static, settings.adaptive) {
        (Some(qs), _) => quasi_static_loop(sim, qs, (time, stage.steps()), watch),
        (None, Some(a)) => {
            let adaptive = a.settings(sim.dt);
            adaptive_loop(sim, adaptive, time + stage.duration(), watch)
        }
        (None, None) => explicit_loop(sim, step + stage.steps(), watch),
    }?;
    watch.resume = None;
    Ok(())
}

/// How long a stage runs.
trait StageLength {
    fn steps(&self) -> u64;
    fn duration(&self) -> f64;
}

impl StageLength for ModelReport {
    fn steps(&self) -> u64 {
        self.steps
    }
    fn duration(&self) -> f64 {
        self.end_time
    }
}

impl StageLength for StageReport {
    fn steps(&self) -> u64 {
        self.steps
    }
    fn duration(&self) -> f64 {
        self.duration
    }
}

/// What the explicit loops do with each committed step besides stepping: offer it to the
/// observers, write the checkpoint that falls on it, stop where asked.
struct Watch<'a, const D: usize> {
    observers: &'a mut [Box<dyn Observer<D>>],
    checkpoints: Option<Checkpoints>,
    stop_after: Option<u64>,
    /// Continuing from a checkpoint (whose step the observers saw before the interruption)
    /// with the driver state it kept.
    resume: Option<DriverState<D>>,
    /// The stage in progress is the run's last: its end is the end of the run.
    final_stage: bool,
    /// The stage in progress and the step and time it started at.
    stage: u64,
    stage_start: (u64, f64),
}

impl<'a, const D: usize> Watch<'a, D> {
    /// Only observers.
    fn observers(observers: &'a mut [Box<dyn Observer<D>>]) -> Self {
        Watch {
            observers,
            checkpoints: None,
            stop_after: None,
            resume: None,
            final_stage: true,
            stage: 0,
            stage_start: (0, 0.0),
        }
    }

    /// Offers a committed step; `stage_end`: it ends the stage (and the run, in the last).
    /// `driver` gives the solver's part of a checkpoint, when one is written.
    fn commit<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        stage_end: bool,
        driver: impl FnOnce(&Simulation<D, M>) -> DriverState<D>,
    ) -> Result<(), RunError> {
        let last = stage_end && self.final_stage;
        offer(sim, self.observers, last, stage_end)?;
        let step = sim.state.step;
        if let Some(c) = self.checkpoints.as_ref().filter(|c| c.wants(step, last)) {
            let started = Instant::now();
            // The files first: a restart keeps what they hold up to the checkpoint's step.
            for o in self.observers.iter_mut() {
                o.flush()?;
            }
            let driver = DriverState {
                stage: self.stage,
                stage_start: self.stage_start,
                impactors: sim.impactors.states(),
                ..driver(sim)
            };
            c.write(&sim.state, &driver)?;
            sim.counters.observe += started.elapsed();
        }
        match self.stop_after {
            Some(n) if step >= n && !last => Err(RunError::Stopped(step)),
            _ => Ok(()),
        }
    }
}

/// The step loop: step, check for blow-up, offer the committed step to observers.
pub fn drive<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    steps: u64,
    observers: &mut [Box<dyn Observer<D>>],
) -> Result<(), RunError> {
    explicit_loop(sim, steps, &mut Watch::observers(observers))
}

/// Fixed steps until step `steps` (counted from the run's start).
fn explicit_loop<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    steps: u64,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let driver = |sim: &Simulation<D, M>| DriverState {
        next_dt: sim.dt,
        ..DriverState::default()
    };
    if watch.resume.is_none() && sim.state.step == 0 {
        watch.commit(sim, steps == 0, driver)?;
    }
    let given = energy_given(sim);
    for k in sim.state.step + 1..=steps {
        sim.step()?;
        if k % 100 == 0 || k == steps {
            sim.check_finite()?;
        }
        // Every 10 steps: an O(nodes) sum that sees an instability before it overflows.
        if k % 10 == 0 || k == steps {
            sim.check_energy(given)?;
        }
        watch.commit(sim, k == steps, driver)?;
    }
    Ok(())
}

/// The energy a loop starts with (kinetic and strain energy, and contact's: penalty energy
/// and the impactors' kinetic energy), and the external work done until then: what
/// `Simulation::check_energy` measures the energy given against.
fn energy_given<const D: usize, M: Material<D>>(sim: &Simulation<D, M>) -> (f64, f64) {
    (
        sim.kinetic_energy()
            + sim.strain_energy()
            + Fields::contact_energy(sim)
            + Fields::impactor_kinetic_energy(sim),
        sim.state.external_work,
    )
}

/// The explicit loop with an adaptive time step: committed steps until `end_time` (the last
/// one shortened to land on it), each offered to observers; rejected attempts are not seen.
pub fn drive_adaptive<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: AdaptiveDtSettings,
    end_time: f64,
    observers: &mut [Box<dyn Observer<D>>],
) -> Result<(), RunError> {
    adaptive_loop(sim, settings, end_time, &mut Watch::observers(observers))
}

fn adaptive_loop<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: AdaptiveDtSettings,
    end_time: f64,
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    // Times closer than this to the end are the end (rounding of accumulated steps); from
    // the initial dt, also when continuing.
    let slack = 1e-9 * sim.dt;
    let mut controller = match &watch.resume {
        None => AdaptiveDt::new(settings),
        Some(d) => {
            sim.dt = d.next_dt;
            AdaptiveDt::resumed(settings, d.since_change, d.rejected)
        }
    };
    let driver = |sim: &Simulation<D, M>, c: &AdaptiveDt<D>| DriverState {
        next_dt: sim.dt,
        since_change: c.since_change(),
        rejected: c.rejected,
        ..DriverState::default()
    };
    if watch.resume.is_none() && sim.state.step == 0 {
        watch.commit(sim, end_time <= slack, |sim| driver(sim, &controller))?;
    }
    let mut k = sim.state.step;
    let given = energy_given(sim);
    while end_time - sim.state.time > slack {
        sim.dt = sim.dt.min(end_time - sim.state.time);
        controller.step(sim)?;
        k += 1;
        let last = end_time - sim.state.time <= slack;
        if k.is_multiple_of(100) || last {
            sim.check_finite()?;
        }
        if k.is_multiple_of(10) || last {
            sim.check_energy(given)?;
        }
        watch.commit(sim, last, |sim| driver(sim, &controller))?;
    }
    Ok(())
}

/// The quasi-static loop: `load_steps` equal load steps of pseudo-time `sim.dt`, each
/// committed in one piece or, when it breaks too many bonds, in several (every committed piece
/// is offered to observers).
pub fn drive_quasi_static<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: QuasiStaticSettings,
    load_steps: u64,
    observers: &mut [Box<dyn Observer<D>>],
) -> Result<(), RunError> {
    let start = sim.state.time;
    let watch = &mut Watch::observers(observers);
    quasi_static_loop(sim, settings, (start, load_steps), watch)
}

/// Load steps from the stage's start time `start`; a continued run skips the load steps whose
/// targets it has passed and takes the solver's memory from the checkpoint.
fn quasi_static_loop<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    settings: QuasiStaticSettings,
    (start, load_steps): (f64, u64),
    watch: &mut Watch<D>,
) -> Result<(), RunError> {
    let increment = sim.dt;
    let mut solver = QuasiStatic::new(sim, settings, increment);
    let driver = |solver: &QuasiStatic<D>| DriverState {
        quasi_static: Some(solver.memory()),
        ..DriverState::default()
    };
    match watch.resume.as_mut().and_then(|d| d.quasi_static.take()) {
        Some(memory) => solver.resume(memory),
        None if watch.resume.is_none() && sim.state.step == 0 => {
            watch.commit(sim, load_steps == 0, |_| driver(&solver))?;
        }
        None => {}
    }
    for k in 1..=load_steps {
        // The target from k, not by summing increments: no drift over many steps.
        let target = start + k as f64 * increment;
        while sim.state.time < target {
            solver.advance(sim, target)?;
            sim.check_finite()?;
            let stage_end = k == load_steps && sim.state.time >= target;
            watch.commit(sim, stage_end, |_| driver(&solver))?;
        }
    }
    Ok(())
}

/// Offers a committed step to the observers that want it; every observer's schedule
/// includes the last step of each stage (`stage_end`) as it does the run's (`last`).
fn offer<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    observers: &mut [Box<dyn Observer<D>>],
    last: bool,
    stage_end: bool,
) -> Result<(), RunError> {
    let step = sim.state.step;
    let wanted = last || stage_end;
    if !observers.iter().any(|o| o.wants(step, wanted)) {
        return Ok(());
    }
    let started = Instant::now();
    {
        let view = StepView::new(&*sim as &dyn Fields<D>, last);
        for o in observers.iter_mut() {
            if o.wants(step, wanted) {
                o.observe(&view)?;
            }
        }
    }
    sim.counters.observe += started.elapsed();
    Ok(())
}

/// The deck with every default filled in, as `resolved.toml` holds it (and checkpoints hash).
fn resolved_deck(ld: &LoadedDeck) -> Result<String, RunError> {
    // A point-cloud or mesh path is made absolute so the resolved deck runs from the results folder.
    let mut resolved = ld.deck.clone();
    resolved.output.history_interval = Some(ld.deck.history_interval());
    for (k, stage) in resolved.stages.iter_mut().enumerate() {
        stage.history_interval = Some(ld.deck.stage_history_interval(k + 1));
    }
    if let crate::deck::schema::Discretization::PointCloud { file, .. }
    | crate::deck::schema::Discretization::Gmsh { file, .. } = &mut resolved.discretization
    {
        let path = ld.base_dir().join(&*file);
        *file = std::fs::canonicalize(&path)
            .unwrap_or(path)
            .display()
            .to_string();
    }
    Ok(toml::to_string(&resolved).map_err(|e| std::io::Error::other(e.to_string()))?)
}

/// Writes `resolved.toml`: the resolved `deck` text, and the derived constants.
fn write_resolved(
    ld: &LoadedDeck,
    deck: &str,
    report: &ModelReport,
    out: &std::path::Path,
) -> Result<(), RunError> {
    #[derive(Serialize)]
    struct Derived<'a> {
        derived: &'a ModelReport,
    }
    let derived = toml::to_string(&Derived { derived: report })
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    let text = format!("# Resolved deck written by peridyn {} from {}\n# Every default is filled in; [derived] holds the constants computed from it.\n\n{deck}\n{derived}", env!("CARGO_PKG_VERSION"), ld.file.display());
    crate::atomic_file::write_atomic(&out.join("resolved.toml"), text.as_bytes())?;
    Ok(())
}
