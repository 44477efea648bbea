//! A CSV writer's file continued after a restart. The writers rewrite their file whole from
//! the rows they hold, and a continued run holds only the rows after the checkpoint; so the
//! writer writes a side file, and `ResumedCsv` keeps the real file as the interrupted run's
//! rows up to the checkpoint's step followed by the side file's rows, rewritten atomically (at
//! most once a second, at every flush and at the end, when the side file is removed).

use super::observer::{Observer, StepView};
use crate::atomic_file::{with_path, write_atomic};
use std::io;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Minimum wall-clock time between two merges after `observe`.
const MERGE_INTERVAL: Duration = Duration::from_secs(1);

pub struct ResumedCsv<const D: usize> {
    inner: Box<dyn Observer<D>>,
    path: PathBuf,
    side: PathBuf,
    /// The header and the rows kept from the interrupted run, as they were on disk.
    kept: String,
    last_merge: Instant,
}

impl<const D: usize> ResumedCsv<D> {
    /// Continues the CSV at `path` after step `step`: keeps its rows whose `step` column is at
    /// most `step`, and wraps the writer `make` builds for the side file it is given.
    pub fn new(
        path: &Path,
        step: u64,
        make: impl FnOnce(&Path) -> Box<dyn Observer<D>>,
    ) -> io::Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| with_path(e, "cannot read", path))?;
        let mut name = std::ffi::OsString::from(".");
        name.push(path.file_name().unwrap_or_default());
        name.push(".continued");
        let side = path.with_file_name(name);
        // One left by an earlier continuation that was killed holds rows of that run.
        remove_if_present(&side)?;
        Ok(ResumedCsv {
            inner: make(&side),
            kept: rows_up_to(&text, step, path)?,
            path: path.to_path_buf(),
            side,
            last_merge: Instant::now(),
        })
    }

    /// Rewrites the file: the kept rows, then the side file's.
    fn merge(&mut self) -> io::Result<()> {
        let side = read_if_present(&self.side)?;
        let mut text = self.kept.clone();
        if let Some((header, rows)) = side.split_once('\n') {
            let kept_header = self.kept.lines().next().unwrap_or_default();
            if header != kept_header {
                return Err(cannot_continue(
                    &self.path,
                    format!("its columns are {kept_header:?}, the continued run's {header:?}"),
                ));
            }
            text.push_str(rows);
        }
        write_atomic(&self.path, text.as_bytes())?;
        self.last_merge = Instant::now();
        Ok(())
    }
}

/// The header and the rows of CSV `text` (read from `path`) whose `step` column is at most
/// `step`.
pub fn rows_up_to(text: &str, step: u64, path: &Path) -> io::Result<String> {
    let invalid = |what: String| cannot_continue(path, what);
    let mut lines = text.lines();
    let header = lines
        .next()
        .ok_or_else(|| invalid("expected a header line, found an empty file".into()))?;
    let column = header
        .split(',')
        .position(|c| c == "step")
        .ok_or_else(|| invalid(format!("expected a 'step' column, found {header:?}")))?;
    let mut kept = format!("{header}\n");
    for line in lines {
        let value = line
            .split(',')
            .nth(column)
            .and_then(|c| c.parse::<f64>().ok())
            .ok_or_else(|| {
                invalid(format!(
                    "expected a step in column {}, found {line:?}",
                    column + 1
                ))
            })?;
        // Rows are in step order: the first one past the checkpoint ends the kept part.
        if value > step as f64 {
            break;
        }
        kept.push_str(line);
        kept.push('\n');
    }
    Ok(kept)
}

impl<const D: usize> Observer<D> for ResumedCsv<D> {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.inner.wants(step, last)
    }

    fn begin_stage(&mut self, stage: &super::observer::StageStart) {
        self.inner.begin_stage(stage);
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        self.inner.observe(view)?;
        if view.last || self.last_merge.elapsed() > MERGE_INTERVAL {
            self.merge()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()?;
        self.merge()
    }

    fn finish(&mut self) -> io::Result<()> {
        self.inner.finish()?;
        self.merge()?;
        remove_if_present(&self.side)
    }
}

/// The rows of CSV `text` (read from `path`) after its header, as numbers: what a table
/// writer held, to hold again (its numbers print back to the same text).
pub(crate) fn parse_rows(text: &str, path: &Path) -> io::Result<Vec<Vec<f64>>> {
    text.lines()
        .skip(1)
        .map(|line| {
            line.split(',')
                .map(|c| c.parse::<f64>())
                .collect::<Result<Vec<f64>, _>>()
                .map_err(|_| cannot_continue(path, format!("expected numbers, found {line:?}")))
        })
        .collect()
}

/// A file of the interrupted run that cannot be continued, and why.
pub(crate) fn cannot_continue(path: &Path, what: String) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("cannot continue '{}': {what}", path.display()),
    )
}

/// The file's text, empty when there is none yet.
pub(crate) fn read_if_present(path: &Path) -> io::Result<String> {
    match std::fs::read_to_string(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(String::new()),
        r => r.map_err(|e| with_path(e, "cannot read", path)),
    }
}

fn remove_if_present(path: &Path) -> io::Result<()> {
    std::fs::remove_file(path).or_else(|e| match e.kind() {
        io::ErrorKind::NotFound => Ok(()),
        _ => Err(with_path(e, "cannot remove", path)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_header_and_rows_up_to_the_step() {
        let text = "time,step,x\n0,0,1\n0.5,10,2\n1,20,3\n";
        let p = Path::new("h.csv");
        assert_eq!(
            rows_up_to(text, 10, p).unwrap(),
            "time,step,x\n0,0,1\n0.5,10,2\n"
        );
        assert_eq!(rows_up_to(text, 25, p).unwrap(), text);
        let err = rows_up_to("time,x\n0,1\n", 10, p).unwrap_err();
        assert!(err.to_string().contains("'step' column"), "{err}");
        assert!(err.to_string().contains("h.csv"), "{err}");
    }
}
