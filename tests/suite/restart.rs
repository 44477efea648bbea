//! Checkpoint and restart: a run stopped after a checkpoint and continued with `--restart`
//! leaves the same files, byte for byte, as the run that never stopped (for any thread
//! counts); a checkpoint from another deck or program, or a damaged one, is refused.

use peridyn::deck::LoadedDeck;
use peridyn::run::{run, run_with, RunControl, RunError, RunOptions};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A notched 8 mm × 4 mm PMB plate (Δx = 0.1 mm, δ = 3Δx, 3200 nodes) whose grips are pulled
/// apart at 20 m/s each: the crack runs from step ≈ 150 on. `solver` is appended to
/// `[solver]`, `output` to `[output]`.
fn deck_text(youngs_modulus: f64, solver: &str, output: &str) -> String {
    format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.008, 0.004] }}
spacing = 0.1e-3
horizon_ratio = 3.0

[material]
type = "pmb"
density = 1180.0
youngs_modulus = {youngs_modulus:e}
fracture_energy = 300.0

[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, 0.0037], max = [1.0, 1.0] }}
[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.0003] }}

[[precracks]]
type = "segment"
start = [-0.001, 0.002]
end = [0.002, 0.002]

[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "y"
value = 20.0
[[boundary_conditions]]
set = "bottom"
kind = "velocity"
component = "y"
value = -20.0

[solver]
type = "explicit"
{solver}

[output]
history_interval = 7
snapshots = 4
png = false
plots = false
{output}
"#
    )
}

