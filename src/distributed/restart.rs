//! Continuing a distributed run from its checkpoint (`--restart`), on any number of ranks:
//! `checkpoint.bin` is the file one process writes whatever the number of ranks that wrote
//! it, so rank 0 opens it (with every check of `checkpoint::restore`: program, deck, sizes,
//! length, checksum) and reads each rank's part from it in turn: the scalars of the state and
//! of the driver (the same on every rank: the adaptive step's controller, the stage in
//! progress, the quasi-static solver's increment, largest load and iteration count, the
//! impactors' motion and penalty energy), its owned nodes' u, v, y, f and b, the quasi-static
//! predictor's last displacements and a non-central model's previous positions and own-half
//! matrices, and its rows' bond status and history (a rank's rows are contiguous in the
//! global order: they follow the rows of the ranks before it). The ghosts then take their
//! owners' u, v and y (and previous positions) by the halo exchange, not from the file. Rank
//! 0 holds one rank's part at a time, never the whole body's arrays.

use crate::checkpoint::{DriverState, Origin, Parts, Section, Sizes};
use crate::material::Material;
use crate::math::Vector;
use crate::run::{RunControl, RunError};
use crate::solver::impactor::ImpactorState;
use crate::solver::quasi_static::QuasiStaticMemory;
use crate::solver::ranks::{bytes_from_words, bytes_to_words};
use crate::solver::Simulation;
use crate::state::State;
use std::path::Path;

/// Where a rank's share lies in the whole state: its owned nodes (global indices
/// `first..first + owned`), its bond entries and history words (counts; their offsets are the
/// counts of the ranks before it).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rows {
    first: usize,
    owned: usize,
    entries: usize,
    history: usize,
}

/// The scalars a part starts with: the state's and the driver's, and the impactors' count
/// (their motion and energy, `impactor_words(D)` each, follow the quasi-static scalars).
const HEAD: usize = 15;

/// An impactor's words: its position, velocity and force (D each) and its penalty energy.
const fn impactor_words(d: usize) -> usize {
    3 * d + 1
}

/// The quasi-static solver's scalars after them: whether it has a memory, its increment,
/// largest load and iterations, whether it has a predictor's point, that point's time (its
/// displacements, D words per owned node, follow the node vectors), whether Gershgorin's
/// masses replaced the spectral ones, and whether the spectral radius was measured, its value
/// and the force evaluations it took.
const QUASI_STATIC: usize = 10;

/// With `control.restart`, restores every rank's share of the checkpoint in `out` into
/// `sim` (a distributed run's) and returns the driver state, on every rank. Every rank calls
/// it; a checkpoint rank 0 refuses is refused on every rank, before anything is written.
pub fn restore<const D: usize, M: Material<D>>(
    control: &RunControl,
    out: &Path,
    origin: &Origin,
    sim: &mut Simulation<D, M>,
) -> Result<Option<DriverState<D>>, RunError> {
    if !control.restart {
        return Ok(None);
    }
    let share = sim.share.clone().expect("a distributed run's share");
    let ranks = &*share.ranks;
    let state = &mut sim.state;
    // Every rank keeps the previous evaluation's positions and matrices or none (a
    // non-central model under a critical energy), with the same words per node.
    let kept = Kept {
        previous: !state.previous.is_empty(),
        matrix_words: state.previous_matrices.len() / state.u.len().max(1),
    };
    let mine = Rows {
        first: share.first,
        owned: share.owned,
        entries: state.status.len(),
        history: state.history.len(),
    };
    let opened = ranks.gather(&mine.words()).map(|words| {
        let rows = Rows::from_words(&words);
        open::<D>(out, origin, &rows, kept).map(|parts| (parts, rows))
    });
    let refused = match &opened {
        Some(Err(e)) => Some(e.to_string()),
        _ => None,
    };
    if let Some(message) = ranks.first_message(refused) {
        return Err(match opened {
            Some(Err(e)) => e,
            _ => RunError::Distributed(message),
        });
    }
    let mut opened = opened.and_then(Result::ok);
    let part = ranks.scatter(&mut |r| {
        let (parts, rows) = opened.as_mut().expect("rank 0 opened the checkpoint");
        // A read that fails after the checks: an empty part, refused on its rank.
        part_of(parts, rows, r).unwrap_or_default()
    });
    let unread = part.is_empty().then(|| {
        format!(
            "rank {} could not read its part of {}",
            ranks.rank(),
            out.join(crate::checkpoint::FILE_NAME).display()
        )
    });
    if let Some(message) = ranks.first_message(unread) {
        return Err(RunError::Distributed(message));
    }
    let driver = unpack(&part, state, share.owned);
    share.halo.exchange(ranks, state);
    // A ghost's previous position is read by its neighbours' work increments (its
    // matrices only by itself: a ghost's are never read).
    if kept.previous {
        share.halo.exchange_items(
            ranks,
            D,
            &mut state.previous,
            |y, buf| buf.extend_from_slice(y.as_slice()),
            |y, w| *y = Vector::<D>::from_column_slice(w),
        );
    }
    // The impactors' motion and penalty energy: the same on every rank.
    sim.impactors.restore(&driver.impactors);
    Ok(Some(driver))
}

