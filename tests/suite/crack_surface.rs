//! The crack as a surface (`analysis::crack_surface`, `[analysis.crack_surface]`).
//!
//! The area estimator A = Σ ½ φ V_i V_j / ρ_A over broken halves (ρ_A = π δ⁴/4 in 3D,
//! 2 t δ³/3 in 2D; derived in `src/analysis/crack_surface.rs`) is checked on planar cuts
//! through lattice bodies built by the library with HHB partial volumes: the bonds a cut
//! crosses are marked broken (as a pre-crack would remove them) and the estimate is compared
//! with the cut's geometric area.

use peridyn::analysis::{crack_area, crack_surface, BrokenHalf};
use peridyn::body::Body;
use peridyn::bonds::search::build_bonds;
use peridyn::bonds::{PartialVolume, Precrack, Quadrature};
use peridyn::discretize::lattice::lattice;
use peridyn::geometry::Shape;
use peridyn::observe::crack_surface::broken_halves;
use peridyn::state::BROKEN;

/// A lattice block or plate of `n` cells of side `dx`, δ = `ratio`·dx, HHB partial volumes,
/// with every bond the `cut` crosses broken; its broken halves.
fn cut_body<const D: usize>(
    n: [usize; D],
    dx: f64,
    ratio: f64,
    thickness: f64,
    cut: &Precrack,
) -> (Body<D>, Vec<BrokenHalf<D>>) {
    let shape = match D {
        2 => Shape::Rectangle {
            min: [0.0; 2],
            max: [n[0] as f64 * dx, n[1] as f64 * dx],
        },
        _ => Shape::Box {
            min: [0.0; 3],
            max: [n[0] as f64 * dx, n[1] as f64 * dx, n[D - 1] as f64 * dx],
        },
    };
    let body = Body::<D>::from_cloud(
        lattice(&shape, D, dx, thickness).unwrap(),
        ratio * dx,
        thickness,
    );
    let bonds = build_bonds(&body, PartialVolume::Hhb, &[]);
    let quad = Quadrature::for_body(PartialVolume::Hhb, &body, &bonds);
    let mut status = vec![0u8; bonds.len()];
    for i in 0..body.len() {
        for b in bonds.family(i) {
            let j = bonds.neighbors[b] as usize;
            if cut.cuts(body.positions[i].as_slice(), body.positions[j].as_slice()) {
                status[b] = BROKEN;
            }
        }
    }
    let halves = broken_halves(&body, &bonds.offsets, &bonds.neighbors, &quad, &status);
    (body, halves)
}

/// (estimate / geometric area − 1).
fn relative(estimate: f64, geometric: f64) -> f64 {
    estimate / geometric - 1.0
}

/// The lattice's own ρ_A over the continuum's for a cut of unit normal `n` (its last
/// component unused in 2D): ½ Σ φ(|ξ|) |ξ·n| over the lattice vectors ξ (in cells) of a
/// uniform HHB horizon of `ratio` cells, over π ratio⁴/4 (3D) or 2 ratio³/3 (2D) — the
/// quadrature error of the estimator's normalisation, direction-dependent on a lattice.
fn lattice_moment(dim: usize, ratio: f64, n: [f64; 3]) -> f64 {
    let r = ratio.ceil() as i64 + 1;
    let phi = |l: f64| (ratio + 0.5 - l).clamp(0.0, 1.0);
    let mut sum = 0.0;
    let zs: Vec<i64> = if dim == 3 {
        (-r..=r).collect()
    } else {
        vec![0]
    };
    for i in -r..=r {
        for j in -r..=r {
            for &k in &zs {
                let (a, b, c) = (i as f64, j as f64, k as f64);
                sum += 0.5
                    * phi((a * a + b * b + c * c).sqrt())
                    * (a * n[0] + b * n[1] + c * n[2]).abs();
            }
        }
    }
    let continuum = if dim == 3 {
        std::f64::consts::PI * ratio.powi(4) / 4.0
    } else {
        2.0 * ratio.powi(3) / 3.0
    };
    sum / continuum
}

/// Free-end deficit of a 2D crack line per free end, in units of its length: 3δ/16.
fn end_deficit_2d(delta: f64) -> f64 {
    3.0 * delta / 16.0
}

/// How far the estimate may sit from its prediction (the lattice quadrature of ρ_A, plus the
/// free-edge deficit where the cut meets a free surface): the cut's edges alias on the
/// lattice (a bond whose crossing point falls just inside or outside the edge); measured
/// ≤ 0.77 % over the cases below.
const ALIASING: f64 = 0.01;

