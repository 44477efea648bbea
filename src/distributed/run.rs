//! A run distributed over ranks: `run::run_model`'s stages with the pieces a rank must do
//! differently — it builds its share of the body and bonds, exchanges its halo inside each
//! step (`Simulation::share`), and gathers the fields rank 0's observers read; rank 0 alone
//! writes the files.

use super::gather::{Gather, PieceWriter};
use super::partition::{bond_weights, ranges};
use super::refuse::constitution_refusal;
use super::share::split;
use crate::body::Body;
use crate::deck::build::{
    build_constitution, build_model_with, Constitution, MaterialChoice, Model, Part,
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

fn run_dim<const D: usize>(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
    ranks: Arc<dyn Ranks>,
) -> Result<RunSummary, RunError> {
    let mut built: Option<Built<D>> = None;
    let size = ranks.size();
    let model = build_model_with::<D>(ld, |body, families| {
        let weights = bond_weights(&body, families.rule);
        let Some(ranges) = ranges(&weights, size) else {
            return Err(too_few(ld, body.len(), size));
        };
        let s = split(&body, families.rule, &ld.deck.precracks, &ranges, &*ranks);
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
    let mut c = build_constitution(ld, &model)?;
    whole_constitution_reports(&mut c, &model, built.owned, &*ranks);
    let (material, rest) = c.split();
    constitution_refusal(&rest, size)?;
    let run = (opts, control);
    match material {
        MaterialChoice::Pmb(m) => run_model(ld, model, m, rest, run, built, ranks),
        MaterialChoice::Lps(m) => run_model(ld, model, m, rest, run, built, ranks),
        MaterialChoice::Correspondence(m) => run_model(ld, model, m, rest, run, built, ranks),
        // PMB and LPS blocks only: the scalar path.
        MaterialChoice::Mixed(m) => match m.into_central() {
            Ok(m) => run_model(ld, model, m, rest, run, built, ranks),
            Err(m) => run_model(ld, model, m, rest, run, built, ranks),
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

/// Refuses a body too small to give every rank a node chunk.
fn too_few(ld: &LoadedDeck, nodes: usize, ranks: usize) -> crate::deck::DeckError {
    not_distributed(
        ld,
        &format!(
            "a body of {nodes} nodes on {ranks} ranks (each rank needs at least {} nodes)",
            crate::solver::forces::NODE_CHUNK
        ),
        ranks,
    )
}

fn not_distributed(ld: &LoadedDeck, what: &str, ranks: usize) -> crate::deck::DeckError {
    ld.locate(vec![crate::deck::DeckIssue::new(
        "discretization",
        format!("{what} is not yet distributed: run it on 1 rank (this run has {ranks})"),
    )])
}

fn run_model<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    mut model: Model<D>,
    material: M,
    rest: DamageAndReports,
    (opts, control): (&RunOptions, &RunControl),
    built: Built<D>,
    ranks: Arc<dyn Ranks>,
) -> Result<RunSummary, RunError> {
    let out = &opts.out_dir;
    let root = ranks.rank() == 0;
    let Built {
        whole,
        first,
        owned,
        halo,
        grid,
    } = built;
    let global_nodes = ranks.sum_u64(owned as u64) as usize;
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
    let share = Share {
        ranks: ranks.clone(),
        first,
        owned,
        global_nodes,
        halo,
    };
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
    let checkpoints = checkpoints(&ld.deck, out, origin, snapshot_every);
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
        + directed * report.bytes_per_bond;
    if let Some(g) = grid {
        report.grid = g;
    }
    report
}
