//! A run distributed over ranks: `run::run_model`'s stages with the pieces a rank must do
//! differently — it builds its share of the body and bonds, exchanges its halo inside each
//! step (`Simulation::share`), and gathers the fields rank 0's observers read; rank 0 alone
//! writes the files.

use super::gather::{Gather, PieceWriter};
use super::partition::{bond_weights, ranges};
use super::share::split;
use crate::body::Body;
use crate::deck::build::{
    build_constitution_shared, build_model_with, Constitution, MaterialChoice, Model, Part,
};
use crate::deck::schema::Pieces;
use crate::deck::solver_settings::solver_settings;
use crate::deck::LoadedDeck;
use crate::grid::GridReport;
use crate::material::Material;
use crate::observe::observer::Every;
use crate::run::finish::{finish, Finished};
use crate::run::observers::{attach_to, Attached};
use crate::run::restart::checkpoints;
use crate::run::stages::{drive_stages, Watch};
use crate::run::{
    prepare_shared, resolved, with_threads, DamageAndReports, ModelReport, RunControl, RunError,
    RunOptions, RunSummary,
};
use crate::solver::ranks::{Halo, Ranks, Share};
use std::sync::Arc;
use std::time::Instant;

/// Runs a deck over `ranks` (every rank calls it); the summary is rank 0's to print.
pub fn run_with(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
    ranks: Arc<dyn Ranks>,
) -> Result<RunSummary, RunError> {
    with_threads(opts.threads, || match ld.deck.dimension {
        2 => run_dim::<2>(ld, opts, control, ranks),
        _ => run_dim::<3>(ld, opts, control, ranks),
    })?
}

/// What building a rank's share leaves besides the model.
struct Built<const D: usize> {
    /// Rank 0: the whole body.
    whole: Option<Body<D>>,
    first: usize,
    owned: usize,
    halo: Halo,
    grid: Option<GridReport>,
}

/// A rank's share of the model (its nodes' families and their ghosts) and of the
/// constitution, with what the simulation reads of the other ranks.
fn build_share<const D: usize>(
    ld: &LoadedDeck,
    ranks: &Arc<dyn Ranks>,
) -> Result<(Model<D>, Constitution, Built<D>, Share), RunError> {
    let mut built: Option<Built<D>> = None;
    let size = ranks.size();
    let model = build_model_with::<D>(ld, |body, families| {
        let weights = bond_weights(&body, families.rule);
        let Some(ranges) = ranges(&weights, size) else {
            return Err(too_few(ld, body.len(), size));
        };
        let s = split(&body, families.rule, &ld.deck.precracks, &ranges, &**ranks);
        let spacing = (ranks.min_f64(s.spacing.0), ranks.max_f64(s.spacing.1));
        let root = ranks.rank() == 0;
        built = Some(Built {
            grid: root.then(|| crate::grid::grid_report_spaced(ld, &body, spacing)),
            whole: root.then_some(body),
            first: s.owned.start,
            owned: s.owned.len(),
            halo: s.halo,
        });
        Ok(Part {
            body: s.body,
            bonds: s.bonds,
            globals: Some(s.globals),
        })
    })?;
    let built = built.expect("the share was built");
    let share = share_of(&built, ranks);
    let mut c = build_constitution_shared(ld, &model, Some(&share))?;
    whole_constitution_reports(&mut c, &model, built.owned, &**ranks);
    Ok((model, c, built, share))
}

/// A rank's part of the whole run: what the constitution and the simulation read of the
/// other ranks.
fn share_of<const D: usize>(built: &Built<D>, ranks: &Arc<dyn Ranks>) -> Share {
    Share {
        ranks: ranks.clone(),
        first: built.first,
        owned: built.owned,
        global_nodes: ranks.sum_u64(built.owned as u64) as usize,
        halo: built.halo.clone(),
    }
}

fn run_dim<const D: usize>(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
    ranks: Arc<dyn Ranks>,
) -> Result<RunSummary, RunError> {
    let (model, c, built, share) = build_share::<D>(ld, &ranks)?;
    let (material, rest) = c.split();
    let run = (opts, control);
    let parts = (built, share);
    match material {
        MaterialChoice::Pmb(m) => run_model(ld, model, m, rest, run, parts),
        MaterialChoice::Lps(m) => run_model(ld, model, m, rest, run, parts),
        MaterialChoice::Correspondence(m) => run_model(ld, model, m, rest, run, parts),
        // PMB and LPS blocks only: the scalar path.
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => run_model(ld, model, m, rest, run, parts),
            Err(m) => run_model(ld, model, m, rest, run, parts),
        },
    }
}

