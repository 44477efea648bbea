//! Energy accounting of fracture runs: the notched PMMA plate of `crack_tracking` (a mode-I
//! crack runs from the notch under grips pulled apart) with PMB, LPS and a bilinear softening
//! law. The balance W_ext = E_kin + E_strain + E_diss must close within 2% of W_ext, with
//! E_diss the energy the force engine books as bonds break (not the balance's deficit), and
//! the dissipation per unit crack area Γ = dE_diss/dā must be of the order of G0: above it
//! (a dynamic crack leaves a damaged band several bonds wide and rough faces, seed 002
//! §4.2.2 measures Γ/G0 ≈ 1 at the slowest load and more above), below the 2G0 of two cracks
//! since this crack does not branch.

use super::crack_tracking::{num, out_dir, plate_of, read_csv, run_in, NOTCH_TIP, TRACK};
use std::path::Path;

const G0: f64 = 300.0;
const THICKNESS: f64 = 0.5e-3;

/// The last row of `history.csv` as (column, value) lookup.
fn last_row(dir: &Path) -> impl Fn(&str) -> f64 {
    let (header, rows) = read_csv(&dir.join("history.csv"));
    let last = rows.last().expect("history rows").clone();
    move |column: &str| {
        let k = header
            .iter()
            .position(|h| h == column)
            .unwrap_or_else(|| panic!("no column {column} in {header:?}"));
        num(&last[k])
    }
}

/// Runs the plate with `material` and returns (residual / W_ext, E_diss / (G0 ā), mean Γ/G0
/// over the run's second half) with ā the tip's advance times the thickness.
fn account(tag: &str, material: &str) -> (f64, f64, f64) {
    let dir = out_dir(tag);
    run_in(&plate_of(material, TRACK), &dir, 2);
    let last = last_row(&dir);
    let (w, residual, dissipated) = (
        last("external_work"),
        last("energy_residual"),
        last("damage_dissipation"),
    );
    let balance = w - (last("kinetic_energy") + last("strain_energy") + dissipated);
    assert!(
        (balance - residual).abs() <= 1e-9 * w,
        "the residual column is W − E_kin − E_strain − E_diss"
    );
    let (_, tips) = read_csv(&dir.join("crack_tip.csv"));
    let tip_x = tips.iter().filter(|r| !r[2].is_empty()).map(|r| num(&r[2]));
    let advance = tip_x.clone().fold(f64::MIN, f64::max) - NOTCH_TIP;
    let (header, rates) = read_csv(&dir.join("dissipation_rate.csv"));
    assert_eq!(
        header,
        ["time", "crack_length", "dissipation_rate", "rate_over_g0"]
    );
    let late: Vec<f64> = rates[rates.len() / 2..]
        .iter()
        .map(|r| num(&r[3]))
        .collect();
    let mean_rate = late.iter().sum::<f64>() / late.len() as f64;
    for plot in ["crack_tip", "crack_speed", "dissipation_rate", "energies"] {
        let path = dir.join("plots").join(format!("{plot}.png"));
        assert!(path.is_file(), "{} was not drawn", path.display());
    }
    std::fs::remove_dir_all(&dir).ok();
    let ratios = (
        residual / w,
        dissipated / (G0 * advance * THICKNESS),
        mean_rate,
    );
    println!(
        "{tag:10} W = {w:.4e} J, E_diss = {dissipated:.4e} J, residual/W = {:+.4}, \
         E_diss/(G0 ā) = {:.3} (tip advance {:.2} mm), mean Γ/G0 (second half) = {:.3}",
        ratios.0,
        ratios.1,
        advance * 1e3,
        ratios.2
    );
    ratios
}

#[test]
fn fracture_runs_close_the_energy_balance_and_dissipate_about_g0_per_area() {
    let lps = r#"
[material]
type = "lps"
density = 1180.0
youngs_modulus = 3.09e9
poisson_ratio = 0.33
fracture_energy = 300.0
"#;
    let bilinear = r#"
[material]
type = "pmb"
density = 1180.0
youngs_modulus = 3.09e9
fracture_energy = 300.0
damage = { type = "bilinear", tensile_strength = 60e6 }
"#;
    for (tag, material) in [
        ("pmb", super::crack_tracking::PMMA_PMB),
        ("lps", lps),
        ("bilinear", bilinear),
    ] {
        let (residual, per_area, rate) = account(tag, material);
        assert!(residual.abs() < 0.02, "{tag}: residual {residual:+.4} of W");
        assert!(
            (1.0..2.0).contains(&per_area) && (1.0..2.0).contains(&rate),
            "{tag}: E_diss/(G0 ā) = {per_area:.3}, Γ/G0 = {rate:.3}"
        );
    }
}
