//! History table (`history.csv`): one row per recorded step, rewritten whole
//! and atomically so the file on disk is always a complete, parseable table.
//! Rewrites are throttled to at most one per second of wall-clock time during
//! `push`; `flush` forces one (call it at snapshots and at the end of a run).

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::atomic_file as atomic;

/// Minimum wall-clock time between two automatic rewrites in `push`.
const AUTO_FLUSH_INTERVAL: Duration = Duration::from_secs(1);

/// An in-memory table of `f64` rows mirrored to a CSV file.
#[derive(Debug, Clone)]
pub struct CsvHistory {
    path: PathBuf,
    header: Vec<String>,
    rows: Vec<Vec<f64>>,
    last_flush: Instant,
    flushed_rows: usize,
}

impl CsvHistory {
    /// A new table with the given column names, to be written to `path`.
    /// Nothing is written until the first flush.
    pub fn new(path: impl Into<PathBuf>, header: Vec<String>) -> Self {
        Self {
            path: path.into(),
            header,
            rows: Vec::new(),
            last_flush: Instant::now(),
            flushed_rows: 0,
        }
    }

    /// Appends a column name; only before the first row.
    pub fn add_column(&mut self, name: String) {
        assert!(self.rows.is_empty(), "columns are fixed once rows exist");
        self.header.push(name);
    }

    /// Path of the CSV file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Column names.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Rows recorded so far.
    pub fn rows(&self) -> &[Vec<f64>] {
        &self.rows
    }

    /// Number of rows that were on disk after the last write.
    pub fn flushed_rows(&self) -> usize {
        self.flushed_rows
    }

    /// Records a row; rewrites the file if more than a second has passed
    /// since the last write. A row whose length differs from the header's is
    /// rejected with an `InvalidInput` error (and not stored).
    pub fn push(&mut self, row: Vec<f64>) -> io::Result<()> {
        if row.len() != self.header.len() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "history '{}': row has {} values but the header has {} columns",
                    self.path.display(),
                    row.len(),
                    self.header.len()
                ),
            ));
        }
        self.rows.push(row);
        if self.last_flush.elapsed() > AUTO_FLUSH_INTERVAL {
            self.flush()?;
        }
        Ok(())
    }

    /// Rewrites the whole file now; a table with an empty path lives in memory only.
    pub fn flush(&mut self) -> io::Result<()> {
        if self.path.as_os_str().is_empty() {
            return Ok(());
        }
        atomic::write_atomic(&self.path, self.render().as_bytes())?;
        self.last_flush = Instant::now();
        self.flushed_rows = self.rows.len();
        Ok(())
    }

    fn render(&self) -> String {
        let cols = self.header.len().max(1);
        let mut s = String::with_capacity(64 + self.rows.len() * cols * 14);
        let header: Vec<String> = self.header.iter().map(|h| quote(h)).collect();
        s.push_str(&header.join(","));
        s.push('\n');
        for row in &self.rows {
            push_row(&mut s, row);
        }
        s
    }
}

/// Appends `v` in a form that parses back to the identical `f64`.
///
/// Rust's `{}` and `{:e}` both print the shortest round-trip digits; `{}`
/// never switches to exponent form, so tiny/huge values would become very long
/// strings of zeros. Use plain form in a readable range (integral values such
/// as step counts print without `.0`, e.g. `100`) and scientific otherwise.
pub(crate) fn push_number(s: &mut String, v: f64) {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e16).contains(&a) {
        let _ = write!(s, "{v}");
    } else {
        let _ = write!(s, "{v:e}");
    }
}

/// Appends `row` as one line of comma-separated numbers (`push_number` each).
pub(crate) fn push_row(s: &mut String, row: &[f64]) {
    for (i, v) in row.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        push_number(s, *v);
    }
    s.push('\n');
}

/// Quotes a header cell if it contains a separator, quote or newline.
pub(crate) fn quote(h: &str) -> String {
    if h.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", h.replace('"', "\"\""))
    } else {
        h.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn header(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn integral_values_print_without_fraction() {
        assert_eq!(format!("{}", 100.0_f64), "100");
        let mut s = String::new();
        push_number(&mut s, 100.0);
        s.push(' ');
        push_number(&mut s, 1.5e-7);
        s.push(' ');
        push_number(&mut s, 0.25);
        assert_eq!(s, "100 1.5e-7 0.25");
    }

    #[test]
    fn round_trip_is_bitwise_exact() {
        let dir = atomic::test_dir("csv");
        let path = dir.join("history.csv");
        let mut h = CsvHistory::new(&path, header(&["step", "time", "energy, total", "damage"]));
        let rows = vec![
            vec![0.0, 0.0, -0.0, 0.0],
            vec![100.0, 1.2345678901234567e-7, 0.1 + 0.2, 1.0 / 3.0],
            vec![2e6, 5e-324, f64::MAX, -123456.789],
            vec![3e16, 1e-5, f64::NAN, f64::INFINITY],
        ];
        for r in &rows {
            h.push(r.clone()).unwrap();
        }
        h.flush().unwrap();
        assert_eq!(h.flushed_rows(), rows.len());

        let text = fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("step,time,\"energy, total\",damage"));
        let parsed: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()).collect())
            .collect();
        assert_eq!(parsed.len(), rows.len());
        for (p, r) in parsed.iter().zip(&rows) {
            for (a, b) in p.iter().zip(r) {
                assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{a} vs {b}"
                );
            }
        }
        assert!(
            text.contains("\n100,"),
            "step 100 printed as integer: {text}"
        );
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1, "no temp file left");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn length_mismatch_is_rejected() {
        let dir = atomic::test_dir("csv-bad");
        let path = dir.join("history.csv");
        let mut h = CsvHistory::new(&path, header(&["a", "b"]));
        let err = h.push(vec![1.0]).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
        assert!(err.to_string().contains("history.csv"), "{err}");
        assert!(h.rows().is_empty());
        h.push(vec![1.0, 2.0]).unwrap();
        assert_eq!(h.rows().len(), 1);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn push_flushes_after_interval() {
        let dir = atomic::test_dir("csv-auto");
        let path = dir.join("h.csv");
        let mut h = CsvHistory::new(&path, header(&["x"]));
        h.push(vec![1.0]).unwrap();
        assert!(!path.exists(), "no write within the first second");
        // Pretend the last write was long ago instead of sleeping.
        h.last_flush = Instant::now() - Duration::from_secs(2);
        h.push(vec![2.0]).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "x\n1\n2\n");
        assert_eq!(h.flushed_rows(), 2);
        fs::remove_dir_all(&dir).unwrap();
    }
}