/// What a non-central model under a critical energy keeps of the previous evaluation: each
/// node's position (`State::previous`) and `matrix_words` of its own-half matrices
/// (`State::previous_matrices`); none otherwise.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Kept {
    previous: bool,
    matrix_words: usize,
}

impl Rows {
    fn words(&self) -> [f64; 4] {
        [self.first, self.owned, self.entries, self.history].map(|n| n as f64)
    }

    /// Every rank's rows from their gathered words, in rank order.
    fn from_words(words: &[f64]) -> Vec<Rows> {
        words
            .chunks_exact(4)
            .map(|w| Rows {
                first: w[0] as usize,
                owned: w[1] as usize,
                entries: w[2] as usize,
                history: w[3] as usize,
            })
            .collect()
    }
}

/// Rank 0: the checkpoint opened for reading by parts, for ranks of `rows` (in rank order).
fn open<const D: usize>(
    out: &Path,
    origin: &Origin,
    rows: &[Rows],
    kept: Kept,
) -> Result<Parts<D>, RunError> {
    let sum = |f: fn(&Rows) -> usize| rows.iter().map(f).sum::<usize>();
    let nodes = sum(|r| r.owned);
    let expected = Sizes {
        nodes,
        entries: sum(|r| r.entries),
        history: sum(|r| r.history),
        previous: if kept.previous { nodes } else { 0 },
        matrices: nodes * kept.matrix_words,
        predictor: 0,
    };
    let path = out.join(crate::checkpoint::FILE_NAME);
    Ok(Parts::open(&path, origin, &expected)?)
}

/// Rank `r`'s part of the checkpoint: the scalars, its owned nodes' vectors, its entries'
/// status and history (u64 scalars and status bytes carried as f64: exact).
fn part_of<const D: usize>(
    parts: &mut Parts<D>,
    rows: &[Rows],
    r: usize,
) -> std::io::Result<Vec<f64>> {
    let Rows {
        first,
        owned,
        entries,
        history,
    } = rows[r];
    let entries_first: usize = rows[..r].iter().map(|x| x.entries).sum();
    let history_first: usize = rows[..r].iter().map(|x| x.history).sum();
    let (whole, driver) = (parts.scalars(), parts.driver());
    let qs = driver.quasi_static.as_ref();
    let spectrum = qs.and_then(|m| m.spectrum);
    let predictor = parts.predictor_time();
    let mut part =
        Vec::with_capacity(HEAD + QUASI_STATIC + owned * 6 * D + 1 + entries.div_ceil(8) + history);
    part.extend([
        whole.time,
        f64::from_bits(whole.step),
        f64::from_bits(whole.broken),
        whole.external_work,
        whole.dissipated_viscous,
        whole.dissipated_damage,
        whole.dt,
        f64::from_bits(whole.iterations),
        driver.next_dt,
        f64::from_bits(driver.since_change),
        f64::from_bits(driver.rejected),
        f64::from_bits(driver.stage),
        f64::from_bits(driver.stage_start.0),
        driver.stage_start.1,
        driver.impactors.len() as f64,
    ]);
    part.extend([
        qs.is_some() as u8 as f64,
        qs.map_or(0.0, |m| m.increment),
        qs.map_or(0.0, |m| m.largest_load),
        f64::from_bits(qs.map_or(0, |m| m.iterations)),
        predictor.is_some() as u8 as f64,
        predictor.unwrap_or(0.0),
        qs.is_some_and(|m| m.gershgorin) as u8 as f64,
        spectrum.is_some() as u8 as f64,
        spectrum.map_or(0.0, |s| s.0),
        f64::from_bits(spectrum.map_or(0, |s| s.1)),
    ]);
    for im in &driver.impactors {
        for x in [&im.position, &im.velocity, &im.force] {
            part.extend_from_slice(x.as_slice());
        }
        part.push(im.energy);
    }
    let words = |bytes: Vec<u8>| -> Vec<f64> {
        bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect()
    };
    for section in [
        Section::U,
        Section::V,
        Section::Current,
        Section::Force,
        Section::BodyForce,
    ] {
        part.extend(words(parts.read(section, first, owned)?));
    }
    if predictor.is_some() {
        part.extend(words(parts.read(Section::Predictor, first, owned)?));
    }
    // A non-central model's previous evaluation: its owned nodes' positions and matrices
    // (none in the file when the model keeps none).
    part.extend(words(parts.read(Section::Previous, first, owned)?));
    part.extend(words(parts.read(
        Section::PreviousMatrices,
        first,
        owned,
    )?));
    part.extend(bytes_to_words(&parts.read(
        Section::Status,
        entries_first,
        entries,
    )?));
    part.extend(words(parts.read(
        Section::History,
        history_first,
        history,
    )?));
    Ok(part)
}

