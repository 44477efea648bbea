//! The command line's words: the commands and their options (clap).

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "peridyn",
    version,
    about = "Peridynamic fracture simulation in 2D and 3D"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Run a deck: fields (VTU/PVD), history (CSV), damage maps (PNG, 2D), resolved deck.
    Run {
        deck: PathBuf,
        /// Results folder (default: results/<deck name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Worker threads (default: all cores). Results are identical for any count.
        #[arg(long)]
        threads: Option<usize>,
        /// No progress output.
        #[arg(short, long)]
        quiet: bool,
        /// Continue a killed run from the checkpoint in its results folder (-o, or DIR if
        /// given), with the same deck; its files continue as if it had not stopped.
        #[arg(long, value_name = "DIR", num_args = 0..=1)]
        restart: Option<Option<PathBuf>>,
        /// Stop after this step as if killed (tests of restarts).
        #[arg(long, hide = true)]
        stop_after_step: Option<u64>,
        /// Also write a checkpoint every M minutes of wall time, whatever the deck says, and
        /// inside a quasi-static load step that lasts longer (its relaxation pauses for it):
        /// a killed run loses at most M minutes. One process only.
        #[arg(long, value_name = "M")]
        checkpoint_minutes: Option<f64>,
    },
    /// Draw the PNG plots of a finished (or interrupted) run's history.csv into RUN_DIR/plots:
    /// energies, load–displacement per loaded node set, openings, broken bonds, time step.
    Plot { run_dir: PathBuf },
    /// Validate a deck and print the model it builds (nodes, bonds, δ/Δx, constants, dt, memory);
    /// given a study file, validate it and every run's deck (as `study --dry-run`); given a
    /// validation case, the same for its full and reduced versions.
    Check {
        deck: PathBuf,
        #[arg(long)]
        threads: Option<usize>,
        /// Also predict a distributed run on N ranks: each rank's nodes, ghosts, bonds, halo
        /// bytes per step and memory (docs/distributed.md).
        #[arg(long, value_name = "N")]
        ranks: Option<usize>,
        /// With --ranks: the memory one rank may use, in GB (default: this machine's
        /// available memory shared by the N ranks); a share larger than that is refused.
        #[arg(long, value_name = "GB", requires = "ranks")]
        rank_memory: Option<f64>,
    },
    /// Write a deck's grid without running it: nodes (VTU: volume, cell size, horizon, block)
    /// and, in 2D, a PNG of the nodes with the shape's outline.
    Grid {
        deck: PathBuf,
        /// Output folder (default: results/<deck name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Run a parameter study of a deck (study file: the deck, the numbers to vary, Morris
    /// screening or a sweep, the outputs to read): every run in DIR/runs/, runs.csv, and for
    /// Morris morris.csv and a μ*–σ plot per output. Started again, it continues where it
    /// stopped (a run left midway, from its checkpoint: every 10 minutes).
    Study {
        study: PathBuf,
        /// Results folder (default: results/<study name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Worker threads of each run (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress lines.
        #[arg(short, long)]
        quiet: bool,
        /// Validate the study and every run's deck, print the runs, run nothing.
        #[arg(long)]
        dry_run: bool,
    },
    /// Reproduce the papers' results: run validation cases (validation/seed*/*.toml; all of
    /// them when none is named), compare with the papers' numbers, and write
    /// docs/validation.md with its figures (full size). Started again, a case continues where
    /// it stopped (a run left midway, from its checkpoint: every 10 minutes).
    Validate(ValidateArgs),
    /// Measure force-loop throughput (node-steps/s, bond evaluations/s, bytes per bond).
    Bench {
        /// Target number of directed bonds per case.
        #[arg(long, default_value_t = 4_000_000)]
        bonds: usize,
        /// Steps per measurement.
        #[arg(long, default_value_t = 20)]
        steps: u64,
        /// Thread counts to measure, comma separated (default: 1 and all cores).
        #[arg(long, value_delimiter = ',')]
        threads: Vec<usize>,
        /// Cases to measure, comma separated (default: all; `peridyn bench --cases list` names them).
        #[arg(long, value_delimiter = ',')]
        cases: Vec<String>,
    },
}

/// The options of `peridyn validate`.
#[derive(Args)]
pub struct ValidateArgs {
    pub cases: Vec<PathBuf>,
    /// The reduced (CI) version of each case: minutes, not hours; the report is left as
    /// it is, and rows outside their reduced tolerance fail the command.
    #[arg(long)]
    pub reduced: bool,
    /// Only write docs/validation.md again from the committed measurements.
    #[arg(long, conflicts_with_all = ["cases", "reduced"])]
    pub report: bool,
    /// The validation folder (default: validation, or the one holding the named cases).
    #[arg(long)]
    pub root: Option<PathBuf>,
    /// Results folder of the runs (default: results/validation or results/validation-reduced).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Only the first N values of each case's series (coarsest first): a pass over every
    /// case before the long runs of the finest grids; a later run continues with the rest.
    #[arg(long, value_name = "N")]
    pub first: Option<usize>,
    /// Only the last N values of each case's series (the finest grids); the coarser runs
    /// keep their committed measurement (their figures' curves need their folders here).
    #[arg(long, value_name = "N", conflicts_with = "first")]
    pub last: Option<usize>,
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(short, long)]
    pub quiet: bool,
}
