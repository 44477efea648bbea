//! Parameter studies (`peridyn study`): a Morris screening and a sweep of the quasi-static
//! tension example, on a coarse grid, where the answer is known: the grip reaction of an
//! elastic plate is proportional to E and to the grip displacement and does not depend on
//! the density. Also: a stopped study continues where it stopped with the same results, and
//! bad study files are refused at their line and key.

use peridyn::deck::study::LoadedStudy;
use peridyn::study_run::{plan_study, run_study, run_study_over, Spread, StudyOptions};
use std::path::{Path, PathBuf};

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("peridyn-study-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn example(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
        .display()
        .to_string()
}

/// A study file in `dir` on the quasi-static tension example (a 50 × 50 grid).
fn study_file(dir: &Path, body: &str) -> PathBuf {
    let text = format!(
        r#"version = 1
deck = "{}"
{body}
[[fixed]]
key = "discretization.spacing"
value = 2.0e-3
[[outputs]]
name = "reaction"
column = "reaction_top_y"
reduce = "final"
"#,
        example("quasi_static_tension.toml").replace('\\', "/")
    );
    let path = dir.join("study.toml");
    std::fs::write(&path, text).unwrap();
    path
}

const MORRIS: &str = r#"method = "morris"
[morris]
trajectories = 3
pool = 6
levels = 4
seed = 11
[[factors]]
key = "material.youngs_modulus"
min = 1.0e9
max = 2.0e9
[[factors]]
key = "material.density"
min = 500.0
max = 2000.0
"#;

/// `MORRIS` with its output redefined under the same name: the mean reaction over the run
/// instead of the final one.
fn morris_with_mean_reaction(dir: &Path) -> LoadedStudy {
    let path = study_file(dir, MORRIS);
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replace("reduce = \"final\"", "reduce = \"mean\""),
    )
    .unwrap();
    LoadedStudy::from_file(&path).unwrap()
}

fn options(dir: &Path) -> StudyOptions {
    StudyOptions {
        out_dir: dir.join("out"),
        threads: Some(2),
        quiet: true,
        from_run: 0,
        kept_runs: None,
    }
}

#[test]
fn morris_screening_finds_the_linear_factor_and_the_idle_one() {
    let dir = scratch("morris");
    let ls = LoadedStudy::from_file(&study_file(&dir, MORRIS)).unwrap();
    let report = run_study(&ls, &options(&dir)).unwrap();
    assert_eq!(report.runs.len(), 3 * 3);
    assert_eq!(report.failed(), 0);
    // Every run: R/E is the same number (R ∝ E), to the relaxation's tolerance.
    let ratios: Vec<f64> = report
        .runs
        .iter()
        .map(|r| r.outputs[0].unwrap() / r.values[0])
        .collect();
    let k = ratios[0];
    assert!(k > 0.0);
    let spread = ratios
        .iter()
        .map(|r| (r / k - 1.0).abs())
        .fold(0.0, f64::max);
    println!(
        "R/E = {k:.6e} N/Pa over {} runs, spread {spread:.2e}",
        ratios.len()
    );
    assert!(spread < 1e-5, "R/E varies by {spread}");
    // Morris: the elementary effect of E (unit range) is k (hi − lo) in every trajectory, so
    // μ = μ* = that and σ ≈ 0; the density does nothing.
    let (name, effects) = &report.effects[0];
    assert_eq!(name, "reaction");
    let (e, rho) = (&effects[0], &effects[1]);
    assert_eq!(e.effects, 3);
    let expected = k * 1.0e9;
    println!(
        "E: μ* = {:.6e} (expected {expected:.6e}), σ = {:.2e}; ρ: μ* = {:.2e}",
        e.mu_star.unwrap(),
        e.sigma.unwrap(),
        rho.mu_star.unwrap()
    );
    assert!((e.mu.unwrap() / expected - 1.0).abs() < 1e-4);
    assert!((e.mu_star.unwrap() / expected - 1.0).abs() < 1e-4);
    assert!(e.sigma.unwrap() < 1e-4 * expected);
    assert!(
        rho.mu_star.unwrap() < 1e-6 * expected,
        "the density changed the reaction"
    );
    // The files: runs.csv (a row per run), morris.csv, the plot, each run's deck.
    let out = dir.join("out");
    let runs = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    assert!(runs
        .starts_with("run,trajectory,material.youngs_modulus,material.density,reaction,status\n"));
    assert_eq!(runs.lines().count(), 10);
    let morris = std::fs::read_to_string(out.join("morris.csv")).unwrap();
    assert!(morris.contains("reaction,material.youngs_modulus,"));
    assert!(out.join("plots/morris_reaction.png").exists());
    let deck = std::fs::read_to_string(out.join("runs/run_0004/deck.toml")).unwrap();
    assert!(
        deck.contains("spacing = 0.002"),
        "the fixed spacing is in every run's deck"
    );
}

