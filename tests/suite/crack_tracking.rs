//! Crack-tip tracking during a run (`[analysis.crack_tip]`): a small notched PMMA plate under
//! tension (the quickstart's set-up at a quarter of its size) cracks from the notch tip in
//! mode I; the tracked tip must start at the notch, only move forward, and run below the
//! Rayleigh speed (a mode-I crack cannot outrun c_R; seed 002 measures 0.59 c_R). A deck
//! without `[analysis]` writes no tip files, and the files do not depend on the thread count.

use peridyn::deck::LoadedDeck;
use peridyn::run::{run, RunOptions, RunSummary};
use std::path::{Path, PathBuf};

/// Spacing Δx (m) and notch tip x (m) of the plate.
pub(super) const DX: f64 = 0.1e-3;
pub(super) const NOTCH_TIP: f64 = 2e-3;
const NOTCH_Y: f64 = 2e-3;

/// An 8 mm × 4 mm × 0.5 mm PMB plate, Δx = 0.1 mm, δ = 3.5 Δx, a 2 mm edge notch at
/// mid-height, grips (3 rows top and bottom) pulled apart at 1 m/s each: the crack starts at
/// about 15 µs and reaches x ≈ 7 mm by 22 µs (≈ 350 steps). `analysis` is appended verbatim.
fn plate(analysis: &str) -> LoadedDeck {
    plate_of(PMMA_PMB, analysis)
}

/// The PMMA of the quickstart, PMB with critical stretch from G0 = 300 J/m².
pub(super) const PMMA_PMB: &str = r#"
[material]
type = "pmb"
density = 1180.0
youngs_modulus = 3.09e9
fracture_energy = 300.0
"#;

