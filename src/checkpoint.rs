//! The checkpoint file `checkpoint.bin`: every field of `State` and the driver's own state, so
//! a killed run continues bitwise as if it had not stopped. Little-endian binary:
//!
//! - magic `PDYNCKPT`, format (u32);
//! - origin: peridyn version and deck file (u32 length + UTF-8 each), hash of the resolved deck
//!   (u64, FNV-1a 64 of its text);
//! - sizes (u64 each): dimension, nodes, directed bond entries, history words, previous
//!   positions, previous own-half matrices (words), the quasi-static predictor's
//!   displacements (0 or nodes), impactors, and the load step in progress (0: none; 1: a
//!   paused ADR relaxation; 2: one with its start kept for the Gershgorin fallback; 3: a
//!   paused NCG minimisation);
//! - payload: the State scalars, the driver state (time step controller, stage in progress,
//!   quasi-static solver), then the arrays (u, v, current, force, body_force as D f64 per
//!   node; status as u8; history as f64; previous as D f64 each; the previous matrices as
//!   f64; the predictor's
//!   displacements as D f64 each; per impactor its position, velocity and force as D f64
//!   each and its penalty energy);
//! - the load step in progress, when the quasi-static solver paused inside one: its scalars
//!   (t0, t1, the iterations, equilibria, broken bond halves and residual so far, the
//!   relaxation's iterations and its first residual, or for NCG its iterations since the last
//!   restart), then u0, the applied forces at t0, the ADR velocities and last accelerations
//!   or the NCG search direction (D f64 per node each), the work record (history, previous
//!   positions, previous matrices, as the state's), and with the fallback start its u,
//!   current positions, forces, body forces and work record;
//! - FNV-1a 64 of every byte before it.
//!
//! Written atomically (temp file + rename): the file on disk is always a whole checkpoint.

use crate::atomic_file::{with_path, write_atomic_with};
use crate::math::Vector;
use crate::observe::Every;
use crate::solver::impactor::ImpactorState;
use crate::solver::quasi_static::{LoadStepReport, QuasiStaticMemory, StepInProgress};
use crate::solver::quasi_static_memory::{RelaxationPaused, RelaxationStart, WorkRecord};
use crate::state::State;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub const FILE_NAME: &str = "checkpoint.bin";
const MAGIC: &[u8; 8] = b"PDYNCKPT";
const FORMAT: u32 = 6;
/// The earliest format still read: 4, before load steps could pause (without the header's
/// word for the load step in progress and the Gershgorin scalar), and 5, before the spectral
/// radius was kept (without its three scalars).
const EARLIER_FORMAT: u32 = 4;
/// State and driver scalars in the payload.
const SCALARS: usize = 24;

/// The scalars a checkpoint of `format` holds.
fn scalars_in(format: u32) -> usize {
    match format {
        4 => SCALARS - 4,
        5 => SCALARS - 3,
        _ => SCALARS,
    }
}
/// Scalars of a load step in progress.
const IN_STEP_SCALARS: usize = 8;

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

/// When and where a run writes its checkpoint: at the snapshots (`[output] checkpoint`),
/// every `checkpoint_interval` steps, and (for the runs of studies and validation cases) at the
/// first step after a stretch of wall time; each one replaces the last.
#[derive(Debug, Clone)]
pub struct Checkpoints {
    pub path: PathBuf,
    pub origin: Origin,
    /// The snapshots' schedule, when checkpoints go with them.
    pub snapshots: Option<Every>,
    pub interval: Option<u64>,
    pub wall: Option<WallClock>,
}

/// Checkpoints by the clock: a run killed after hours loses at most `every` of them. Which
/// step a checkpoint falls on depends on the machine; the results do not, since a run
/// continued from any step is bitwise the run that did not stop.
#[derive(Debug, Clone)]
pub struct WallClock {
    pub every: Duration,
    pub last: Instant,
}