#[test]
fn a_stopped_study_continues_with_the_same_results() {
    let dir = scratch("resume");
    let ls = LoadedStudy::from_file(&study_file(&dir, MORRIS)).unwrap();
    let first = run_study(&ls, &options(&dir)).unwrap();
    assert_eq!(first.reused, 0);
    // As if stopped after three runs: the table keeps their rows only, and a fourth run's
    // folder is left half written.
    let table = dir.join("out/runs.csv");
    let text = std::fs::read_to_string(&table).unwrap();
    let kept: Vec<&str> = text.lines().take(4).collect();
    std::fs::write(&table, kept.join("\n") + "\n").unwrap();
    std::fs::write(dir.join("out/runs/run_0003/history.csv"), "time\n").unwrap();
    let second = run_study(&ls, &options(&dir)).unwrap();
    assert_eq!(second.reused, 3);
    // Bitwise the same outputs (the runs are deterministic, and the reused ones read back
    // exactly).
    assert_eq!(first.runs, second.runs);
    assert_eq!(first.effects, second.effects);
    // A run whose deck changed (here: one run's deck edited by hand, as a changed base deck or
    // fixed number would change every run's) is run again.
    let deck = dir.join("out/runs/run_0005/deck.toml");
    let edited = std::fs::read_to_string(&deck).unwrap() + "\n# edited\n";
    std::fs::write(&deck, edited).unwrap();
    let third = run_study(&ls, &options(&dir)).unwrap();
    assert_eq!(third.reused, first.runs.len() - 1);
    assert_eq!(first.runs, third.runs);
    // An output redefined under the same name (the final reaction becomes the mean over the
    // run) is read again from every finished run's folder, not taken from the table.
    let fourth = run_study(&morris_with_mean_reaction(&dir), &options(&dir)).unwrap();
    assert_eq!(fourth.reused, first.runs.len());
    for (a, b) in first.runs.iter().zip(&fourth.runs) {
        assert_ne!(
            a.outputs, b.outputs,
            "the redefined output was not read again"
        );
    }
    // An output added to the study reuses every finished run: all outputs are read from the
    // runs' folders.
    let added = MORRIS.to_string()
        + "[[outputs]]\nname = \"peak\"\ncolumn = \"reaction_top_y\"\nreduce = \"max\"\n";
    let ls = LoadedStudy::from_file(&study_file(&dir, &added)).unwrap();
    let fifth = run_study(&ls, &options(&dir)).unwrap();
    assert_eq!(fifth.reused, first.runs.len());
    assert!(fifth
        .runs
        .iter()
        .all(|r| r.outputs.len() == 2 && r.outputs[1].is_some()));
    // A changed design does not reuse runs of another one.
    let other = MORRIS.replace("seed = 11", "seed = 12");
    let ls = LoadedStudy::from_file(&study_file(&dir, &other)).unwrap();
    let planned = plan_study(&ls, Some(1)).unwrap();
    assert_ne!(
        planned.iter().map(|r| r.values.clone()).collect::<Vec<_>>(),
        first
            .runs
            .iter()
            .map(|r| r.values.clone())
            .collect::<Vec<_>>()
    );
}

/// Runs side by side in one process (a screening's small runs, one per thread) are the runs
/// one after another, bit for bit: the same outputs, table and statistics.
#[test]
fn runs_side_by_side_are_the_runs_one_after_another() {
    let dir = scratch("at-once");
    let ls = LoadedStudy::from_file(&study_file(&dir, MORRIS)).unwrap();
    let serial = run_study(&ls, &options(&dir)).unwrap();
    let table = std::fs::read_to_string(dir.join("out/runs.csv")).unwrap();
    let apart = StudyOptions {
        out_dir: dir.join("apart"),
        ..options(&dir)
    };
    let side_by_side = run_study_over(&ls, &apart, &Spread::AtOnce(4)).unwrap();
    assert_eq!(side_by_side.reused, 0);
    assert_eq!(serial.runs, side_by_side.runs);
    assert_eq!(serial.effects, side_by_side.effects);
    assert_eq!(
        table,
        std::fs::read_to_string(dir.join("apart/runs.csv")).unwrap()
    );
}

