//! PNG plots of a run's crack files (written with `[analysis.crack_tip]`), drawn with the
//! history plots: the crack advance against time per branch (`crack_tip.png`), the crack
//! speed over the Rayleigh speed (`crack_speed.png`) and the dissipation rate Γ/G0 (or Γ)
//! against the crack length (`dissipation_rate.png`); with `[analysis.crack_surface]` (3D) the
//! crack area against time (`crack_area.png`) and Γ/G0 (or Γ) against the crack area
//! (`dissipation_rate_area.png`). A missing file draws nothing.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::curve::write_named_curves_png;
use super::damage_map::PlotError;

/// A CSV with a header; cells are kept as text (tip files leave cells empty before a branch
/// has a tip, the speed file names its branch).
struct TextTable {
    columns: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl TextTable {
    /// Reads `path`; None if it does not exist.
    fn read(path: &Path) -> Result<Option<Self>, PlotError> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => {
                return Err(PlotError::Io {
                    path: path.to_path_buf(),
                    source,
                })
            }
        };
        let split = |l: &str| -> Vec<String> {
            l.split(',')
                .map(|c| c.trim().trim_matches('"').to_string())
                .collect()
        };
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let Some(header) = lines.next() else {
            return Ok(None);
        };
        Ok(Some(TextTable {
            columns: split(header),
            rows: lines.map(split).collect(),
        }))
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// (x, y) of two columns over the rows where both cells are numbers.
    fn pairs(&self, x: usize, y: usize) -> Vec<(f64, f64)> {
        self.rows
            .iter()
            .filter_map(|r| Some((r.get(x)?.parse().ok()?, r.get(y)?.parse().ok()?)))
            .collect()
    }
}

/// Draws the crack plots of `run_dir` into `dir`; returns the files written.
pub fn write_crack_plots(run_dir: &Path, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let mut written = Vec::new();
    let mut plot =
        |file: &str, title: &str, x: &str, y: &str, series: Vec<(String, Vec<(f64, f64)>)>| {
            let series: Vec<_> = series.into_iter().filter(|(_, p)| p.len() > 1).collect();
            if series.is_empty() {
                return Ok::<(), PlotError>(());
            }
            let path = dir.join(file);
            write_named_curves_png(&path, title, x, y, &series)?;
            written.push(path);
            Ok(())
        };

    if let Some(tips) = TextTable::read(&run_dir.join("crack_tip.csv"))? {
        // Each branch's advance: its distance from where it was first seen.
        let mut series = Vec::new();
        let branches = tips
            .columns
            .iter()
            .filter_map(|c| c.strip_suffix("_x"))
            .filter(|b| !b.ends_with("_front_mean"));
        for branch in branches {
            let axes: Vec<usize> = ["x", "y", "z"]
                .iter()
                .filter_map(|a| tips.index(&format!("{branch}_{a}")))
                .collect();
            let (Some(time), false) = (tips.index("time"), axes.is_empty()) else {
                continue;
            };
            let mut first: Option<Vec<f64>> = None;
            let mut points = Vec::new();
            for row in &tips.rows {
                let (Ok(t), Some(p)) = (
                    row[time].parse::<f64>(),
                    axes.iter()
                        .map(|&k| row.get(k)?.parse::<f64>().ok())
                        .collect::<Option<Vec<f64>>>(),
                ) else {
                    continue;
                };
                let p0 = first.get_or_insert_with(|| p.clone());
                let advance = p.iter().zip(p0.iter()).map(|(a, b)| (a - b).powi(2));
                points.push((t, advance.sum::<f64>().sqrt()));
            }
            series.push((branch.to_string(), points));
        }
        plot(
            "crack_tip.png",
            "Crack advance",
            "time (s)",
            "tip distance from its first position (m)",
            series,
        )?;
    }

    if let Some(speeds) = TextTable::read(&run_dir.join("crack_speed.csv"))? {
        if let (Some(b), Some(t), Some(v)) = (
            speeds.index("branch"),
            speeds.index("time"),
            speeds.index("speed_over_rayleigh"),
        ) {
            let mut per_branch: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
            for row in &speeds.rows {
                if let (Some(name), Ok(t), Ok(v)) =
                    (row.get(b), row[t].parse::<f64>(), row[v].parse::<f64>())
                {
                    per_branch.entry(name.clone()).or_default().push((t, v));
                }
            }
            plot(
                "crack_speed.png",
                "Crack speed",
                "time (s)",
                "speed / Rayleigh speed",
                per_branch.into_iter().collect(),
            )?;
        }
    }

    if let Some(rates) = TextTable::read(&run_dir.join("dissipation_rate.csv"))? {
        let a = rates.index("crack_length");
        let over_g0 = rates
            .index("rate_over_g0")
            .map(|k| rates.pairs(a.unwrap_or(0), k));
        let (column, label) = match over_g0 {
            Some(p) if !p.is_empty() => (p, "Γ / G0"),
            _ => (
                rates
                    .index("dissipation_rate")
                    .map(|k| rates.pairs(a.unwrap_or(0), k))
                    .unwrap_or_default(),
                "Γ (J/m²)",
            ),
        };
        if a.is_some() {
            plot(
                "dissipation_rate.png",
                "Dissipation rate Γ = dE_diss/dā",
                "crack length a − a0 (m)",
                label,
                vec![("Γ".to_string(), column)],
            )?;
        }
    }
    if let Some(areas) = TextTable::read(&run_dir.join("crack_area.csv"))? {
        if let (Some(t), Some(a)) = (areas.index("time"), areas.index("crack_area")) {
            plot(
                "crack_area.png",
                "Crack area",
                "time (s)",
                "crack area (m²)",
                vec![("A".to_string(), areas.pairs(t, a))],
            )?;
            let over_g0 = areas.index("rate_over_g0").map(|k| areas.pairs(a, k));
            let (column, label) = match over_g0 {
                Some(p) if !p.is_empty() => (p, "Γ / G0"),
                _ => (
                    areas
                        .index("dissipation_rate")
                        .map(|k| areas.pairs(a, k))
                        .unwrap_or_default(),
                    "Γ (J/m²)",
                ),
            };
            plot(
                "dissipation_rate_area.png",
                "Dissipation rate Γ = dE_diss/dA",
                "crack area A (m²)",
                label,
                vec![("Γ".to_string(), column)],
            )?;
        }
    }
    Ok(written)
}