impl Checkpoints {
    /// Whether `step` gets a checkpoint; a step taken by the clock restarts it.
    pub fn wants(&mut self, step: u64, last: bool) -> bool {
        let by_clock = match self.wall.as_mut() {
            Some(w) if w.last.elapsed() >= w.every => {
                w.last = Instant::now();
                true
            }
            _ => false,
        };
        by_clock
            || self.snapshots.is_some_and(|e| e.hits(step, last))
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
    #[error("{} has checkpoint format {found}; this peridyn reads formats {EARLIER_FORMAT} to {FORMAT}", path.display())]
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
    #[error("checkpoint {} was written inside a quasi-static load step, which only a run in one process pauses in and continues: continue it without MPI", .0.display())]
    InsideLoadStep(PathBuf),
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// FNV-1a 64 of `bytes`: a fingerprint stable across Rust versions and machines.
pub fn fnv1a_64(bytes: &[u8]) -> u64 {
    fnv1a(FNV_OFFSET, bytes)
}

/// FNV-1a 64 continued from `hash` over `bytes`: simple, and stable across Rust versions
/// (unlike std's `DefaultHasher`).
fn fnv1a(mut hash: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        hash = (hash ^ b as u64).wrapping_mul(FNV_PRIME);
    }
    hash
}

/// A writer that hashes what passes through it.
pub struct Hashing<W: Write> {
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

fn put_f64s(w: &mut impl Write, a: &[f64]) -> io::Result<()> {
    a.iter().try_for_each(|x| w.write_all(&x.to_le_bytes()))
}

/// The load step the quasi-static solver paused in, when it did.
fn in_step<const D: usize>(driver: &DriverState<D>) -> Option<&StepInProgress<D>> {
    driver.quasi_static.as_ref()?.in_step.as_deref()
}

/// The header's word for the load step in progress (see the module docs).
fn in_step_kind<const D: usize>(driver: &DriverState<D>) -> u64 {
    in_step(driver).map_or(0, |p| match p.relaxation.fallback_start {
        _ if !p.direction.is_empty() => NCG_IN_STEP,
        Some(_) => 2,
        None => 1,
    })
}

/// The header's word for a load step paused inside an NCG minimisation.
const NCG_IN_STEP: u64 = 3;

fn put_record<const D: usize>(w: &mut impl Write, r: &WorkRecord<D>) -> io::Result<()> {
    put_f64s(w, &r.history)?;
    put_vectors(w, &r.previous)?;
    put_f64s(w, &r.previous_matrices)
}

/// The load step in progress, in the order `read_in_step` reads it.
fn put_in_step<const D: usize>(w: &mut impl Write, p: &StepInProgress<D>) -> io::Result<()> {
    let r = &p.report;
    let ncg = !p.direction.is_empty();
    let scalars: [u64; IN_STEP_SCALARS] = [
        p.t0.to_bits(),
        p.t1.to_bits(),
        r.iterations,
        r.equilibria as u64,
        r.broken,
        r.residual.to_bits(),
        p.relaxation.iterations,
        if ncg {
            p.relaxation.since_restart
        } else {
            p.relaxation.start_residual.to_bits()
        },
    ];
    for x in scalars {
        w.write_all(&x.to_le_bytes())?;
    }
    let relaxation = if ncg {
        vec![&p.direction]
    } else {
        vec![&p.velocity, &p.previous_acceleration]
    };
    for a in [&p.u0, &p.load0].into_iter().chain(relaxation) {
        put_vectors(w, a)?;
    }
    put_record(w, &p.record)?;
    if let Some(f) = &p.relaxation.fallback_start {
        for a in [&f.u, &f.current, &f.force, &f.body_force] {
            put_vectors(w, a)?;
        }
        put_record(w, &f.record)?;
    }
    Ok(())
}

/// The arrays of a checkpoint, in the file's order: the node vectors, the bond status and
/// history, a non-central model's previous evaluation (positions and own-half matrices) and
/// the quasi-static predictor's displacements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Section {
    U,
    V,
    Current,
    Force,
    BodyForce,
    Status,
    History,
    Previous,
    PreviousMatrices,
    Predictor,
}

impl Section {
    pub const ALL: [Section; 10] = [
        Section::U,
        Section::V,
        Section::Current,
        Section::Force,
        Section::BodyForce,
        Section::Status,
        Section::History,
        Section::Previous,
        Section::PreviousMatrices,
        Section::Predictor,
    ];
}

/// The lengths of the whole body's arrays, as the header gives them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sizes {
    pub nodes: usize,
    /// Directed bond entries.
    pub entries: usize,
    pub history: usize,
    /// Previous positions (0 or nodes).
    pub previous: usize,
    /// Previous own-half matrix words.
    pub matrices: usize,
    /// The quasi-static predictor's displacements (0 or nodes).
    pub predictor: usize,
}

impl Sizes {
    /// The sizes of a one-process run's arrays.
    pub fn of<const D: usize>(state: &State<D>, driver: &DriverState<D>) -> Self {
        Sizes {
            nodes: state.u.len(),
            entries: state.status.len(),
            history: state.history.len(),
            previous: state.previous.len(),
            matrices: state.previous_matrices.len(),
            predictor: predictor(driver).map_or(0, <[_]>::len),
        }
    }
}

/// The quasi-static predictor's displacements, when the driver has them.
fn predictor<const D: usize>(driver: &DriverState<D>) -> Option<&[Vector<D>]> {
    let qs = driver.quasi_static.as_ref()?;
    qs.previous.as_ref().map(|(_, u)| &u[..])
}

/// Writes `section` of the nodes `..owned` of `state` (all of them in one process; a rank's
/// owned nodes, which come first) and of all its bond entries.
pub fn write_section<const D: usize>(
    section: Section,
    state: &State<D>,
    driver: &DriverState<D>,
    owned: usize,
    w: &mut impl Write,
) -> io::Result<()> {
    match section {
        Section::U => put_vectors(w, &state.u[..owned]),
        Section::V => put_vectors(w, &state.v[..owned]),
        Section::Current => put_vectors(w, &state.current[..owned]),
        Section::Force => put_vectors(w, &state.force[..owned]),
        Section::BodyForce => put_vectors(w, &state.body_force[..owned]),
        Section::Status => w.write_all(&state.status),
        Section::History => put_f64s(w, &state.history),
        Section::Previous => put_vectors(w, &state.previous[..owned.min(state.previous.len())]),
        Section::PreviousMatrices => {
            let words = state.previous_matrices.len() / state.u.len().max(1);
            put_f64s(w, &state.previous_matrices[..owned * words])
        }
        Section::Predictor => match predictor(driver) {
            Some(u) => put_vectors(w, &u[..owned]),
            None => Ok(()),
        },
    }
}

