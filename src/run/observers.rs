//! The observers a run attaches: history, snapshots and progress, a staged run's stage
//! record, and the `[analysis]` observers; on a restart each continues its files from the
//! checkpoint's step.

use super::{ModelReport, RunError, RunOptions};
use crate::body::Body;
use crate::deck::LoadedDeck;
use crate::material::Material;
use crate::math::Vector;
use crate::observe::crack_crossings::{CrackCrossings, CrossingSettings};
use crate::observe::crack_path::{CrackPath, PathReport, PathSettings};
use crate::observe::crack_surface::{CrackSurface, CrackSurfaceReport, SurfaceSettings};
use crate::observe::crack_tip::{CrackReport, CrackTips};
use crate::observe::displacement_error::DisplacementError;
use crate::observe::history::History;
use crate::observe::progress::Progress;
use crate::observe::resume::ResumedCsv;
use crate::observe::snapshots::Snapshots;
use crate::observe::stage_record::StageRecord;
use crate::observe::Observer;
use crate::solver::Simulation;
use std::cell::RefCell;
use std::path::Path;
use std::rc::Rc;

/// A run's observers, and the handles the analysis observers leave their end-of-run reports
/// in.
pub(crate) struct Attached<const D: usize> {
    pub observers: Vec<Box<dyn Observer<D>>>,
    /// Steps between snapshots (`u64::MAX`: none), which checkpoints may follow.
    pub snapshot_every: u64,
    pub crack: Option<Rc<RefCell<Option<CrackReport>>>>,
    pub path: Option<Rc<RefCell<Option<PathReport>>>>,
    pub surface: Option<Rc<RefCell<Option<CrackSurfaceReport>>>>,
}

/// Attaches the deck's observers to a run writing into `opts.out_dir`; `restarting`: they
/// continue the files of the run's checkpoint (at `sim`'s step and time).
pub(super) fn attach<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    opts: &RunOptions,
    sim: &Simulation<D, M>,
    report: &ModelReport,
    staged: bool,
    restarting: bool,
) -> Result<Attached<D>, RunError> {
    let at = (sim.state.step, sim.state.time);
    let body = (&sim.body, sim.densities[0]);
    attach_to(ld, opts, body, report, (staged, restarting), at, 1)
}

/// `attach` for the whole `body` (and node 0's density) of a run at `(step, time)` on `ranks`
/// ranks: a distributed run's rank 0 attaches its observers to the whole body it gathers.
pub(crate) fn attach_to<const D: usize>(
    ld: &LoadedDeck,
    opts: &RunOptions,
    (body, density): (&Body<D>, f64),
    report: &ModelReport,
    (staged, restarting): (bool, bool),
    (step, time): (u64, f64),
    ranks: usize,
) -> Result<Attached<D>, RunError> {
    let deck = &ld.deck;
    let out = &opts.out_dir;
    let snapshot_every = if deck.output.snapshots == 0 {
        u64::MAX
    } else {
        report.steps.div_ceil(deck.output.snapshots).max(1)
    };
    let title = ld.title();
    let history =
        |path: &Path| -> Box<dyn Observer<D>> { Box::new(history::<D>(deck, body, staged, path)) };
    let history_path = out.join("history.csv");
    let output = &deck.output;
    let (history, snapshots) = if restarting {
        // The files keep what they held up to the checkpoint's step.
        (
            Box::new(ResumedCsv::new(&history_path, step, history)?) as Box<dyn Observer<D>>,
            Snapshots::resume(out.clone(), time, snapshot_every, output, &title)?.on_ranks(
                ranks,
                body.len(),
                output,
            ),
        )
    } else {
        (
            history(&history_path),
            Snapshots::new(out.clone(), snapshot_every, output, &title)?.on_ranks(
                ranks,
                body.len(),
                output,
            ),
        )
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
        let bin = body.min_cell_size();
        let record = StageRecord::new(out, direction, bin);
        observers.push(Box::new(match restarting {
            true => record.resume(step)?,
            false => record,
        }));
    }
    let analysis = deck.analysis.as_ref();
    let crack = match analysis.and_then(|a| a.crack_tip.as_ref()) {
        Some(tip) => Some(attach_analysis(
            &mut observers,
            crack_tips(deck, tip, (body, density), report, out),
            restarting,
            |o| o.resume(step, &body.positions),
            CrackTips::report,
        )?),
        None => None,
    };
    let path = match analysis.and_then(|a| a.crack_path.as_ref()) {
        Some(p) if D == 2 => Some(attach_analysis(
            &mut observers,
            crack_path(p, body, out),
            restarting,
            |o| o.resume(step),
            CrackPath::report,
        )?),
        _ => None,
    };
    let surface = match analysis.and_then(|a| a.crack_surface.as_ref()) {
        Some(a) if D == 3 => Some(attach_analysis(
            &mut observers,
            crack_surface(deck, a, body, out),
            restarting,
            |o| o.resume(step),
            CrackSurface::report,
        )?),
        _ => None,
    };
    if let Some(c) = analysis.and_then(|a| a.crack_crossings.as_ref()) {
        if D == 2 {
            let counts = out.join("crack_crossings.csv");
            observers.push(csv_observer(&counts, restarting.then_some(step), |path| {
                Box::new(crack_crossings(c, body, path, out))
            })?);
        }
    }
    if let Some(e) = analysis.and_then(|a| a.displacement_error.as_ref()) {
        let errors = out.join("displacement_error.csv");
        observers.push(csv_observer(&errors, restarting.then_some(step), |path| {
            Box::new(displacement_error(e, body, report, path))
        })?);
    }
    Ok(Attached {
        observers,
        snapshot_every,
        crack,
        path,
        surface,
    })
}