/// The constitution's reports of the whole body from a rank's share: each material's node
/// count, and the range of the surface correction's factors, over every rank's owned nodes
/// (a ghost's factor here comes from its empty row; its owner's replaces it in the model,
/// `Material::share_constants`).
fn whole_constitution_reports<const D: usize>(
    c: &mut Constitution,
    model: &Model<D>,
    owned: usize,
    ranks: &dyn Ranks,
) {
    for (k, report) in c.reports.iter_mut().enumerate() {
        let mine = model.material_of[..owned]
            .iter()
            .filter(|&&m| m as usize == k)
            .count();
        report.nodes = ranks.sum_u64(mine as u64) as usize;
    }
    if let Some(s) = &mut c.surface {
        let mine = &s.factors[..owned];
        s.report.min = ranks.min_f64(mine.iter().copied().fold(f64::INFINITY, f64::min));
        s.report.max = ranks.max_f64(mine.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    }
}

/// Refuses a body too small to give every rank a node chunk (a rank owns whole chunks of
/// the force loop, so that its sums are the one process's).
fn too_few(ld: &LoadedDeck, nodes: usize, ranks: usize) -> crate::deck::DeckError {
    let chunk = crate::solver::forces::NODE_CHUNK;
    ld.locate(vec![crate::deck::DeckIssue::new(
        "discretization",
        format!(
            "a body of {nodes} nodes cannot be shared by {ranks} ranks: each rank owns whole \
             chunks of {chunk} nodes, and this body has {}; run it on at most that many ranks",
            nodes.div_ceil(chunk)
        ),
    )])
}

fn run_model<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    mut model: Model<D>,
    material: M,
    rest: DamageAndReports,
    (opts, control): (&RunOptions, &RunControl),
    (built, share): (Built<D>, Share),
) -> Result<RunSummary, RunError> {
    let out = &opts.out_dir;
    let ranks = share.ranks.clone();
    let root = ranks.rank() == 0;
    let Built {
        whole,
        first,
        owned,
        halo,
        grid,
    } = built;
    let global_nodes = share.global_nodes;
    if !opts.quiet {
        eprintln!(
            "rank {} of {}: nodes {}..{} ({} owned, {} ghosts from {} peers), halo {} B sent per step",
            ranks.rank(),
            ranks.size(),
            first,
            first + owned,
            owned,
            halo.ghosts(),
            halo.peers.len(),
            halo.bytes_sent(3 * D + M::HALO_WORDS)
        );
    }
    let pores = model.pores.clone();
    let plans = std::mem::take(&mut model.stages);
    let staged = !plans.is_empty();
    let (mut sim, report) = prepare_shared(ld, model, material, rest, Some(share))?;
    let report = whole_report::<D, M>(report, &sim, grid, &*ranks);
    // Node 0's density on every rank (the crack tip's Rayleigh speed reads it on rank 0).
    let densities = ranks.gather(&sim.densities[..owned]);
    let resolved = resolved::resolved_deck(ld)?;
    let origin = crate::checkpoint::Origin::new(&resolved, &ld.file);
    // Before anything is written: a refused restart leaves the folder as it was.
    let resume = super::restart::restore(control, out, &origin, &mut sim)?;
    let (attached, whole) = if root {
        resolved::write_start(ld, &resolved, &report, pores.as_deref(), out)?;
        let body = whole.expect("rank 0 keeps the whole body");
        let densities = densities.expect("gathered on rank 0");
        let at = (sim.state.step, sim.state.time);
        let restarting = resume.is_some();
        let attached = attach_to(
            ld,
            opts,
            (&body, densities[0]),
            &report,
            (staged, restarting),
            at,
            ranks.size(),
        )?;
        (Some(attached), Some((body, densities)))
    } else {
        (None, None)
    };
    // The snapshots' schedule as `observers::attach` makes it (checkpoints follow it).
    let snapshot_every = match ld.deck.output.snapshots {
        0 => u64::MAX,
        k => report.steps.div_ceil(k).max(1),
    };
    let checkpoints = checkpoints(&ld.deck, out, origin, snapshot_every, None);
    let (mut observers, crack, path, surface) = match attached {
        Some(Attached {
            observers,
            crack,
            path,
            surface,
            ..
        }) => (observers, crack, path, surface),
        None => (Vec::new(), None, None, None),
    };
    // Each rank writes its piece of every snapshot into the folder rank 0's snapshots made
    // before the first step (each piece follows rank 0's word that the step is observed).
    let pieces =
        (ld.deck.output.pieces == Pieces::PerRank && ranks.size() > 1).then(|| PieceWriter {
            dir: out.join("fields"),
            every: Every(snapshot_every),
        });
    let mut gather = Gather::writing(ranks.clone(), owned, whole, pieces);
    let started = Instant::now();
    let result = {
        let stop_after = control.stop_after_step;
        // Progress inside long quasi-static load steps on rank 0 only.
        let mut watch = Watch::new(&mut observers, checkpoints, stop_after, resume, staged)
            .with_source(&mut gather)
            .with_progress(root && !opts.quiet);
        drive_stages(
            &mut sim,
            solver_settings(&ld.deck),
            &report,
            plans,
            &mut watch,
        )
    };
    let finished = Finished {
        result,
        started,
        latest_checkpoint: None,
        crack,
        path,
        surface,
        nodes: global_nodes,
        writes: root,
    };
    finish(ld, &mut sim, observers, report, finished, out)
}

