//! The `peridyn._peridyn` extension module: decks, simulations stepped from Python, runs and
//! studies, over the library's own entry points (no second configuration language). Every
//! call into the library is guarded: an error becomes a Python exception, and so does a panic.

mod convert;
mod errors;
mod simulation;

use convert::{report_dict, study_table, toml_from_py, toml_to_py};
use errors::{guard, to_py, Failure};
use peridyn::deck::edit::{number_at, set_number};
use peridyn::deck::study::LoadedStudy;
use peridyn::deck::{KeyPath, LoadedDeck};
use peridyn::run::{check, run_with, RunControl, RunOptions};
use peridyn::study_run::{run_study, StudyOptions};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A validated deck: its TOML text and the file it came from (which names it in messages
/// and anchors its relative paths). Make one with `peridyn.load`.
#[pyclass(module = "peridyn", frozen)]
#[derive(Clone)]
pub struct Deck {
    pub(crate) ld: LoadedDeck,
}

#[pymethods]
impl Deck {
    /// Reads and validates a deck file, as `peridyn check` does.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Deck> {
        let ld = guard(|| LoadedDeck::from_file(&path).map_err(Failure::from))?;
        Ok(Deck { ld })
    }

    /// Validates deck text; `path` names it in messages and anchors relative paths
    /// (default `<string>`, paths relative to the working directory).
    #[staticmethod]
    #[pyo3(signature = (text, path = None))]
    fn from_toml(text: &str, path: Option<PathBuf>) -> PyResult<Deck> {
        let file = path.unwrap_or_else(|| PathBuf::from("<string>"));
        let ld = guard(|| LoadedDeck::from_str(text, &file).map_err(Failure::from))?;
        Ok(Deck { ld })
    }

    /// Validates a deck given as a dict with the keys of a deck file (nested dicts for
    /// tables, lists of dicts for arrays of tables); it is written as TOML first, and
    /// messages locate problems in that text (`Deck.text`).
    #[staticmethod]
    #[pyo3(signature = (data, path = None))]
    fn from_dict(data: &Bound<'_, PyDict>, path: Option<PathBuf>) -> PyResult<Deck> {
        let text = toml_from_py(data)?;
        let file = path.unwrap_or_else(|| PathBuf::from("<dict>"));
        let ld = guard(|| LoadedDeck::from_str(&text, &file).map_err(Failure::from))?;
        Ok(Deck { ld })
    }

    /// The deck's TOML text.
    #[getter]
    fn text(&self) -> &str {
        &self.ld.src
    }

    /// The deck's file (or `<string>`, `<dict>`).
    #[getter]
    fn file(&self) -> String {
        self.ld.file.display().to_string()
    }

    /// The deck's title ("" when it has none).
    #[getter]
    fn title(&self) -> &str {
        &self.ld.deck.title
    }

    /// 2 or 3.
    #[getter]
    fn dimension(&self) -> usize {
        self.ld.deck.dimension
    }

    /// The number at a key path (`material.youngs_modulus`, `boundary_conditions[1].value`).
    fn get(&self, key: &str) -> PyResult<f64> {
        number_at(&self.ld.src, &KeyPath::parse(key))
            .map_err(|m| to_py(Failure::Deck(format!("{}: {m}", self.ld.file.display()))))
    }

    /// A new deck with the number at `key` replaced by `value` (an integer key takes it
    /// rounded), validated again; this deck is unchanged. As `peridyn study` edits decks:
    /// every other byte of the text stays, so messages keep their line numbers.
    fn set(&self, key: &str, value: f64) -> PyResult<Deck> {
        self.edited(&[(key.to_string(), value)])
    }

    /// `set` for several keys at once: `deck.with_values({"material.density": 1200.0})`.
    fn with_values(&self, values: std::collections::BTreeMap<String, f64>) -> PyResult<Deck> {
        let values: Vec<(String, f64)> = values.into_iter().collect();
        self.edited(&values)
    }

    /// The deck as a dict (a copy: changing it does not change the deck).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let value: toml::Value =
            toml::from_str(&self.ld.src).map_err(|e| to_py(Failure::Deck(e.to_string())))?;
        toml_to_py(py, &value)
    }

    /// Builds the model and reports it without stepping (`peridyn check`'s numbers).
    #[pyo3(signature = (threads = None))]
    fn check(&self, py: Python<'_>, threads: Option<usize>) -> PyResult<Py<PyDict>> {
        let threads = errors::threads(threads)?;
        let ld = &self.ld;
        let report = py.detach(|| guard(|| check(ld, threads).map_err(Failure::from)))?;
        Ok(report_dict(py, &report)?.unbind())
    }

    /// Builds a simulation of this deck (`threads`: worker threads, default all cores).
    #[pyo3(signature = (threads = None))]
    fn build(&self, py: Python<'_>, threads: Option<usize>) -> PyResult<simulation::Simulation> {
        simulation::Simulation::build(py, &self.ld, threads)
    }

    fn __repr__(&self) -> String {
        format!(
            "<peridyn.Deck {} ({}D{})>",
            self.ld.file.display(),
            self.ld.deck.dimension,
            if self.ld.deck.title.is_empty() {
                String::new()
            } else {
                format!(", {:?}", self.ld.deck.title)
            }
        )
    }
}