/// `plate` with the `[material]` table given.
pub(super) fn plate_of(material: &str, analysis: &str) -> LoadedDeck {
    let text = format!(
        r#"
version = 2
dimension = 2
plane = "stress"
thickness = 0.5e-3
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = {{ type = "rectangle", min = [0.0, 0.0], max = [0.008, 0.004] }}
spacing = {DX}
horizon_ratio = 3.5
partial_volume = "hhb"

{material}

[[node_sets]]
name = "top"
region = {{ type = "rectangle", min = [-1.0, 0.0037], max = [1.0, 1.0] }}

[[node_sets]]
name = "bottom"
region = {{ type = "rectangle", min = [-1.0, -1.0], max = [1.0, 0.0003] }}

[[precracks]]
type = "segment"
start = [-0.001, {NOTCH_Y}]
end = [{NOTCH_TIP}, {NOTCH_Y}]

[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "y"
value = 1.0
time = {{ type = "ramp", duration = 1e-6 }}

[[boundary_conditions]]
set = "bottom"
kind = "velocity"
component = "y"
value = -1.0
time = {{ type = "ramp", duration = 1e-6 }}

[solver]
type = "explicit"
end_time = 22e-6

[output]
history_interval = 0
snapshots = 0
png = false

{analysis}
"#
    );
    LoadedDeck::from_str(&text, Path::new("crack_tracking.toml")).unwrap_or_else(|e| panic!("{e}"))
}

pub(super) const TRACK: &str = r#"
[analysis.crack_tip]
direction = [1.0, 0.0]
interval = 5
window = 5
"#;

pub(super) fn out_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("peridyn-crack-{tag}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    dir
}

pub(super) fn run_in(ld: &LoadedDeck, out: &Path, threads: usize) -> RunSummary {
    run(
        ld,
        &RunOptions {
            out_dir: out.to_path_buf(),
            threads: Some(threads),
            quiet: true,
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// A CSV as its header and rows of cells (text; an empty cell is an empty string).
pub(super) fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header = lines
        .next()
        .expect("a header")
        .split(',')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

pub(super) fn num(cell: &str) -> f64 {
    cell.parse()
        .unwrap_or_else(|e| panic!("{cell:?} is not a number: {e}"))
}

#[test]
fn tip_starts_at_the_notch_moves_forward_and_runs_below_the_rayleigh_speed() {
    let out = out_dir("plate");
    let summary = run_in(&plate(TRACK), &out, 2);

    let (header, rows) = read_csv(&out.join("crack_tip.csv"));
    assert_eq!(
        header,
        ["time", "step", "crack_x", "crack_y", "damage_dissipation"]
    );
    assert_eq!(rows[0][1], "0", "step 0 is sampled");
    assert_eq!(rows.last().unwrap()[1], summary.report.steps.to_string());
    let tips: Vec<(f64, f64, f64)> = rows
        .iter()
        .filter(|r| !r[2].is_empty())
        .map(|r| (num(&r[0]), num(&r[2]), num(&r[3])))
        .collect();
    assert!(
        tips.len() >= 20,
        "the crack runs: {} tip samples",
        tips.len()
    );
    // Once a tip exists, every later row has one (damage never heals).
    let first = rows.iter().position(|r| !r[2].is_empty()).unwrap();
    assert!(rows[first..].iter().all(|r| !r[2].is_empty()));

    let (t0, x0, y0) = tips[0];
    eprintln!("tip first seen at t = {t0:.4e} s, x = {x0:.4e} m, y = {y0:.4e} m");
    assert!(
        (x0 - NOTCH_TIP).abs() <= 0.5e-3 && (y0 - NOTCH_Y).abs() <= 0.5e-3,
        "the crack starts at the notch tip (2 mm, 2 mm), found ({x0}, {y0})"
    );
    for w in tips.windows(2) {
        assert!(w[1].1 >= w[0].1, "tip x went back: {:?} → {:?}", w[0], w[1]);
    }
    let (_, x_end, _) = *tips.last().unwrap();
    assert!(
        x_end - x0 >= 3e-3,
        "the crack runs at least 3 mm: {x0} → {x_end}"
    );
    // Mode I: the crack stays near the notch line.
    assert!(tips.iter().all(|t| (t.2 - NOTCH_Y).abs() <= 0.5e-3));

    let crack = summary.crack.as_ref().expect("a crack report");
    // Plane stress, E = 3.09 GPa, ν = 1/3 (PMB), ρ = 1180 kg/m³: c_R ≈ 911 m/s.
    assert!(
        (crack.rayleigh - 911.1).abs() < 0.5,
        "c_R = {}",
        crack.rayleigh
    );
    let (header, rows) = read_csv(&out.join("crack_speed.csv"));
    assert_eq!(header, ["branch", "time", "speed", "speed_over_rayleigh"]);
    assert_eq!(rows.len(), tips.len() - 5, "n − w speeds");
    let mut mean = 0.0;
    for r in &rows {
        assert_eq!(r[0], "crack");
        let (v, ratio) = (num(&r[2]), num(&r[3]));
        assert!(
            v > 0.0 && ratio < 1.0,
            "speed {v} m/s ({ratio} c_R) at t = {}",
            r[1]
        );
        assert!((ratio - v / crack.rayleigh).abs() < 1e-12);
        mean += v / rows.len() as f64;
    }
    let reported = crack.branches[0].mean_speed.unwrap();
    assert!((reported - mean).abs() <= 1e-9 * mean);
    // A running mode-I crack: well above creep, below c_R (seed 002: 0.59 c_R).
    assert!(
        (0.4..1.0).contains(&(mean / crack.rayleigh)),
        "mean speed {:.3} c_R",
        mean / crack.rayleigh
    );
    eprintln!(
        "mean crack speed {mean:.1} m/s = {:.3} c_R (c_R = {:.1} m/s)",
        mean / crack.rayleigh,
        crack.rayleigh
    );
    let text = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(text.contains("Rayleigh speed c_R = 911.1 m/s"), "{text}");
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn tip_files_do_not_depend_on_the_thread_count() {
    let ld = plate(TRACK);
    let (a, b) = (out_dir("threads-1"), out_dir("threads-2"));
    run_in(&ld, &a, 1);
    run_in(&ld, &b, 2);
    for file in ["crack_tip.csv", "crack_speed.csv"] {
        let (x, y) = (
            std::fs::read(a.join(file)).unwrap(),
            std::fs::read(b.join(file)).unwrap(),
        );
        assert!(x == y, "{file} differs between 1 and 2 threads");
    }
    std::fs::remove_dir_all(&a).ok();
    std::fs::remove_dir_all(&b).ok();
}

#[test]
fn no_analysis_table_writes_no_tip_files() {
    let ld = plate("");
    assert!(ld.deck.analysis.is_none());
    let out = out_dir("off");
    let summary = run_in(&ld, &out, 2);
    assert!(summary.crack.is_none());
    assert!(out.join("history.csv").exists());
    assert!(!out.join("crack_tip.csv").exists());
    assert!(!out.join("crack_speed.csv").exists());
    // The resolved deck has no [analysis] either, so it reads as the old format.
    let resolved = std::fs::read_to_string(out.join("resolved.toml")).unwrap();
    assert!(!resolved.contains("analysis"), "{resolved}");
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn resolved_deck_fills_in_the_defaults() {
    let ld = plate("[analysis.crack_tip]\ndirection = [1.0, 0.0]\n");
    let tip = ld
        .deck
        .analysis
        .as_ref()
        .unwrap()
        .crack_tip
        .as_ref()
        .unwrap();
    assert_eq!(
        (tip.threshold, tip.interval, tip.window),
        (0.35, 10, 30),
        "seed 000 App. 2 defaults"
    );
    assert!(tip.branches.is_empty());
    let text = toml::to_string(&ld.deck).unwrap();
    assert!(text.contains("[analysis.crack_tip]") && text.contains("window = 30"));
    // The resolved text reads back to the same settings.
    let again = LoadedDeck::from_str(&text, Path::new("resolved.toml")).unwrap();
    let tip2 = again.deck.analysis.unwrap().crack_tip.unwrap();
    assert_eq!(tip2.direction, vec![1.0, 0.0]);
    assert_eq!(tip2.threshold, 0.35);
}

#[test]
fn branches_get_their_own_columns_and_boxes() {
    let ld = plate(
        r#"
[analysis.crack_tip]
direction = [1.0, 0.0]
threshold = 0.4
interval = 5
window = 5

[[analysis.crack_tip.branches]]
name = "upper"
min = [0.0, 2.0e-3]
max = [8.0e-3, 4.0e-3]

[[analysis.crack_tip.branches]]
name = "lower"
min = [0.0, 0.0]
max = [8.0e-3, 2.0e-3]
"#,
    );
    let out = out_dir("branches");
    let summary = run_in(&ld, &out, 2);
    let (header, rows) = read_csv(&out.join("crack_tip.csv"));
    assert_eq!(
        header,
        [
            "time",
            "step",
            "upper_x",
            "upper_y",
            "lower_x",
            "lower_y",
            "damage_dissipation"
        ]
    );
    for r in rows.iter().filter(|r| !r[2].is_empty()) {
        assert!(num(&r[3]) >= 2.0e-3, "upper tip below its box: {r:?}");
    }
    for r in rows.iter().filter(|r| !r[4].is_empty()) {
        assert!(num(&r[5]) <= 2.0e-3, "lower tip above its box: {r:?}");
    }
    let names: Vec<&str> = summary
        .crack
        .as_ref()
        .unwrap()
        .branches
        .iter()
        .map(|b| b.name.as_str())
        .collect();
    assert_eq!(names, ["upper", "lower"]);
    let (_, speeds) = read_csv(&out.join("crack_speed.csv"));
    assert!(speeds.iter().all(|r| r[0] == "upper" || r[0] == "lower"));
    std::fs::remove_dir_all(&out).ok();
}

/// In 3D the crack has a front: each row with a tip also gives the mean of the damaged nodes
/// within one spacing of it (a 3 mm × 2 mm × 0.6 mm PMB block with a through notch, pulled hard).
#[test]
fn three_d_runs_write_the_front_mean() {
    let text = format!(
        r#"
version = 2
dimension = 3
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = {{ type = "box", min = [0.0, 0.0, 0.0], max = [0.003, 0.002, 0.0006] }}
spacing = {DX}
horizon_ratio = 3.0

{PMMA_PMB}

[[node_sets]]
name = "top"
region = {{ type = "box", min = [-1.0, 0.0017, -1.0], max = [1.0, 1.0, 1.0] }}

[[node_sets]]
name = "bottom"
region = {{ type = "box", min = [-1.0, -1.0, -1.0], max = [1.0, 0.0003, 1.0] }}

[[precracks]]
type = "rectangle"
origin = [-0.001, 0.001, -0.001]
edge1 = [0.002, 0.0, 0.0]
edge2 = [0.0, 0.0, 0.003]

[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "y"
value = 3.0
time = {{ type = "ramp", duration = 1e-6 }}

[[boundary_conditions]]
set = "bottom"
kind = "velocity"
component = "y"
value = -3.0
time = {{ type = "ramp", duration = 1e-6 }}

[solver]
type = "explicit"
end_time = 6e-6

[output]
history_interval = 0
snapshots = 0
png = false

[analysis.crack_tip]
direction = [1.0, 0.0, 0.0]
interval = 10
window = 3
"#
    );
    let ld =
        LoadedDeck::from_str(&text, Path::new("crack_3d.toml")).unwrap_or_else(|e| panic!("{e}"));
    let out = out_dir("3d");
    let summary = run_in(&ld, &out, 2);
    let (header, rows) = read_csv(&out.join("crack_tip.csv"));
    assert_eq!(
        header,
        [
            "time",
            "step",
            "crack_x",
            "crack_y",
            "crack_z",
            "crack_front_mean_x",
            "crack_front_mean_y",
            "crack_front_mean_z",
            "damage_dissipation"
        ]
    );
    let with_tip: Vec<&Vec<String>> = rows.iter().filter(|r| !r[2].is_empty()).collect();
    assert!(!with_tip.is_empty(), "the block cracks");
    for r in with_tip {
        let (tip_x, mean_x) = (num(&r[2]), num(&r[5]));
        assert!(
            mean_x <= tip_x + 1e-12 && mean_x >= tip_x - DX - 1e-12,
            "front mean x {mean_x} within one spacing behind the tip {tip_x}"
        );
    }
    // 3D: c_R from the 3D wave speeds (PMB ν = 1/4).
    let c_r = summary.crack.unwrap().rayleigh;
    assert!((c_r - 941.0).abs() < 0.5, "c_R = {c_r}");
    std::fs::remove_dir_all(&out).ok();
}
