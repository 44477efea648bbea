//! The figures of a case: an output against the series (a point per run) or a column of a
//! CSV file against another (a curve per run), with the paper's points drawn on the same axes.

use super::measured::Measured;
use super::others::Others;
use super::verdict::number;
use crate::deck::case::{AxisSpec, LoadedCase, PlotSpec};
use crate::plot::curve::write_curves_and_points_png;
use crate::study::table::Table;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Draws every plot of `case` into `dir` as `<case>-<plot>.png`; `runs_dir` holds the runs
/// (`run_NNNN/`, in the order of the series values as the case lists them). Returns the files.
pub fn draw(
    case: &LoadedCase,
    measured: &Measured,
    others: &Others,
    runs_dir: &Path,
    dir: &Path,
) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut files = Vec::new();
    for (k, plot) in case.case.plots.iter().enumerate() {
        let path = dir.join(file_name(case, plot));
        let curves = if plot.x.is_column() {
            column_curves(case, plot, measured, runs_dir).map_err(|e| {
                format!("{}: plots[{k}] (`{}`): {e}", case.file.display(), plot.name)
            })?
        } else {
            vec![(
                "peridyn".to_string(),
                run_points(case, plot, measured, others),
            )]
        };
        let paper: Vec<(f64, f64)> = plot.paper.iter().map(|p| (p[0], p[1])).collect();
        let curves_ref: Vec<(&str, &[(f64, f64)])> = curves
            .iter()
            .map(|(n, p)| (n.as_str(), p.as_slice()))
            .collect();
        let marks: Vec<(&str, &[(f64, f64)])> = if paper.is_empty() {
            Vec::new()
        } else {
            vec![("paper", paper.as_slice())]
        };
        write_curves_and_points_png(
            &path,
            &plot.title,
            &plot.x.label,
            &plot.y.label,
            &curves_ref,
            &marks,
        )
        .map_err(|e| e.to_string())?;
        files.push(path);
    }
    Ok(files)
}

/// `<case>-<plot>.png`, the name the report links.
pub fn file_name(case: &LoadedCase, plot: &PlotSpec) -> String {
    format!("{}-{}.png", case.name(), plot.name)
}

fn axis_value(axis: &AxisSpec, series: Option<f64>, outputs: &BTreeMap<String, f64>) -> f64 {
    let v = if axis.series {
        series
    } else {
        axis.output.as_ref().and_then(|o| outputs.get(o).copied())
    };
    v.map_or(f64::NAN, |v| v * axis.scale)
}

fn run_points(
    case: &LoadedCase,
    plot: &PlotSpec,
    measured: &Measured,
    others: &Others,
) -> Vec<(f64, f64)> {
    let mut points: Vec<(f64, f64)> = measured
        .runs
        .iter()
        .map(|r| {
            let values = r.values(case, others);
            (
                axis_value(&plot.x, r.series, &values),
                axis_value(&plot.y, r.series, &values),
            )
        })
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points
}

/// A named curve of (x, y) points.
pub type Curve = (String, Vec<(f64, f64)>);

/// The curves of a plot over columns of the runs' files, one per measured run that finished,
/// read from its folder in `runs_dir`.
pub fn column_curves(
    case: &LoadedCase,
    plot: &PlotSpec,
    measured: &Measured,
    runs_dir: &Path,
) -> Result<Vec<Curve>, String> {
    let mut curves = Vec::new();
    let series = case.series_values(measured.size == "reduced");
    for (k, run) in measured.runs.iter().enumerate() {
        // The study numbers its run folders by their place in the series, which a run measured
        // alone (`--last`) keeps: not by its place among the runs measured.
        let place = run.series.and_then(|v| series.iter().position(|s| *s == v));
        let dir = crate::study_run::run_folder::of_run(runs_dir, place.unwrap_or(k));
        let column = |axis: &AxisSpec| -> Result<Vec<f64>, String> {
            let file = axis.file.as_deref().unwrap_or("history.csv");
            let path = dir.join(file);
            let text = std::fs::read_to_string(&path)
                .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            let table = Table::parse(&text).map_err(|e| format!("{}: {e}", path.display()))?;
            let c = table
                .column(axis.column.as_deref().unwrap_or(""))
                .map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(table
                .rows
                .iter()
                .map(|r| r.get(c).copied().unwrap_or(f64::NAN) * axis.scale)
                .collect())
        };
        if run.status != "ok" {
            continue;
        }
        // A run measured by an earlier invocation whose folder is not here (another results
        // folder or machine): its curve is left out, and said so, until it runs here again.
        if !dir.exists() {
            eprintln!(
                "note: {}: plot `{}` leaves out the run at {} = {}: its folder {} is not here",
                case.file.display(),
                plot.name,
                series_name(case),
                run.series.map_or("—".into(), number),
                dir.display()
            );
            continue;
        }
        let (x, y) = (column(&plot.x)?, column(&plot.y)?);
        let name = match run.series {
            Some(v) => format!("peridyn, {} = {}", series_name(case), number(v)),
            None => "peridyn".into(),
        };
        curves.push((name, x.into_iter().zip(y).collect()));
    }
    Ok(curves)
}

/// The last part of the series key ("horizon" of `discretization.horizon`).
fn series_name(case: &LoadedCase) -> String {
    let key = case.case.series.as_ref().map_or("", |s| s.key.as_str());
    key.rsplit('.').next().unwrap_or(key).to_string()
}
