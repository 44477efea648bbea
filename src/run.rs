//! Dispatch-once: the deck's dimension and material pick `run_model::<D, M>()`; everything
//! below is monomorphised. Also `check` (build and report without stepping).

use crate::deck::build::{build_material, build_model, explicit_settings, MaterialChoice, Model};
use crate::deck::{DeckError, DeckIssue, LoadedDeck};
use crate::material::{Elasticity, Material};
use crate::observe::history::History;
use crate::observe::progress::Progress;
use crate::observe::snapshots::Snapshots;
use crate::observe::{Observer, StepView};
use crate::solver::{Simulation, StepError};
use serde::Serialize;
use std::path::PathBuf;
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
}

/// Options of `peridyn run`.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub out_dir: PathBuf,
    pub threads: Option<usize>,
    /// No progress output.
    pub quiet: bool,
}

/// The model as built: what `peridyn check` prints and `resolved.toml` records.
#[derive(Debug, Clone, Serialize)]
pub struct ModelReport {
    pub dimension: usize,
    pub model: String,
    pub nodes: usize,
    /// Physical bonds (each counted once).
    pub bonds: usize,
    pub bonds_per_node: f64,
    pub horizon: f64,
    pub spacing: f64,
    pub horizon_over_spacing: f64,
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
    /// PMB micromodulus c0 as the papers write it (2D: per unit thickness); 0 for LPS.
    pub micromodulus: f64,
    pub critical_stretch: f64,
    pub p_wave_speed: f64,
    pub dt: f64,
    pub dt_stable: f64,
    pub steps: u64,
    pub end_time: f64,
    pub memory_bytes: usize,
    pub bytes_per_bond: usize,
}

impl std::fmt::Display for ModelReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "model            {} ({}D)", self.model, self.dimension)?;
        writeln!(f, "nodes            {}", self.nodes)?;
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
        if self.micromodulus > 0.0 {
            writeln!(f, "micromodulus c0  {:.4e}", self.micromodulus)?;
        }
        writeln!(f, "critical stretch s0 = {:.5e}", self.critical_stretch)?;
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
    with_threads(threads, || match ld.deck.dimension {
        2 => check_dim::<2>(ld),
        _ => check_dim::<3>(ld),
    })?
}

fn check_dim<const D: usize>(ld: &LoadedDeck) -> Result<ModelReport, RunError> {
    let model = build_model::<D>(ld)?;
    match build_material(&ld.deck, model.horizon) {
        MaterialChoice::Pmb(m) => Ok(prepare(ld, model, m)?.1),
        MaterialChoice::Lps(m) => Ok(prepare(ld, model, m)?.1),
    }
}

/// Runs a deck, writing results into `opts.out_dir`.
pub fn run(ld: &LoadedDeck, opts: &RunOptions) -> Result<RunSummary, RunError> {
    with_threads(opts.threads, || match ld.deck.dimension {
        2 => run_dim::<2>(ld, opts),
        _ => run_dim::<3>(ld, opts),
    })?
}

fn run_dim<const D: usize>(ld: &LoadedDeck, opts: &RunOptions) -> Result<RunSummary, RunError> {
    let model = build_model::<D>(ld)?;
    match build_material(&ld.deck, model.horizon) {
        MaterialChoice::Pmb(m) => run_model(ld, model, m, opts),
        MaterialChoice::Lps(m) => run_model(ld, model, m, opts),
    }
}

/// Builds the simulation, checks the time step and reports the model.
pub fn prepare<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    model: Model<D>,
    material: M,
) -> Result<(Simulation<D, M>, ModelReport), RunError> {
    let settings = explicit_settings(&ld.deck);
    let started = Instant::now();
    let Model {
        body,
        bonds,
        loading,
        rule,
        horizon,
        spacing,
        initial_velocities,
        ..
    } = model;
    let mut sim = Simulation::new(
        body,
        bonds,
        material,
        rule,
        loading,
        settings.dt,
        settings.safety_factor,
    );
    if let Some(dt) = settings.dt {
        if dt > sim.dt_stable {
            return Err(ld
                .locate(vec![DeckIssue::new("solver.dt", format!("dt = {dt:.4e} s exceeds the stable time step {:.4e} s (Silling–Askari estimate); lower dt or remove it to use safety_factor × the estimate", sim.dt_stable))])
                .into());
        }
    }
    for iv in &initial_velocities {
        iv.apply(&sim.body, &mut sim.state);
    }
    // Prescribed velocities win over initial ones on constrained components.
    sim.loading.apply_end_velocities(&mut sim.state, 0.0);
    sim.counters.setup = started.elapsed();
    let steps = settings
        .steps
        .unwrap_or_else(|| (settings.end_time.unwrap_or(0.0) / sim.dt).ceil() as u64);
    let el: Elasticity = sim.engine.material.elasticity();
    let micromodulus = match ld.deck.material {
        crate::deck::schema::MaterialDeck::Pmb { .. } => crate::material::Pmb::micromodulus(
            el.youngs_modulus,
            el.dimensionality,
            profile_of(&ld.deck),
            horizon,
        ),
        _ => 0.0,
    };
    let nodes = sim.body.len();
    let per_node = std::mem::size_of::<M::Point>() + 8 * D * 6 + 8 * 4 + 32 + 5;
    let report = ModelReport {
        dimension: D,
        model: match ld.deck.material {
            crate::deck::schema::MaterialDeck::Pmb { .. } => "pmb".into(),
            _ => "lps".into(),
        },
        nodes,
        bonds: sim.bonds.len() / 2,
        bonds_per_node: sim.bonds.bonds_per_node(),
        horizon,
        spacing,
        horizon_over_spacing: horizon / spacing,
        youngs_modulus: el.youngs_modulus,
        poisson_ratio: el.poisson_ratio,
        micromodulus,
        critical_stretch: sim.engine.material.critical_stretch(),
        p_wave_speed: (el.p_wave_modulus() / sim.engine.material.density()).sqrt(),
        dt: sim.dt,
        dt_stable: sim.dt_stable,
        steps,
        end_time: steps as f64 * sim.dt,
        memory_bytes: nodes * per_node
            + sim.bonds.len()
                * (crate::bonds::Bonds::BYTES_PER_BOND + sim.engine.quad.bytes_per_bond()),
        bytes_per_bond: crate::bonds::Bonds::BYTES_PER_BOND + sim.engine.quad.bytes_per_bond(),
    };
    Ok((sim, report))
}