/// Free-edge deficit per unit length of a crack edge on a free surface, 3D: 8δ/(15π).
fn edge_deficit_3d(delta: f64) -> f64 {
    8.0 * delta / (15.0 * std::f64::consts::PI)
}

#[test]
fn planar_cuts_through_3d_lattice_blocks_give_their_area() {
    let dx = 1e-3;
    for ratio in [3.0, 4.0] {
        let delta = ratio * dx;
        // (1) An interior square cut 12 × 12 dx at z = 8 dx (between node layers), 9 dx from
        // every side: no free edge. Its edges sit off the lattice's special lines (0.37 dx):
        // an edge where many bonds' crossing points fall (x = k dx) counts them all or none.
        let cut = Precrack::Rectangle {
            origin: [9.37 * dx, 9.37 * dx, 8.0 * dx],
            edge1: [12.0 * dx, 0.0, 0.0],
            edge2: [0.0, 12.0 * dx, 0.0],
        };
        let (_, halves) = cut_body::<3>([30, 30, 16], dx, ratio, 1.0, &cut);
        let interior = relative(crack_area(&halves, 1.0), 144.0 * dx * dx);
        // (2) The same square tilted by 30° about y: normal (−sin 30°, 0, cos 30°).
        let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
        let l = 12.0 * dx;
        let centre = [15.37 * dx, 15.37 * dx, 15.0 * dx];
        let cut = Precrack::Rectangle {
            origin: [
                centre[0] - 0.5 * l * c,
                centre[1] - 0.5 * l,
                centre[2] - 0.5 * l * s,
            ],
            edge1: [l * c, 0.0, l * s],
            edge2: [0.0, l, 0.0],
        };
        let (_, halves) = cut_body::<3>([30, 30, 30], dx, ratio, 1.0, &cut);
        let tilted = relative(crack_area(&halves, 1.0), l * l);
        // (3) A through cut of the block 24 × 12 × 12 dx at z = 6 dx: a 24 × 12 crack whose
        // whole edge (72 dx) lies on free surfaces.
        let cut = Precrack::Rectangle {
            origin: [-dx, -dx, 6.0 * dx],
            edge1: [26.0 * dx, 0.0, 0.0],
            edge2: [0.0, 14.0 * dx, 0.0],
        };
        let (_, halves) = cut_body::<3>([24, 12, 12], dx, ratio, 1.0, &cut);
        let geometric = 24.0 * 12.0 * dx * dx;
        let area = crack_area(&halves, 1.0);
        let through = relative(area, geometric);
        let expected = -edge_deficit_3d(delta) * 72.0 * dx / geometric;
        let q_axis = lattice_moment(3, ratio, [0.0, 0.0, 1.0]) - 1.0;
        let q_tilt = lattice_moment(3, ratio, [-s, 0.0, c]) - 1.0;
        println!(
            "3D δ = {ratio} dx: A/A_geo − 1: interior {interior:+.4} (lattice ρ_A {q_axis:+.4}), tilted 30° {tilted:+.4} (lattice ρ_A {q_tilt:+.4}), through cut {through:+.4} (lattice + free edges {:+.4})",
            q_axis + expected
        );
        assert!((interior - q_axis).abs() < ALIASING, "interior cut");
        assert!((tilted - q_tilt).abs() < ALIASING, "tilted cut");
        assert!(
            (through - (q_axis + expected)).abs() < ALIASING,
            "through cut"
        );
        // Against the geometric area alone (away from free surfaces): within 3 % / 7 % at
        // δ = 3Δx (axis-aligned / 30°), 1 % / 3.5 % at δ = 4Δx — the quadrature converging.
        let (aligned_tol, tilted_tol) = if ratio == 3.0 {
            (0.03, 0.07)
        } else {
            (0.01, 0.035)
        };
        assert!(interior.abs() < aligned_tol && tilted.abs() < tilted_tol);
        // The surface of the through cut: every cell at the cut's height; its areas add up.
        let h = 2.0 * dx;
        let halves3: Vec<BrokenHalf<3>> = halves.clone();
        let cells = crack_surface(&halves3, 2, h);
        assert_eq!(cells.len(), 12 * 6, "one cell per 2 dx × 2 dx of the cut");
        for cell in &cells {
            assert!(
                (cell.height - 6.0 * dx).abs() < 1e-9 * dx,
                "cell {cell:?} off the cut"
            );
        }
        let sum: f64 = cells.iter().map(|c| c.area).sum();
        println!("Σ cells / A − 1 = {:.2e}", sum / area - 1.0);
        assert!((sum / area - 1.0).abs() < 1e-10);
    }
}

