//! A study whose every run is one model over all the ranks `mpirun` started (`mpirun -np N
//! peridyn-mpi validate`: a case's finest grid needs them all), the runs one after another.
//! Rank 0 alone touches the study's files, as in a distributed run: it decides which runs are
//! pending and whether a run continues from its checkpoint, reads the outputs and writes
//! `runs.csv`, and tells the other ranks what they need, so they need not see its files.

use super::run_folder::{self, Start};
use super::{failed, read_outputs, StudyOptions, StudyRunError};
use crate::deck::study::LoadedStudy;
use crate::deck::LoadedDeck;
use crate::distributed::study::Outcome;
use crate::run::{RunControl, RunError, RunOptions};
use crate::solver::ranks::Ranks;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// The runs rank 0 found pending (its `runs.csv` and run folders), on every rank.
pub(super) fn agreed_pending(
    ranks: &dyn Ranks,
    candidates: std::ops::Range<usize>,
    pending: &[usize],
) -> Vec<usize> {
    candidates
        .filter(|k| ranks.broadcast_bool(pending.contains(k)))
        .collect()
}

/// Runs one design point's `deck` in `dir` over every rank (or continues it from the
/// checkpoint a stopped invocation left there). Rank 0's outcome holds the outputs; the other
/// ranks' hold none.
pub(super) fn run_point_over_ranks(
    ls: &LoadedStudy,
    opts: &StudyOptions,
    deck: &LoadedDeck,
    dir: &Path,
    ranks: &Arc<dyn Ranks>,
) -> Result<Outcome, StudyRunError> {
    let started = Instant::now();
    let root = ranks.rank() == 0;
    let start = if root {
        run_folder::prepare(dir, &deck.src)
    } else {
        Ok(Start::Afresh)
    };
    agree(&**ranks, start.as_ref().err().cloned())?;
    let continued = ranks.broadcast_bool(start == Ok(Start::FromCheckpoint));
    if continued && root && !opts.quiet {
        println!("{}: continued from its checkpoint", dir.display());
    }
    // No wall-clock checkpoints: the ranks' clocks would not agree on the step to write it
    // at; the deck's own checkpoints (`checkpoint_interval`, snapshots) continue a run.
    let run = |restart: bool| {
        let run_opts = RunOptions {
            out_dir: dir.to_path_buf(),
            threads: opts.threads,
            quiet: opts.quiet,
        };
        let control = RunControl {
            restart,
            ..RunControl::default()
        };
        crate::distributed::run_with(deck, &run_opts, &control, ranks.clone())
    };
    let mut result = run(continued);
    // A checkpoint of another version or deck is refused on every rank alike: start again.
    if continued && matches!(result, Err(RunError::Checkpoint(_))) {
        if let (true, false, Err(e)) = (root, opts.quiet, &result) {
            println!("{}: {e}; started again", dir.display());
        }
        let afresh = if root {
            run_folder::start_afresh(dir, &deck.src)
        } else {
            Ok(())
        };
        agree(&**ranks, afresh.err())?;
        result = run(false);
    }
    match &result {
        // One rank's error (a file rank 0 cannot write): the others may be waiting for it.
        Err(e) if !e.on_every_rank() => {
            eprintln!("error (rank {}): {e}", ranks.rank());
            ranks.abort(1)
        }
        _ => {}
    }
    let outputs = match (&result, root) {
        (Ok(_), true) => read_outputs(ls, dir).map(Some),
        _ => Ok(None),
    };
    agree(&**ranks, outputs.as_ref().err().map(|e| e.to_string()))?;
    let (status, outputs) = match result {
        Ok(_) => (
            "ok".to_string(),
            outputs?.unwrap_or_else(|| vec![None; ls.study.outputs.len()]),
        ),
        Err(e) => failed(ls, &e),
    };
    Ok(Outcome {
        status,
        outputs,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Stops every rank with the lowest rank's error, if any rank has one.
fn agree(ranks: &dyn Ranks, local: Option<String>) -> Result<(), StudyRunError> {
    match ranks.first_message(local) {
        Some(message) => Err(StudyRunError::Io(message)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::super::{run_study, run_study_over, Spread, StudyOptions};
    use crate::deck::study::LoadedStudy;
    use crate::distributed::thread_ranks::ThreadRanks;
    use std::path::{Path, PathBuf};

    fn scratch() -> PathBuf {
        let dir = std::env::temp_dir().join(format!("peridyn-over-ranks-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A sweep of two runs of the quickstart plate (its crack runs in both), coarsened.
    fn sweep(dir: &Path) -> LoadedStudy {
        let deck = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/quickstart.toml");
        let text = format!(
            "version = 1\ndeck = \"{}\"\nmethod = \"sweep\"\n\
             [[factors]]\nkey = \"material.fracture_energy\"\nvalues = [300.0, 400.0]\n\
             [[fixed]]\nkey = \"discretization.spacing\"\nvalue = 4e-4\n\
             [[outputs]]\nname = \"broken\"\ncolumn = \"broken_bonds\"\nreduce = \"final\"\n\
             [[outputs]]\nname = \"speed\"\nfile = \"crack_speed.csv\"\ncolumn = \"speed\"\n\
             reduce = \"mean\"\n",
            deck.display().to_string().replace('\\', "/")
        );
        let path = dir.join("study.toml");
        std::fs::write(&path, text).unwrap();
        LoadedStudy::from_file(&path).unwrap()
    }

    fn options(out_dir: PathBuf) -> StudyOptions {
        StudyOptions {
            out_dir,
            threads: Some(1),
            quiet: true,
            from_run: 0,
            kept_runs: None,
        }
    }

    /// Each run of a study over 2 and 3 ranks writes the files one process writes, byte for
    /// byte (`runs.csv`, each run's history and crack speed), and a study started again over
    /// the ranks finds every run finished (the ranks agree on rank 0's `runs.csv`).
    #[test]
    fn each_run_over_the_ranks_gives_the_one_process_study() {
        let dir = scratch();
        let ls = sweep(&dir);
        let alone = run_study(&ls, &options(dir.join("one"))).unwrap();
        assert!(alone.runs.iter().all(|r| r.status == "ok"));
        assert!(alone.runs[0].outputs[0].unwrap() > 0.0, "no bond broke");
        let files = [
            "runs.csv",
            "runs/run_0000/history.csv",
            "runs/run_0001/crack_speed.csv",
        ];
        for size in [2, 3] {
            let out = dir.join(format!("over{size}"));
            let reports = ThreadRanks::run(size, |ranks| {
                run_study_over(&ls, &options(out.clone()), &Spread::RunOverRanks(ranks)).unwrap()
            });
            assert_eq!(reports[0].runs, alone.runs);
            for file in files {
                let read = |root: &Path| std::fs::read(root.join(file)).unwrap();
                assert!(
                    read(&out) == read(&dir.join("one")),
                    "{file} on {size} ranks"
                );
            }
            let again = ThreadRanks::run(size, |ranks| {
                run_study_over(&ls, &options(out.clone()), &Spread::RunOverRanks(ranks)).unwrap()
            });
            assert!(
                again.iter().all(|r| r.reused == 2),
                "a finished run ran again"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