/// Sets a rank's `state` (its `owned` nodes first) from its part; the driver state.
fn unpack<const D: usize>(part: &[f64], state: &mut State<D>, owned: usize) -> DriverState<D> {
    let (head, rest) = part.split_at(HEAD);
    let bits = |k: usize| head[k].to_bits();
    state.time = head[0];
    state.step = bits(1);
    state.broken = bits(2);
    state.external_work = head[3];
    state.dissipated_viscous = head[4];
    state.dissipated_damage = head[5];
    state.dt = head[6];
    state.iterations = bits(7);
    let (qs, rest) = rest.split_at(QUASI_STATIC);
    let (impactors, rest) = rest.split_at(head[14] as usize * impactor_words(D));
    let mut driver = DriverState {
        next_dt: head[8],
        since_change: bits(9),
        rejected: bits(10),
        stage: bits(11),
        stage_start: (bits(12), head[13]),
        quasi_static: None,
        impactors: impactors
            .chunks_exact(impactor_words(D))
            .map(|w| ImpactorState {
                position: Vector::<D>::from_column_slice(&w[..D]),
                velocity: Vector::<D>::from_column_slice(&w[D..2 * D]),
                force: Vector::<D>::from_column_slice(&w[2 * D..3 * D]),
                energy: w[3 * D],
            })
            .collect(),
    };
    let (vectors, rest) = rest.split_at(owned * 5 * D);
    let mut words = vectors.chunks_exact(D);
    for a in [
        &mut state.u,
        &mut state.v,
        &mut state.current,
        &mut state.force,
        &mut state.body_force,
    ] {
        for (x, w) in a[..owned].iter_mut().zip(&mut words) {
            *x = Vector::<D>::from_column_slice(w);
        }
    }
    // The predictor's point: this rank's owned nodes (it moves only those).
    let (previous, rest) = rest.split_at(if qs[4] == 1.0 { owned * D } else { 0 });
    if qs[0] == 1.0 {
        driver.quasi_static = Some(QuasiStaticMemory {
            increment: qs[1],
            largest_load: qs[2],
            iterations: qs[3].to_bits(),
            previous: (qs[4] == 1.0).then(|| {
                let u = previous.chunks_exact(D);
                (qs[5], u.map(Vector::<D>::from_column_slice).collect())
            }),
            gershgorin: qs[6] == 1.0,
            spectrum: (qs[7] == 1.0).then_some((qs[8], qs[9].to_bits())),
            in_step: None,
        });
    }
    // A non-central model's previous evaluation, as this rank keeps it (ghosts: exchanged).
    let previous_words = if state.previous.is_empty() {
        0
    } else {
        owned * D
    };
    let (previous, rest) = rest.split_at(previous_words);
    for (y, w) in state.previous.iter_mut().zip(previous.chunks_exact(D)) {
        *y = Vector::<D>::from_column_slice(w);
    }
    let words = state.previous_matrices.len() / state.u.len().max(1);
    let (matrices, rest) = rest.split_at(owned * words);
    state.previous_matrices[..owned * words].copy_from_slice(matrices);
    let (status, history) = bytes_from_words(rest);
    assert!(
        status.len() == state.status.len() && history.len() == state.history.len(),
        "a part of this rank's size"
    );
    state.status = status;
    state.history.copy_from_slice(history);
    driver
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A state of `nodes` nodes, `entries` bond entries and `history` history words, zeroed.
    fn sized<const D: usize>(nodes: usize, entries: usize, history: usize) -> State<D> {
        State {
            u: vec![Vector::<D>::zeros(); nodes],
            v: vec![Vector::<D>::zeros(); nodes],
            current: vec![Vector::<D>::zeros(); nodes],
            force: vec![Vector::<D>::zeros(); nodes],
            body_force: vec![Vector::<D>::zeros(); nodes],
            status: vec![0; entries],
            history: vec![0.0; history],
            ..State::empty()
        }
    }

    /// The checkpoint of `whole` and `driver` as one process writes it, opened by parts.
    fn parts(whole: &State<2>, driver: &DriverState<2>, tag: &str) -> Parts<2> {
        let dir = crate::atomic_file::test_dir(tag);
        let path = dir.join(crate::checkpoint::FILE_NAME);
        let origin = Origin::new("a deck", Path::new("t.toml"));
        crate::checkpoint::write(&path, &origin, whole, driver).expect("written");
        let expected = Sizes::of(whole, &DriverState::default());
        Parts::open(&path, &origin, &expected).expect("opened")
    }

    /// A whole state of 7 nodes whose every number tells where it is.
    fn whole() -> State<2> {
        let mut s = sized::<2>(7, 20, 40);
        for i in 0..7 {
            let x = i as f64;
            s.u[i] = Vector::<2>::new(x, -x);
            s.v[i] = Vector::<2>::new(10.0 + x, 0.5);
            s.current[i] = Vector::<2>::new(20.0 + x, 1.5);
            s.force[i] = Vector::<2>::new(30.0 + x, 2.5);
            s.body_force[i] = Vector::<2>::new(40.0 + x, 3.5);
        }
        s.status = (0..20).map(|b| (b % 4) as u8).collect();
        s.history = (0..40).map(|k| 0.25 * k as f64).collect();
        (s.time, s.step, s.broken) = (1e-6, 123, 17);
        (s.external_work, s.dissipated_viscous, s.dissipated_damage) = (0.1, 0.2, 0.3);
        (s.dt, s.iterations) = (1e-8, 1);
        s
    }

    /// Three ranks of 3, 2 and 2 nodes (with 2, 1 and 0 ghosts) get their own nodes, rows and
    /// the scalars; the ghosts are left to the halo exchange.
    #[test]
    fn each_rank_gets_its_nodes_rows_and_the_scalars() {
        let whole = whole();
        let driver = DriverState::<2> {
            next_dt: 2e-8,
            since_change: 5,
            rejected: 3,
            stage: 0,
            stage_start: (0, 0.0),
            ..DriverState::default()
        };
        let rows = [(0, 3, 9, 2), (3, 2, 6, 1), (5, 2, 5, 0)].map(|(first, owned, e, ghosts)| {
            (
                Rows {
                    first,
                    owned,
                    entries: e,
                    history: 2 * e,
                },
                ghosts,
            )
        });
        let words: Vec<f64> = rows.iter().flat_map(|(r, _)| r.words()).collect();
        let all = Rows::from_words(&words);
        let mut parts = parts(&whole, &driver, "restart-rows");
        let (mut entry, mut word) = (0, 0);
        for (r, (mine, ghosts)) in rows.iter().enumerate() {
            assert_eq!(all[r], *mine);
            let mut local = sized::<2>(mine.owned + ghosts, mine.entries, mine.history);
            let got = unpack(
                &part_of(&mut parts, &all, r).unwrap(),
                &mut local,
                mine.owned,
            );
            assert_eq!(got, driver);
            let nodes = mine.first..mine.first + mine.owned;
            assert_eq!(local.u[..mine.owned], whole.u[nodes.clone()]);
            assert_eq!(local.body_force[..mine.owned], whole.body_force[nodes]);
            assert!(local.u[mine.owned..]
                .iter()
                .all(|x| *x == Vector::<2>::zeros()));
            assert_eq!(local.status, whole.status[entry..entry + mine.entries]);
            assert_eq!(local.history, whole.history[word..word + mine.history]);
            assert_eq!((local.step, local.broken, local.time), (123, 17, 1e-6));
            assert_eq!((local.dissipated_damage, local.iterations), (0.3, 1));
            (entry, word) = (entry + mine.entries, word + mine.history);
        }
    }

    /// The quasi-static solver's memory: its scalars on every rank, the predictor's point as
    /// each rank's owned nodes; the stage in progress with the other scalars.
    #[test]
    fn each_rank_gets_the_quasi_static_memory_of_its_nodes() {
        let whole = whole();
        let previous: Vec<Vector<2>> = (0..7)
            .map(|i| Vector::<2>::new(0.5 * i as f64, 1.0))
            .collect();
        let mut driver = DriverState::<2> {
            stage: 1,
            stage_start: (40, 3e-6),
            quasi_static: Some(QuasiStaticMemory {
                increment: 0.125,
                largest_load: 7.5,
                previous: Some((9e-7, previous.clone())),
                iterations: 4321,
                gershgorin: true,
                spectrum: Some((2.75, 31)),
                in_step: None,
            }),
            ..DriverState::default()
        };
        let all = [(0, 3), (3, 2), (5, 2)].map(|(first, owned)| Rows {
            first,
            owned,
            entries: 0,
            history: 0,
        });
        let (whole_status, whole_history) = (Vec::new(), Vec::new());
        let whole = State {
            status: whole_status,
            history: whole_history,
            ..whole
        };
        let mut with_point = parts(&whole, &driver, "restart-predictor");
        for (r, mine) in all.iter().enumerate() {
            let mut local = sized::<2>(mine.owned + 1, 0, 0);
            let got = unpack(
                &part_of(&mut with_point, &all, r).unwrap(),
                &mut local,
                mine.owned,
            );
            let memory = got.quasi_static.as_ref().expect("a memory");
            let (t, u) = memory.previous.as_ref().expect("a predictor's point");
            assert_eq!(*t, 9e-7);
            assert_eq!(u[..], previous[mine.first..mine.first + mine.owned]);
            assert_eq!((memory.increment, memory.largest_load), (0.125, 7.5));
            assert_eq!(memory.iterations, 4321);
            assert_eq!((got.stage, got.stage_start), (1, (40, 3e-6)));
        }
        // Before the first committed load step: no predictor's point.
        driver.quasi_static.as_mut().unwrap().previous = None;
        let mut local = sized::<2>(3, 0, 0);
        let mut without = parts(&whole, &driver, "restart-no-predictor");
        let got = unpack(&part_of(&mut without, &all, 0).unwrap(), &mut local, 3);
        assert_eq!(got, driver);
    }

    /// The impactors' motion and energy on every rank; a non-central model's previous
    /// positions and own-half matrices (3 words per node here) as each rank's owned nodes,
    /// its ghosts' left to the halo exchange.
    #[test]
    fn each_rank_gets_the_impactors_and_its_nodes_previous_evaluation() {
        let mut whole = whole();
        whole.previous = (0..7).map(|i| Vector::<2>::new(i as f64, 0.75)).collect();
        whole.previous_matrices = (0..21).map(|k| 0.5 * k as f64).collect();
        let impactor = |k: f64| ImpactorState::<2> {
            position: Vector::<2>::new(k, -k),
            velocity: Vector::<2>::new(80.0 * k, 0.0),
            force: Vector::<2>::new(-3.0 * k, 1.0),
            energy: 1e-3 * k,
        };
        let driver = DriverState::<2> {
            impactors: vec![impactor(1.0), impactor(2.0)],
            ..DriverState::default()
        };
        let rows = [(0, 3, 9, 2), (3, 2, 6, 1), (5, 2, 5, 0)];
        let all: Vec<Rows> = rows
            .iter()
            .map(|&(first, owned, e, _)| Rows {
                first,
                owned,
                entries: e,
                history: 2 * e,
            })
            .collect();
        let mut parts = parts(&whole, &driver, "restart-impactors");
        for (r, (mine, &(_, _, _, ghosts))) in all.iter().zip(&rows).enumerate() {
            let nodes = mine.owned + ghosts;
            let mut local = sized::<2>(nodes, mine.entries, mine.history);
            local.previous = vec![Vector::<2>::zeros(); nodes];
            local.previous_matrices = vec![0.0; nodes * 3];
            let got = unpack(
                &part_of(&mut parts, &all, r).unwrap(),
                &mut local,
                mine.owned,
            );
            assert_eq!(got, driver);
            let owned = mine.first..mine.first + mine.owned;
            assert_eq!(local.previous[..mine.owned], whole.previous[owned.clone()]);
            assert_eq!(
                local.previous_matrices[..mine.owned * 3],
                whole.previous_matrices[owned.start * 3..owned.end * 3]
            );
            assert!(local.previous_matrices[mine.owned * 3..]
                .iter()
                .all(|x| *x == 0.0));
            assert_eq!(local.u[..mine.owned], whole.u[owned]);
        }
    }
}
