//! `[analysis.crack_path]` in a run: the mode-I crack of the notched plate of
//! `crack_tracking` runs along the notch line y = 2 mm, so its path lies within a grid spacing
//! of that line, a reference shifted by 0.5 mm reads 0.5 mm away, and no fork is found; the
//! table is refused in 3D. `[analysis.crack_crossings]` on the same run: a line across the
//! crack's path is crossed once, on the notch line, from the time the tip passes it; a line
//! ahead of where the crack stops is not crossed.

use super::crack_tracking::{num, out_dir, plate_of, read_csv, run_in, DX, PMMA_PMB, TRACK};
use peridyn::deck::LoadedDeck;
use std::path::Path;

#[test]
fn a_straight_crack_follows_the_notch_line_and_does_not_fork() {
    for (offset, tag) in [(0.0, "on"), (0.5e-3, "shifted")] {
        let analysis = format!(
            "{TRACK}\n[analysis.crack_path]\nreference = [[0.002, {y}], [0.008, {y}]]\n",
            y = 2e-3 + offset
        );
        let dir = out_dir(&format!("path-{tag}"));
        let summary = run_in(&plate_of(PMMA_PMB, &analysis), &dir, 2);
        let (header, points) = read_csv(&dir.join("crack_path.csv"));
        assert_eq!(header, ["x", "y", "length"]);
        assert!(points.len() >= 10, "{} path points", points.len());
        // The length along a straight path is its span (each bin's point within a spacing
        // of the line adds at most a few parts in a thousand).
        let (first, last) = (&points[0], &points[points.len() - 1]);
        let span = num(&last[0]) - num(&first[0]);
        let length = num(&last[2]);
        assert!(
            num(&first[2]) == 0.0 && length >= span && length < 1.02 * span,
            "length {length} m along a path spanning {span} m"
        );
        for p in &points {
            assert!(
                (num(&p[1]) - 2e-3).abs() < DX,
                "path point {p:?} off the notch line"
            );
        }
        let report = summary.crack_path.expect("a path report");
        let c = report.comparison.expect("the path overlaps the reference");
        assert!(
            (c.mean_distance - offset).abs() < 0.5 * DX,
            "mean distance {} for a reference {offset} m away",
            c.mean_distance
        );
        assert!(report.forks.is_empty(), "forks {:?}", report.forks);
        let (header, rows) = read_csv(&dir.join("branching.csv"));
        assert_eq!(header[..5], ["time", "step", "fork", "x", "y"]);
        assert!(rows.is_empty());
        assert!(dir.join("crack_path_comparison.csv").is_file());
        std::fs::remove_dir_all(&dir).ok();
    }
}

/// With a region, only the damaged nodes inside it make the path: the crack cut off at
/// x = 4 mm ends there, shorter by what lies beyond (the crack reaches x ≈ 5.7 mm).
#[test]
fn a_region_keeps_the_path_inside_it() {
    let path = |region: &str, tag: &str| {
        let analysis = format!("{TRACK}\n[analysis.crack_path]\n{region}\n");
        let dir = out_dir(&format!("path-region-{tag}"));
        run_in(&plate_of(PMMA_PMB, &analysis), &dir, 2);
        let (_, points) = read_csv(&dir.join("crack_path.csv"));
        let _ = std::fs::remove_dir_all(&dir);
        let xs: Vec<f64> = points.iter().map(|p| num(&p[0])).collect();
        let length = num(&points[points.len() - 1][2]);
        (xs, length)
    };
    let (whole, whole_length) = path("", "whole");
    let region = "region = { type = \"rectangle\", min = [0.0, 0.0], max = [0.004, 0.004] }";
    let (cut, cut_length) = path(region, "cut");
    let largest = |xs: &[f64]| xs.iter().cloned().fold(f64::MIN, f64::max);
    assert!(
        largest(&whole) > 5e-3,
        "the crack runs past x = 5 mm: {whole:?}"
    );
    assert!(largest(&cut) < 4e-3, "{cut:?}");
    assert!(
        cut_length < whole_length - 1e-3,
        "{cut_length} m inside the region against {whole_length} m"
    );
}