impl Deck {
    fn edited(&self, values: &[(String, f64)]) -> PyResult<Deck> {
        let mut src = self.ld.src.clone();
        for (key, value) in values {
            src = set_number(&src, &KeyPath::parse(key), *value)
                .map_err(|m| to_py(Failure::Deck(format!("{}: {m}", self.ld.file.display()))))?;
        }
        let file = self.ld.file.clone();
        let ld = guard(|| LoadedDeck::from_str(&src, &file).map_err(Failure::from))?;
        Ok(Deck { ld })
    }
}

/// A deck from a `Deck`, a dict, a path (str or os.PathLike) or TOML text (a str with a
/// newline is text, any other str a path).
pub(crate) fn deck_of(source: &Bound<'_, PyAny>) -> PyResult<Deck> {
    if let Ok(deck) = source.cast::<Deck>() {
        return Ok(deck.get().clone());
    }
    if let Ok(dict) = source.cast::<PyDict>() {
        return Deck::from_dict(dict, None);
    }
    if let Ok(s) = source.cast::<PyString>() {
        let s = s.to_cow()?;
        if s.contains('\n') {
            return Deck::from_toml(&s, None);
        }
        return Deck::from_file(PathBuf::from(&*s));
    }
    match source.extract::<PathBuf>() {
        Ok(path) => Deck::from_file(path),
        Err(_) => Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "a deck is a peridyn.Deck, a dict, a path or TOML text, not {}",
            source.get_type().name()?
        ))),
    }
}

/// Loads and validates a deck from a path (str or os.PathLike), TOML text (a str holding a
/// newline) or a dict, as the command line does; a bad deck raises `DeckError` with
/// `file:line:column: key: message` lines.
#[pyfunction]
fn load(source: &Bound<'_, PyAny>) -> PyResult<Deck> {
    deck_of(source)
}

/// Builds a deck's model and reports it without stepping: `peridyn check`'s numbers
/// (nodes, bonds, δ/Δx, constants, dt, memory) as a dict.
#[pyfunction]
#[pyo3(signature = (deck, threads = None))]
fn check_deck(
    py: Python<'_>,
    deck: &Bound<'_, PyAny>,
    threads: Option<usize>,
) -> PyResult<Py<PyDict>> {
    deck_of(deck)?.check(py, threads)
}

