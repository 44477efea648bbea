//! The commands a process started by `mpirun` on several ranks runs (`docs/distributed.md`):
//! `run`, `study` (each run on one rank) and `validate` (each run over every rank). Rank 0
//! prints. An error every rank meets (the deck or study, too few nodes for the ranks, a
//! refused checkpoint, an unstable step) ends every rank; any other (a file rank 0 cannot
//! write) aborts the others, which may be waiting for it.

use super::args::Command;
use super::{deck_name, run_folder};
use crate::deck::study::LoadedStudy;
use crate::deck::LoadedDeck;
use crate::run::{RunControl, RunError, RunOptions};
use crate::solver::ranks::Ranks;
use crate::study_run::{run_study_over, Spread, StudyOptions, StudyRunError};
use std::fmt::Display;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

/// Runs `command` on this rank of `ranks`.
pub(super) fn run_command(command: Command, ranks: Arc<dyn Ranks>) -> ExitCode {
    let root = ranks.rank() == 0;
    let refuse = |msg: String| {
        if root {
            eprintln!("error: {msg}");
        }
        ExitCode::FAILURE
    };
    match command {
        Command::Study {
            study,
            output,
            threads,
            quiet,
            dry_run: false,
        } => {
            let out_dir = output.unwrap_or_else(|| PathBuf::from("results").join(deck_name(&study)));
            let opts = StudyOptions {
                out_dir,
                threads,
                quiet,
                from_run: 0,
                kept_runs: None,
            };
            match LoadedStudy::from_file(&study) {
                Ok(ls) => study_over(&ls, &opts, ranks),
                Err(e) => refuse(e.to_string()),
            }
        }
        Command::Run {
            deck,
            output,
            threads,
            quiet,
            restart,
            stop_after_step,
            checkpoint_minutes,
        } => {
            if checkpoint_minutes.is_some() {
                return refuse("--checkpoint-minutes is for runs in one process: the ranks' clocks would not agree on the step to checkpoint; use checkpoint_interval in [output]".into());
            }
            let ld = match LoadedDeck::from_file(&deck) {
                Ok(ld) => ld,
                Err(e) => return refuse(e.to_string()),
            };
            let out_dir = match run_folder(&deck, output, &restart) {
                Ok(dir) => dir,
                Err(e) => return refuse(e),
            };
            let opts = RunOptions {
                out_dir,
                threads,
                quiet,
            };
            let control = RunControl {
                restart: restart.is_some(),
                stop_after_step,
                ..RunControl::default()
            };
            run_over(&ld, &opts, &control, ranks)
        }
        Command::Validate(args) if !args.report => {
            // Every rank meets an error alike (the ranks agree after each step that could
            // fail on one alone, or abort).
            match super::validate_cases(args, Some(ranks.clone())) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => refuse(e),
            }
        }
        _ => refuse("only `peridyn run`, `peridyn study` (not --dry-run) and `peridyn validate` (not --report) are distributed: start other commands without mpirun (or with -np 1)".into()),
    }
}

/// `run` over the ranks.
fn run_over(
    ld: &LoadedDeck,
    opts: &RunOptions,
    control: &RunControl,
    ranks: Arc<dyn Ranks>,
) -> ExitCode {
    let outcome = crate::distributed::run_with(ld, opts, control, ranks.clone());
    finish(&*ranks, outcome, RunError::on_every_rank)
}

/// `study` over the ranks, each run on one rank; rank 0 writes the study's files.
fn study_over(ls: &LoadedStudy, opts: &StudyOptions, ranks: Arc<dyn Ranks>) -> ExitCode {
    let outcome = run_study_over(ls, opts, &Spread::RunPerRank(ranks.clone()));
    finish(&*ranks, outcome, |e| {
        matches!(
            e,
            StudyRunError::Deck(_)
                | StudyRunError::Design(_)
                | StudyRunError::Point { .. }
                | StudyRunError::Output { .. }
        )
    })
}

/// Rank 0 prints the outcome. An error `every_rank` says all ranks met ends each with a
/// failure; any other aborts them all.
fn finish<T: Display, E: Display>(
    ranks: &dyn Ranks,
    outcome: Result<T, E>,
    every_rank: impl Fn(&E) -> bool,
) -> ExitCode {
    let root = ranks.rank() == 0;
    match outcome {
        Ok(report) => {
            if root {
                println!("{report}");
            }
            ExitCode::SUCCESS
        }
        Err(e) if every_rank(&e) => {
            if root {
                eprintln!("error: {e}");
            }
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("error (rank {}): {e}", ranks.rank());
            ranks.abort(1)
        }
    }
}
