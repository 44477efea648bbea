//! PNG plots of a run's `history.csv`, written at the end of every run and by `peridyn plot`:
//! the energies, a load–displacement curve per loaded node set, the openings, the broken
//! bonds and the time step (or load increment); with them the crack files' plots
//! (`crack_plots`).

use std::path::{Path, PathBuf};

use super::curve::write_named_curves_png;
use super::damage_map::PlotError;

/// A history table: column names and rows of numbers.
pub struct HistoryTable {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

impl HistoryTable {
    /// Reads a history CSV written by peridyn; names the file and line of a bad cell.
    pub fn read(path: &Path) -> Result<Self, PlotError> {
        let invalid = |msg: String| PlotError::InvalidInput {
            path: path.to_path_buf(),
            msg,
        };
        let text = std::fs::read_to_string(path).map_err(|source| PlotError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut lines = text.lines();
        let columns: Vec<String> = lines
            .next()
            .ok_or_else(|| invalid("the file is empty, expected a header line".into()))?
            .split(',')
            .map(|c| c.trim_matches('"').to_string())
            .collect();
        let mut rows = Vec::new();
        for (k, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
            let row = line
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<Vec<f64>, _>>()
                .map_err(|e| invalid(format!("line {}: {e}", k + 2)))?;
            if row.len() != columns.len() {
                return Err(invalid(format!(
                    "line {}: {} values for {} columns",
                    k + 2,
                    row.len(),
                    columns.len()
                )));
            }
            rows.push(row);
        }
        Ok(HistoryTable { columns, rows })
    }

    /// The values of a column, if it exists.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let k = self.columns.iter().position(|c| c == name)?;
        Some(self.rows.iter().map(|r| r[k]).collect())
    }

    /// (x, y) points of two columns.
    fn pairs(&self, x: &str, y: &str) -> Option<Vec<(f64, f64)>> {
        Some(self.column(x)?.into_iter().zip(self.column(y)?).collect())
    }
}

/// Writes the plots of the history in `run_dir/history.csv` into `run_dir/plots/`; returns
/// the files written.
pub fn write_history_plots(run_dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let table = HistoryTable::read(&run_dir.join("history.csv"))?;
    let dir = run_dir.join("plots");
    std::fs::create_dir_all(&dir).map_err(|source| PlotError::Io {
        path: dir.clone(),
        source,
    })?;
    let mut written = Vec::new();
    let mut plot =
        |file: String, title: &str, x: &str, y: &str, series: Vec<(String, Vec<(f64, f64)>)>| {
            if series.is_empty() {
                return Ok(());
            }
            let path = dir.join(file);
            write_named_curves_png(&path, title, x, y, &series)?;
            written.push(path);
            Ok::<(), PlotError>(())
        };

    // Energies against time, with the energy damage dissipated and what the balance leaves
    // unexplained (histories written before damage dissipation was booked: what the
    // balance has lost).
    let mut energies = Vec::new();
    for (column, label) in [
        ("kinetic_energy", "kinetic"),
        ("strain_energy", "strain"),
        ("external_work", "external work"),
        ("viscous_dissipation", "viscous dissipation"),
    ] {
        if let Some(p) = table.pairs("time", column) {
            if column != "viscous_dissipation" || p.iter().any(|q| q.1 != 0.0) {
                energies.push((label.to_string(), p));
            }
        }
    }
    if let Some(p) = table.pairs("time", "damage_dissipation") {
        energies.push(("dissipated by damage".into(), p));
        if let Some(p) = table.pairs("time", "energy_residual") {
            energies.push(("residual W − E_kin − E_strain − D".into(), p));
        }
    } else if let Some(p) = table.pairs("time", "energy_balance") {
        energies.push((
            "dissipated (W − E_kin − E_strain − D_visc)".into(),
            p.into_iter().map(|(t, b)| (t, -b)).collect(),
        ));
    }
    plot(
        "energies.png".into(),
        "Energies",
        "time (s)",
        "energy (J)",
        energies,
    )?;

    // Load–displacement of every node set that carries a reaction, along its largest one.
    let loaded = loaded_sets(&table);
    for (set, axis) in &loaded {
        if let Some(p) = table.pairs(
            &format!("displacement_{set}_{axis}"),
            &format!("reaction_{set}_{axis}"),
        ) {
            plot(
                format!("load_displacement_{set}.png"),
                &format!("Load–displacement of {set} ({axis})"),
                &format!("mean displacement u_{axis} of {set} (m)"),
                &format!("reaction F_{axis} on {set} (N)"),
                vec![(set.clone(), p)],
            )?;
        }
    }

    let opening_names: Vec<String> = table
        .columns
        .iter()
        .filter_map(|c| c.strip_prefix("opening_").map(String::from))
        .collect();
    let openings: Vec<(String, Vec<(f64, f64)>)> = opening_names
        .iter()
        .filter_map(|o| Some((o.clone(), table.pairs("time", &format!("opening_{o}"))?)))
        .collect();
    plot(
        "openings.png".into(),
        "Openings",
        "time (s)",
        "opening (m)",
        openings,
    )?;
    // Every probe's velocity components against time (`probe_<name>_velocity_<axis>`).
    let probes: Vec<(String, Vec<(f64, f64)>)> = table
        .columns
        .iter()
        .filter(|c| c.starts_with("probe_") && c.contains("_velocity_"))
        .filter_map(|c| {
            let label = c.strip_prefix("probe_")?.replace("_velocity_", " v_");
            Some((label, table.pairs("time", c)?))
        })
        .collect();
    plot(
        "probes.png".into(),
        "Probes",
        "time (s)",
        "velocity (m/s)",
        probes,
    )?;
    // Load against each opening (e.g. load–CMOD): every loaded set's reaction along its axis.
    for o in &opening_names {
        let curves: Vec<(String, Vec<(f64, f64)>)> = loaded
            .iter()
            .filter_map(|(set, axis)| {
                let p = table.pairs(&format!("opening_{o}"), &format!("reaction_{set}_{axis}"))?;
                Some((format!("{set} F_{axis}"), p))
            })
            .collect();
        if !curves.is_empty() {
            plot(
                format!("load_opening_{o}.png"),
                &format!("Load against the opening {o}"),
                &format!("opening {o} (m)"),
                "reaction (N)",
                curves,
            )?;
        }
    }

    for (column, file, title, label) in [
        ("broken_bonds", "broken_bonds.png", "Broken bonds", "bonds"),
        (
            "dt",
            "time_step.png",
            "Time step (load increment when quasi-static)",
            "dt (s)",
        ),
    ] {
        if let Some(p) = table.pairs("time", column) {
            plot(
                file.into(),
                title,
                "time (s)",
                label,
                vec![(column.to_string(), p)],
            )?;
        }
    }
    written.extend(super::crack_plots::write_crack_plots(run_dir, &dir)?);
    Ok(written)
}

/// The node sets with a reaction in the history, each with the axis of its largest one
/// (sets whose reaction stays zero are left out).
fn loaded_sets(table: &HistoryTable) -> Vec<(String, &'static str)> {
    let sets = table.columns.iter().filter_map(|c| {
        c.strip_prefix("reaction_")?
            .strip_suffix("_x")
            .map(String::from)
    });
    sets.filter_map(|set| {
        let mut best: Option<(&'static str, f64)> = None;
        for axis in ["x", "y", "z"] {
            if let Some(r) = table.column(&format!("reaction_{set}_{axis}")) {
                let peak = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                if peak > 0.0 && best.is_none_or(|(_, b)| peak > b) {
                    best = Some((axis, peak));
                }
            }
        }
        Some((set, best?.0))
    })
    .collect()
}
