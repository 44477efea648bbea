//! A study's finished runs kept outside its output folder (for a validation case's screening,
//! beside its measurement in `validation/measured/`): a screening of many hours runs over
//! several sessions, on machines that need not keep the output folder, and the runs already
//! made are not made again. A row is `runs.csv`'s with the run's wall minutes and a
//! fingerprint of what made its outputs (the run's deck and the study's output definitions);
//! a row whose factor values or fingerprint differ from the design's is not used, so a changed
//! deck or output runs again.

use super::RunRecord;
use crate::atomic_file::write_atomic;
use crate::deck::study::OutputSpec;
use std::path::Path;

/// What the table keeps of one finished run.
#[derive(Debug, Clone, PartialEq)]
pub struct KeptRun {
    pub status: String,
    pub outputs: Vec<Option<f64>>,
    pub minutes: Option<f64>,
}

/// The fingerprint of a run: FNV-1a 64 of its deck and of the study's output definitions.
pub fn fingerprint(deck_src: &str, outputs: &[OutputSpec]) -> String {
    let text = format!("{deck_src}\n{outputs:?}");
    format!("{:016x}", crate::checkpoint::fnv1a_64(text.as_bytes()))
}

/// `runs.csv`'s header (run, trajectory, factors, outputs, status) with the minutes and the
/// fingerprint before the status.
fn kept_header(runs_header: &[String]) -> Vec<String> {
    let (status, front) = runs_header
        .split_last()
        .expect("a header ends with the status");
    let mut h = front.to_vec();
    h.extend([
        "minutes".to_string(),
        "fingerprint".to_string(),
        status.clone(),
    ]);
    h
}

/// The kept runs that match the design's run of the same index (the same factor values and
/// fingerprint): one entry per run of the design. A missing or foreign table keeps none.
pub fn read(
    path: &Path,
    runs_header: &[String],
    runs: &[RunRecord],
    fingerprints: &[String],
) -> Vec<Option<KeptRun>> {
    let mut kept = vec![None; runs.len()];
    let Ok(text) = std::fs::read_to_string(path) else {
        return kept;
    };
    let header = kept_header(runs_header);
    let mut lines = text.lines();
    if lines.next() != Some(header.join(",").as_str()) {
        return kept;
    }
    let outputs = outputs_in(runs, runs_header);
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != header.len() {
            continue;
        }
        let Some((k, end)) = super::row_of_design(&cells, runs) else {
            continue;
        };
        let [minutes, print, status] = cells[cells.len() - 3..] else {
            continue;
        };
        if print != fingerprints[k] || status.is_empty() {
            continue;
        }
        let values = &cells[end..end + outputs];
        kept[k] = Some(KeptRun {
            status: status.to_string(),
            outputs: values.iter().map(|c| c.parse().ok()).collect(),
            minutes: minutes.parse().ok(),
        });
    }
    kept
}

/// The number of output columns of `runs.csv`'s header: after the run, trajectory (Morris)
/// and factor columns, before the status.
fn outputs_in(runs: &[RunRecord], runs_header: &[String]) -> usize {
    let design = runs
        .first()
        .map_or(1, |r| 1 + r.trajectory.is_some() as usize + r.values.len());
    runs_header.len() - 1 - design
}

/// Rewrites the table with every finished run (values written so that they read back
/// exactly).
pub fn write(
    path: &Path,
    runs_header: &[String],
    runs: &[RunRecord],
    minutes: &[Option<f64>],
    fingerprints: &[String],
) -> std::io::Result<()> {
    if let Some(folder) = path.parent() {
        std::fs::create_dir_all(folder)?;
    }
    let outputs = outputs_in(runs, runs_header);
    let cell = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    let mut text = kept_header(runs_header).join(",") + "\n";
    for (k, r) in runs
        .iter()
        .enumerate()
        .filter(|(_, r)| !r.status.is_empty())
    {
        let mut cells = vec![k.to_string()];
        cells.extend(r.trajectory.map(|t| t.to_string()));
        cells.extend(r.values.iter().map(|v| v.to_string()));
        cells.extend((0..outputs).map(|o| cell(r.outputs.get(o).copied().flatten())));
        cells.push(cell(minutes[k]));
        cells.push(fingerprints[k].clone());
        cells.push(r.status.clone());
        text += &(cells.join(",") + "\n");
    }
    write_atomic(path, text.as_bytes())
}