/// The writer a checkpoint's arrays go through (it hashes them).
pub type SectionWriter<'a> = Hashing<&'a mut std::io::BufWriter<std::fs::File>>;

/// Writes the checkpoint of `state` atomically to `path`.
pub fn write<const D: usize>(
    path: &Path,
    origin: &Origin,
    state: &State<D>,
    driver: &DriverState<D>,
) -> io::Result<()> {
    let nodes = state.u.len();
    write_with(
        path,
        origin,
        &Sizes::of(state, driver),
        state,
        driver,
        |w| {
            Section::ALL
                .iter()
                .try_for_each(|&s| write_section(s, state, driver, nodes, w))
        },
    )
}

/// Writes a checkpoint atomically to `path`: the header of arrays of `sizes`, the scalars of
/// `state` and `driver`, then the arrays as `arrays` writes them ([`Section::ALL`] in order,
/// each of the whole body: a distributed run's come from every rank in turn), then the
/// impactors and the hash.
pub fn write_with<const D: usize>(
    path: &Path,
    origin: &Origin,
    sizes: &Sizes,
    state: &State<D>,
    driver: &DriverState<D>,
    arrays: impl FnOnce(&mut SectionWriter) -> io::Result<()>,
) -> io::Result<()> {
    // Destructured without `..`: a scalar added to State fails to compile until it is saved
    // (an array, until `Section` writes it).
    let State {
        time,
        step,
        u: _,
        v: _,
        current: _,
        force: _,
        body_force: _,
        status: _,
        history: _,
        previous: _,
        previous_matrices: _,
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
        let spectrum = qs.and_then(|m| m.spectrum);
        for size in [
            D,
            sizes.nodes,
            sizes.entries,
            sizes.history,
            sizes.previous,
            sizes.matrices,
            sizes.predictor,
            driver.impactors.len(),
            in_step_kind(driver) as usize,
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
            qs.is_some_and(|m| m.gershgorin) as u64,
            spectrum.is_some() as u64,
            spectrum.map_or(0.0, |s| s.0).to_bits(),
            spectrum.map_or(0, |s| s.1),
        ];
        for x in scalars {
            w.write_all(&x.to_le_bytes())?;
        }
        arrays(&mut w)?;
        for im in &driver.impactors {
            put_vectors(&mut w, &[im.position, im.velocity, im.force])?;
            w.write_all(&im.energy.to_le_bytes())?;
        }
        if let Some(p) = in_step(driver) {
            put_in_step(&mut w, p)?;
        }
        let hash = w.hash;
        w.inner.write_all(&hash.to_le_bytes())
    })
}

/// Reads a checkpoint front to back, from the file or from bytes already read; running past
/// its end is truncation. The arrays go straight into their destinations (a checkpoint of a
/// large run is as large as its state: reading it whole first would need its size twice).
struct Reader<'a, R> {
    source: R,
    pos: u64,
    /// The file's length, which a truncation names.
    len: u64,
    path: &'a Path,
}

/// Values converted per read of an array (64 KiB of bytes).
const CHUNK_VALUES: usize = 8192;