/// The report of the whole model from a rank's share: node and bond counts, memory and the
/// grid as one process reports them.
fn whole_report<const D: usize, M: Material<D>>(
    mut report: ModelReport,
    sim: &crate::solver::Simulation<D, M>,
    grid: Option<GridReport>,
    ranks: &dyn Ranks,
) -> ModelReport {
    let nodes = sim
        .share
        .as_ref()
        .map_or(sim.body.len(), |s| s.global_nodes);
    let directed = ranks.sum_u64(sim.bonds.len() as u64) as usize;
    report.nodes = nodes;
    report.bonds = directed / 2;
    report.bonds_per_node = directed as f64 / nodes.max(1) as f64;
    report.memory_bytes = nodes
        * crate::memory::bytes_per_node(D, std::mem::size_of::<M::Point>() + M::NODE_BYTES)
        + directed * (report.bytes_per_bond + report.relaxation_bytes_per_bond);
    if let Some(g) = grid {
        report.grid = g;
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distributed::thread_ranks::ThreadRanks;
    use std::path::Path;

    /// A square plate (1 600 nodes) with seed 000's iterated surface correction at
    /// δ = `ratio` Δx.
    fn deck(ratio: f64) -> LoadedDeck {
        let src = format!(
            r#"version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [40e-3, 40e-3] }}
spacing = 1e-3
horizon_ratio = {ratio}
surface_correction = "energy_iterated"
[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
fracture_energy = 100.0
[solver]
type = "explicit"
end_time = 1e-6
"#
        );
        LoadedDeck::from_str(&src, Path::new("t.toml")).expect("a valid deck")
    }

    /// On `size` ranks: the owned nodes' factors joined in rank order, the report's
    /// iterations, or each rank's error.
    fn factors_on(ld: &LoadedDeck, size: usize) -> Vec<Result<(Vec<f64>, usize), String>> {
        ThreadRanks::run(size, |ranks| {
            let (_, c, built, share) = build_share::<2>(ld, &ranks).map_err(|e| e.to_string())?;
            let s = c.surface.expect("corrected");
            let all = share.ranks.all_gather(&s.factors[..built.owned]);
            Ok((all, s.report.iterations))
        })
    }

    /// Each sweep reads the neighbours' factors of the sweep before: the ghosts must take
    /// their owners' after every sweep, and the ranks must stop at the same sweep, for the
    /// factors to be the one process's bit for bit.
    #[test]
    fn iterated_surface_factors_are_the_one_process_ones_on_any_rank_count() {
        let ld = deck(3.0);
        let model = crate::deck::build::build_model::<2>(&ld).expect("a model");
        let one = crate::deck::build::build_constitution(&ld, &model)
            .expect("converges at δ = 3Δx")
            .surface
            .expect("corrected");
        assert!(one.report.iterations > 10, "{}", one.report.iterations);
        for size in [2, 3] {
            for (rank, got) in factors_on(&ld, size).into_iter().enumerate() {
                let (factors, iterations) = got.expect("converges");
                assert_eq!(
                    iterations, one.report.iterations,
                    "{size} ranks, rank {rank}"
                );
                let same = factors
                    .iter()
                    .zip(&one.factors)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same && factors.len() == one.factors.len(), "{size} ranks");
            }
        }
    }

    /// Where the iteration has no positive fixed point (δ = 3.5Δx) every rank refuses at the
    /// same sweep, with the one process's message (the first vanishing node in global order).
    #[test]
    fn a_vanishing_factor_is_refused_alike_on_every_rank() {
        let ld = deck(3.5);
        let model = crate::deck::build::build_model::<2>(&ld).expect("a model");
        let Err(one) = crate::deck::build::build_constitution(&ld, &model) else {
            panic!("refused in one process");
        };
        let one = one.to_string();
        assert!(one.contains("no positive solution"), "{one}");
        for size in [2, 3] {
            for got in factors_on(&ld, size) {
                assert_eq!(got.expect_err("refused"), one, "{size} ranks");
            }
        }
    }
}
