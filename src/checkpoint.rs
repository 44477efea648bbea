//! The checkpoint file `checkpoint.bin`: every field of `State` and the driver's own state, so
//! a killed run continues bitwise as if it had not stopped. Little-endian binary:
//!
//! - magic `PDYNCKPT`, format (u32);
//! - origin: peridyn version and deck file (u32 length + UTF-8 each), hash of the resolved deck
//!   (u64, FNV-1a 64 of its text);
//! - sizes (u64 each): dimension, nodes, directed bond entries, history words, previous
//!   positions, previous own-half matrices (words), the quasi-static predictor's
//!   displacements (0 or nodes), impactors;
//! - payload: the State scalars, the driver state (time step controller, stage in progress,
//!   quasi-static solver), then the arrays (u, v, current, force, body_force as D f64 per
//!   node; status as u8; history as f64; previous as D f64 each; the previous matrices as
//!   f64; the predictor's
//!   displacements as D f64 each; per impactor its position, velocity and force as D f64
//!   each and its penalty energy);
//! - FNV-1a 64 of every byte before it.
//!
//! Written atomically (temp file + rename): the file on disk is always a whole checkpoint.

use crate::atomic_file::{with_path, write_atomic_with};
use crate::math::Vector;
use crate::observe::Every;
use crate::solver::impactor::ImpactorState;
use crate::solver::quasi_static::QuasiStaticMemory;
use crate::state::State;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

pub const FILE_NAME: &str = "checkpoint.bin";
const MAGIC: &[u8; 8] = b"PDYNCKPT";
const FORMAT: u32 = 4;
/// State and driver scalars in the payload.
const SCALARS: usize = 20;

/// Where a checkpoint comes from: it continues only with the same program and deck.
#[derive(Debug, Clone, PartialEq)]
pub struct Origin {
    pub version: String,
    /// The deck file, for messages (a moved deck with the same text still matches).
    pub deck_file: String,
    /// FNV-1a 64 of the resolved deck's text.
    pub deck_hash: u64,
}

impl Origin {
    /// This peridyn running the deck whose resolved text is `resolved_deck`.
    pub fn new(resolved_deck: &str, deck_file: &Path) -> Self {
        Origin {
            version: env!("CARGO_PKG_VERSION").to_string(),
            deck_file: deck_file.display().to_string(),
            deck_hash: fnv1a(FNV_OFFSET, resolved_deck.as_bytes()),
        }
    }
}

/// What the next step depends on besides `State`: the time step to try next (the adaptive
/// controller changes it) and the adaptive controller's counters, the stage in progress and
/// where it started, the quasi-static solver's memory and the impactors' motion.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DriverState<const D: usize> {
    pub next_dt: f64,
    /// Committed steps since the adaptive dt last changed.
    pub since_change: u64,
    /// Adaptive steps rejected so far.
    pub rejected: u64,
    /// The stage in progress (0: the deck's own) and the step and time it started at.
    pub stage: u64,
    pub stage_start: (u64, f64),
    pub quasi_static: Option<QuasiStaticMemory<D>>,
    pub impactors: Vec<ImpactorState<D>>,
}

/// When and where a run writes its checkpoint: at the snapshots (`[output] checkpoint`) and
/// every `checkpoint_interval` steps; each one replaces the last.
#[derive(Debug, Clone)]
pub struct Checkpoints {
    pub path: PathBuf,
    pub origin: Origin,
    /// The snapshots' schedule, when checkpoints go with them.
    pub snapshots: Option<Every>,
    pub interval: Option<u64>,
}

impl Checkpoints {
    pub fn wants(&self, step: u64, last: bool) -> bool {
        self.snapshots.is_some_and(|e| e.hits(step, last))
            || self.interval.is_some_and(|n| step.is_multiple_of(n))
    }

    pub fn write<const D: usize>(
        &self,
        state: &State<D>,
        driver: &DriverState<D>,
    ) -> io::Result<()> {
        write(&self.path, &self.origin, state, driver)
    }
}