#[test]
fn cuts_through_2d_lattice_plates_give_their_area() {
    let (dx, t) = (1e-3, 0.5e-3);
    for ratio in [3.0, 4.0] {
        let delta = ratio * dx;
        // An interior cut 20 dx long at y = 15 dx in a 40 × 30 plate, 10 dx from the sides.
        let cut = Precrack::Segment {
            start: [10.37 * dx, 15.0 * dx],
            end: [30.37 * dx, 15.0 * dx],
        };
        let (_, halves) = cut_body::<2>([40, 30], dx, ratio, t, &cut);
        let interior = relative(crack_area(&halves, t), 20.0 * dx * t);
        // Tilted by 30°.
        let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
        let l = 20.0 * dx;
        let cut = Precrack::Segment {
            start: [20.37 * dx - 0.5 * l * c, 15.0 * dx - 0.5 * l * s],
            end: [20.37 * dx + 0.5 * l * c, 15.0 * dx + 0.5 * l * s],
        };
        let (_, halves) = cut_body::<2>([40, 30], dx, ratio, t, &cut);
        let tilted = relative(crack_area(&halves, t), l * t);
        // Through the plate: two free ends, each short by 3δ/16 (times t).
        let cut = Precrack::Segment {
            start: [-dx, 15.0 * dx],
            end: [41.0 * dx, 15.0 * dx],
        };
        let (_, halves) = cut_body::<2>([40, 30], dx, ratio, t, &cut);
        let through = relative(crack_area(&halves, t), 40.0 * dx * t);
        let expected = -2.0 * end_deficit_2d(delta) / (40.0 * dx);
        let q_axis = lattice_moment(2, ratio, [0.0, 1.0, 0.0]) - 1.0;
        let q_tilt = lattice_moment(2, ratio, [-s, c, 0.0]) - 1.0;
        println!(
            "2D δ = {ratio} dx: A/A_geo − 1: interior {interior:+.4} (lattice ρ_A {q_axis:+.4}), tilted 30° {tilted:+.4} (lattice ρ_A {q_tilt:+.4}), through cut {through:+.4} (lattice + free ends {:+.4})",
            q_axis + expected
        );
        assert!((interior - q_axis).abs() < ALIASING, "interior cut");
        assert!((tilted - q_tilt).abs() < ALIASING, "tilted cut");
        assert!(
            (through - (q_axis + expected)).abs() < ALIASING,
            "through cut"
        );
        // Against the geometric area alone: within 1 % aligned, 3.5 % at 30°.
        assert!(interior.abs() < 0.01 && tilted.abs() < 0.035);
    }
}

// ---------------------------------------------------------------------------------------------
// A crack running in a 3D run.

use super::crack_tracking::{num, read_csv};
use peridyn::deck::LoadedDeck;
use peridyn::run::{run, run_with, RunControl, RunError, RunOptions, RunSummary};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Spacing (m), horizon (m), notch plane y (m), notch tip x (m), thickness in z (m), G0.
const DX3: f64 = 0.1e-3;
const DELTA3: f64 = 3.0 * DX3;
const NOTCH_Y3: f64 = 1e-3;
const NOTCH_TIP3: f64 = 1e-3;
const DEPTH3: f64 = 1e-3;
const G0: f64 = 300.0;

/// A 4 × 2 × 1 mm PMMA block (PMB, G0 = 300 J/m², ν = 1/4), Δx = 0.1 mm (8000 nodes),
/// δ = 3Δx, a through-thickness pre-crack in the plane y = 1 mm from x = 0 to 1 mm, grips of
/// three layers top and bottom pulled apart at `speed` m/s each (held in z).
fn block(speed: f64, end_time: f64, analysis: &str) -> LoadedDeck {
    let text = format!(
        r#"
version = 2
dimension = 3
no_fail = ["top", "bottom"]

[discretization]
type = "lattice"
shape = {{ type = "box", min = [0.0, 0.0, 0.0], max = [0.004, 0.002, {DEPTH3}] }}
spacing = {DX3}
horizon_ratio = 3.0
partial_volume = "hhb"

[material]
type = "pmb"
density = 1180.0
youngs_modulus = 3.09e9
fracture_energy = {G0}

[[node_sets]]
name = "top"
region = {{ type = "box", min = [-1.0, 0.0017, -1.0], max = [1.0, 1.0, 1.0] }}

[[node_sets]]
name = "bottom"
region = {{ type = "box", min = [-1.0, -1.0, -1.0], max = [1.0, 0.0003, 1.0] }}

[[precracks]]
type = "rectangle"
origin = [-0.001, {NOTCH_Y3}, -0.001]
edge1 = [{e1}, 0.0, 0.0]
edge2 = [0.0, 0.0, 0.003]

[[boundary_conditions]]
set = "top"
kind = "velocity"
component = "y"
value = {speed}
time = {{ type = "ramp", duration = 1e-6 }}

[[boundary_conditions]]
set = "bottom"
kind = "velocity"
component = "y"
value = {neg}
time = {{ type = "ramp", duration = 1e-6 }}

[[boundary_conditions]]
set = "top"
kind = "displacement"
component = "z"
value = 0.0

[[boundary_conditions]]
set = "bottom"
kind = "displacement"
component = "z"
value = 0.0

[solver]
type = "explicit"
end_time = {end_time}

[output]
history_interval = 0
snapshots = 0
png = false
plots = false
checkpoint_interval = 100

{analysis}
"#,
        e1 = NOTCH_TIP3 + 0.001,
        neg = -speed,
    );
    LoadedDeck::from_str(&text, Path::new("crack_surface.toml")).unwrap_or_else(|e| panic!("{e}"))
}