#[test]
fn the_crack_crosses_a_line_across_its_path_once_from_when_the_tip_passes_it() {
    let analysis = format!(
        "{TRACK}
[analysis.crack_crossings]
interval = 20
[[analysis.crack_crossings.lines]]
name = \"across\"
from = [0.004, 0.0]
to = [0.004, 0.004]
[[analysis.crack_crossings.lines]]
name = \"ahead\"
from = [0.0079, 0.0]
to = [0.0079, 0.004]
"
    );
    let dir = out_dir("crossings");
    run_in(&plate_of(PMMA_PMB, &analysis), &dir, 2);
    let (header, rows) = read_csv(&dir.join("crack_crossings.csv"));
    assert_eq!(header, ["time", "step", "across", "ahead"]);
    let across: Vec<f64> = rows.iter().map(|r| num(&r[2])).collect();
    assert_eq!(across.first(), Some(&0.0), "no crack crosses at the start");
    assert_eq!(
        across.last(),
        Some(&1.0),
        "one crack at the end: {across:?}"
    );
    assert!(
        across.windows(2).all(|w| w[0] <= w[1]),
        "a crossing, once there, stays: {across:?}"
    );
    assert!(
        rows.iter().all(|r| num(&r[3]) == 0.0),
        "nothing reaches x = 7.9 mm"
    );
    // The tip passes x = 4 mm no later than the first count of one crossing.
    let (_, tips) = read_csv(&dir.join("crack_tip.csv"));
    let first_crossed = rows.iter().find(|r| num(&r[2]) == 1.0).map(|r| num(&r[0]));
    let first_past = tips
        .iter()
        .find(|r| !r[2].is_empty() && num(&r[2]) >= 0.004)
        .map(|r| num(&r[0]));
    assert!(
        matches!((first_past, first_crossed), (Some(a), Some(b)) if a <= b),
        "tip past x = 4 mm at {first_past:?}, crossing counted at {first_crossed:?}"
    );
    let (header, points) = read_csv(&dir.join("crack_crossing_points.csv"));
    assert_eq!(header, ["line", "crossing", "x", "y", "along", "nodes"]);
    assert_eq!(points.len(), 1);
    assert_eq!(num(&points[0][2]), 0.004);
    assert!((num(&points[0][3]) - 2e-3).abs() < DX, "{points:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A small PMB block, 2D or 3D, with the analysis tables given.
fn small_deck(dimension: usize, analysis: &str) -> String {
    let shape = match dimension {
        2 => r#"{ type = "rectangle", min = [0.0, 0.0], max = [0.004, 0.004] }"#,
        _ => r#"{ type = "box", min = [0.0, 0.0, 0.0], max = [0.002, 0.002, 0.002] }"#,
    };
    format!(
        r#"
version = 2
dimension = {dimension}

[discretization]
type = "lattice"
shape = {shape}
spacing = 0.5e-3
horizon_ratio = 3.0

[material]
type = "pmb"
density = 1180.0
youngs_modulus = 3.09e9
fracture_energy = 300.0

[solver]
type = "explicit"
end_time = 1e-7

{analysis}
"#
    )
}

#[test]
fn crack_paths_are_refused_in_3d() {
    let text = small_deck(3, "[analysis.crack_path]");
    let Err(err) = LoadedDeck::from_str(&text, Path::new("path3d.toml")) else {
        panic!("refused")
    };
    let err = err.to_string();
    assert!(
        err.contains("analysis.crack_path") && err.contains("2D"),
        "{err}"
    );
}

#[test]
fn crossing_lines_that_cannot_be_counted_are_refused_with_their_keys() {
    let deck = |dimension: usize, lines: &str| {
        small_deck(dimension, &format!("[analysis.crack_crossings]\n{lines}"))
    };
    let error = |text: String| match LoadedDeck::from_str(&text, Path::new("crossings.toml")) {
        Err(err) => err.to_string(),
        Ok(_) => panic!("refused: {text}"),
    };
    let err = error(deck(
        2,
        r#"
[[analysis.crack_crossings.lines]]
name = "a"
from = [0.0, 0.002]
to = [0.004, 0.002]
[[analysis.crack_crossings.lines]]
name = "a"
from = [0.001, 0.001]
to = [0.001, 0.001]
width = -1.0
[[analysis.crack_crossings.lines]]
name = "step"
from = [0.0, 0.0, 0.0]
to = [0.004, 0.0]
"#,
    ));
    for expected in [
        "analysis.crack_crossings.lines[1].name",
        "defined twice",
        "analysis.crack_crossings.lines[1].to",
        "two distinct ends",
        "analysis.crack_crossings.lines[1].width",
        "analysis.crack_crossings.lines[2].name",
        "analysis.crack_crossings.lines[2].from",
        "expected 2 components",
    ] {
        assert!(err.contains(expected), "{expected:?} in {err}");
    }
    let err = error(deck(2, "threshold = 0.2"));
    assert!(err.contains("at least one line"), "{err}");
    let err = error(deck(
        3,
        "[[analysis.crack_crossings.lines]]\nname = \"a\"\nfrom = [0.0, 0.0, 0.0]\nto = [0.002, 0.0, 0.0]",
    ));
    assert!(
        err.contains("analysis.crack_crossings") && err.contains("2D"),
        "{err}"
    );
}
