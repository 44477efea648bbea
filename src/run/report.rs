//! What a run reports: the model as built (`ModelReport`, printed by `peridyn check` and kept
//! in `resolved.toml`) and the finished run (`RunSummary`, `summary.txt`).

use crate::deck::build::MaterialReport;
use crate::deck::stages::StageReport;
use crate::material::surface_correction::SurfaceReport;
use crate::observe::crack_path::PathReport;
use crate::observe::crack_surface::CrackSurfaceReport;
use crate::observe::crack_tip::CrackReport;
use serde::Serialize;
use std::path::PathBuf;

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
    /// "explicit", or "quasi-static (" the equilibrium method ")".
    pub solver: String,
    /// Time step (s), or the load increment in pseudo-time of a quasi-static run.
    pub dt: f64,
    pub dt_stable: f64,
    /// Steps, or load steps of a quasi-static run.
    pub steps: u64,
    pub end_time: f64,
    pub memory_bytes: usize,
    pub bytes_per_bond: usize,
    /// What an adaptive dynamic relaxation holds per directed bond besides them (0 without
    /// one): counted in `memory_bytes`.
    #[serde(skip_serializing_if = "is_zero")]
    pub relaxation_bytes_per_bond: usize,
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
        )?;
        if self.relaxation_bytes_per_bond > 0 {
            write!(
                f,
                " (with the {} B per directed bond the relaxation holds)",
                self.relaxation_bytes_per_bond
            )?;
        }
        Ok(())
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
    /// What the run left out of its output, and why (e.g. maps of a body too large).
    pub notes: Vec<String>,
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
        for note in &self.notes {
            writeln!(f, "note             {note}")?;
        }
        writeln!(f, "timers           {}", self.timers)?;
        write!(f, "results in       {}", self.out_dir.display())
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}
