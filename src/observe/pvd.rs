//! ParaView `.pvd` collection file tying a series of `.vtu` snapshots to
//! their simulation times. The whole file is rewritten atomically after every
//! snapshot so that it is valid at all times, even if the run dies later.

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use crate::atomic_file as atomic;

/// A time series of snapshot files, kept in memory and mirrored to disk.
#[derive(Debug, Clone)]
pub struct PvdSeries {
    path: PathBuf,
    entries: Vec<(f64, String)>,
}

impl PvdSeries {
    /// A new, empty series that will be written to `path` (nothing is written
    /// until the first [`add`](Self::add)).
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            entries: Vec::new(),
        }
    }

    /// The series of an interrupted run continued at simulation time `time`: the entries of
    /// the `.pvd` at `path` up to `time` (none if there is no file yet). Nothing is written
    /// until the next [`add`](Self::add).
    pub fn resume(path: impl Into<PathBuf>, time: f64) -> io::Result<Self> {
        let path = path.into();
        let text = super::resume::read_if_present(&path)?;
        let mut entries = Vec::new();
        for line in text.lines().filter(|l| l.contains("<DataSet")) {
            let parsed = attribute(line, "timestep")
                .and_then(|t| t.parse::<f64>().ok())
                .zip(attribute(line, "file").map(xml_unescape));
            let Some((t, file)) = parsed else {
                return Err(super::resume::cannot_continue(
                    &path,
                    format!("expected <DataSet timestep=\"…\" file=\"…\"/>, found {line:?}"),
                ));
            };
            if t <= time {
                entries.push((t, file));
            }
        }
        Ok(Self { path, entries })
    }

    /// Path of the `.pvd` file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends a snapshot at simulation `time` whose file is
    /// `file_name_relative` (relative to the `.pvd`'s directory), then
    /// rewrites the `.pvd` atomically.
    pub fn add(&mut self, time: f64, file_name_relative: &str) -> io::Result<()> {
        self.entries.push((time, file_name_relative.to_string()));
        atomic::write_atomic(&self.path, self.render().as_bytes())
    }

    /// The full XML text of the collection.
    fn render(&self) -> String {
        let mut s = String::new();
        s.push_str("<?xml version=\"1.0\"?>\n");
        s.push_str("<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n");
        s.push_str("  <Collection>\n");
        for (time, file) in &self.entries {
            // `{:e}` is Rust's shortest round-trip form in scientific notation,
            // so times like 1.2345678901234566e-7 survive exactly.
            let _ = writeln!(
                s,
                "    <DataSet timestep=\"{time:e}\" group=\"\" part=\"0\" file=\"{}\"/>",
                xml_attr(file)
            );
        }
        s.push_str("  </Collection>\n");
        s.push_str("</VTKFile>\n");
        s
    }
}

/// Escapes the characters that are not allowed inside an XML attribute value.
fn xml_attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The value of `name="…"` in an XML tag.
fn attribute<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    let len = tag[start..].find('"')?;
    Some(&tag[start..start + len])
}

/// Undoes `xml_attr`.
fn xml_unescape(s: &str) -> String {
    s.replace("&quot;", "\"")
        .replace("&gt;", ">")
        .replace("&lt;", "<")
        .replace("&amp;", "&")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    #[test]
    fn content_after_two_adds() {
        let dir = atomic::test_dir("pvd");
        let path = dir.join("run.pvd");
        let mut series = PvdSeries::new(&path);
        let t1 = 1.2345678901234566e-7;
        series.add(0.0, "snap_000000.vtu").unwrap();
        let after_one = fs::read_to_string(&path).unwrap();
        assert_eq!(after_one.matches("<DataSet").count(), 1);
        assert!(after_one.trim_end().ends_with("</VTKFile>"));

        series.add(t1, "snap_000100.vtu").unwrap();
        let text = fs::read_to_string(&path).unwrap();
        let expected = "<?xml version=\"1.0\"?>\n\
            <VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  \
            <Collection>\n    \
            <DataSet timestep=\"0e0\" group=\"\" part=\"0\" file=\"snap_000000.vtu\"/>\n    \
            <DataSet timestep=\"1.2345678901234566e-7\" group=\"\" part=\"0\" file=\"snap_000100.vtu\"/>\n  \
            </Collection>\n\
            </VTKFile>\n";
        assert_eq!(text, expected);
        // The written time parses back to the identical f64.
        let ts = text.split("timestep=\"").nth(2).unwrap();
        let t: f64 = ts[..ts.find('"').unwrap()].parse().unwrap();
        assert_eq!(t.to_bits(), t1.to_bits());
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1, "no temp file left");

        // Resumed at t1 the series is the same; resumed before t1 it drops the second entry.
        let mut resumed = PvdSeries::resume(&path, t1).unwrap();
        assert_eq!(resumed.render(), expected);
        resumed = PvdSeries::resume(&path, 1e-7).unwrap();
        resumed.add(2e-7, "a&b.vtu").unwrap();
        let again = PvdSeries::resume(&path, 1.0).unwrap();
        assert_eq!(again.entries[1], (2e-7, "a&b.vtu".to_string()));
        assert_eq!(again.entries.len(), 2);
        fs::remove_dir_all(&dir).unwrap();
    }
}
