//! Crash-safe file replacement: write a sibling temp file, sync it, rename it
//! over the target. A reader (ParaView, a plotting script, a user tailing the
//! output directory) therefore sees either the old or the new file, never a
//! half-written one, even if the run is killed mid-write.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Wraps an io error so that its message names the file involved; the kind is
/// kept so callers can still match on it.
pub(crate) fn with_path(err: io::Error, what: &str, path: &Path) -> io::Error {
    io::Error::new(err.kind(), format!("{what} '{}': {err}", path.display()))
}

/// Temp path `.NAME.tmp` (plus `suffix`) next to `path`. Same directory so the
/// final rename never crosses a file system (which would not be atomic).
pub(crate) fn temp_path(path: &Path, suffix: &str) -> io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("'{}' has no file name", path.display()),
        )
    })?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(".tmp");
    tmp_name.push(suffix);
    Ok(path.with_file_name(tmp_name))
}

/// Syncs an already written temp file and renames it over `path`; removes the
/// temp file if either step fails.
pub(crate) fn commit_temp(tmp: &Path, path: &Path) -> io::Result<()> {
    let result = File::open(tmp)
        .and_then(|f| f.sync_data())
        .map_err(|e| with_path(e, "cannot sync", tmp))
        .and_then(|()| fs::rename(tmp, path).map_err(|e| with_path(e, "cannot rename onto", path)));
    if result.is_err() {
        let _ = fs::remove_file(tmp);
    }
    result
}

/// Atomically replaces the file at `path` with `bytes`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Atomically replaces the file at `path` with whatever `f` writes into the
/// buffered writer. Errors (from `f` or the file system) name `path`; on error
/// the temp file is removed and the old target, if any, is left untouched.
pub fn write_atomic_with(
    path: &Path,
    f: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = temp_path(path, "")?;
    let result = (|| {
        let file = File::create(&tmp).map_err(|e| with_path(e, "cannot create", &tmp))?;
        let mut w = BufWriter::new(file);
        f(&mut w).map_err(|e| with_path(e, "cannot write", path))?;
        let file = w
            .into_inner()
            .map_err(|e| with_path(e.into_error(), "cannot write", path))?;
        file.sync_data()
            .map_err(|e| with_path(e, "cannot sync", &tmp))?;
        fs::rename(&tmp, path).map_err(|e| with_path(e, "cannot rename onto", path))
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Fresh, empty, uniquely named directory under the system temp dir for tests.
#[cfg(test)]
pub(crate) fn test_dir(tag: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let dir = std::env::temp_dir().join(format!(
        "peridyn-{tag}-{}-{nanos}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    fs::create_dir_all(&dir).unwrap();
    dir
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn replaces_content_and_leaves_no_temp() {
        let dir = test_dir("atomic");
        let path = dir.join("out.txt");
        write_atomic(&path, b"first version, rather long").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"first version, rather long");
        write_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        assert_eq!(entries(&dir), vec!["out.txt".to_string()]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failed_writer_keeps_old_file_and_names_path() {
        let dir = test_dir("atomic-fail");
        let path = dir.join("keep.txt");
        write_atomic(&path, b"old").unwrap();
        let err = write_atomic_with(&path, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("keep.txt"), "{err}");
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(&dir), vec!["keep.txt".to_string()]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_directory_error_names_path() {
        let dir = test_dir("atomic-missing");
        let path = dir.join("no_such_dir").join("x.txt");
        let err = write_atomic(&path, b"x").unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::NotFound);
        assert!(err.to_string().contains("no_such_dir"), "{err}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
