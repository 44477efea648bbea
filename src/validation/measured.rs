//! What a case's runs measured, kept so that the report can be written again without running:
//! `validation/measured/<paper folder>-<case>.toml` for the full runs (committed: a few lines),
//! the same file in the results folder for reduced runs. The report judges these outputs
//! against the case file as it is now, so a changed tolerance or explanation needs no run.

use crate::atomic_file::write_atomic;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Measured {
    /// The case file, relative to the repository.
    pub case: String,
    /// "full" or "reduced".
    pub size: String,
    /// The wall time of all runs, as each run's summary reports it.
    pub wall_minutes: f64,
    /// The threads of the invocation that wrote the file; a run measured by an earlier one
    /// keeps its own in `MeasuredRun::threads`.
    pub threads: usize,
    pub runs: Vec<MeasuredRun>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredRun {
    /// The series value of the run (none without a series).
    pub series: Option<f64>,
    /// "ok" or "failed: …".
    pub status: String,
    pub wall_minutes: f64,
    /// The threads it ran on, when not the file's (a run kept from an earlier invocation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threads: Option<usize>,
    /// Each output that has a value.
    pub outputs: BTreeMap<String, f64>,
}

impl Measured {
    /// The threads of each run, in run order.
    pub fn run_threads(&self) -> impl Iterator<Item = usize> + '_ {
        self.runs.iter().map(|r| r.threads.unwrap_or(self.threads))
    }

    pub fn read(path: &Path) -> Result<Option<Measured>, String> {
        match std::fs::read_to_string(path) {
            Ok(text) => toml::from_str(&text)
                .map(Some)
                .map_err(|e| format!("{}: {}", path.display(), e.message())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(format!("cannot read {}: {e}", path.display())),
        }
    }

    pub fn write(&self, path: &Path) -> Result<(), String> {
        let text = toml::to_string(self).map_err(|e| e.to_string())?;
        let text = format!(
            "# What `peridyn validate` measured on the {} runs of {}; the report is written from it.\n{text}",
            self.size, self.case
        );
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        write_atomic(path, text.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    }
}