/// A study whose output folder is lost (another machine) continues from the runs kept
/// outside it: the kept runs are not run again and give the same statistics; a kept run
/// whose deck or outputs differ from the design's is run again.
#[test]
fn kept_runs_outlive_the_output_folder() {
    let dir = scratch("kept");
    let kept = dir.join("kept.runs.csv");
    let with_kept = |dir: &Path| StudyOptions {
        kept_runs: Some(kept.clone()),
        ..options(dir)
    };
    let ls = LoadedStudy::from_file(&study_file(&dir, MORRIS)).unwrap();
    let first = run_study(&ls, &with_kept(&dir)).unwrap();
    assert_eq!(first.failed(), 0);
    let text = std::fs::read_to_string(&kept).unwrap();
    assert!(text.starts_with(
        "run,trajectory,material.youngs_modulus,material.density,reaction,minutes,fingerprint,status\n"
    ));
    assert_eq!(text.lines().count(), 1 + first.runs.len());
    assert!(
        first.minutes.iter().all(Option::is_some),
        "every run's wall time is kept"
    );

    // The folder gone: nothing runs, and the runs, their minutes and the statistics are the
    // first invocation's, bitwise.
    std::fs::remove_dir_all(dir.join("out")).unwrap();
    let second = run_study(&ls, &with_kept(&dir)).unwrap();
    assert_eq!(second.reused, first.runs.len());
    assert!(
        !dir.join("out/runs/run_0000").exists(),
        "a kept run ran again"
    );
    assert_eq!(first.runs, second.runs);
    assert_eq!(first.minutes, second.minutes);
    assert_eq!(first.effects, second.effects);

    // One kept row from another deck (its fingerprint differs): that run alone runs again,
    // with the same result.
    std::fs::remove_dir_all(dir.join("out")).unwrap();
    let row = text.lines().nth(3).unwrap();
    let print = row.split(',').nth_back(1).unwrap();
    std::fs::write(
        &kept,
        text.replace(row, &row.replace(print, "0000000000000000")),
    )
    .unwrap();
    let third = run_study(&ls, &with_kept(&dir)).unwrap();
    assert_eq!(third.reused, first.runs.len() - 1);
    assert!(dir.join("out/runs/run_0002/deck.toml").exists());
    assert_eq!(first.runs, third.runs);

    // An output redefined under the same name: every kept run runs again.
    std::fs::remove_dir_all(dir.join("out")).unwrap();
    let fourth = run_study(&morris_with_mean_reaction(&dir), &with_kept(&dir)).unwrap();
    assert_eq!(fourth.reused, 0);
    assert_ne!(first.runs, fourth.runs);
}