/// Why a checkpoint cannot be continued.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("no checkpoint to restart from: {} does not exist (a run writes it at every snapshot unless [output] checkpoint = false)", .0.display())]
    Missing(PathBuf),
    #[error("{0}")]
    Io(#[from] io::Error),
    #[error("{} is not a peridyn checkpoint (it does not start with {:?})", .0.display(), std::str::from_utf8(MAGIC).unwrap_or_default())]
    NotCheckpoint(PathBuf),
    #[error("{} has checkpoint format {found}; this peridyn reads format {FORMAT}", path.display())]
    Format { path: PathBuf, found: u32 },
    #[error("checkpoint {} was written by peridyn {found}; this is peridyn {}: continue the run with the version that started it", path.display(), env!("CARGO_PKG_VERSION"))]
    Version { path: PathBuf, found: String },
    #[error("checkpoint in {} was written by a different deck: {found_file} (resolved-deck hash {found_hash:016x}), not {deck_file} ({deck_hash:016x}); restart with the deck that started the run, or run this one into another folder", dir.display())]
    Deck {
        dir: PathBuf,
        found_file: String,
        found_hash: u64,
        deck_file: String,
        deck_hash: u64,
    },
    #[error("checkpoint {} holds {found} {what}; this deck builds {expected}", path.display())]
    Size {
        path: PathBuf,
        what: &'static str,
        found: u64,
        expected: u64,
    },
    #[error("checkpoint {} is truncated: {found} bytes, expected {expected}", path.display())]
    Truncated {
        path: PathBuf,
        found: u64,
        expected: u64,
    },
    #[error("checkpoint {} is corrupt: {what}", path.display())]
    Corrupt { path: PathBuf, what: String },
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// FNV-1a 64 continued from `hash` over `bytes`: simple, and stable across Rust versions
/// (unlike std's `DefaultHasher`).
fn fnv1a(mut hash: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        hash = (hash ^ b as u64).wrapping_mul(FNV_PRIME);
    }
    hash
}