impl<'a, R: Read> Reader<'a, R> {
    fn new(source: R, len: u64, path: &'a Path) -> Self {
        Reader {
            source,
            pos: 0,
            len,
            path,
        }
    }
    fn fill(&mut self, out: &mut [u8]) -> Result<(), CheckpointError> {
        let end = self.pos.saturating_add(out.len() as u64);
        match self.source.read_exact(out) {
            Ok(()) => {
                self.pos = end;
                Ok(())
            }
            Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => Err(CheckpointError::Truncated {
                path: self.path.to_path_buf(),
                found: self.len,
                expected: end,
            }),
            Err(e) => Err(with_path(e, "cannot read", self.path).into()),
        }
    }
    fn take(&mut self, n: usize) -> Result<Vec<u8>, CheckpointError> {
        let mut bytes = vec![0; n];
        self.fill(&mut bytes)?;
        Ok(bytes)
    }
    fn skip(&mut self, n: u64) -> Result<(), CheckpointError> {
        let skipped = io::copy(&mut (&mut self.source).take(n), &mut io::sink())
            .map_err(|e| with_path(e, "cannot read", self.path))?;
        if skipped < n {
            return Err(CheckpointError::Truncated {
                path: self.path.to_path_buf(),
                found: self.pos + skipped,
                expected: self.pos + n,
            });
        }
        self.pos += n;
        Ok(())
    }
    fn u32(&mut self) -> Result<u32, CheckpointError> {
        let mut b = [0; 4];
        self.fill(&mut b)?;
        Ok(u32::from_le_bytes(b))
    }
    fn u64(&mut self) -> Result<u64, CheckpointError> {
        let mut b = [0; 8];
        self.fill(&mut b)?;
        Ok(u64::from_le_bytes(b))
    }
    fn f64(&mut self) -> Result<f64, CheckpointError> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn str(&mut self) -> Result<String, CheckpointError> {
        let n = self.u32()? as usize;
        let bytes = self.take(n)?;
        String::from_utf8(bytes).map_err(|_| CheckpointError::Corrupt {
            path: self.path.to_path_buf(),
            what: "a header text is not UTF-8".into(),
        })
    }
    fn f64s(&mut self, out: &mut [f64]) -> Result<(), CheckpointError> {
        let mut bytes = vec![0u8; 8 * out.len().min(CHUNK_VALUES)];
        for part in out.chunks_mut(CHUNK_VALUES) {
            let bytes = &mut bytes[..8 * part.len()];
            self.fill(bytes)?;
            for (x, b) in part.iter_mut().zip(bytes.chunks_exact(8)) {
                *x = f64::from_le_bytes(b.try_into().expect("8 bytes"));
            }
        }
        Ok(())
    }
    fn vectors<const D: usize>(&mut self, out: &mut [Vector<D>]) -> Result<(), CheckpointError> {
        let mut values = vec![0.0; (D * out.len()).min(CHUNK_VALUES)];
        for part in out.chunks_mut((CHUNK_VALUES / D).max(1)) {
            let values = &mut values[..D * part.len()];
            self.f64s(values)?;
            for (x, v) in part.iter_mut().zip(values.chunks_exact(D)) {
                x.copy_from_slice(v);
            }
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

/// What a checkpoint's header and scalars say, checked against the run continuing it.
struct Head<const D: usize> {
    /// The state's scalars (its arrays left empty).
    scalars: State<D>,
    /// The driver state but the quasi-static predictor's displacements and the impactors.
    driver: DriverState<D>,
    /// Whether the quasi-static memory has a predictor's point, and its time.
    predictor: Option<f64>,
    /// Sizes of the file's arrays (its history words may be a record this build reads past).
    sizes: Sizes,
    impactors: usize,
    /// The load step in progress (the header's word: 0 to 3).
    in_step: u64,
    /// Where the arrays begin.
    arrays: u64,
}

impl<const D: usize> Head<D> {
    /// Where `section` begins in the file, and its bytes per element (a node, an entry, a
    /// word).
    fn section(&self, section: Section) -> (u64, u64) {
        let n = self.sizes.nodes as u64;
        let vectors = 8 * D as u64;
        let matrix_words = (self.sizes.matrices / self.sizes.nodes.max(1)) as u64;
        let lengths = [
            n * vectors,
            n * vectors,
            n * vectors,
            n * vectors,
            n * vectors,
            self.sizes.entries as u64,
            8 * self.sizes.history as u64,
            vectors * self.sizes.previous as u64,
            8 * self.sizes.matrices as u64,
            vectors * self.sizes.predictor as u64,
        ];
        let k = Section::ALL
            .iter()
            .position(|&x| x == section)
            .expect("a section");
        let start = self.arrays + lengths[..k].iter().sum::<u64>();
        // An array the file does not hold (no previous evaluation, no predictor) has no
        // elements to read.
        let element = match section {
            Section::Status => 1,
            Section::History => 8,
            Section::PreviousMatrices => 8 * matrix_words,
            Section::Previous if self.sizes.previous == 0 => 0,
            Section::Predictor if self.sizes.predictor == 0 => 0,
            _ => vectors,
        };
        (start, element)
    }

    /// Where the impactors begin (after the arrays).
    fn impactors_start(&self) -> u64 {
        let (start, element) = self.section(Section::Predictor);
        start + element * self.sizes.predictor as u64
    }

    /// Where the load step in progress begins (after the impactors) and its length.
    fn in_step_bytes(&self) -> (u64, u64) {
        let start = self
            .impactors_start()
            .saturating_add((self.impactors as u64).saturating_mul(((3 * D + 1) * 8) as u64));
        let s = &self.sizes;
        let vectors = (s.nodes * D * 8) as u64;
        let record = (8 * (s.history + s.previous * D + s.matrices)) as u64;
        let len = match self.in_step {
            0 => 0,
            NCG_IN_STEP => (8 * IN_STEP_SCALARS) as u64 + 3 * vectors + record,
            kind => {
                let fallback = if kind == 2 { 4 * vectors + record } else { 0 };
                (8 * IN_STEP_SCALARS) as u64 + 4 * vectors + record + fallback
            }
        };
        (start, len)
    }
}

/// Reads and checks the header and scalars of a checkpoint of `file_len` bytes (`r` reads
/// its beginning): another program or deck, arrays of sizes other than `expected` (the
/// predictor's may be 0 or the nodes), or a length other than they give, are refused.
fn read_head<const D: usize>(
    r: &mut Reader<impl Read>,
    origin: &Origin,
    expected: &Sizes,
    file_len: u64,
) -> Result<Head<D>, CheckpointError> {
    let path = r.path;
    if r.take(MAGIC.len()).ok().as_deref() != Some(MAGIC.as_slice()) {
        return Err(CheckpointError::NotCheckpoint(path.to_path_buf()));
    }
    let format = r.u32()?;
    if !(EARLIER_FORMAT..=FORMAT).contains(&format) {
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
    // History words in the file: a record that this build's damage law no longer keeps is
    // read past (see `unused_history`).
    let mut sizes = *expected;
    for (what, want) in [
        ("dimensions", D),
        ("nodes", expected.nodes),
        ("directed bond entries", expected.entries),
        ("damage history words", expected.history),
        ("previous positions", expected.previous),
        ("previous own-half matrix words", expected.matrices),
    ] {
        let found = r.u64()?;
        if what == "damage history words" && unused_history(found, want, expected.entries) {
            sizes.history = found as usize;
            continue;
        }
        if found != want as u64 {
            return Err(CheckpointError::Size {
                path: path.to_path_buf(),
                what,
                found,
                expected: want as u64,
            });
        }
    }
    let n = expected.nodes;
    sizes.predictor = r.u64()? as usize;
    if sizes.predictor != 0 && sizes.predictor != n {
        return Err(CheckpointError::Size {
            path: path.to_path_buf(),
            what: "quasi-static predictor displacements",
            found: sizes.predictor as u64,
            expected: n as u64,
        });
    }
    let impactors = r.u64()? as usize;
    // Format 4 has no load step in progress, nor the Gershgorin scalar; format 5 no spectrum.
    let pauses = format >= 5;
    let in_step = if pauses { r.u64()? } else { 0 };
    if in_step > NCG_IN_STEP {
        return Err(CheckpointError::Corrupt {
            path: path.to_path_buf(),
            what: format!("its load step in progress is marked {in_step} (0 to 3 expected)"),
        });
    }
    // A paused load step's work record has the state's history words.
    if in_step != 0 && sizes.history != expected.history {
        return Err(CheckpointError::Size {
            path: path.to_path_buf(),
            what: "damage history words",
            found: sizes.history as u64,
            expected: expected.history as u64,
        });
    }
    let arrays = r.pos + (scalars_in(format) * 8) as u64;
    let mut head = Head {
        scalars: State::empty(),
        driver: DriverState::default(),
        predictor: None,
        sizes,
        impactors,
        in_step,
        arrays,
    };
    let (in_step_start, in_step_len) = head.in_step_bytes();
    let expected_len = in_step_start.saturating_add(in_step_len).saturating_add(8);
    if file_len != expected_len {
        return Err(CheckpointError::Truncated {
            path: path.to_path_buf(),
            found: file_len,
            expected: expected_len,
        });
    }
    let s = &mut head.scalars;
    s.time = r.f64()?;
    s.step = r.u64()?;
    s.broken = r.u64()?;
    s.external_work = r.f64()?;
    s.dissipated_viscous = r.f64()?;
    s.dissipated_damage = r.f64()?;
    s.dt = r.f64()?;
    s.iterations = r.u64()?;
    head.driver = DriverState {
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
    let gershgorin = pauses && r.u64()? == 1;
    let spectrum = match format >= 6 {
        true => {
            let (measured, rho, evaluations) = (r.u64()? == 1, r.f64()?, r.u64()?);
            measured.then_some((rho, evaluations))
        }
        false => None,
    };
    if qs {
        head.driver.quasi_static = Some(QuasiStaticMemory {
            increment,
            largest_load,
            iterations,
            previous: None,
            gershgorin,
            spectrum,
            in_step: None,
        });
        head.predictor = has_previous.then_some(previous_time);
    } else if in_step != 0 {
        return Err(CheckpointError::Corrupt {
            path: path.to_path_buf(),
            what: "a load step in progress without a quasi-static solver".into(),
        });
    }
    Ok(head)
}

/// The impactors' motion and penalty energy (`r` at their start).
fn read_impactors<const D: usize>(
    r: &mut Reader<impl Read>,
    count: usize,
) -> Result<Vec<ImpactorState<D>>, CheckpointError> {
    (0..count)
        .map(|_| {
            let mut motion = [Vector::<D>::zeros(); 3];
            r.vectors(&mut motion)?;
            let [position, velocity, force] = motion;
            Ok(ImpactorState {
                position,
                velocity,
                force,
                energy: r.f64()?,
            })
        })
        .collect()
}

/// The quasi-static memory with the predictor's displacements, when it has a point.
fn with_predictor<const D: usize>(head: &mut Head<D>, displacements: Vec<Vector<D>>) {
    if let (Some(m), Some(t)) = (head.driver.quasi_static.as_mut(), head.predictor) {
        m.previous = Some((t, displacements));
    }
}

/// Opens the checkpoint at `path` and its length.
fn open(path: &Path) -> Result<(std::fs::File, u64), CheckpointError> {
    let file = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(CheckpointError::Missing(path.to_path_buf()))
        }
        Err(e) => return Err(with_path(e, "cannot open", path).into()),
    };
    let len = file
        .metadata()
        .map_err(|e| with_path(e, "cannot read", path))?
        .len();
    Ok((file, len))
}

/// Checks the checksum at the end of the checkpoint `file` of `len` bytes, reading it once
/// in pieces; leaves the file at its start.
fn check_sum(file: &mut std::fs::File, len: u64, path: &Path) -> Result<(), CheckpointError> {
    use std::io::{Seek, SeekFrom};
    let cannot = |e: io::Error| CheckpointError::from(with_path(e, "cannot read", path));
    if len < 8 {
        return Err(CheckpointError::NotCheckpoint(path.to_path_buf()));
    }
    file.seek(SeekFrom::Start(0)).map_err(cannot)?;
    let mut hash = FNV_OFFSET;
    let mut left = len - 8;
    let mut chunk = vec![0u8; 1 << 22];
    while left > 0 {
        let n = left.min(chunk.len() as u64) as usize;
        file.read_exact(&mut chunk[..n]).map_err(cannot)?;
        hash = fnv1a(hash, &chunk[..n]);
        left -= n as u64;
    }
    let mut tail = [0u8; 8];
    file.read_exact(&mut tail).map_err(cannot)?;
    file.seek(SeekFrom::Start(0)).map_err(cannot)?;
    match u64::from_le_bytes(tail) == hash {
        true => Ok(()),
        false => Err(corrupt(path)),
    }
}

fn corrupt(path: &Path) -> CheckpointError {
    CheckpointError::Corrupt {
        path: path.to_path_buf(),
        what: "its checksum does not match its contents".into(),
    }
}

/// Restores `state` (built by the same deck) and returns the driver state from the checkpoint
/// at `path`, refusing one from another program or deck, of other sizes, truncated or corrupt.
/// The file is read twice, in pieces (its checksum, then its arrays into `state`): never
/// whole, so a run continues in the memory it ran in.
pub fn restore<const D: usize>(
    path: &Path,
    origin: &Origin,
    state: &mut State<D>,
) -> Result<DriverState<D>, CheckpointError> {
    let (mut file, len) = open(path)?;
    let expected = Sizes::of(state, &DriverState::default());
    // The header first, so that another deck or program is named rather than a checksum.
    let mut head = {
        let mut r = Reader::new(io::BufReader::new(&mut file).take(HEAD_BYTES), len, path);
        read_head::<D>(&mut r, origin, &expected, len)?
    };
    check_sum(&mut file, len, path)?;
    let mut r = Reader::new(io::BufReader::with_capacity(1 << 20, file), len, path);
    r.skip(head.arrays)?;
    state.step_scalars_from(&head.scalars);
    for a in [
        &mut state.u,
        &mut state.v,
        &mut state.current,
        &mut state.force,
        &mut state.body_force,
    ] {
        r.vectors(a)?;
    }
    r.fill(&mut state.status)?;
    // A record this build does not keep is read past (`history` is empty then).
    if head.sizes.history == state.history.len() {
        r.f64s(&mut state.history)?;
    } else {
        r.skip(8 * head.sizes.history as u64)?;
    }
    r.vectors(&mut state.previous)?;
    r.f64s(&mut state.previous_matrices)?;
    let mut displacements = vec![Vector::<D>::zeros(); head.sizes.predictor];
    r.vectors(&mut displacements)?;
    with_predictor(&mut head, displacements);
    head.driver.impactors = read_impactors(&mut r, head.impactors)?;
    if head.in_step != 0 {
        let p = read_in_step(&mut r, state, head.in_step)?;
        if let Some(m) = head.driver.quasi_static.as_mut() {
            m.in_step = Some(Box::new(p));
        }
    }
    Ok(head.driver)
}

/// The load step in progress (`r` at its start), with arrays of `state`'s sizes.
fn read_in_step<const D: usize>(
    r: &mut Reader<impl Read>,
    state: &State<D>,
    kind: u64,
) -> Result<StepInProgress<D>, CheckpointError> {
    let n = state.u.len();
    let vectors = |r: &mut Reader<_>| -> Result<Vec<Vector<D>>, CheckpointError> {
        let mut v = vec![Vector::<D>::zeros(); n];
        r.vectors(&mut v)?;
        Ok(v)
    };
    let (t0, t1) = (r.f64()?, r.f64()?);
    let report = LoadStepReport {
        iterations: r.u64()?,
        equilibria: r.u64()? as u32,
        broken: r.u64()?,
        residual: r.f64()?,
    };
    let (iterations, last) = (r.u64()?, r.u64()?);
    let (u0, load0) = (vectors(r)?, vectors(r)?);
    let ncg = kind == NCG_IN_STEP;
    let (start_residual, since_restart) = if ncg {
        (0.0, last)
    } else {
        (f64::from_bits(last), 0)
    };
    let (velocity, previous_acceleration, direction) = if ncg {
        (Vec::new(), Vec::new(), vectors(r)?)
    } else {
        (vectors(r)?, vectors(r)?, Vec::new())
    };
    let record = read_record(r, state)?;
    let fallback_start = if kind == 2 {
        Some(RelaxationStart {
            u: vectors(r)?,
            current: vectors(r)?,
            force: vectors(r)?,
            body_force: vectors(r)?,
            record: read_record(r, state)?,
        })
    } else {
        None
    };
    Ok(StepInProgress {
        t0,
        t1,
        u0,
        load0,
        report,
        record,
        relaxation: RelaxationPaused {
            iterations,
            start_residual,
            since_restart,
            fallback_start,
        },
        velocity,
        previous_acceleration,
        direction,
    })
}

/// A work record of `state`'s sizes.
fn read_record<const D: usize>(
    r: &mut Reader<impl Read>,
    state: &State<D>,
) -> Result<WorkRecord<D>, CheckpointError> {
    let mut history = vec![0.0; state.history.len()];
    r.f64s(&mut history)?;
    let mut previous = vec![Vector::<D>::zeros(); state.previous.len()];
    r.vectors(&mut previous)?;
    let mut previous_matrices = vec![0.0; state.previous_matrices.len()];
    r.f64s(&mut previous_matrices)?;
    Ok(WorkRecord {
        history,
        previous,
        previous_matrices,
    })
}

/// A checkpoint read by parts, for a distributed restart: rank 0 hands each rank its part
/// without holding the whole body's arrays. The header, sizes, length and checksum are checked
/// as `restore` checks them (the checksum in one pass over the file); the arrays stay in the
/// file until a part is read.
pub struct Parts<const D: usize> {
    file: std::fs::File,
    head: Head<D>,
}

/// The header and scalars of a checkpoint fit in this many bytes (the deck's path is the
/// longest part).
const HEAD_BYTES: u64 = 1 << 20;

impl<const D: usize> Parts<D> {
    /// Opens the checkpoint at `path` of a run whose whole body's arrays have `expected`
    /// sizes.
    pub fn open(path: &Path, origin: &Origin, expected: &Sizes) -> Result<Self, CheckpointError> {
        use std::io::{Seek, SeekFrom};
        let (mut file, len) = open(path)?;
        let mut head = {
            let mut r = Reader::new(io::BufReader::new(&mut file).take(HEAD_BYTES), len, path);
            read_head::<D>(&mut r, origin, expected, len)?
        };
        if head.in_step != 0 {
            return Err(CheckpointError::InsideLoadStep(path.to_path_buf()));
        }
        check_sum(&mut file, len, path)?;
        let start = head.impactors_start();
        file.seek(SeekFrom::Start(start))
            .map_err(|e| with_path(e, "cannot read", path))?;
        let mut r = Reader::new(io::BufReader::new(&mut file), len, path);
        head.driver.impactors = read_impactors(&mut r, head.impactors)?;
        Ok(Parts { file, head })
    }

    /// The state's scalars (arrays empty).
    pub fn scalars(&self) -> &State<D> {
        &self.head.scalars
    }

    /// The driver state; its quasi-static memory's predictor displacements are read by part
    /// (`Section::Predictor`): `predictor_time` says whether it has them.
    pub fn driver(&self) -> &DriverState<D> {
        &self.head.driver
    }

    /// The time of the quasi-static predictor's point, when the memory has one.
    pub fn predictor_time(&self) -> Option<f64> {
        self.head.predictor
    }

    /// The little-endian bytes of elements `first..first + count` of `section` (nodes,
    /// entries or history words).
    pub fn read(&mut self, section: Section, first: usize, count: usize) -> io::Result<Vec<u8>> {
        use std::io::{Read, Seek, SeekFrom};
        let (start, element) = self.head.section(section);
        let mut bytes = vec![0u8; count * element as usize];
        self.file
            .seek(SeekFrom::Start(start + first as u64 * element))?;
        self.file.read_exact(&mut bytes)?;
        Ok(bytes)
    }
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

    /// The quasi-static solver's memory inside a paused load step (its start, its decisions
    /// so far, the relaxation's velocities and start) comes back as it was written; one
    /// process continues it, a distributed restart refuses it by name.
    #[test]
    fn a_load_step_paused_inside_comes_back_whole() {
        let dir = std::env::temp_dir().join(format!("peridyn-in-step-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        let origin = Origin::new("deck", Path::new("deck.toml"));
        let saved = state(1);
        let vectors = |k: f64| -> Vec<Vector<2>> {
            (0..3).map(|i| Vector::<2>::new(k + i as f64, -k)).collect()
        };
        let record = |k: f64| WorkRecord {
            history: (0..6).map(|i| k * i as f64).collect(),
            previous: Vec::new(),
            previous_matrices: Vec::new(),
        };
        let in_step = StepInProgress {
            t0: 0.3,
            t1: 0.4,
            u0: vectors(1.0),
            load0: vectors(2.0),
            report: LoadStepReport {
                iterations: 812,
                equilibria: 3,
                broken: 14,
                residual: 2.5e-3,
            },
            record: record(0.5),
            relaxation: RelaxationPaused {
                iterations: 97,
                start_residual: 0.125,
                since_restart: 0,
                fallback_start: Some(RelaxationStart {
                    u: vectors(5.0),
                    current: vectors(6.0),
                    force: vectors(7.0),
                    body_force: vectors(8.0),
                    record: record(0.25),
                }),
            },
            velocity: vectors(3.0),
            previous_acceleration: vectors(4.0),
            direction: Vec::new(),
        };
        let driver = DriverState {
            quasi_static: Some(QuasiStaticMemory {
                increment: 0.1,
                largest_load: 9.0,
                previous: Some((0.2, vectors(9.0))),
                iterations: 4000,
                gershgorin: true,
                spectrum: None,
                in_step: Some(Box::new(in_step)),
            }),
            ..DriverState::default()
        };
        write(&path, &origin, &saved, &driver).unwrap();
        let mut now = state(1);
        now.u.fill(Vector::zeros());
        let restored = restore(&path, &origin, &mut now).unwrap();
        assert_eq!(restored, driver);
        assert!(now.u == saved.u && now.history == saved.history);
        // Without the fallback start the block is shorter, and still read whole.
        let mut shorter = driver.clone();
        if let Some(p) = shorter
            .quasi_static
            .as_mut()
            .and_then(|m| m.in_step.as_mut())
        {
            p.relaxation.fallback_start = None;
        }
        write(&path, &origin, &saved, &shorter).unwrap();
        assert_eq!(restore(&path, &origin, &mut now).unwrap(), shorter);
        // A paused NCG minimisation keeps its direction and restart count instead.
        let mut ncg = shorter.clone();
        if let Some(p) = ncg.quasi_static.as_mut().and_then(|m| m.in_step.as_mut()) {
            p.relaxation.start_residual = 0.0;
            p.relaxation.since_restart = 41;
            p.velocity.clear();
            p.previous_acceleration.clear();
            p.direction = vectors(10.0);
        }
        write(&path, &origin, &saved, &ncg).unwrap();
        assert_eq!(restore(&path, &origin, &mut now).unwrap(), ncg);
        let parts = Parts::<2>::open(&path, &origin, &Sizes::of(&saved, &shorter));
        assert!(
            matches!(parts, Err(CheckpointError::InsideLoadStep(_))),
            "{:?}",
            parts.err()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Checkpoints of formats 4 (before load steps could pause: no word for a load step in
    /// progress in the header, no Gershgorin scalar) and 5 (before the spectral radius was
    /// kept) continue: a run in progress survives the upgrade, and measures its spectrum
    /// again.
    #[test]
    fn checkpoints_of_formats_4_and_5_continue() {
        let dir = std::env::temp_dir().join(format!("peridyn-format-4-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        let origin = Origin::new("deck", Path::new("deck.toml"));
        let saved = state(1);
        let mut driver = DriverState {
            quasi_static: Some(QuasiStaticMemory {
                increment: 0.1,
                largest_load: 9.0,
                previous: None,
                iterations: 4000,
                gershgorin: false,
                spectrum: Some((3.5, 12)),
                in_step: None,
            }),
            ..DriverState::default()
        };
        write(&path, &origin, &saved, &driver).unwrap();
        let mut now = state(1);
        assert_eq!(restore(&path, &origin, &mut now).unwrap(), driver);
        let written = std::fs::read(&path).unwrap();
        let sizes = 8 + 4 + (4 + origin.version.len()) + (4 + origin.deck_file.len()) + 8;
        let scalar = |k: usize| sizes + 9 * 8 + k * 8;
        let rewrite = |bytes: &mut Vec<u8>, format: u32| {
            bytes[8..12].copy_from_slice(&format.to_le_bytes());
            let body = bytes.len() - 8;
            let hash = fnv1a(FNV_OFFSET, &bytes[..body]);
            bytes[body..].copy_from_slice(&hash.to_le_bytes());
            std::fs::write(&path, &bytes).unwrap();
        };
        // The same checkpoint as format 5 wrote it: no spectrum.
        let mut bytes = written.clone();
        bytes.drain(scalar(21)..scalar(24));
        rewrite(&mut bytes, 5);
        driver.quasi_static.as_mut().unwrap().spectrum = None;
        now.u.fill(Vector::zeros());
        assert_eq!(restore(&path, &origin, &mut now).unwrap(), driver);
        assert!(now.u == saved.u && now.history == saved.history && now.time == saved.time);
        // As format 4 wrote it: nor the Gershgorin scalar, nor the load step's header word.
        bytes.drain(scalar(20)..scalar(21));
        bytes.drain(sizes + 8 * 8..sizes + 9 * 8);
        rewrite(&mut bytes, 4);
        now.u.fill(Vector::zeros());
        assert_eq!(restore(&path, &origin, &mut now).unwrap(), driver);
        assert!(now.u == saved.u && now.history == saved.history && now.time == saved.time);
        let _ = std::fs::remove_dir_all(&dir);
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