#[test]
fn a_sweep_of_the_grip_displacement_is_linear() {
    let dir = scratch("sweep");
    let body = r#"method = "sweep"
[[factors]]
key = "boundary_conditions[1].value"
values = [2.0e-6, 4.0e-6, 6.0e-6]
"#;
    let ls = LoadedStudy::from_file(&study_file(&dir, body)).unwrap();
    let report = run_study(&ls, &options(&dir)).unwrap();
    let r: Vec<f64> = report.runs.iter().map(|r| r.outputs[0].unwrap()).collect();
    println!("reactions {r:?}");
    assert!((r[1] / r[0] - 2.0).abs() < 1e-4 && (r[2] / r[0] - 3.0).abs() < 1e-4);
    assert!(report.effects.is_empty());
    assert!(dir.join("out/plots/sweep_reaction.png").exists());
    // A number set with the factor: twice the displacement at half the modulus, the same
    // reaction (R ∝ E u).
    let dir = scratch("sweep-with");
    let body = r#"method = "sweep"
[[factors]]
key = "boundary_conditions[1].value"
values = [2.0e-6, 4.0e-6]
with = [{ key = "material.youngs_modulus", values = [2.0e9, 1.0e9] }]
"#;
    let ls = LoadedStudy::from_file(&study_file(&dir, body)).unwrap();
    let report = run_study(&ls, &options(&dir)).unwrap();
    let r: Vec<f64> = report.runs.iter().map(|r| r.outputs[0].unwrap()).collect();
    assert!((r[1] / r[0] - 1.0).abs() < 1e-4, "reactions {r:?}");
    // A word fixed in every run (the solver's method): the conjugate-gradient runs reach the
    // same linear reactions, and each run's deck holds the word.
    let dir = scratch("sweep-word");
    let body = r#"method = "sweep"
[[factors]]
key = "boundary_conditions[1].value"
values = [2.0e-6, 4.0e-6]
[[fixed]]
key = "solver.method"
value = "ncg"
"#;
    let ls = LoadedStudy::from_file(&study_file(&dir, body)).unwrap();
    let report = run_study(&ls, &options(&dir)).unwrap();
    let r: Vec<f64> = report.runs.iter().map(|r| r.outputs[0].unwrap()).collect();
    assert!((r[1] / r[0] - 2.0).abs() < 1e-4, "reactions {r:?}");
    let deck = std::fs::read_to_string(dir.join("out/runs/run_0001/deck.toml")).unwrap();
    // The example's header mentions `method = "ncg"` in a comment: the key's own line counts.
    assert!(
        deck.lines().any(|l| l.starts_with("method = \"ncg\"")),
        "{deck}"
    );
    // A number set to the factor's own value (`also`): the modulus's value also becomes the
    // density, which a quasi-static run does not read (a check of where the value goes, not
    // a material), so the reaction still doubles with the modulus.
    let dir = scratch("sweep-also");
    let body = r#"method = "sweep"
[[factors]]
key = "material.youngs_modulus"
values = [1.0e9, 2.0e9]
also = ["material.density"]
"#;
    let ls = LoadedStudy::from_file(&study_file(&dir, body)).unwrap();
    let report = run_study(&ls, &options(&dir)).unwrap();
    let r: Vec<f64> = report.runs.iter().map(|r| r.outputs[0].unwrap()).collect();
    assert!((r[1] / r[0] - 2.0).abs() < 1e-4, "reactions {r:?}");
    for (k, value) in ["1.0e9", "2.0e9"].iter().enumerate() {
        let deck =
            std::fs::read_to_string(dir.join(format!("out/runs/run_{k:04}/deck.toml"))).unwrap();
        let value: f64 = value.parse().unwrap();
        let density = peridyn::deck::LoadedDeck::from_str(&deck, Path::new("deck.toml"))
            .unwrap()
            .deck
            .material
            .density();
        assert_eq!(density, value, "run {k}");
    }
}

