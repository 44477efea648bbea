//! The package's exceptions, and the guard every library call runs under: errors and panics
//! alike come back as values, so nothing unwinds into the interpreter.

use peridyn::deck::DeckError as CoreDeckError;
use peridyn::run::RunError;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};

pyo3::create_exception!(
    peridyn,
    PeridynError,
    PyException,
    "Base class of peridyn's errors."
);
pyo3::create_exception!(
    peridyn,
    DeckError,
    PeridynError,
    "A deck that cannot be used: one `file:line:column: key: message` line per problem, as the command line prints them."
);
pyo3::create_exception!(
    peridyn,
    SimulationError,
    PeridynError,
    "A run that cannot continue: unstable, not converging, or an output that cannot be written."
);
pyo3::create_exception!(
    peridyn,
    CheckpointError,
    PeridynError,
    "A checkpoint that cannot be written or continued (another deck, version, size, or corrupt)."
);

/// A failure on the library's side, carried across the released GIL as plain text.
#[derive(Debug)]
pub enum Failure {
    Deck(String),
    Run(String),
    Checkpoint(String),
    Value(String),
    /// A panic in the library: a bug, reported as an exception instead of an abort.
    Internal(String),
}

impl From<CoreDeckError> for Failure {
    fn from(e: CoreDeckError) -> Self {
        Failure::Deck(e.to_string())
    }
}

impl From<RunError> for Failure {
    fn from(e: RunError) -> Self {
        match e {
            RunError::Deck(d) => Failure::Deck(d.to_string()),
            RunError::Checkpoint(c) => Failure::Checkpoint(c.to_string()),
            other => Failure::Run(other.to_string()),
        }
    }
}

pub fn to_py(f: Failure) -> PyErr {
    match f {
        Failure::Deck(m) => DeckError::new_err(m),
        Failure::Run(m) => SimulationError::new_err(m),
        Failure::Checkpoint(m) => CheckpointError::new_err(m),
        Failure::Value(m) => PyValueError::new_err(m),
        Failure::Internal(m) => PeridynError::new_err(format!(
            "internal error in peridyn (a bug; please report it with the deck): {m}"
        )),
    }
}

impl From<Failure> for PyErr {
    fn from(f: Failure) -> Self {
        to_py(f)
    }
}

/// Runs `f`, turning a panic into `Failure::Internal`.
pub fn guard<T>(f: impl FnOnce() -> Result<T, Failure>) -> Result<T, Failure> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => Err(Failure::Internal(panic_message(&*payload))),
    }
}

pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".into()
    }
}

/// A thread count: at least one.
pub fn threads(threads: Option<usize>) -> PyResult<Option<usize>> {
    match threads {
        Some(0) => Err(PyValueError::new_err(
            "threads must be at least 1 (None: all cores)",
        )),
        t => Ok(t),
    }
}