const SURFACE: &str = r#"
[analysis.crack_surface]
axis = "y"
interval = 10
"#;

/// Grip speed (m/s) and run length (s): the crack starts at ≈ 8 µs and crosses the 3 mm
/// ligament by ≈ 14 µs (370 steps, ≈ 2 s on one core).
const SPEED: f64 = 1.0;
const END_TIME: f64 = 16e-6;

fn out_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("peridyn-surface-{tag}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    dir
}

fn run_in(ld: &LoadedDeck, out: &Path, threads: usize) -> RunSummary {
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

/// The 2-thread run, shared by the tests that read it.
fn two_thread_run() -> &'static (PathBuf, RunSummary) {
    static RUN: OnceLock<(PathBuf, RunSummary)> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = out_dir("t2");
        let summary = run_in(&block(SPEED, END_TIME, SURFACE), &dir, 2);
        (dir, summary)
    })
}

#[test]
fn a_running_crack_grows_on_the_notch_plane_and_dissipates_about_g0_per_area() {
    let (dir, summary) = two_thread_run();
    let (header, rows) = read_csv(&dir.join("crack_area.csv"));
    assert_eq!(
        header,
        [
            "time",
            "step",
            "crack_area",
            "damage_dissipation",
            "dissipation_rate",
            "rate_over_g0"
        ]
    );
    assert_eq!(rows[0][..4], ["0", "0", "0", "0"], "step 0: no crack yet");
    let areas: Vec<f64> = rows.iter().map(|r| num(&r[2])).collect();
    let energies: Vec<f64> = rows.iter().map(|r| num(&r[3])).collect();
    // Breakage is irreversible and each half's share fixed: the area never decreases.
    for w in areas.windows(2) {
        assert!(w[1] >= w[0], "the area shrank: {w:?}");
    }
    let (area, energy) = (*areas.last().unwrap(), *energies.last().unwrap());
    let (header, cells) = read_csv(&dir.join("crack_surface.csv"));
    assert_eq!(header, ["x", "z", "y", "area"]);
    let cells: Vec<[f64; 4]> = cells
        .iter()
        .map(|c| [num(&c[0]), num(&c[1]), num(&c[2]), num(&c[3])])
        .collect();
    let off = cells
        .iter()
        .map(|c| (c[2] - NOTCH_Y3).abs())
        .fold(0.0, f64::max);
    let sum: f64 = cells.iter().map(|c| c.iter().last().unwrap()).sum();
    // A clean flat crack across the ligament, as the estimator sees it: the lattice's ρ_A
    // (+2.5 % at δ = 3Δx) less the free-edge deficit 0.170 δ per metre of edge on the faces
    // z = 0, z = depth (the ligament's length each) and x = 4 mm (the depth).
    let ligament = 4e-3 - NOTCH_TIP3;
    let q = lattice_moment(3, 3.0, [0.0, 1.0, 0.0]);
    let clean = ligament * DEPTH3 * q - edge_deficit_3d(DELTA3) * (2.0 * ligament + DEPTH3);
    let ratio = energy / (G0 * area);
    println!(
        "3D run: {} samples, {} steps; final area {:.4} mm² = {:.3} × a clean flat crack ({:.4} mm²), {} cells, max |y − notch| = {:.2e} m, Σ cells / A − 1 = {:.1e}, E_diss = {:.4e} J, E_diss/(G0 A) = {:.4}",
        rows.len(),
        summary.report.steps,
        area * 1e6,
        area / clean,
        clean * 1e6,
        cells.len(),
        off,
        sum / area - 1.0,
        energy,
        ratio
    );
    // The crack stays on the notch plane: every cell's mean height within a horizon of it
    // (the set-up is symmetric about the plane, so the measured offset is rounding only).
    assert!(off < DELTA3, "surface {off} m off the notch plane");
    // It crossed the ligament: every 0.2 mm column from the notch tip to the far face holds
    // cells, and the area is at least 90 % of a clean flat crack's (measured 1.8×: a
    // dynamic crack breaks a band of bonds, each of which the estimator counts).
    let h = 2.0 * DX3;
    for k in 0..(ligament / h).round() as usize {
        let x = NOTCH_TIP3 + (k as f64 + 0.5) * h;
        assert!(
            cells.iter().any(|c| (c[0] - x).abs() < 0.25 * h),
            "no crack at x = {x}"
        );
    }
    assert!(
        area > 0.9 * clean,
        "area {area} against a clean crack's {clean}"
    );
    // The files agree: the history's last area is the sum of the final surface's cells (the
    // same halves summed in another order: rounding only).
    assert!((sum / area - 1.0).abs() < 1e-10);
    let report = summary.crack_surface.as_ref().expect("a surface report");
    assert_eq!((report.area, report.dissipated), (area, energy));
    // E_diss / A: A counts every broken half at the bulk density of crossing bonds, and each
    // half dissipates its bond's critical energy, so the ratio is G0 whatever the width of
    // the band — up to the lattice: the code's separation energy at δ = 3Δx is 1.016 G0 per
    // geometric area (docs/verification.md) and its ρ_A 1.025 of the continuum's, so a clean
    // separation gives 0.99 G0; bonds overshooting s0 within a step add a little. Measured
    // 0.980 here (0.980 at 0.5 m/s, 0.992 at 2 m/s); asserted 0.99 ± 0.05.
    assert!((ratio - 0.99).abs() < 0.05, "E_diss/(G0 A) = {ratio}");
}

