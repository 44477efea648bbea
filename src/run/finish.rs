//! The end of a run: the observers finish their files (or, after a diagnosed failure, the
//! last good state is written), then the summary and the history plots.

use super::{restart, ModelReport, RunError, RunSummary};
use crate::checkpoint::Origin;
use crate::deck::LoadedDeck;
use crate::material::Material;
use crate::observe::crack_path::PathReport;
use crate::observe::crack_surface::CrackSurfaceReport;
use crate::observe::crack_tip::CrackReport;
use crate::observe::Observer;
use crate::solver::Simulation;
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

/// How the stages ended, and what the summary reads besides the simulation.
pub(crate) struct Finished {
    /// The solvers' notes (`stages::drive_stages`), or why the run stopped.
    pub result: Result<Vec<String>, RunError>,
    /// When stepping started (the wall time of the summary).
    pub started: Instant,
    /// The checkpoint a failed run's last good state is read from.
    pub latest_checkpoint: Option<(PathBuf, Origin)>,
    pub crack: Option<Rc<RefCell<Option<CrackReport>>>>,
    pub path: Option<Rc<RefCell<Option<PathReport>>>>,
    pub surface: Option<Rc<RefCell<Option<CrackSurfaceReport>>>>,
    /// Nodes of the whole body (of which `sim` may be one rank's share).
    pub nodes: usize,
    /// This process writes the results (every process but a distributed run's ranks > 0).
    pub writes: bool,
}

/// Finishes the observers' files, and for a run that went to its end writes `summary.txt`
/// (and the history plots when the deck asks for them).
pub(crate) fn finish<const D: usize, M: Material<D>>(
    ld: &LoadedDeck,
    sim: &mut Simulation<D, M>,
    mut observers: Vec<Box<dyn Observer<D>>>,
    report: ModelReport,
    finished: Finished,
    out: &Path,
) -> Result<RunSummary, RunError> {
    let Finished {
        result,
        started,
        latest_checkpoint,
        crack,
        path,
        surface,
        nodes,
        writes,
    } = finished;
    // A stop stands for a kill: the files stay as the last flush left them.
    if !matches!(result, Err(RunError::Stopped(_))) {
        for o in observers.iter_mut() {
            o.finish()?;
        }
    }
    if let (Err(RunError::Step(_)), Some(latest)) = (&result, &latest_checkpoint) {
        if let Some(file) = restart::write_last_good(sim, latest, out) {
            eprintln!(
                "peridyn: the last good state (the latest checkpoint, step {}) is in {}",
                sim.state.step,
                file.display()
            );
        }
    }
    let solver_notes = result?;
    let wall = started.elapsed().as_secs_f64();
    let c = &sim.counters;
    let summary = RunSummary {
        wall_seconds: wall,
        node_steps_per_second: c.node_steps_per_second(nodes),
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
        ) + &sim.share.as_ref().map_or(String::new(), |s| {
            format!(
                "; rank 0: halo exchange {:.2} s",
                s.halo.seconds_waited()
            )
        }),
        out_dir: out.to_path_buf(),
        report,
        crack: crack.and_then(|c| c.borrow().clone()),
        crack_path: path.and_then(|c| c.borrow().clone()),
        crack_surface: surface.and_then(|c| c.borrow().clone()),
        notes: crate::observe::snapshots::maps_skipped(&ld.deck.output, nodes)
            .then(|| crate::observe::snapshots::maps_skipped_note(nodes))
            .into_iter()
            .chain(solver_notes)
            .collect(),
    };
    if !writes {
        return Ok(summary);
    }
    if ld.deck.output.plots {
        crate::plot::history_plots::write_history_plots(out)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
    }
    crate::atomic_file::write_atomic(&out.join("summary.txt"), format!("{summary}\n").as_bytes())?;
    Ok(summary)
}