/// Runs a deck to its end as `peridyn run DECK -o OUT_DIR` does, writing the same files
/// (byte for byte but for the wall times in summary.txt). `restart=True` continues a killed
/// run from the checkpoint in `out_dir`. Returns the summary as a dict. Ctrl-C stops the run
/// after the step in progress and raises KeyboardInterrupt, its files finished up to that
/// step (no summary.txt).
#[pyfunction]
#[pyo3(signature = (deck, out_dir, threads = None, quiet = true, restart = false))]
fn run<'py>(
    py: Python<'py>,
    deck: &Bound<'py, PyAny>,
    out_dir: PathBuf,
    threads: Option<usize>,
    quiet: bool,
    restart: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let deck = deck_of(deck)?;
    let opts = RunOptions {
        out_dir,
        threads: errors::threads(threads)?,
        quiet,
    };
    let interrupt = Arc::new(AtomicBool::new(false));
    let control = RunControl {
        restart,
        interrupt: Some(interrupt.clone()),
        ..RunControl::default()
    };
    let ld = &deck.ld;
    // The run goes on in a thread of its own while this one, the main thread, looks for
    // Ctrl-C (Python's signal handlers run there only) and asks the run to stop at it.
    let summary = std::thread::scope(|scope| {
        let main = std::thread::current();
        let running = scope.spawn(move || {
            let result = guard(|| run_with(ld, &opts, &control).map_err(Failure::from));
            main.unpark();
            result
        });
        loop {
            py.detach(|| std::thread::park_timeout(simulation::SIGNAL_INTERVAL));
            if running.is_finished() {
                break;
            }
            if let Err(e) = py.check_signals() {
                interrupt.store(true, Ordering::Relaxed);
                // It stops after the step in progress, its files finished there.
                let _ = py.detach(|| running.join());
                return Err(e);
            }
        }
        Ok(running
            .join()
            .unwrap_or_else(|p| Err(Failure::Internal(errors::panic_message(&*p)))))
    })??;
    let d = PyDict::new(py);
    d.set_item("report", report_dict(py, &summary.report)?)?;
    d.set_item("wall_seconds", summary.wall_seconds)?;
    d.set_item("node_steps_per_second", summary.node_steps_per_second)?;
    d.set_item("broken_bonds", summary.broken_bonds)?;
    d.set_item("kinetic_energy", summary.kinetic_energy)?;
    d.set_item("strain_energy", summary.strain_energy)?;
    d.set_item("external_work", summary.external_work)?;
    d.set_item("out_dir", summary.out_dir.display().to_string())?;
    d.set_item("text", summary.to_string())?;
    Ok(d)
}

/// Runs (or continues) the parameter study in a study file as `peridyn study STUDY -o
/// OUT_DIR` does, and returns its table (`runs.csv`) as a dict of columns: `run`, each
/// factor's key and each output's name (numpy arrays, NaN where a run failed) and `status`
/// (a list of str).
#[pyfunction]
#[pyo3(signature = (path, out_dir, threads = None, quiet = true))]
fn study<'py>(
    py: Python<'py>,
    path: PathBuf,
    out_dir: PathBuf,
    threads: Option<usize>,
    quiet: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let threads = errors::threads(threads)?;
    let (ls, report) = py.detach(|| {
        guard(|| {
            let ls = LoadedStudy::from_file(&path).map_err(Failure::from)?;
            let opts = StudyOptions {
                out_dir,
                threads,
                quiet,
                from_run: 0,
                kept_runs: None,
            };
            let report = run_study(&ls, &opts).map_err(|e| match e {
                peridyn::study_run::StudyRunError::Deck(d) => Failure::from(d),
                other => Failure::Run(other.to_string()),
            })?;
            Ok((ls, report))
        })
    })?;
    study_table(py, &ls, &report)
}

#[pymodule]
fn _peridyn(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("PeridynError", py.get_type::<errors::PeridynError>())?;
    m.add("DeckError", py.get_type::<errors::DeckError>())?;
    m.add("SimulationError", py.get_type::<errors::SimulationError>())?;
    m.add("CheckpointError", py.get_type::<errors::CheckpointError>())?;
    m.add_class::<Deck>()?;
    m.add_class::<simulation::Simulation>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(check_deck, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(study, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