/// An observer writing one CSV file at `path`, made by `make`; `resume_at`: continuing the
/// rows the file holds up to that step (a restart).
fn csv_observer<const D: usize>(
    path: &Path,
    resume_at: Option<u64>,
    make: impl FnOnce(&Path) -> Box<dyn Observer<D>>,
) -> std::io::Result<Box<dyn Observer<D>>> {
    Ok(match resume_at {
        Some(step) => Box::new(ResumedCsv::new(path, step, make)?),
        None => make(path),
    })
}

/// The history of a run on `body` written to `path` (`staged`: with the column `stage`); a
/// session keeps one in memory.
pub(crate) fn history<const D: usize>(
    deck: &crate::deck::Deck,
    body: &Body<D>,
    staged: bool,
    path: &Path,
) -> History {
    let sets: Vec<(String, Vec<u32>)> = body
        .node_sets
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    let every = match deck.history_interval() {
        0 => u64::MAX,
        k => k,
    };
    let h = History::new::<D>(path, every, &sets)
        .with_openings(&opening_nodes(body, &deck.output.openings))
        .with_probes::<D>(&probe_nodes(body, &deck.output.probes));
    let h = if deck.contact.is_some() || !deck.impactors.is_empty() {
        let names: Vec<String> = deck.impactors.iter().map(|i| i.name.clone()).collect();
        h.with_contact::<D>(&names)
    } else {
        h
    };
    if staged {
        h.with_stages()
    } else {
        h
    }
}

/// Each opening's name and the nodes nearest its two points.
pub(crate) fn opening_nodes<const D: usize>(
    body: &crate::body::Body<D>,
    openings: &[crate::deck::schema::OpeningDeck],
) -> Vec<(String, usize, usize)> {
    openings
        .iter()
        .map(|o| {
            (
                o.name.clone(),
                nearest_node(body, &o.between[0]),
                nearest_node(body, &o.between[1]),
            )
        })
        .collect()
}

/// Each probe's name and the node nearest its point.
fn probe_nodes<const D: usize>(
    body: &crate::body::Body<D>,
    probes: &[crate::deck::schema::ProbeDeck],
) -> Vec<(String, usize)> {
    probes
        .iter()
        .map(|p| (p.name.clone(), nearest_node(body, &p.at)))
        .collect()
}