#[test]
fn surface_files_do_not_depend_on_the_thread_count() {
    let (two, _) = two_thread_run();
    let one = out_dir("t1");
    run_in(&block(SPEED, END_TIME, SURFACE), &one, 1);
    for file in ["crack_area.csv", "crack_surface.csv", "crack_surface.vtu"] {
        let a = std::fs::read(one.join(file)).unwrap();
        let b = std::fs::read(two.join(file)).unwrap();
        assert!(a == b, "{file} differs between 1 and 2 threads");
        assert!(a.len() > 100, "{file} is nearly empty");
    }
    std::fs::remove_dir_all(&one).ok();
}

#[test]
fn a_run_continued_from_a_checkpoint_writes_the_same_surface_files() {
    let (whole, _) = two_thread_run();
    // Checkpoints every 100 steps; stopped after step 230 as a killed run, continued from
    // step 200 (the crack has started at ≈ 8 µs ≈ step 180) on the other thread count.
    let ld = block(SPEED, END_TIME, SURFACE);
    let dir = out_dir("restart");
    let opts = RunOptions {
        out_dir: dir.clone(),
        threads: Some(1),
        quiet: true,
    };
    let stop = RunControl {
        stop_after_step: Some(230),
        ..RunControl::default()
    };
    let stopped = run_with(&ld, &opts, &stop);
    assert!(
        matches!(stopped, Err(RunError::Stopped(230))),
        "{stopped:?}"
    );
    let (_, rows) = read_csv(&dir.join("crack_area.csv"));
    assert!(
        rows.iter().any(|r| num(&r[2]) > 0.0),
        "the checkpoint comes after the crack started"
    );
    let restart = RunControl {
        restart: true,
        ..RunControl::default()
    };
    run_with(&ld, &opts, &restart).unwrap_or_else(|e| panic!("{e}"));
    for file in ["crack_area.csv", "crack_surface.csv", "crack_surface.vtu"] {
        let a = std::fs::read(dir.join(file)).unwrap();
        let b = std::fs::read(whole.join(file)).unwrap();
        assert!(a == b, "{file} differs after a restart");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_crack_area_and_its_dissipation_rate_are_plotted() {
    let (dir, _) = two_thread_run();
    let plots = out_dir("plots");
    std::fs::create_dir_all(&plots).unwrap();
    let written = peridyn::plot::crack_plots::write_crack_plots(dir, &plots).unwrap();
    for name in ["crack_area.png", "dissipation_rate_area.png"] {
        let file = plots.join(name);
        assert!(written.contains(&file), "{name} in {written:?}");
        let header = std::fs::read(&file).unwrap();
        assert_eq!(&header[1..4], b"PNG", "{name} is a PNG");
    }
    std::fs::remove_dir_all(&plots).ok();
}