fn profile_of(deck: &crate::deck::Deck) -> crate::material::MicromodulusProfile {
    match deck.material {
        crate::deck::schema::MaterialDeck::Pmb { profile, .. } => profile,
        _ => Default::default(),
    }
}

fn run_model<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    model: Model<D>,
    material: M,
    opts: &RunOptions,
) -> Result<RunSummary, RunError> {
    let (mut sim, report) = prepare(ld, model, material)?;
    let out = &opts.out_dir;
    std::fs::create_dir_all(out)
        .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", out.display())))?;
    write_resolved(ld, &report, out)?;

    let deck = &ld.deck;
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
    let history_every = if deck.output.history_interval == 0 {
        u64::MAX
    } else {
        deck.output.history_interval
    };
    let title = if deck.title.is_empty() {
        ld.file
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default()
    } else {
        deck.title.clone()
    };
    let mut observers: Vec<Box<dyn Observer<D, M>>> = vec![
        Box::new(History::new::<D>(
            &out.join("history.csv"),
            history_every,
            &sets,
        )),
        Box::new(Snapshots::new(
            out.clone(),
            snapshot_every,
            deck.output.png,
            &title,
        )?),
        Box::new(Progress::new(report.steps, opts.quiet)),
    ];

    let started = Instant::now();
    let result = drive(&mut sim, report.steps, &mut observers);
    for o in observers.iter_mut() {
        o.finish()?;
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
            "setup {:.2} s, force {:.2} s, integrate {:.2} s, observe {:.2} s",
            c.setup.as_secs_f64(),
            c.force.as_secs_f64(),
            c.integrate.as_secs_f64(),
            c.observe.as_secs_f64()
        ),
        out_dir: out.clone(),
        report,
    };
    crate::atomic_file::write_atomic(
        &out.join("summary.txt"),
        format!("{summary}\n").as_bytes(),
    )?;
    Ok(summary)
}

/// The step loop: step, check for blow-up, offer the committed step to observers.
pub fn drive<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    steps: u64,
    observers: &mut [Box<dyn Observer<D, M>>],
) -> Result<(), RunError> {
    offer(sim, observers, steps == 0)?;
    for k in 1..=steps {
        sim.step()?;
        if k % 100 == 0 || k == steps {
            sim.check_finite()?;
        }
        offer(sim, observers, k == steps)?;
    }
    Ok(())
}

fn offer<const D: usize, M: Material<D>>(
    sim: &mut Simulation<D, M>,
    observers: &mut [Box<dyn Observer<D, M>>],
    last: bool,
) -> Result<(), RunError> {
    let step = sim.state.step;
    if !observers.iter().any(|o| o.wants(step, last)) {
        return Ok(());
    }
    let started = Instant::now();
    {
        let view = StepView::new(sim, last);
        for o in observers.iter_mut() {
            if o.wants(step, last) {
                o.observe(&view)?;
            }
        }
    }
    sim.counters.observe += started.elapsed();
    Ok(())
}

/// Writes `resolved.toml`: the deck with every default filled in, and the derived constants.
fn write_resolved(
    ld: &LoadedDeck,
    report: &ModelReport,
    out: &std::path::Path,
) -> Result<(), RunError> {
    // A point-cloud path is made absolute so the resolved deck runs from the results folder.
    let mut resolved = ld.deck.clone();
    if let crate::deck::schema::Discretization::PointCloud { file, .. } =
        &mut resolved.discretization
    {
        let path = ld.base_dir().join(&*file);
        *file = std::fs::canonicalize(&path)
            .unwrap_or(path)
            .display()
            .to_string();
    }
    let deck = toml::to_string(&resolved).map_err(|e| std::io::Error::other(e.to_string()))?;
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