/// A writer that hashes what passes through it.
struct Hashing<W: Write> {
    inner: W,
    hash: u64,
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash = fnv1a(self.hash, &buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

fn put_str(w: &mut impl Write, s: &str) -> io::Result<()> {
    w.write_all(&(s.len() as u32).to_le_bytes())?;
    w.write_all(s.as_bytes())
}

fn put_vectors<const D: usize>(w: &mut impl Write, v: &[Vector<D>]) -> io::Result<()> {
    v.iter()
        .flat_map(|x| x.iter())
        .try_for_each(|c| w.write_all(&c.to_le_bytes()))
}

/// Writes the checkpoint of `state` atomically to `path`.
pub fn write<const D: usize>(
    path: &Path,
    origin: &Origin,
    state: &State<D>,
    driver: &DriverState<D>,
) -> io::Result<()> {
    // Destructured without `..`: a field added to State fails to compile until it is saved.
    let State {
        time,
        step,
        u,
        v,
        current,
        force,
        body_force,
        status,
        history,
        previous,
        previous_matrices,
        broken,
        external_work,
        dissipated_viscous,
        dissipated_damage,
        dt,
        iterations,
    } = state;
    write_atomic_with(path, |file| {
        let mut w = Hashing {
            inner: file,
            hash: FNV_OFFSET,
        };
        w.write_all(MAGIC)?;
        w.write_all(&FORMAT.to_le_bytes())?;
        put_str(&mut w, &origin.version)?;
        put_str(&mut w, &origin.deck_file)?;
        w.write_all(&origin.deck_hash.to_le_bytes())?;
        let qs = driver.quasi_static.as_ref();
        let qs_previous = qs.and_then(|m| m.previous.as_ref());
        let predictor = qs_previous.map_or(0, |(_, p)| p.len());
        for size in [
            D,
            u.len(),
            status.len(),
            history.len(),
            previous.len(),
            previous_matrices.len(),
            predictor,
            driver.impactors.len(),
        ] {
            w.write_all(&(size as u64).to_le_bytes())?;
        }
        // The scalars in the order `restore` reads them: f64 and u64 alike as 8 bytes.
        let scalars: [u64; SCALARS] = [
            time.to_bits(),
            *step,
            *broken,
            external_work.to_bits(),
            dissipated_viscous.to_bits(),
            dissipated_damage.to_bits(),
            dt.to_bits(),
            *iterations,
            driver.next_dt.to_bits(),
            driver.since_change,
            driver.rejected,
            driver.stage,
            driver.stage_start.0,
            driver.stage_start.1.to_bits(),
            qs.is_some() as u64,
            qs.map_or(0.0, |m| m.increment).to_bits(),
            qs.map_or(0.0, |m| m.largest_load).to_bits(),
            qs.map_or(0, |m| m.iterations),
            qs_previous.is_some() as u64,
            qs_previous.map_or(0.0, |(t, _)| *t).to_bits(),
        ];
        for x in scalars {
            w.write_all(&x.to_le_bytes())?;
        }
        for a in [u, v, current, force, body_force] {
            put_vectors(&mut w, a)?;
        }
        w.write_all(status)?;
        history
            .iter()
            .try_for_each(|x| w.write_all(&x.to_le_bytes()))?;
        put_vectors(&mut w, previous)?;
        previous_matrices
            .iter()
            .try_for_each(|x| w.write_all(&x.to_le_bytes()))?;
        if let Some((_, displacements)) = qs_previous {
            put_vectors(&mut w, displacements)?;
        }
        for im in &driver.impactors {
            put_vectors(&mut w, &[im.position, im.velocity, im.force])?;
            w.write_all(&im.energy.to_le_bytes())?;
        }
        let hash = w.hash;
        w.inner.write_all(&hash.to_le_bytes())
    })
}

/// Reads the file front to back; running past its end is truncation.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], CheckpointError> {
        let end = self.pos.saturating_add(n);
        if end > self.bytes.len() {
            return Err(CheckpointError::Truncated {
                path: self.path.to_path_buf(),
                found: self.bytes.len() as u64,
                expected: end as u64,
            });
        }
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, CheckpointError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self) -> Result<u64, CheckpointError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn f64(&mut self) -> Result<f64, CheckpointError> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn str(&mut self) -> Result<String, CheckpointError> {
        let n = self.u32()? as usize;
        let bytes = self.take(n)?;
        String::from_utf8(bytes.to_vec()).map_err(|_| CheckpointError::Corrupt {
            path: self.path.to_path_buf(),
            what: "a header text is not UTF-8".into(),
        })
    }
    fn vectors<const D: usize>(&mut self, out: &mut [Vector<D>]) -> Result<(), CheckpointError> {
        let bytes = self.take(out.len() * D * 8)?;
        for (x, chunk) in out
            .iter_mut()
            .flat_map(|x| x.iter_mut())
            .zip(bytes.chunks_exact(8))
        {
            *x = f64::from_le_bytes(chunk.try_into().expect("8 bytes"));
        }
        Ok(())
    }
}

/// Whether a checkpoint's `found` history words, where this build keeps `expected` for the
/// same deck, are a per-bond record it no longer needs: none kept now, a whole number of words
/// per bond entry in the file. PMB under one critical energy wrote two words per bond (the
/// trapezoidal work record) before its work was taken in closed form, ½ f e, which is what
/// the record summed for a linear bond (`damage::Work::Stored`); such a checkpoint continues
/// without it.
fn unused_history(found: u64, expected: usize, bond_entries: usize) -> bool {
    expected == 0 && bond_entries > 0 && found != 0 && found.is_multiple_of(bond_entries as u64)
}

