//! `[analysis.crack_path]` in a run: the mode-I crack of the notched plate of
//! `crack_tracking` runs along the notch line y = 2 mm, so its path lies within a grid spacing
//! of that line, a reference shifted by 0.5 mm reads 0.5 mm away, and no fork is found; the
//! table is refused in 3D.

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
        assert_eq!(header, ["x", "y"]);
        assert!(points.len() >= 10, "{} path points", points.len());
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

#[test]
fn crack_paths_are_refused_in_3d() {
    let text = r#"
version = 2
dimension = 3

[discretization]
type = "lattice"
shape = { type = "box", min = [0.0, 0.0, 0.0], max = [0.002, 0.002, 0.002] }
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

[analysis.crack_path]
"#;
    let Err(err) = LoadedDeck::from_str(text, Path::new("path3d.toml")) else {
        panic!("refused")
    };
    let err = err.to_string();
    assert!(
        err.contains("analysis.crack_path") && err.contains("2D"),
        "{err}"
    );
}