/// The node nearest `point` (the lowest index on a tie).
fn nearest_node<const D: usize>(body: &crate::body::Body<D>, point: &[f64]) -> usize {
    let p = crate::math::vector_from_slice::<D>(point);
    (0..body.len())
        .min_by(|&a, &b| {
            (body.positions[a] - p)
                .norm()
                .total_cmp(&(body.positions[b] - p).norm())
                .then(a.cmp(&b))
        })
        .unwrap_or(0)
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
fn crack_tips<const D: usize>(
    deck: &crate::deck::Deck,
    tip: &crate::deck::schema::CrackTipDeck,
    (body, density): (&Body<D>, f64),
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
        tracker = tracker.with_front(body.min_cell_size());
    }
    let setting = match (D, deck.plane) {
        (3, _) => WaveSetting::ThreeD,
        (_, Some(Plane::Strain)) => WaveSetting::PlaneStrain,
        _ => WaveSetting::PlaneStress,
    };
    let rayleigh = rayleigh_speed(
        report.youngs_modulus,
        report.poisson_ratio,
        density,
        setting,
    );
    let tips = CrackTips::new(out, tracker, tip.interval, tip.window, rayleigh);
    if D == 2 {
        tips.with_dissipation_rate(body.thickness, deck.material.fracture_energy())
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
            region: p.region.clone(),
        },
    )
}

/// The crossing counter of `[analysis.crack_crossings]`, counting into `counts`: the link
/// defaults to three times the smallest cell size (as `[analysis.crack_path]`'s), a strip's
/// width to the link.
fn crack_crossings<const D: usize>(
    c: &crate::deck::schema::CrackCrossingsDeck,
    body: &Body<D>,
    counts: &Path,
    out: &Path,
) -> CrackCrossings {
    use crate::analysis::CrossingLine;
    let link = c.link.unwrap_or(3.0 * body.min_cell_size());
    let point = |v: &[f64]| Vector::<2>::new(v[0], v[1]);
    let lines = c
        .lines
        .iter()
        .map(|l| {
            let line = CrossingLine {
                from: point(&l.from),
                to: point(&l.to),
                width: l.width.unwrap_or(link),
            };
            (l.name.trim().to_string(), line)
        })
        .collect();
    let settings = CrossingSettings {
        threshold: c.threshold,
        interval: c.interval,
        link,
        lines,
    };
    CrackCrossings::new(counts, out, settings)
}

/// The crack-surface observer of `[analysis.crack_surface]`: the cell side defaults to twice
/// the smallest cell size, and Γ is compared with the deck's `[material]` G0, as the 2D
/// dissipation rate of `[analysis.crack_tip]` is.
fn crack_surface<const D: usize>(
    deck: &crate::deck::Deck,
    a: &crate::deck::schema::CrackSurfaceDeck,
    body: &Body<D>,
    out: &std::path::Path,
) -> CrackSurface {
    let settings = SurfaceSettings {
        axis: a.axis.index(),
        bin_width: a.bin_width.unwrap_or(2.0 * body.min_cell_size()),
        interval: a.interval,
        g0: deck.material.fracture_energy(),
    };
    CrackSurface::new(out, body, settings)
}

/// The error observer of `[analysis.displacement_error]`, writing into `path`: each set's
/// nodes on the bar, whose waves travel at the model's P-wave speed unless the deck says.
fn displacement_error<const D: usize>(
    e: &crate::deck::schema::DisplacementErrorDeck,
    body: &Body<D>,
    report: &ModelReport,
    path: &Path,
) -> DisplacementError {
    let bar = e.solution.bar(report.p_wave_speed);
    let sets = e
        .sets
        .iter()
        .map(|name| {
            let nodes = body.node_set(name).unwrap_or_default();
            let on_bar = nodes
                .into_iter()
                .filter(|&i| bar.contains(body.positions[i as usize][0]))
                .collect();
            (name.clone(), on_bar)
        })
        .collect();
    DisplacementError::new(path, bar, e.interval, sets)
}