#[test]
fn bad_study_files_are_refused_at_their_key() {
    let dir = scratch("bad");
    let cases = [
        (
            "method = \"morris\"\n[[factors]]\nkey = \"material.stiffness\"\nmin = 1.0\nmax = 2.0\n",
            "factors[0].key: the deck has no number at `material.stiffness`",
        ),
        (
            "method = \"morris\"\n[[factors]]\nkey = \"material.type\"\nmin = 1.0\nmax = 2.0\n",
            "holds a string, not a number",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nvalues = [1.0, 2.0]\n[[fixed]]\nkey = \"solver.method\"\nvalue = 3.0\n",
            "fixed[0].key: `solver.method` holds a string, not a number",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nvalues = [1.0, 2.0]\n[[fixed]]\nkey = \"material.youngs_modulus\"\nvalue = \"ncg\"\n",
            "fixed[0].key: `material.youngs_modulus` holds a float, not a word",
        ),
        (
            "method = \"morris\"\n[[factors]]\nkey = \"material.density\"\nmin = 2.0\nmax = 1.0\n",
            "factors[0].max: expected max above min",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nmin = 1.0\nmax = 2.0\n",
            "a sweep factor takes `values`",
        ),
        (
            "method = \"morris\"\n[morris]\ntrajectories = 1\n[[factors]]\nkey = \"material.density\"\nmin = 1.0\nmax = 2.0\n",
            "morris.trajectories: r = 1 trajectories is too few",
        ),
        (
            "method = \"morris\"\n[[factors]]\nkey = \"discretization.spacing\"\nmin = 1.0e-3\nmax = 2.0e-3\n",
            "is also a factor",
        ),
        (
            "method = \"screening\"\n",
            "unknown variant `screening`",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nvalues = [1.0, 2.0]\nwith = [{ key = \"material.youngs_modulus\", values = [1.0e9] }]\n",
            "factors[0].with[0].values: expected one value per value of the factor (2), got 1",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nvalues = [1.0, 1.0]\nwith = [{ key = \"material.youngs_modulus\", values = [1.0e9, 2.0e9] }]\n",
            "factors[0].values: a factor with numbers set with it (`with`) needs distinct values",
        ),
        (
            "method = \"morris\"\n[[factors]]\nkey = \"material.density\"\nmin = 1.0\nmax = 2.0\nalso = [\"material.stiffness\"]\n",
            "factors[0].also[0]: the deck has no number at `material.stiffness`",
        ),
        (
            "method = \"morris\"\n[[factors]]\nkey = \"material.density\"\nmin = 1.0\nmax = 2.0\nalso = [\"material.density\"]\n",
            "factors[0].also[0]: `material.density` is varied twice",
        ),
        (
            "method = \"morris\"\n[[factors]]\nkey = \"material.density\"\nmin = 1.0\nmax = 2.0\nwith = [{ key = \"material.youngs_modulus\", values = [1.0e9] }]\n",
            "numbers set with a factor (`with`) are for method = \"sweep\"",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nvalues = [1.0, 2.0]\n[[outputs]]\nname = \"r\"\ncolumn = \"reaction_top_y\"\nreduce = \"final\"\nwithin = 1.0\n",
            "outputs[0].within: `within` (1) is used by reduce = \"time_of_max\" only",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nvalues = [1.0, 2.0]\n[[outputs]]\nname = \"v\"\nfile = \"crack_tip.csv\"\ncolumn = \"crack_x\"\nreduce = \"slope\"\nagainst = \"time\"\nbetween = [0.03, 0.004]\n",
            "outputs[0].between: expected [low, high], finite with low < high, got [0.03, 0.004]",
        ),
        (
            "method = \"sweep\"\n[[factors]]\nkey = \"material.density\"\nvalues = [1.0, 2.0]\n[[outputs]]\nname = \"v\"\nfile = \"crack_tip.csv\"\ncolumn = \"crack_x\"\nreduce = \"max\"\nbetween = [0.004, 0.03]\n",
            "outputs[0].between: `between` ([0.004, 0.03]) is used by reduce = \"slope\" or \"angle\" only",
        ),
    ];
    for (body, expected) in cases {
        let err = LoadedStudy::from_file(&study_file(&dir, body))
            .unwrap_err()
            .to_string();
        println!("{err}");
        assert!(err.contains(expected), "expected {expected:?} in {err}");
        assert!(
            err.contains("study.toml:"),
            "the study file is named: {err}"
        );
    }
    // An output the runs do not write stops the study after its first run, naming it.
    let body = MORRIS.to_string()
        + "[[outputs]]\nname = \"tip\"\nfile = \"crack_tip.csv\"\ncolumn = \"x\"\nreduce = \"final\"\n";
    let ls = LoadedStudy::from_file(&study_file(&dir, &body)).unwrap();
    let err = run_study(&ls, &options(&dir)).unwrap_err().to_string();
    assert!(
        err.contains("outputs[0] (`tip`): the run wrote no crack_tip.csv"),
        "{err}"
    );
    // A design point whose deck cannot run is refused before anything runs.
    let body = MORRIS.replace("min = 500.0", "min = -500.0");
    let ls = LoadedStudy::from_file(&study_file(&dir, &body)).unwrap();
    let err = run_study(&ls, &options(&dir)).unwrap_err().to_string();
    assert!(
        err.contains("cannot run") && err.contains("material.density = -"),
        "{err}"
    );
}

/// `peridyn check` takes a study file as well as a deck: the shipped study validates with
/// every run's deck, and a deck is still checked as a deck.
#[test]
fn check_takes_a_study_file_or_a_deck() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = env!("CARGO_BIN_EXE_peridyn");
    let check = |file: &str| {
        let out = std::process::Command::new(exe)
            .arg("check")
            .arg(root.join(file))
            .output()
            .unwrap();
        assert!(out.status.success(), "check {file}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let study = check("examples/seed004_morris_study.toml");
    assert!(study.contains("study is valid, 16 runs"), "{study}");
    assert!(LoadedStudy::is_study(
        &std::fs::read_to_string(root.join("examples/seed004_morris_study.toml")).unwrap()
    ));
    let deck = check("examples/quickstart.toml");
    assert!(deck.contains("deck is valid"), "{deck}");
    // A validation case is checked as a case: both its versions, each run's deck.
    let case = check("validation/seed002/ex_c_branching_du70.toml");
    assert!(case.contains("full: 3 runs"), "{case}");
    assert!(case.contains("reduced: 1 run,"), "{case}");
}
