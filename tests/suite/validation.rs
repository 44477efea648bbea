//! `peridyn validate`: the case files of `validation/` are valid and their ids unique; every
//! case's reduced version reproduces the paper's numbers within the reduced tolerances its
//! rows justify; the committed report is the one its measurements give; and the verdicts are
//! right on a case whose measurements are known.

use peridyn::deck::case::LoadedCase;
use peridyn::validation::figures::column_curves;
use peridyn::validation::measured::{Measured, MeasuredRun};
use peridyn::validation::others::Others;
use peridyn::validation::verdict::{judge_case, Status};
use peridyn::validation::{
    keep_full, load_all, report_texts, run_case, validate, Layout, ValidateOptions,
};
use std::path::{Path, PathBuf};

fn repository() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn layout() -> Layout {
    Layout::new(repository().join("validation"))
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("peridyn-validation-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The five seed papers, each with its reduced-case test.
const PAPERS: [&str; 5] = ["000", "001", "002", "003", "004"];

#[test]
fn every_case_file_is_valid_and_its_ids_unique() {
    let entries = load_all(&layout()).unwrap_or_else(|e| panic!("{e}"));
    let rows: usize = entries
        .iter()
        .map(|e| e.case.case.results.len() + e.case.case.not_run.len())
        .sum();
    println!("{} cases, {rows} rows", entries.len());
    // The reduced-case tests below run the cases paper by paper.
    for entry in &entries {
        let paper = entry.case.case.paper.as_str();
        assert!(
            PAPERS.contains(&paper),
            "{}: paper {paper} has no reduced-case test",
            entry.path
        );
    }
}

#[test]
fn the_committed_report_is_the_one_its_measurements_give() {
    let (report, readme) = report_texts(&layout()).unwrap();
    let committed = |f: &str| std::fs::read_to_string(repository().join(f)).unwrap();
    let stale = "is stale: run `peridyn validate --report` and commit it";
    assert!(
        report == committed("docs/validation.md"),
        "docs/validation.md {stale}"
    );
    assert!(
        readme.expect("README.md has the summary markers") == committed("README.md"),
        "README.md's validation summary {stale}"
    );
}

/// Runs the reduced version of every case of one paper and asserts its rows. One test per
/// paper: the test harness runs them beside the other tests (one test for all cases, about 5
/// minutes on 2 cores, started last in name order and ran alone at the end of the suite).
fn reduced_cases_of_paper(paper: &str) {
    let out = scratch(&format!("reduced-{paper}"));
    let opts = ValidateOptions {
        out_dir: out.clone(),
        reduced: true,
        first: None,
        last: None,
        threads: None,
        quiet: true,
    };
    // A case too slow for CI's budget says why (`not_in_ci`); it runs with `--reduced`. A
    // case with no measured row (only NOT RUN rows) has nothing to assert.
    let mut cases = Vec::new();
    for entry in load_all(&layout()).unwrap() {
        let case = &entry.case.case;
        if case.paper != paper {
            continue;
        }
        match &case.not_in_ci {
            Some(why) => println!("not in CI: {}: {why}", entry.path),
            None if case.results.is_empty() => {
                println!("not in CI: {}: no measured row", entry.path)
            }
            None => cases.push(entry.case.file.clone()),
        }
    }
    assert!(!cases.is_empty(), "no case of paper {paper} runs in CI");
    let done = validate(&cases, &layout(), &opts, true, None).unwrap_or_else(|e| panic!("{e}"));
    println!("{done}");
    assert_eq!(
        done.differing(),
        0,
        "rows outside their reduced tolerance:\n{done}"
    );
    assert!(
        done.report.is_none(),
        "a reduced validation leaves the report alone"
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn reduced_cases_of_seed_000_reproduce_the_papers_numbers() {
    reduced_cases_of_paper("000");
}

#[test]
fn reduced_cases_of_seed_001_reproduce_the_papers_numbers() {
    reduced_cases_of_paper("001");
}

#[test]
fn reduced_cases_of_seed_002_reproduce_the_papers_numbers() {
    reduced_cases_of_paper("002");
}

#[test]
fn reduced_cases_of_seed_003_reproduce_the_papers_numbers() {
    reduced_cases_of_paper("003");
}

#[test]
fn reduced_cases_of_seed_004_reproduce_the_papers_numbers() {
    reduced_cases_of_paper("004");
}

/// A case on the quickstart deck with a series of two values and rows of every kind.
fn case_file(dir: &Path) -> PathBuf {
    let deck = repository().join("examples/quickstart.toml");
    let text = format!(
        r#"version = 1
paper = "002"
title = "verdicts"
section = "§1"
deck = "{}"
[series]
key = "material.fracture_energy"
values = [300.0, 400.0]
[[outputs]]
name = "speed"
file = "crack_speed.csv"
column = "speed"
reduce = "mean"
[[outputs]]
name = "absent"
file = "crack_speed.csv"
column = "speed"
reduce = "max"
[[results]]
id = "near"
quantity = "a speed 4 % from the paper's"
source = "Fig. 1"
paper = 500.0
unit = "m/s"
output = "speed"
at = 300.0
tolerance = 0.05
why = "5 %"
[[results]]
id = "far"
quantity = "a speed 20 % from the paper's"
source = "Fig. 1"
paper = 500.0
output = "speed"
at = 400.0
abs_tolerance = 50.0
why = "50 m/s"
reduced_at = 300.0
reduced_abs_tolerance = 50.0
why_reduced = "the other run"
explanation = "it is slower"
[[results]]
id = "falls"
quantity = "slower with a larger G"
source = "Fig. 1"
output = "speed"
trend = "decreasing"
[[results]]
id = "rises"
quantity = "faster with a larger G"
source = "Fig. 1"
output = "speed"
trend = "increasing"
[[derived]]
name = "twice"
sum = ["speed", "speed"]
[[derived]]
name = "one"
ratio = ["twice", "twice"]
[[results]]
id = "sum"
quantity = "a derived output"
source = "Fig. 1"
paper = 1040.0
output = "twice"
at = 300.0
abs_tolerance = 0.0
why = "exact"
[[results]]
id = "ratio"
quantity = "a derived output of a derived output"
source = "Fig. 1"
paper = 1.0
output = "one"
at = 400.0
abs_tolerance = 0.0
why = "exact"
[[derived]]
name = "least"
min = ["twice", "speed", "absent"]
[[results]]
id = "least"
quantity = "the smallest of the outputs with a value"
source = "Fig. 1"
paper = 520.0
output = "least"
at = 300.0
abs_tolerance = 0.0
why = "exact"
[[not_run]]
id = "big"
quantity = "3D"
source = "Fig. 2"
needs = "more memory"
"#,
        deck.display().to_string().replace('\\', "/")
    );
    let path = dir.join("case.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// A finished run of the series value `series` whose output `speed` measured `speed`.
fn speed_run(series: f64, speed: f64) -> MeasuredRun {
    MeasuredRun {
        series: Some(series),
        status: "ok".into(),
        wall_minutes: 1.0,
        threads: None,
        outputs: [("speed".to_string(), speed)].into_iter().collect(),
    }
}

#[test]
fn verdicts_follow_the_tolerances_and_trends() {
    let dir = scratch("verdicts");
    let case = LoadedCase::from_file(&case_file(&dir)).unwrap();
    let measured = Measured {
        runs: vec![speed_run(300.0, 520.0), speed_run(400.0, 400.0)],
        ..Measured::default()
    };
    let rows = judge_case(&case, Some(&measured), false, &Others::none());
    let status: Vec<(&str, Status)> = rows.iter().map(|r| (r.id.as_str(), r.status)).collect();
    assert_eq!(
        status,
        [
            ("near", Status::Pass),
            ("far", Status::Differs),
            ("falls", Status::Pass),
            ("rises", Status::Differs),
            ("sum", Status::Pass),
            ("ratio", Status::Pass),
            ("least", Status::Pass),
            ("big", Status::NotRun),
        ]
    );
    assert_eq!(rows[1].note, "it is slower");
    assert!((rows[0].relative_difference().unwrap() - 0.04).abs() < 1e-12);
    // Never run: every result NOT RUN; at the reduced size no row has a tolerance.
    let never = judge_case(&case, None, false, &Others::none());
    assert!(never.iter().all(|r| r.status == Status::NotRun));
    let reduced = judge_case(&case, Some(&measured), true, &Others::none());
    assert_eq!(reduced[0].status, Status::Unchecked);
    assert_eq!(
        (reduced[1].status, reduced[1].measured),
        (Status::Pass, Some(520.0)),
        "reduced_at reads the other run"
    );
    assert_eq!(
        reduced[3].status,
        Status::Unchecked,
        "a trend without why_reduced"
    );
    // A finished run without a value (no crack where the paper has a speed) differs, with
    // the row's explanation; a failed run stays NOT RUN, with its status.
    let mut silent = measured.clone();
    silent.runs[1].outputs.clear();
    let rows = judge_case(&case, Some(&silent), false, &Others::none());
    assert_eq!((rows[1].status, rows[1].measured), (Status::Differs, None));
    assert_eq!(
        rows[1].note,
        "The run gave no value of `speed`. it is slower"
    );
    assert_eq!(
        rows[2].status,
        Status::Differs,
        "a trend over a run without value"
    );
    silent.runs[1].status = "failed: diverged".into();
    let rows = judge_case(&case, Some(&silent), false, &Others::none());
    assert_eq!(rows[1].status, Status::NotRun);
    assert_eq!(rows[1].note, "The run gave no value (failed: diverged).");
    assert_eq!(rows[2].status, Status::NotRun);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_case_files_are_refused_at_their_key() {
    let dir = scratch("bad");
    let good = std::fs::read_to_string(case_file(&dir)).unwrap();
    for (from, to, expect) in [
        (
            "at = 300.0",
            "at = 350.0",
            "results[0].at: 350 is not one of the series values",
        ),
        (
            "reduced_at = 300.0",
            "reduced_at = 350.0",
            "results[1].reduced_at: 350 is not one of the reduced series values",
        ),
        (
            "output = \"speed\"\nat = 400.0",
            "output = \"sped\"\nat = 400.0",
            "results[1].output: no output `sped`",
        ),
        (
            "why = \"5 %\"\n",
            "",
            "results[0].why: say why the tolerance",
        ),
        (
            "needs = \"more memory\"",
            "needs = \"\"",
            "not_run[0].needs",
        ),
        (
            "key = \"material.fracture_energy\"",
            "key = \"material.toughness\"",
            "series.key",
        ),
        (
            "values = [300.0, 400.0]",
            "values = [300.0, 400.0]\nwith = [{ key = \"material.density\", values = [1.0] }]",
            "series.with[0].values: expected one value per series value (2), got 1",
        ),
        (
            "values = [300.0, 400.0]",
            "values = [300.0, 400.0]\nwith = [{ key = \"material.fracture_energy\", values = [1.0, 2.0] }]",
            "series.with[0].key: `material.fracture_energy` is set twice",
        ),
        (
            "values = [300.0, 400.0]",
            "values = [300.0, 300.0]\nwith = [{ key = \"material.density\", values = [1.0, 2.0] }]",
            "series.values: a series with numbers set with it (`with`) needs distinct values",
        ),
        (
            "ratio = [\"twice\", \"twice\"]",
            "ratio = [\"twice\", \"thrice\"]",
            "derived[1].name: no output `thrice`",
        ),
        (
            "name = \"speed\"",
            "name = \"wall_minutes\"",
            "outputs[0].name: output `wall_minutes` is named twice (`wall_minutes` is every run's)",
        ),
        (
            "sum = [\"speed\", \"speed\"]",
            "sum = [\"speed\", \"speed\"]\nother_case = \"b.toml\"",
            "derived[0].other_case: `other_case` goes with `difference` or `ratio`",
        ),
        (
            "file = \"crack_speed.csv\"\ncolumn = \"speed\"\nreduce = \"mean\"",
            "file = \"resolved.toml\"",
            "outputs[0].key: a number of resolved.toml is read by key path",
        ),
        (
            "file = \"crack_speed.csv\"\ncolumn = \"speed\"\nreduce = \"mean\"",
            "file = \"resolved.toml\"\nkey = \"derived.horizon\"\nreduce = \"mean\"",
            "outputs[0].reduce: `reduce` applies to a CSV file",
        ),
        (
            "reduce = \"mean\"",
            "reduce = \"at_first_above\"\nthreshold = 1.0",
            "outputs[0].reduce: at_first_above needs `when_column`",
        ),
        (
            "reduce = \"mean\"",
            "reduce = \"angle\"\nagainst = \"time\"",
            "outputs[0].reduce: angle needs `first`",
        ),
        (
            "reduce = \"mean\"",
            "reduce = \"mean\"\nwhen_column = \"crack_x\"",
            "outputs[0].when_column: `when_column` is used by reduce = \"at_first_above\" only",
        ),
    ] {
        assert!(good.contains(from), "{from}");
        let path = dir.join("bad.toml");
        std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
        let e = LoadedCase::from_file(&path).unwrap_err().to_string();
        assert!(e.contains(expect), "expected `{expect}` in:\n{e}");
        assert!(e.contains("bad.toml:"), "{e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Two cases on the quickstart deck in a validation layout of their own: `a.toml` compares
/// its speed with `b.toml`'s, whose full measurement is committed, run by run in the order of
/// the two series (of other keys, whose values differ).
fn two_cases(root: &Path, b_values: &str) -> (Layout, LoadedCase) {
    two_cases_over(root, ("material.density", b_values))
}

/// As `two_cases`, `b.toml` sweeping the given key over the given values.
fn two_cases_over(root: &Path, (b_key, b_values): (&str, &str)) -> (Layout, LoadedCase) {
    let deck = repository()
        .join("examples/quickstart.toml")
        .display()
        .to_string()
        .replace('\\', "/");
    let seed = root.join("validation/seed002");
    std::fs::create_dir_all(&seed).unwrap();
    let case = |key: &str, series: &str, extra: &str| {
        format!(
            "version = 1\npaper = \"002\"\ntitle = \"t\"\nsection = \"§1\"\ndeck = \"{deck}\"\n\
             [series]\nkey = \"{key}\"\nvalues = {series}\n\
             [[outputs]]\nname = \"speed\"\nfile = \"crack_speed.csv\"\ncolumn = \"speed\"\n\
             reduce = \"mean\"\n{extra}"
        )
    };
    let a = case(
        "material.fracture_energy",
        "[300.0, 400.0]",
        "[[derived]]\nname = \"minus_b\"\ndifference = [\"speed\", \"speed\"]\n\
         other_case = \"b.toml\"\n\
         [[results]]\nid = \"below\"\nquantity = \"q\"\nsource = \"s\"\noutput = \"minus_b\"\n\
         trend = \"below\"\n\
         [[results]]\nid = \"above\"\nquantity = \"q\"\nsource = \"s\"\npaper = 450.0\n\
         output = \"speed\"\ntrend = \"above\"\n",
    );
    std::fs::write(seed.join("a.toml"), a).unwrap();
    std::fs::write(seed.join("b.toml"), case(b_key, b_values, "")).unwrap();
    let layout = Layout::new(root.join("validation"));
    let b = Measured {
        runs: vec![
            speed_run(30.0, 500.0),
            speed_run(40.0, 600.0),
            speed_run(300.0, 470.0),
            speed_run(400.0, 580.0),
        ],
        ..Measured::default()
    };
    let case_b = LoadedCase::from_file(&seed.join("b.toml")).unwrap();
    b.write(&layout.measured_file(&case_b)).unwrap();
    let case_a = LoadedCase::from_file(&seed.join("a.toml")).unwrap();
    (layout, case_a)
}

/// `a.toml`'s comparison with `b.toml`, run by run.
fn minus_b(a: &LoadedCase, others: &Others, measured: &Measured) -> Vec<f64> {
    let values = measured.runs.iter().map(|r| r.values(a, others)["minus_b"]);
    values.collect()
}

#[test]
fn a_comparison_across_cases_pairs_the_runs_of_the_two_series() {
    let root = scratch("across");
    let (layout, a) = two_cases(&root, "[30.0, 40.0]");
    let others = Others::load(&a, &layout).unwrap_or_else(|e| panic!("{e}"));
    // The first runs pair (300 with 30), the second ones (400 with 40).
    let measured = Measured {
        runs: vec![speed_run(300.0, 480.0), speed_run(400.0, 590.0)],
        ..Measured::default()
    };
    let values = minus_b(&a, &others, &measured);
    assert_eq!(values, [-20.0, -10.0]);
    let rows = judge_case(&a, Some(&measured), false, &others);
    assert_eq!(rows[0].status, Status::Pass, "{:?}", rows[0]);
    assert_eq!(rows[0].values, [-20.0, -10.0]);
    assert!(
        rows[0]
            .note
            .contains("Second value from validation/measured/seed002-b.toml"),
        "{}",
        rows[0].note
    );
    assert_eq!(rows[0].tolerance, "below 0 at every run");
    // 480 and 590 above 450: a bound at the paper's level holds at every run.
    assert_eq!(rows[1].status, Status::Pass);
    assert_eq!(rows[1].tolerance, "above 450 at every run");
    // One run above the other case's: the difference is not below 0 at every run.
    let crossing = Measured {
        runs: vec![speed_run(300.0, 480.0), speed_run(400.0, 610.0)],
        ..Measured::default()
    };
    let rows = judge_case(&a, Some(&crossing), false, &others);
    assert_eq!(rows[0].status, Status::Differs);
    // One run at 440, below the bound of 450.
    let low = Measured {
        runs: vec![speed_run(300.0, 440.0), speed_run(400.0, 590.0)],
        ..Measured::default()
    };
    assert_eq!(
        judge_case(&a, Some(&low), false, &others)[1].status,
        Status::Differs
    );
    // At the reduced size there is nothing to compare with: no value, nothing asserted.
    let reduced = judge_case(&a, Some(&measured), true, &Others::none());
    assert_eq!(reduced[0].status, Status::NotRun);
    let _ = std::fs::remove_dir_all(&root);
}

/// A bound may be read at one series value (the paper's grid, where coarser ones are not the
/// paper's claim); a direction or a constant may not.
#[test]
fn a_bound_read_at_one_series_value_ignores_the_other_runs() {
    let root = scratch("bound-at");
    let (_, a) = two_cases(&root, "[30.0, 40.0]");
    let path = root.join("validation/seed002/a.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replacen("trend = \"above\"\n", "trend = \"above\"\nat = 400.0\n", 1),
    )
    .unwrap();
    let a_at = LoadedCase::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
    // 440 at 300 would break the bound of 450 at every run; at 400 alone it holds.
    let low = Measured {
        runs: vec![speed_run(300.0, 440.0), speed_run(400.0, 590.0)],
        ..Measured::default()
    };
    let row = &judge_case(&a_at, Some(&low), false, &Others::none())[1];
    assert_eq!(row.status, Status::Pass, "{row:?}");
    assert_eq!(
        (row.values.as_slice(), row.tolerance.as_str()),
        ([590.0].as_slice(), "above 450")
    );
    assert_eq!(
        judge_case(&a, Some(&low), false, &Others::none())[1].status,
        Status::Differs
    );
    // The value read is not run: the row is not run, whatever the other runs say.
    let other = Measured {
        runs: vec![speed_run(300.0, 440.0)],
        ..Measured::default()
    };
    let row = &judge_case(&a_at, Some(&other), false, &Others::none())[1];
    assert_eq!(row.status, Status::NotRun, "{row:?}");
    assert!(
        row.note.contains("The series value 400 is not run"),
        "{}",
        row.note
    );
    // A constant compares runs: `at` is refused.
    std::fs::write(
        &path,
        text.replacen(
            "trend = \"above\"\n",
            "trend = \"constant\"\nat = 400.0\ntolerance = 0.1\n",
            1,
        ),
    )
    .unwrap();
    let e = LoadedCase::from_file(&path).unwrap_err().to_string();
    assert!(
        e.contains("a direction or a constant reads every run of the series"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// A trend may read some of the series' runs (the paper's own horizons, not coarser ones).
#[test]
fn a_trend_among_some_series_values_ignores_the_others() {
    let root = scratch("among");
    let (_, _) = two_cases(&root, "[30.0, 40.0]");
    let path = root.join("validation/seed002/a.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("values = [300.0, 400.0]", "values = [300.0, 350.0, 400.0]");
    let case = |trend: &str| {
        std::fs::write(
            &path,
            text.replacen("trend = \"above\"\n", &format!("{trend}\n"), 1),
        )
        .unwrap();
        LoadedCase::from_file(&path)
    };
    let a = case("trend = \"constant\"\ntolerance = 0.05\nwhy = \"w\"\namong = [350.0, 400.0]")
        .unwrap_or_else(|e| panic!("{e}"));
    // 500 at 300 is far from the others, but only 350 and 400 are read: 590 and 600.
    let measured = Measured {
        runs: vec![
            speed_run(300.0, 500.0),
            speed_run(350.0, 590.0),
            speed_run(400.0, 600.0),
        ],
        ..Measured::default()
    };
    let row = &judge_case(&a, Some(&measured), false, &Others::none())[1];
    assert_eq!(
        (row.status, row.values.as_slice()),
        (Status::Pass, [590.0, 600.0].as_slice())
    );
    for (bad, expect) in [
        (
            "trend = \"constant\"\ntolerance = 0.05\nwhy = \"w\"\namong = [350.0, 410.0]",
            "410 is not one of the series values",
        ),
        (
            "trend = \"constant\"\ntolerance = 0.05\nwhy = \"w\"\namong = [350.0]",
            "two or more for a direction or a constant",
        ),
    ] {
        let e = case(bad).unwrap_err().to_string();
        assert!(
            e.contains(expect) && e.contains("results[1].among"),
            "expected `{expect}` in:\n{e}"
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// A run measured alone at the end of its series (`--last 1`, the earlier values not run) is
/// drawn from its own folder, numbered by its place in the series.
#[test]
fn a_curve_is_read_from_the_folder_of_its_place_in_the_series() {
    let root = scratch("curve-folder");
    let (_, a) = two_cases(&root, "[30.0, 40.0]");
    let path = root.join("validation/seed002/a.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("values = [300.0, 400.0]", "values = [300.0, 350.0, 400.0]");
    let plot = "[[plots]]\nname = \"p\"\ntitle = \"t\"\n\
        x = { file = \"history.csv\", column = \"time\", label = \"t\" }\n\
        y = { file = \"history.csv\", column = \"speed\", label = \"v\" }\n";
    std::fs::write(
        &path,
        text.replace("[[results]]", &format!("{plot}[[results]]")),
    )
    .unwrap();
    let a_three = LoadedCase::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_ne!(a.case.plots.len(), a_three.case.plots.len());
    let runs = root.join("runs");
    for (k, speed) in [(0, 1.0), (2, 3.0)] {
        let dir = runs.join(format!("run_{k:04}"));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("history.csv"),
            format!("time,speed\n0,{speed}\n1,{speed}\n"),
        )
        .unwrap();
    }
    let measured = Measured {
        size: "full".into(),
        runs: vec![speed_run(300.0, 0.0), speed_run(400.0, 0.0)],
        ..Measured::default()
    };
    let curves = column_curves(&a_three, &a_three.case.plots[0], &measured, &runs).unwrap();
    let speeds: Vec<f64> = curves.iter().map(|(_, points)| points[0].1).collect();
    assert_eq!(speeds, [1.0, 3.0], "{curves:?}");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_comparison_across_cases_refuses_series_it_cannot_pair() {
    let root = scratch("across-bad");
    let (layout, a) = two_cases(&root, "[30.0]");
    let e = Others::load(&a, &layout).unwrap_err();
    assert!(e.contains("a.toml: derived[0].other_case"), "{e}");
    assert!(
        e.contains("this case has 2 full values and validation/seed002/b.toml has 1"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Two cases sweeping the same key (2D and 3D at one grid spacing) pair their runs by its
/// value, whatever the series' lengths and order; a value the other case lacks is refused.
#[test]
fn a_comparison_across_cases_of_the_same_key_pairs_the_runs_by_value() {
    let root = scratch("across-key");
    let b = ("material.fracture_energy", "[400.0, 200.0, 300.0]");
    let (layout, a) = two_cases_over(&root, b);
    let others = Others::load(&a, &layout).unwrap_or_else(|e| panic!("{e}"));
    let measured = Measured {
        runs: vec![speed_run(300.0, 480.0), speed_run(400.0, 590.0)],
        ..Measured::default()
    };
    let values = minus_b(&a, &others, &measured);
    // 300 with b's 300 (470), 400 with b's 400 (580).
    assert_eq!(values, [10.0, 10.0]);
    let (layout, a) = two_cases_over(&root, ("material.fracture_energy", "[300.0, 500.0]"));
    let e = Others::load(&a, &layout).unwrap_err();
    assert!(
        e.contains("validation/seed002/b.toml has no full run at 400"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Every run has its wall time as an output: one case's cost over another's (seed 003's
/// Table 3) is a ratio across cases of `wall_minutes`, paired run by run.
#[test]
fn a_wall_time_ratio_across_cases() {
    let root = scratch("across-wall");
    let (layout, _) = two_cases(&root, "[30.0, 40.0]");
    let a = root.join("validation/seed002/a.toml");
    let text = std::fs::read_to_string(&a).unwrap();
    let start = text.find("[[derived]]").unwrap();
    let costlier = format!(
        "{}[[derived]]\nname = \"cost\"\nratio = [\"wall_minutes\", \"wall_minutes\"]\n\
         other_case = \"b.toml\"\n",
        &text[..start]
    );
    std::fs::write(&a, costlier).unwrap();
    let a = LoadedCase::from_file(&a).unwrap_or_else(|e| panic!("{e}"));
    let others = Others::load(&a, &layout).unwrap_or_else(|e| panic!("{e}"));
    // b's runs took 1 minute each (speed_run); a's 2.5 and 0.5.
    let measured = Measured {
        runs: vec![
            MeasuredRun {
                wall_minutes: 2.5,
                ..speed_run(300.0, 480.0)
            },
            MeasuredRun {
                wall_minutes: 0.5,
                ..speed_run(400.0, 590.0)
            },
        ],
        ..Measured::default()
    };
    let cost: Vec<f64> = measured
        .runs
        .iter()
        .map(|r| r.values(&a, &others)["cost"])
        .collect();
    assert_eq!(cost, [2.5, 0.5]);
    let _ = std::fs::remove_dir_all(&root);
}

/// A curve plot of runs measured by an earlier invocation whose folders are not here (another
/// results folder) leaves their curves out and is drawn; a folder that is here but misses the
/// plot's file is an error naming it.
#[test]
fn a_plot_leaves_out_runs_whose_folders_are_not_here() {
    let dir = scratch("figures");
    let plot = "[[plots]]\nname = \"energy\"\ntitle = \"t\"\nx = { column = \"time\", label = \"t\" }\ny = { column = \"kinetic_energy\", label = \"E\" }\n";
    let path = case_file(&dir);
    let text = std::fs::read_to_string(&path).unwrap() + plot;
    std::fs::write(&path, text).unwrap();
    let case = LoadedCase::from_file(&path).unwrap();
    let measured = Measured {
        runs: vec![speed_run(300.0, 520.0), speed_run(400.0, 400.0)],
        ..Measured::default()
    };
    let runs = dir.join("runs");
    std::fs::create_dir_all(runs.join("run_0000")).unwrap();
    std::fs::write(
        runs.join("run_0000/history.csv"),
        "time,kinetic_energy\n0,0\n1,2\n",
    )
    .unwrap();
    let draw = || {
        let figures = dir.join("figures");
        peridyn::validation::figures::draw(&case, &measured, &Others::none(), &runs, &figures)
    };
    let drawn = draw().unwrap();
    assert_eq!(drawn.len(), 1);
    assert!(drawn[0].exists());
    std::fs::create_dir_all(runs.join("run_0001")).unwrap();
    let err = draw().unwrap_err();
    assert!(err.contains("run_0001/history.csv"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes the full measurement of case `a` as an earlier invocation on 2 threads left it:
/// one run, at 300.
fn measured_on_two_threads(layout: &Layout, case: &LoadedCase) -> Measured {
    let earlier = Measured {
        case: "a".into(),
        size: "full".into(),
        wall_minutes: 1.0,
        threads: 2,
        runs: vec![speed_run(300.0, 480.0)],
    };
    earlier.write(&layout.measured_file(case)).unwrap();
    earlier
}

/// A case continued by an invocation with another thread count keeps, for each run it found
/// finished, the threads that run was measured on, and the report names both counts.
#[test]
fn a_continued_case_keeps_the_threads_each_run_was_measured_on() {
    let root = scratch("threads");
    let (layout, case) = two_cases(&root, "[30.0, 40.0]");
    let earlier = measured_on_two_threads(&layout, &case);
    let now = Measured {
        threads: 1,
        wall_minutes: 2.0,
        runs: vec![speed_run(300.0, 480.0), speed_run(400.0, 590.0)],
        ..earlier.clone()
    };
    let opts = ValidateOptions {
        out_dir: root.join("results"),
        reduced: false,
        first: None,
        last: None,
        threads: Some(1),
        quiet: true,
    };
    keep_full(&case, &now, &layout, &opts).unwrap();
    let kept = Measured::read(&layout.measured_file(&case))
        .unwrap()
        .unwrap();
    assert_eq!(kept.run_threads().collect::<Vec<_>>(), vec![2, 1]);
    let (report, _) = report_texts(&layout).unwrap();
    assert!(
        report.contains("2 runs in 2 min on 1-2 threads"),
        "{report}"
    );
    // Written again by a one-thread invocation that ran nothing but read one output more
    // from the runs' folders, it keeps both counts.
    let mut reread = kept.clone();
    for run in &mut reread.runs {
        run.threads = None;
        run.outputs.insert("slope".into(), 1.0);
    }
    keep_full(&case, &reread, &layout, &opts).unwrap();
    let again = Measured::read(&layout.measured_file(&case))
        .unwrap()
        .unwrap();
    assert_eq!(again.run_threads().collect::<Vec<_>>(), vec![2, 1]);
    let _ = std::fs::remove_dir_all(&root);
}

/// `--last 1` runs only the finest value of a series: the coarser run is neither run nor
/// measured again, and the measurement keeps what an earlier invocation measured for it.
#[test]
fn the_last_values_run_alone_and_the_others_keep_their_measurement() {
    let root = scratch("last");
    let (layout, case) = two_cases(&root, "[30.0, 40.0]");
    let path = case.file.clone();
    let small = "[[fixed]]\nkey = \"discretization.spacing\"\nvalue = 4e-4\n";
    let text = std::fs::read_to_string(&path).unwrap() + small;
    std::fs::write(&path, text).unwrap();
    let case = LoadedCase::from_file(&path).unwrap();
    measured_on_two_threads(&layout, &case);
    let opts = ValidateOptions {
        out_dir: root.join("results"),
        reduced: false,
        first: None,
        last: Some(1),
        threads: Some(1),
        quiet: true,
    };
    run_case(&case, &layout, &opts, None, &mut |m| {
        keep_full(&case, m, &layout, &opts)
    })
    .unwrap();
    let runs = root.join("results/seed002-a/runs");
    assert!(!runs.join("run_0000").exists(), "the coarser run ran");
    assert!(runs.join("run_0001/history.csv").exists());
    let kept = Measured::read(&layout.measured_file(&case))
        .unwrap()
        .unwrap();
    let series: Vec<_> = kept.runs.iter().map(|r| r.series).collect();
    assert_eq!(series, vec![Some(300.0), Some(400.0)]);
    assert_eq!(kept.runs[0].outputs["speed"], 480.0);
    assert_eq!(kept.runs[1].status, "ok");
    let _ = std::fs::remove_dir_all(&root);
}

/// A screening case reads its Morris study's statistics as one run's outputs: on the
/// quasi-static tension plate the reaction grows with the modulus and does not see the
/// density (a quasi-static run never reads it), so the modulus ranks first, the density's
/// μ* is nothing beside it, and the runs' reactions spread.
#[test]
fn a_screening_case_ranks_the_factors_of_its_study() {
    let root = scratch("screening");
    let seed = root.join("validation/seed004");
    std::fs::create_dir_all(seed.join("decks")).unwrap();
    let deck = repository()
        .join("examples/quasi_static_tension.toml")
        .display()
        .to_string()
        .replace('\\', "/");
    let study = format!(
        "version = 1\ndeck = \"{deck}\"\nmethod = \"morris\"\n\
         [morris]\ntrajectories = 2\npool = 4\nlevels = 4\nseed = 5\n\
         [[fixed]]\nkey = \"discretization.spacing\"\nvalue = 2.0e-3\n\
         [[factors]]\nkey = \"material.youngs_modulus\"\nmin = 1.0e9\nmax = 2.0e9\n\
         [[factors]]\nkey = \"material.density\"\nmin = 500.0\nmax = 2000.0\n\
         [[outputs]]\nname = \"reaction\"\ncolumn = \"reaction_top_y\"\nreduce = \"final\"\n"
    );
    std::fs::write(seed.join("decks/study.toml"), study).unwrap();
    let case = "version = 1\npaper = \"004\"\ntitle = \"t\"\nsection = \"§3\"\n\
        screening = \"decks/study.toml\"\n\
        [[derived]]\nname = \"idle\"\n\
        ratio = [\"mu_star.reaction.material.density\", \"mu_star.reaction.material.youngs_modulus\"]\n\
        [[derived]]\nname = \"spread\"\ndifference = [\"max.reaction\", \"min.reaction\"]\n\
        [[results]]\nid = \"first\"\nquantity = \"q\"\nsource = \"s\"\npaper = 1.0\n\
        output = \"rank.reaction.material.youngs_modulus\"\nabs_tolerance = 0.5\nwhy = \"a rank\"\n\
        [[results]]\nid = \"idle\"\nquantity = \"q\"\nsource = \"s\"\npaper = 1e-9\n\
        output = \"idle\"\ntrend = \"below\"\n\
        [[results]]\nid = \"spread\"\nquantity = \"q\"\nsource = \"s\"\noutput = \"spread\"\n\
        trend = \"above\"\n";
    std::fs::write(seed.join("screen.toml"), case).unwrap();
    let layout = Layout::new(root.join("validation"));
    let case = LoadedCase::from_file(&seed.join("screen.toml")).unwrap_or_else(|e| panic!("{e}"));
    let opts = ValidateOptions {
        out_dir: root.join("results"),
        reduced: false,
        first: None,
        last: None,
        threads: Some(2),
        quiet: true,
    };
    let measured = run_case(&case, &layout, &opts, None, &mut |m| {
        keep_full(&case, m, &layout, &opts)
    })
    .unwrap();
    assert_eq!(measured.runs.len(), 1);
    let run = &measured.runs[0];
    assert_eq!(run.status, "ok");
    assert_eq!(run.outputs["rank.reaction.material.density"], 2.0);
    let rows = judge_case(&case, Some(&measured), false, &Others::none());
    for row in &rows {
        assert_eq!(row.status, Status::Pass, "{row:?}\n{:?}", run.outputs);
    }
    // The measurement is kept and read back like any case's.
    let kept = Measured::read(&layout.measured_file(&case))
        .unwrap()
        .unwrap();
    assert_eq!(&kept.runs[0], run);
    // A screening case with a deck of its own, or reading a sweep, is refused at its key.
    let text = std::fs::read_to_string(seed.join("screen.toml")).unwrap();
    let sweep = std::fs::read_to_string(seed.join("decks/study.toml"))
        .unwrap()
        .replace("method = \"morris\"", "method = \"sweep\"")
        .replace(
            "[morris]\ntrajectories = 2\npool = 4\nlevels = 4\nseed = 5\n",
            "",
        )
        .replace("min = 1.0e9\nmax = 2.0e9", "values = [1.0e9]")
        .replace("min = 500.0\nmax = 2000.0", "values = [500.0]");
    std::fs::write(seed.join("decks/sweep.toml"), sweep).unwrap();
    for (from, to, expect) in [
        (
            "section = \"§3\"\n",
            format!("section = \"§3\"\ndeck = \"{deck}\"\n"),
            "deck: a screening case reads its study's runs: remove `deck`",
        ),
        (
            "decks/study.toml",
            "decks/sweep.toml".to_string(),
            "screening: decks/sweep.toml is a sweep; a screening case reads a Morris study",
        ),
    ] {
        let path = seed.join("bad.toml");
        std::fs::write(&path, text.replacen(from, &to, 1)).unwrap();
        let e = LoadedCase::from_file(&path).unwrap_err().to_string();
        assert!(
            e.contains(expect) && e.contains("bad.toml:"),
            "expected `{expect}` in:\n{e}"
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}