/// Restores `state` (built by the same deck) and returns the driver state from the checkpoint
/// at `path`, refusing one from another program or deck, of other sizes, truncated or corrupt.
pub fn restore<const D: usize>(
    path: &Path,
    origin: &Origin,
    state: &mut State<D>,
) -> Result<DriverState<D>, CheckpointError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(CheckpointError::Missing(path.to_path_buf()))
        }
        Err(e) => return Err(with_path(e, "cannot read", path).into()),
    };
    let mut r = Reader {
        bytes: &bytes,
        pos: 0,
        path,
    };
    if r.take(MAGIC.len()).ok() != Some(MAGIC.as_slice()) {
        return Err(CheckpointError::NotCheckpoint(path.to_path_buf()));
    }
    let format = r.u32()?;
    if format != FORMAT {
        return Err(CheckpointError::Format {
            path: path.to_path_buf(),
            found: format,
        });
    }
    let (version, deck_file, deck_hash) = (r.str()?, r.str()?, r.u64()?);
    if version != origin.version {
        return Err(CheckpointError::Version {
            path: path.to_path_buf(),
            found: version,
        });
    }
    if deck_hash != origin.deck_hash {
        return Err(CheckpointError::Deck {
            dir: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
            found_file: deck_file,
            found_hash: deck_hash,
            deck_file: origin.deck_file.clone(),
            deck_hash: origin.deck_hash,
        });
    }
    let State {
        time,
        step,
        u,
        v,
        current,
        force,
        body_force,
        status,
        history,
        previous,
        previous_matrices,
        broken,
        external_work,
        dissipated_viscous,
        dissipated_damage,
        dt,
        iterations,
    } = state;
    // History words in the file: a record that this build's damage law no longer keeps is
    // read past (see `unused_history`).
    let mut file_history = history.len();
    for (what, expected) in [
        ("dimensions", D),
        ("nodes", u.len()),
        ("directed bond entries", status.len()),
        ("damage history words", history.len()),
        ("previous positions", previous.len()),
        ("previous own-half matrix words", previous_matrices.len()),
    ] {
        let found = r.u64()?;
        if what == "damage history words" && unused_history(found, expected, status.len()) {
            file_history = found as usize;
            continue;
        }
        if found != expected as u64 {
            return Err(CheckpointError::Size {
                path: path.to_path_buf(),
                what,
                found,
                expected: expected as u64,
            });
        }
    }
    let n = u.len();
    let predictor = r.u64()? as usize;
    if predictor != 0 && predictor != n {
        return Err(CheckpointError::Size {
            path: path.to_path_buf(),
            what: "quasi-static predictor displacements",
            found: predictor as u64,
            expected: n as u64,
        });
    }
    let impactors = r.u64()? as usize;
    let payload = SCALARS * 8
        + 5 * n * D * 8
        + status.len()
        + (file_history + previous_matrices.len()) * 8
        + (previous.len() + predictor) * D * 8
        + impactors.saturating_mul((3 * D + 1) * 8);
    let expected = r.pos.saturating_add(payload).saturating_add(8) as u64;
    if bytes.len() as u64 != expected {
        return Err(CheckpointError::Truncated {
            path: path.to_path_buf(),
            found: bytes.len() as u64,
            expected,
        });
    }
    let body = &bytes[..bytes.len() - 8];
    let stored = u64::from_le_bytes(bytes[body.len()..].try_into().expect("8 bytes"));
    if fnv1a(FNV_OFFSET, body) != stored {
        return Err(CheckpointError::Corrupt {
            path: path.to_path_buf(),
            what: "its checksum does not match its contents".into(),
        });
    }
    *time = r.f64()?;
    *step = r.u64()?;
    *broken = r.u64()?;
    *external_work = r.f64()?;
    *dissipated_viscous = r.f64()?;
    *dissipated_damage = r.f64()?;
    *dt = r.f64()?;
    *iterations = r.u64()?;
    let mut driver = DriverState {
        next_dt: r.f64()?,
        since_change: r.u64()?,
        rejected: r.u64()?,
        stage: r.u64()?,
        stage_start: (r.u64()?, r.f64()?),
        quasi_static: None,
        impactors: Vec::with_capacity(impactors),
    };
    let qs = r.u64()? == 1;
    let (increment, largest_load, iterations) = (r.f64()?, r.f64()?, r.u64()?);
    let (has_previous, previous_time) = (r.u64()? == 1, r.f64()?);
    for a in [u, v, current, force, body_force] {
        r.vectors(a)?;
    }
    let bond_entries = status.len();
    status.copy_from_slice(r.take(bond_entries)?);
    // (Nothing is copied from a record this build does not keep: `history` is empty then.)
    for (x, chunk) in history
        .iter_mut()
        .zip(r.take(file_history * 8)?.chunks_exact(8))
    {
        *x = f64::from_le_bytes(chunk.try_into().expect("8 bytes"));
    }
    r.vectors(previous)?;
    let words = previous_matrices.len();
    for (x, chunk) in previous_matrices
        .iter_mut()
        .zip(r.take(words * 8)?.chunks_exact(8))
    {
        *x = f64::from_le_bytes(chunk.try_into().expect("8 bytes"));
    }
    if qs {
        let mut displacements = vec![Vector::<D>::zeros(); predictor];
        r.vectors(&mut displacements)?;
        driver.quasi_static = Some(QuasiStaticMemory {
            increment,
            largest_load,
            iterations,
            previous: has_previous.then_some((previous_time, displacements)),
        });
    }
    for _ in 0..impactors {
        let mut motion = [Vector::<D>::zeros(); 3];
        r.vectors(&mut motion)?;
        let [position, velocity, force] = motion;
        driver.impactors.push(ImpactorState {
            position,
            velocity,
            force,
            energy: r.f64()?,
        });
    }
    Ok(driver)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_the_reference_values() {
        // From the FNV reference test suite.
        assert_eq!(fnv1a(FNV_OFFSET, b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a(FNV_OFFSET, b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a(FNV_OFFSET, b"foobar"), 0x85944171f73967e8);
    }

    /// A state of three nodes and six bond entries with `words` history words per entry,
    /// every field set to something other than its reference value.
    fn state(words: usize) -> State<2> {
        let vectors = |k: f64| (0..3).map(|i| Vector::<2>::new(k * i as f64, -k)).collect();
        State {
            time: 0.25,
            step: 7,
            u: vectors(1e-6),
            v: vectors(2.0),
            current: vectors(1e-3),
            force: vectors(5e9),
            body_force: vectors(0.0),
            status: vec![0, 1, 0, 0, 3, 0],
            history: (0..6 * words).map(|k| 1.5 * k as f64).collect(),
            previous: Vec::new(),
            previous_matrices: Vec::new(),
            broken: 2,
            external_work: 4.0,
            dissipated_viscous: 0.5,
            dissipated_damage: 1.5,
            dt: 1e-8,
            iterations: 3,
        }
    }

    /// A checkpoint with a per-bond record that this build keeps none of for the deck (PMB's
    /// critical-energy work record before its closed form) continues without it; a record of
    /// another size than this build keeps is still refused.
    #[test]
    fn a_history_record_no_longer_kept_is_read_past() {
        let dir = std::env::temp_dir().join(format!("peridyn-checkpoint-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        let origin = Origin::new("deck", Path::new("deck.toml"));
        let old = state(2);
        write(&path, &origin, &old, &DriverState::default()).unwrap();

        let mut now = state(0);
        now.u.fill(Vector::zeros());
        now.status.fill(0);
        now.step = 0;
        let driver = restore(&path, &origin, &mut now).unwrap();
        assert_eq!(driver, DriverState::default());
        assert!(now.u == old.u && now.status == old.status && now.step == old.step);
        assert!(now.force == old.force && now.dissipated_damage == old.dissipated_damage);
        assert!(now.history.is_empty());

        let mut other = state(4);
        let refused = restore(&path, &origin, &mut other);
        assert!(
            matches!(
                refused,
                Err(CheckpointError::Size {
                    what: "damage history words",
                    found: 12,
                    expected: 24,
                    ..
                })
            ),
            "{refused:?}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