/// A fresh folder for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("restart-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `text` as `dir/name` and loads it.
fn load(dir: &Path, name: &str, text: &str) -> LoadedDeck {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    LoadedDeck::from_file(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn options(out_dir: &Path, threads: Option<usize>) -> RunOptions {
    RunOptions {
        out_dir: out_dir.to_path_buf(),
        threads,
        quiet: true,
    }
}

/// Every file under `dir` (relative path → bytes) except the wall-clock summary.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().unwrap() != "summary.txt" {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

fn assert_same_files(expected: &Path, found: &Path) {
    let (a, b) = (files(expected), files(found));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    for (name, bytes) in &a {
        assert!(bytes == &b[name], "{name} differs after the restart");
    }
}

/// Runs `ld` whole into `whole/`, then into `parts/` stopped after `stop` (with 1 thread) and
/// continued (with 2), and asserts the two folders hold the same files byte for byte.
fn assert_restart_matches(ld: &LoadedDeck, dir: &Path, stop: u64) {
    let (whole, parts) = (dir.join("whole"), dir.join("parts"));
    let summary = run(ld, &options(&whole, None)).unwrap();
    assert!(summary.broken_bonds > 0, "the plate must fracture");
    let stopped = run_with(
        ld,
        &options(&parts, Some(1)),
        &RunControl {
            stop_after_step: Some(stop),
            ..RunControl::default()
        },
    );
    assert!(
        matches!(stopped, Err(RunError::Stopped(s)) if s == stop),
        "{stopped:?}"
    );
    let history = std::fs::read_to_string(parts.join("history.csv")).unwrap();
    let rows_at_stop = history.lines().count();
    let restart = RunControl {
        restart: true,
        ..RunControl::default()
    };
    let continued = run_with(ld, &options(&parts, Some(2)), &restart).unwrap();
    assert_eq!(continued.broken_bonds, summary.broken_bonds);
    assert_eq!(continued.crack, summary.crack);
    let full_rows = std::fs::read_to_string(whole.join("history.csv"))
        .unwrap()
        .lines()
        .count();
    assert!(
        rows_at_stop < full_rows,
        "the stop must come before the end ({rows_at_stop} of {full_rows} rows)"
    );
    assert_same_files(&whole, &parts);
}

#[test]
fn explicit_run_with_crack_tip_continued_after_a_stop_is_byte_identical() {
    let dir = scratch("explicit");
    // Checkpoints at the snapshots (0, 150, 300, …) and every 100 steps; stopped at 230, the
    // run continues from step 200, after the crack started. The crack tip's samples (and so
    // its speeds) span the restart, and so do the crack path's forks and the crossing counts
    // of a line across the notch plane ahead of the notch, and the displacement's distance
    // from a bar at rest (strain 0: the RMS and largest |u|).
    let tip = "checkpoint_interval = 100\n[analysis.crack_tip]\ndirection = [1.0, 0.0]\ninterval = 10\nwindow = 3\n[analysis.crack_path]\ninterval = 10\n[analysis.crack_crossings]\ninterval = 10\n[[analysis.crack_crossings.lines]]\nname = \"x3mm\"\nfrom = [0.003, 0.0]\nto = [0.003, 0.004]\n[analysis.displacement_error]\nsolution = { type = \"fixed_free_bar\", strain = 0.0, length = 0.008 }\ninterval = 10";
    let ld = load(&dir, "plate.toml", &deck_text(3.09e9, "steps = 600", tip));
    assert_restart_matches(&ld, &dir, 230);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Correspondence under one critical energy keeps each entry's own half of the bond work and
/// each node's matrices of the previous evaluation (split work): both cross the restart.
#[test]
fn correspondence_critical_energy_run_continued_after_a_stop_is_byte_identical() {
    let dir = scratch("split-work");
    let text = deck_text(3.09e9, "steps = 600", "checkpoint_interval = 100").replace(
        "type = \"pmb\"",
        "type = \"correspondence\"\npoisson_ratio = 0.3\n\
         zero_energy_control = { type = \"wan\", coefficient = 1.0 }\n\
         damage = { type = \"critical_energy\" }",
    );
    let ld = load(&dir, "plate.toml", &text);
    assert_restart_matches(&ld, &dir, 330);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn run_with_a_free_impactor_continued_after_a_stop_is_byte_identical() {
    let dir = scratch("impactor");
    // A free disk dropped on the top grip at 50 m/s: it presses on the plate from the first
    // steps on, so the checkpoint at step 200 holds a disk that the plate has slowed down and
    // is pushing back; continued without its position, velocity and force, the disk would
    // jump back to the deck's start.
    let disk = "checkpoint_interval = 100\n\n[[impactors]]\nname = \"disk\"\nshape = \"sphere\"\ncentre = [0.004, 0.0061]\nradius = 0.002\nvelocity = [0.0, -50.0]\nmass = 5e-6";
    let ld = load(&dir, "plate.toml", &deck_text(3.09e9, "steps = 600", disk));
    assert_restart_matches(&ld, &dir, 230);
    let history = std::fs::read_to_string(dir.join("whole/history.csv")).unwrap();
    let mut rows = history.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (step, force) = (column("step"), column("impactor_disk_force_y"));
    let pressed_before_the_checkpoint = rows.any(|r| {
        let r: Vec<&str> = r.split(',').collect();
        r[step].parse::<u64>().unwrap() < 200 && r[force].parse::<f64>().unwrap() > 0.0
    });
    assert!(
        pressed_before_the_checkpoint,
        "the disk must touch the plate before step 200"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn adaptive_run_continued_after_a_stop_is_byte_identical() {
    let dir = scratch("adaptive");
    let ld = load(
        &dir,
        "adaptive.toml",
        &deck_text(
            3.09e9,
            "steps = 600\n[solver.adaptive]\nmax_broken_per_node = 2\nmin_dt = 1e-12",
            "",
        ),
    );
    assert_restart_matches(&ld, &dir, 320);
    // The time step did change (the controller's state crossed the restart).
    let history = std::fs::read_to_string(dir.join("whole/history.csv")).unwrap();
    let dts: std::collections::BTreeSet<&str> = history
        .lines()
        .skip(2)
        .map(|l| l.split(',').nth(8).unwrap())
        .collect();
    assert!(dts.len() > 1, "dt never changed: {dts:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs the plate into `dir/run` and stops it after step 200.
fn stopped_run(dir: &Path) -> (LoadedDeck, PathBuf) {
    let ld = load(dir, "plate.toml", &deck_text(3.09e9, "steps = 400", ""));
    let out = dir.join("run");
    let stop = RunControl {
        stop_after_step: Some(200),
        ..RunControl::default()
    };
    let stopped = run_with(&ld, &options(&out, None), &stop);
    assert!(
        matches!(stopped, Err(RunError::Stopped(200))),
        "{stopped:?}"
    );
    (ld, out)
}

fn restart_error(ld: &LoadedDeck, out: &Path) -> String {
    let restart = RunControl {
        restart: true,
        ..RunControl::default()
    };
    match run_with(ld, &options(out, None), &restart) {
        Ok(_) => panic!("the restart must be refused"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_checkpoint_of_another_deck_is_refused_naming_both() {
    let dir = scratch("other-deck");
    let (_, out) = stopped_run(&dir);
    let before = files(&out);
    let other = load(&dir, "stiffer.toml", &deck_text(3.5e9, "steps = 400", ""));
    let msg = restart_error(&other, &out);
    assert!(msg.contains("written by a different deck"), "{msg}");
    assert!(
        msg.contains("plate.toml") && msg.contains("stiffer.toml"),
        "{msg}"
    );
    assert!(msg.contains(&out.display().to_string()), "{msg}");
    assert!(
        files(&out) == before,
        "a refused restart leaves the folder as it was"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_damaged_or_foreign_checkpoint_is_refused() {
    let dir = scratch("damaged");
    let (ld, out) = stopped_run(&dir);
    let path = out.join("checkpoint.bin");
    let good = std::fs::read(&path).unwrap();

    let mut flipped = good.clone();
    let k = flipped.len() / 2;
    flipped[k] ^= 0x40;
    std::fs::write(&path, &flipped).unwrap();
    let msg = restart_error(&ld, &out);
    assert!(
        msg.contains("corrupt") && msg.contains("checkpoint.bin"),
        "{msg}"
    );

    std::fs::write(&path, &good[..good.len() - 100]).unwrap();
    let msg = restart_error(&ld, &out);
    assert!(msg.contains("truncated"), "{msg}");

    // Another peridyn version, same length so only the version differs.
    let version = env!("CARGO_PKG_VERSION").as_bytes();
    let at = good
        .windows(version.len())
        .position(|w| w == version)
        .unwrap();
    let mut foreign = good.clone();
    foreign[at..at + version.len()].fill(b'9');
    std::fs::write(&path, &foreign).unwrap();
    let msg = restart_error(&ld, &out);
    assert!(msg.contains("written by peridyn 9"), "{msg}");

    std::fs::write(&path, b"not a checkpoint").unwrap();
    let msg = restart_error(&ld, &out);
    assert!(msg.contains("not a peridyn checkpoint"), "{msg}");

    std::fs::remove_file(&path).unwrap();
    let msg = restart_error(&ld, &out);
    assert!(
        msg.contains("no checkpoint") && msg.contains("checkpoint.bin"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The plate pulled quasi-statically by its grips (±`pull` m over the run) on a 0.2 mm grid.
fn quasi_static_text(pull: f64, solver: &str, output: &str) -> String {
    deck_text(3.09e9, "", output)
        .replace("spacing = 0.1e-3", "spacing = 0.2e-3")
        .replace(
            "type = \"explicit\"\n",
            &format!("type = \"quasi_static\"\n{solver}\n"),
        )
        .replace("kind = \"velocity\"", "kind = \"displacement\"")
        .replace(
            "value = 20.0",
            &format!("value = {pull:e}\ntime = {{ type = \"ramp\", duration = 1.0 }}"),
        )
        .replace(
            "value = -20.0",
            &format!(
                "value = {:e}\ntime = {{ type = \"ramp\", duration = 1.0 }}",
                -pull
            ),
        )
}

/// Quasi-static solver keys of the restarts through a crack's growth: load steps halved where
/// more than 40 bonds break.
const SPLIT_STEPS: &str =
    "load_steps = 10\ntolerance = 1e-4\nmax_broken_bonds = 40\nmax_splits = 3";

/// A quasi-static run through the crack's growth, its load steps halved where too many bonds
/// break, stopped after a halved step and continued: the solver's memory (the increment in
/// use, the predictor's last displacements, the largest load) crosses the restart.
#[test]
fn quasi_static_run_continued_after_a_stop_is_byte_identical() {
    let dir = scratch("quasi-static");
    let text = quasi_static_text(2e-5, SPLIT_STEPS, "checkpoint_interval = 2");
    let ld = load(&dir, "qs.toml", &text);
    assert_restart_matches(&ld, &dir, 9);
    // Steps were halved before the stop (the increment in use crossed the restart).
    let history = std::fs::read_to_string(dir.join("whole/history.csv")).unwrap();
    let header = history.lines().next().unwrap();
    let dt = header.split(',').position(|c| c == "dt").unwrap();
    let halved = history.lines().skip(2).take(8).any(|l| {
        let value: f64 = l.split(',').nth(dt).unwrap().parse().unwrap();
        value < 0.09
    });
    assert!(halved, "no load step was halved before step 9:\n{history}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A quasi-static run that stops where the plate breaks through (`stop_when_stored_below`),
/// stopped before that and continued: the continued run stops at the same step, with the
/// same files; the stop needs nothing remembered across the restart.
#[test]
fn a_run_stopped_when_broken_through_continues_byte_identical() {
    let dir = scratch("broken-through");
    let solver = format!("{SPLIT_STEPS}\nstop_when_stored_below = 0.01");
    let text = quasi_static_text(4e-5, &solver, "checkpoint_interval = 2");
    let ld = load(&dir, "qs.toml", &text);
    assert_restart_matches(&ld, &dir, 5);
    let summary = std::fs::read_to_string(dir.join("whole/summary.txt")).unwrap();
    assert!(summary.contains("stopped at load time"), "{summary}");
    let history = std::fs::read_to_string(dir.join("whole/history.csv")).unwrap();
    let last = history.lines().last().unwrap().split(',').next().unwrap();
    let last: f64 = last.parse().unwrap();
    assert!(
        last < 0.9,
        "it broke through before the last load step (t = {last})"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A quasi-static run paused inside its relaxations for checkpoints (as the clock asks in a
/// study's run; here after every ADR iteration), stopped at one of them inside the load step
/// in which the crack runs and continued: the same files, byte for byte, as the run that
/// never paused. The iteration continues where it stopped (its velocities, damping and
/// count), and so does the step (its decisions so far, its work record, its start).
#[test]
fn a_run_stopped_inside_a_load_step_continues_byte_identical() {
    assert_stopped_inside_the_crack_step_continues("inside-step-adr", 2e-5, "", 1, (1, 3));
}

/// As `a_run_stopped_inside_a_load_step_continues_byte_identical`, with conjugate gradients:
/// the minimisation continues along its search direction, with its restart count and its
/// force evaluations so far (a pause after every iteration, each of two force evaluations or
/// more).
#[test]
fn a_conjugate_gradient_run_stopped_inside_a_load_step_continues_byte_identical() {
    assert_stopped_inside_the_crack_step_continues(
        "inside-step-ncg",
        2e-5,
        "method = \"ncg\"",
        2,
        (1, 3),
    );
}

/// The same with the two-level preconditioner: the continued run assembles the coarse
/// matrix of the damage state it continues from, the one the paused minimisation used.
#[test]
fn a_two_level_conjugate_gradient_run_stopped_inside_a_load_step_continues_byte_identical() {
    assert_stopped_inside_the_crack_step_continues(
        "inside-step-ncg-two-level",
        2e-5,
        "method = \"ncg\"\npreconditioner = \"two_level\"",
        2,
        (1, 3),
    );
}

/// Runs the fracturing quasi-static plate pulled to `pull` with `method` whole, then pausing
/// after every iteration (`evaluations_per_pause` force evaluations, or more, apart) and
/// stopped `part_of_step` (a fraction) of the way into the load step in which the crack runs;
/// continued, it must leave the same files and notes, which it returns.
fn assert_stopped_inside_the_crack_step_continues(
    name: &str,
    pull: f64,
    method: &str,
    evaluations_per_pause: u64,
    part_of_step: (u64, u64),
) -> Vec<String> {
    let dir = scratch(name);
    let solver = format!("load_steps = 10\ntolerance = 1e-4\n{method}");
    let text = quasi_static_text(pull, &solver, "")
        .replace("history_interval = 7", "history_interval = 1");
    let ld = load(&dir, "qs.toml", &text);
    let (whole, parts) = (dir.join("whole"), dir.join("parts"));
    let summary = run(&ld, &options(&whole, None)).unwrap();
    assert!(summary.broken_bonds > 0, "the plate must fracture");
    // The iterations of each committed step; the crack's step takes the most.
    let history = std::fs::read_to_string(whole.join("history.csv")).unwrap();
    let column = history
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "iterations")
        .unwrap();
    let iterations: Vec<u64> = history
        .lines()
        .skip(2)
        .map(|l| l.split(',').nth(column).unwrap().parse().unwrap())
        .collect();
    let (crack, most) = (0..iterations.len())
        .map(|k| (k, iterations[k]))
        .max_by_key(|&(_, n)| n)
        .unwrap();
    assert!(crack > 0 && most > 100, "{iterations:?}");
    // Every iteration but a relaxation's first pauses: at most this many pauses come before
    // the crack's step, and the stop falls in it.
    let before: u64 = iterations[..crack].iter().sum();
    let control = RunControl {
        checkpoint_every: Some(std::time::Duration::ZERO),
        stop_at_pause: Some(
            (before + most * part_of_step.0 / part_of_step.1) / evaluations_per_pause,
        ),
        ..RunControl::default()
    };
    let stopped = run_with(&ld, &options(&parts, Some(1)), &control);
    assert!(
        matches!(stopped, Err(RunError::Stopped(s)) if s == crack as u64),
        "expected a stop inside load step {}: {stopped:?}",
        crack + 1
    );
    let restart = RunControl {
        restart: true,
        ..RunControl::default()
    };
    let continued = run_with(&ld, &options(&parts, Some(2)), &restart).unwrap();
    assert_eq!(continued.broken_bonds, summary.broken_bonds);
    assert_eq!(continued.notes, summary.notes);
    assert_same_files(&whole, &parts);
    let _ = std::fs::remove_dir_all(&dir);
    summary.notes
}

/// As `a_run_stopped_inside_a_load_step_continues_byte_identical`, with the stop where the
/// plate breaks through (`stop_when_stored_below`), paused near the end of the step that cuts
/// it: the paused state stores little, but its step's work is not booked yet, so neither the
/// pause nor the continued run's start may end the stage there.
#[test]
fn a_run_paused_inside_the_step_that_breaks_it_through_continues_byte_identical() {
    let notes = assert_stopped_inside_the_crack_step_continues(
        "inside-step-broken-through",
        4e-5,
        "stop_when_stored_below = 0.05",
        1,
        (19, 20),
    );
    // It stopped at the end of the crack's step, the one paused in (step 5 of 10).
    assert!(
        notes
            .iter()
            .any(|n| n.contains("stopped at load time 5e-1")),
        "{notes:?}"
    );
}

/// A relaxation that does not converge stops the run with its load step named, and the last
/// good state (the latest checkpoint: every committed step here) is written beside the
/// snapshots, not in their series.
#[test]
fn a_failed_run_writes_its_last_good_state() {
    let dir = scratch("last-good");
    // 120 ADR iterations relax each elastic load step (the first, from rest, takes 101–110
    // with the spectral masses) but not the crack's step 10 (more than 125).
    let solver = "load_steps = 10\ntolerance = 1e-4\nmax_iterations = 120";
    let text = quasi_static_text(2e-5, solver, "checkpoint_interval = 1");
    let ld = load(&dir, "qs.toml", &text);
    let out = dir.join("run");
    let err = run(&ld, &options(&out, None)).expect_err("120 iterations cannot follow the crack");
    let failed = match &err {
        RunError::Step(peridyn::solver::StepError::NotConverged { step, .. }) => *step,
        other => panic!("expected a relaxation that did not converge, got {other}"),
    };
    let last_good = out.join(format!("fields/last_good_step_{:08}.vtu", failed - 1));
    assert!(last_good.exists(), "{} after {err}", last_good.display());
    let pvd = std::fs::read_to_string(out.join("fields.pvd")).unwrap();
    assert!(!pvd.contains("last_good"), "{pvd}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A staged run (a quasi-static preload, then the grips driven apart in explicit dynamics),
/// stopped inside the quasi-static stage, at its end and inside the dynamic stage: each
/// continuation leaves the files of the run that never stopped, stages.csv included.
#[test]
fn staged_run_continued_after_a_stop_is_byte_identical() {
    let dir = scratch("staged");
    let stages = r#"
[[stages]]
name = "release"
solver = { type = "explicit", steps = 300 }
boundary_conditions = [
  { set = "top", kind = "velocity", component = "y", value = 20.0 },
  { set = "bottom", kind = "velocity", component = "y", value = -20.0 },
]
"#;
    let text = quasi_static_text(
        4e-6,
        "load_steps = 4\ntolerance = 1e-6",
        "checkpoint_interval = 2",
    )
    .replacen("\n[output]", &format!("{stages}\n[output]"), 1);
    let ld = load(&dir, "staged.toml", &text);
    for stop in [3, 4, 150] {
        assert_restart_matches(&ld, &dir.join(format!("stop-{stop}")), stop);
    }
    let stages_csv = std::fs::read_to_string(dir.join("stop-4/parts/stages.csv")).unwrap();
    assert_eq!(stages_csv.lines().count(), 3, "{stages_csv}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn checkpoint_false_writes_none() {
    let dir = scratch("off");
    let ld = load(
        &dir,
        "plate.toml",
        &deck_text(3.09e9, "steps = 20", "checkpoint = false"),
    );
    let out = dir.join("run");
    run(&ld, &options(&out, None)).unwrap();
    assert!(out.join("history.csv").exists());
    assert!(!out.join("checkpoint.bin").exists());
    // Checkpoints by the clock (a study's runs) are written whatever the deck says, here at
    // every step, and change no other file.
    let clocked = dir.join("clocked");
    let control = RunControl {
        checkpoint_every: Some(std::time::Duration::ZERO),
        ..RunControl::default()
    };
    run_with(&ld, &options(&clocked, None), &control).unwrap();
    let checkpoint = clocked.join("checkpoint.bin");
    assert!(checkpoint.exists());
    std::fs::remove_file(checkpoint).unwrap();
    assert_same_files(&out, &clocked);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The command line: a process killed mid-run (after a checkpoint), continued with
/// `--restart DIR`, ends with the files of the run that was not killed.
#[test]
fn killed_process_continues_with_restart_dir() {
    let dir = scratch("killed");
    let deck = dir.join("plate.toml");
    std::fs::write(
        &deck,
        deck_text(3.09e9, "steps = 1500", "checkpoint_interval = 25"),
    )
    .unwrap();
    let exe = env!("CARGO_BIN_EXE_peridyn");
    let peridyn = |args: &[&str]| {
        let status = std::process::Command::new(exe)
            .arg("run")
            .arg(&deck)
            .args(args)
            .arg("-q")
            .stdout(std::process::Stdio::null())
            .status()
            .unwrap();
        assert!(status.success(), "peridyn {args:?}: {status}");
    };
    let whole = dir.join("whole");
    peridyn(&["-o", whole.to_str().unwrap()]);

    let killed = dir.join("killed");
    let mut child = std::process::Command::new(exe)
        .arg("run")
        .arg(&deck)
        .args(["-q", "-o", killed.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Killed once the history (flushed before every checkpoint) passes step 100.
    let history = killed.join("history.csv");
    let started = std::time::Instant::now();
    while std::fs::read_to_string(&history).map_or(true, |h| h.lines().count() < 16) {
        assert!(started.elapsed().as_secs() < 60, "no checkpoint after 60 s");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    peridyn(&["--restart", killed.to_str().unwrap()]);
    assert_same_files(&whole, &killed);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--restart DIR` and `-o` naming another folder, and `--checkpoint-minutes 0`, are refused
/// before anything runs.
#[test]
fn restart_and_output_naming_two_folders_are_refused() {
    let dir = scratch("two-folders");
    let deck = dir.join("plate.toml");
    std::fs::write(&deck, deck_text(3.09e9, "steps = 10", "")).unwrap();
    let (a, b) = (dir.join("a"), dir.join("b"));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .arg("run")
        .arg(&deck)
        .args([
            "-q",
            "-o",
            a.to_str().unwrap(),
            "--restart",
            b.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("name different folders"), "{err}");
    assert!(!a.exists() && !b.exists(), "nothing is written");
    // So is a checkpoint interval that is not a positive number of minutes.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .arg("run")
        .arg(&deck)
        .args(["-q", "-o", a.to_str().unwrap(), "--checkpoint-minutes", "0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("--checkpoint-minutes 0: expected a positive number of minutes"),
        "{err}"
    );
    assert!(!a.exists(), "nothing is written");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A study's (or validation case's) run that an earlier invocation left midway continues
/// from the checkpoint in its folder: the outputs and files are those of the run that never
/// stopped, and the wall time of the first part is kept. A checkpoint that cannot be
/// continued (here: damaged) makes the run start again.
#[test]
fn a_study_run_left_midway_continues_from_its_checkpoint() {
    use peridyn::deck::study::LoadedStudy;
    use peridyn::study_run::{run_folder, run_study, StudyOptions};
    let dir = scratch("study");
    let tip = "checkpoint_interval = 100\n[analysis.crack_tip]\ndirection = [1.0, 0.0]\ninterval = 10\nwindow = 3";
    std::fs::write(
        dir.join("plate.toml"),
        deck_text(3.09e9, "steps = 600", tip),
    )
    .unwrap();
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        "version = 1\ndeck = \"plate.toml\"\nmethod = \"sweep\"\n\
         [[factors]]\nkey = \"material.youngs_modulus\"\nvalues = [3.09e9]\n\
         [[outputs]]\nname = \"tip\"\nfile = \"crack_tip.csv\"\ncolumn = \"crack_x\"\nreduce = \"final\"\n",
    )
    .unwrap();
    let ls = LoadedStudy::from_file(&study).unwrap();
    let study_in = |name: &str| {
        let opts = StudyOptions {
            out_dir: dir.join(name),
            threads: Some(1),
            quiet: true,
            from_run: 0,
            kept_runs: None,
        };
        run_study(&ls, &opts).unwrap()
    };
    let whole = study_in("whole");
    assert!(whole.runs[0].outputs[0].is_some(), "the crack must run");
    let src = std::fs::read_to_string(dir.join("whole/runs/run_0000/deck.toml")).unwrap();
    let point = LoadedDeck::from_str(&src, &dir.join("plate.toml")).unwrap();
    // The stopped invocation: the folder as the study starts it, the run stopped after step
    // 230 (its checkpoint at 200).
    let stop_midway = |name: &str| {
        let run_dir = dir.join(name).join("runs/run_0000");
        run_folder::start_afresh(&run_dir, &src).unwrap();
        let stop = RunControl {
            stop_after_step: Some(230),
            ..RunControl::default()
        };
        let stopped = run_with(&point, &options(&run_dir, Some(2)), &stop);
        assert!(
            matches!(stopped, Err(RunError::Stopped(230))),
            "{stopped:?}"
        );
        run_dir
    };
    let run_dir = stop_midway("parts");
    let parts = study_in("parts");
    assert_eq!(parts.runs, whole.runs);
    let earlier = run_dir.join("earlier_parts_wall_seconds");
    let seconds: f64 = std::fs::read_to_string(&earlier)
        .expect("the run was continued, not started again")
        .trim()
        .parse()
        .unwrap();
    assert!(seconds >= 0.0);
    std::fs::remove_file(&earlier).unwrap();
    assert_same_files(&dir.join("whole/runs/run_0000"), &run_dir);
    // A damaged checkpoint: the run starts again, with the same outputs.
    let run_dir = stop_midway("damaged");
    let checkpoint = run_dir.join("checkpoint.bin");
    let mut bytes = std::fs::read(&checkpoint).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0xff;
    std::fs::write(&checkpoint, bytes).unwrap();
    let again = study_in("damaged");
    assert_eq!(again.runs, whole.runs);
    assert!(!run_dir.join("earlier_parts_wall_seconds").exists());
    assert_same_files(&dir.join("whole/runs/run_0000"), &run_dir);
    let _ = std::fs::remove_dir_all(&dir);
}
