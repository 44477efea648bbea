//! Building the simulation of a deck: the model's bodies and bonds become a `Simulation`,
//! its time step is checked, contact attached, and the `ModelReport` written.

use super::{ModelReport, RunError};
use crate::damage::Damage;
use crate::deck::build::{Constitution, MaterialChoice, MaterialReport, Model};
use crate::deck::solver_settings::{settings_of, solver_settings, SolverSettings};
use crate::deck::stages::{stage_name, StageReport};
use crate::deck::{DeckIssue, LoadedDeck};
use crate::material::surface_correction::SurfaceReport;
use crate::material::{Elasticity, Material};
use crate::solver::cross_bonds::CrossBonds;
use crate::solver::{EquilibriumMethod, Simulation};
use std::time::Instant;

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
    prepare_shared(ld, model, material, rest, None)
}

/// `prepare` for one rank's share of a distributed run (`model` is the share's part of the
/// body): the report's counts are then this part's, for the caller to complete.
pub fn prepare_shared<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    model: Model<D>,
    material: M,
    rest: DamageAndReports,
    share: Option<crate::solver::ranks::Share>,
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
    let mut sim = Simulation::new_shared(
        body,
        bonds,
        material,
        damage,
        rule,
        loading,
        (settings.dt, settings.safety_factor),
        share,
    )
    .map_err(|e| ld.locate(vec![DeckIssue::new("material", e.to_string())]))?;
    // A distributed run pairs the entries of its bonds across ranks (`CrossBonds`).
    let cross = match (&sim.share, porosity.is_empty()) {
        (Some(share), false) => Some((share.clone(), CrossBonds::new(&sim.bonds, share))),
        _ => None,
    };
    for (k, p) in &porosity {
        let member = |i: usize| material_of[i] == *k;
        let status = &mut sim.state.status;
        let n = match &cross {
            Some((share, cross)) => p.prebreak_shared(&sim.bonds, member, status, share, cross),
            None => p.prebreak(&sim.bonds, member, status),
        };
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
    let bytes_per_bond = crate::bonds::Bonds::BYTES_PER_BOND
        + crate::solver::damage_cache::BYTES_PER_BOND
        + sim.engine.quad.bytes_per_bond()
        + history_bytes;
    let relaxation_bytes_per_bond = ld.deck.relaxation_bytes_per_bond(history_bytes);
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
        solver: match &settings.quasi_static {
            None => "explicit".into(),
            Some(q) => match (q.method, q.two_level) {
                (EquilibriumMethod::Adr, _) => "quasi-static (adaptive dynamic relaxation)".into(),
                (EquilibriumMethod::Ncg, false) => "quasi-static (conjugate gradients)".into(),
                (EquilibriumMethod::Ncg, true) => {
                    "quasi-static (conjugate gradients, two-level preconditioner)".into()
                }
            },
        },
        dt: sim.dt,
        dt_stable: sim.dt_stable,
        steps,
        end_time: steps as f64 * sim.dt,
        memory_bytes: nodes
            * crate::memory::bytes_per_node(D, std::mem::size_of::<M::Point>() + M::NODE_BYTES)
            + sim.bonds.len() * (bytes_per_bond + relaxation_bytes_per_bond),
        bytes_per_bond,
        relaxation_bytes_per_bond,
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
    // The mean node volume of the whole body (a rank's part: its owned nodes' sum continued
    // across the ranks, over every node).
    let total_volume = crate::solver::ranks::ordered_sum(
        sim.share.as_deref(),
        sim.body.volumes[..sim.owned()].iter().copied(),
    );
    let nodes = sim
        .share
        .as_deref()
        .map_or(sim.body.len(), |s| s.global_nodes);
    let scales = Scales {
        spacing,
        horizon,
        volume: total_volume / nodes.max(1) as f64,
        thickness: sim.body.thickness,
        elasticity,
    };
    sim.contact = node_contact(&ld.deck, &scales);
    sim.impactors = impactors(&ld.deck, &scales);
    sim.refresh_forces()?;
    Ok(())
}
