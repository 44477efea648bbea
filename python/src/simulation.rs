//! `peridyn.Simulation`: a session (`peridyn::session`) stepped from Python with the GIL
//! released, its node data lent to numpy as read-only views of the session's own buffers.

use crate::errors::{guard, to_py, Failure};
use numpy::ndarray::{ArrayView1, ArrayView2};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use peridyn::deck::LoadedDeck;
use peridyn::loading::Kinematic;
use peridyn::session::{NodeVectors, Session, Target};
use pyo3::exceptions::{PyImportError, PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// How long a stretch of steps runs without the GIL before Ctrl-C is looked for.
pub(crate) const SIGNAL_INTERVAL: Duration = Duration::from_millis(50);

/// A simulation built from a deck and stepped from Python: any deck `peridyn run` runs, a
/// step being one committed step of its run (an explicit step, of the adaptive dt's size
/// with `[solver.adaptive]`; a quasi-static load step; a staged deck's steps cross its
/// stages as the run's do).
///
/// Node data: `positions`, `displacement`, `velocity`, `force` (n × dimension), `volume`
/// and `block` (n) are read-only views of the simulation's own arrays (no copy; they follow
/// the simulation as it steps and keep it alive); `damage()`, `strain_energy_density()`,
/// `node_sets`, `history()` and `energies()` are computed on each call (new arrays).
#[pyclass(module = "peridyn", frozen)]
pub struct Simulation {
    inner: Mutex<Inner>,
    report: Py<PyDict>,
    dimension: usize,
    nodes: usize,
}

struct Inner {
    session: Session,
    /// Set after a panic inside the library: the state is not to be trusted.
    broken: Option<String>,
}

impl Simulation {
    pub fn build(py: Python<'_>, ld: &LoadedDeck, threads: Option<usize>) -> PyResult<Self> {
        let threads = crate::errors::threads(threads)?;
        let session = py.detach(|| guard(|| Session::new(ld, threads).map_err(Failure::from)))?;
        let report = crate::convert::report_dict(py, &session.report)?.unbind();
        Ok(Simulation {
            dimension: session.dimension(),
            nodes: session.nodes(),
            report,
            inner: Mutex::new(Inner {
                session,
                broken: None,
            }),
        })
    }

    fn lock(&self) -> Result<MutexGuard<'_, Inner>, Failure> {
        let inner = match self.inner.try_lock() {
            Ok(g) => g,
            Err(std::sync::TryLockError::WouldBlock) => {
                return Err(Failure::Value(
                    "the simulation is stepping in another thread".into(),
                ))
            }
            Err(std::sync::TryLockError::Poisoned(p)) => p.into_inner(),
        };
        match &inner.broken {
            Some(m) => Err(Failure::Internal(format!(
                "the simulation stopped at an earlier internal error and cannot continue: {m}"
            ))),
            None => Ok(inner),
        }
    }

    /// Runs `f` on the session under the guard; a panic leaves the simulation unusable.
    fn with<T>(&self, f: impl FnOnce(&mut Session) -> Result<T, Failure>) -> Result<T, Failure> {
        let mut inner = self.lock()?;
        let result = guard(|| f(&mut inner.session));
        if let Err(Failure::Internal(m)) = &result {
            inner.broken = Some(m.clone());
        }
        result
    }

    /// Steps towards `target` with the GIL released, looking for Ctrl-C between stretches
    /// of steps (the state is a whole step's when KeyboardInterrupt is raised).
    fn advance(&self, py: Python<'_>, target: Target) -> PyResult<u64> {
        loop {
            let done = py.detach(|| {
                self.with(|s| {
                    s.advance(target, Instant::now() + SIGNAL_INTERVAL)
                        .map_err(Failure::from)
                })
            })?;
            py.check_signals()?;
            if done {
                return Ok(self.with(|s| Ok(s.step()))?);
            }
        }
    }

    /// A view of `n × dimension` numbers the session holds, owned by `slf`.
    fn vector_view<'py>(
        slf: &Bound<'py, Self>,
        which: NodeVectors,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let this = slf.get();
        let (ptr, len) = {
            let inner = this.lock()?;
            let v = inner.session.vectors(which);
            (v.as_ptr(), v.len())
        };
        debug_assert_eq!(len, this.nodes * this.dimension);
        // SAFETY: the buffer belongs to the session inside `slf`, which the array keeps
        // alive, and never moves: the session writes into it in place (stepping, restoring a
        // checkpoint) and never resizes it.
        let array = unsafe {
            let view = ArrayView2::from_shape_ptr((this.nodes, this.dimension), ptr);
            PyArray2::borrow_from_array(&view, slf.clone().into_any())
        };
        read_only(array)
    }
}

/// Marks an array read-only: a write raises ValueError.
fn read_only<'py, A: PyArrayMethods<'py, T, D>, T: numpy::Element, D: numpy::ndarray::Dimension>(
    array: A,
) -> PyResult<A>
where
    A: std::ops::Deref<Target = Bound<'py, PyAny>>,
{
    array.getattr("flags")?.setattr("writeable", false)?;
    Ok(array)
}

/// "x", "y", "z" or 0, 1, 2.
fn component(c: &Bound<'_, PyAny>, dimension: usize) -> PyResult<usize> {
    let k = if let Ok(s) = c.cast::<PyString>() {
        match &*s.to_cow()? {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            other => {
                return Err(PyValueError::new_err(format!(
                    "component {other:?}: expected \"x\", \"y\"{} or an index",
                    if dimension == 3 { ", \"z\"" } else { "" }
                )))
            }
        }
    } else {
        c.extract::<usize>().map_err(|_| {
            PyValueError::new_err("component: expected \"x\", \"y\", \"z\" or 0, 1, 2")
        })?
    };
    if k >= dimension {
        return Err(PyValueError::new_err(format!(
            "component {k} does not exist in {dimension}D"
        )));
    }
    Ok(k)
}

#[pymethods]
impl Simulation {
    /// Builds a simulation of `deck` (a `peridyn.Deck`, a dict, a path or TOML text) on
    /// `threads` worker threads (default: all cores; results are identical for any count).
    #[new]
    #[pyo3(signature = (deck, threads = None))]
    fn new(py: Python<'_>, deck: &Bound<'_, PyAny>, threads: Option<usize>) -> PyResult<Self> {
        let deck = crate::deck_of(deck)?;
        Self::build(py, &deck.ld, threads)
    }

    /// The model as built: `peridyn check`'s numbers (a dict; `report["text"]` as printed).
    #[getter]
    fn report(&self, py: Python<'_>) -> Py<PyDict> {
        self.report.clone_ref(py)
    }

    /// 2 or 3.
    #[getter]
    fn dimension(&self) -> usize {
        self.dimension
    }

    /// Number of nodes.
    #[getter]
    fn nodes(&self) -> usize {
        self.nodes
    }

    /// Simulation time (s).
    #[getter]
    fn time(&self) -> PyResult<f64> {
        Ok(self.with(|s| Ok(s.time()))?)
    }

    /// Steps taken.
    #[getter]
    fn step_count(&self) -> PyResult<u64> {
        Ok(self.with(|s| Ok(s.step()))?)
    }

    /// Time step (s) of the next step: with `[solver.adaptive]` the controller's next try
    /// (the history's `dt` column has each committed one); in a quasi-static stage the load
    /// increment (pseudo-time).
    #[getter]
    fn dt(&self) -> PyResult<f64> {
        Ok(self.with(|s| Ok(s.dt()))?)
    }

    /// The deck's number of steps: load steps of a quasi-static deck, the sum of a staged
    /// deck's stages, an estimate (end time / first dt) with an adaptive time step; `done`
    /// says when the run is over.
    #[getter]
    fn steps(&self) -> PyResult<u64> {
        Ok(self.with(|s| Ok(s.steps()))?)
    }

    /// The deck's end time (s; a quasi-static deck's: its pseudo-time; a staged deck's: the
    /// sum of its stages' durations).
    #[getter]
    fn end_time(&self) -> PyResult<f64> {
        Ok(self.with(|s| Ok(s.report.end_time))?)
    }

    /// Whether the deck's last step is done.
    #[getter]
    fn done(&self) -> PyResult<bool> {
        Ok(self.with(|s| Ok(s.done()))?)
    }

    /// The stage of the last step: 0 for the deck's own (and in an unstaged deck), k for
    /// `[[stages]]` k − 1.
    #[getter]
    fn stage(&self) -> PyResult<usize> {
        Ok(self.with(|s| Ok(s.stage().0))?)
    }

    /// The name of the stage of the last step: the deck's `name`, or its number from 1.
    #[getter]
    fn stage_name(&self) -> PyResult<String> {
        Ok(self.with(|s| Ok(s.stage().1.to_string()))?)
    }

    /// Takes `n` steps, or fewer at the deck's end (the GIL released; Ctrl-C stops between
    /// steps with KeyboardInterrupt). A quasi-static step is one load step (a load step split
    /// because it broke too many bonds counts each committed piece, as `history.csv`'s `step`
    /// column does). Returns the step count.
    #[pyo3(signature = (n = 1))]
    fn step(&self, py: Python<'_>, n: u64) -> PyResult<u64> {
        let target = self.with(|s| Ok(s.step().saturating_add(n)))?;
        self.advance(py, Target::Step(target))
    }

    /// Steps to the deck's end (its last stage's), or to the first step at or past time
    /// `until` (s); returns the step count.
    #[pyo3(signature = (until = None))]
    fn run(&self, py: Python<'_>, until: Option<f64>) -> PyResult<u64> {
        let target = match until {
            Some(t) if !t.is_finite() => {
                return Err(PyValueError::new_err(format!(
                    "until = {t}: expected a time in s"
                )))
            }
            Some(t) => Target::Time(t),
            None => Target::End,
        };
        self.advance(py, target)
    }

    /// Reference positions x (m), n × dimension: a read-only view.
    #[getter]
    fn positions<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Self::vector_view(slf, NodeVectors::Positions)
    }

    /// Displacement u (m), n × dimension: a read-only view that follows the steps.
    #[getter]
    fn displacement<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Self::vector_view(slf, NodeVectors::Displacement)
    }

    /// Velocity v (m/s), n × dimension: a read-only view that follows the steps.
    #[getter]
    fn velocity<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Self::vector_view(slf, NodeVectors::Velocity)
    }

    /// Internal force density of the last evaluation (N/m³), n × dimension: a read-only
    /// view that follows the steps.
    #[getter]
    fn force<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Self::vector_view(slf, NodeVectors::Force)
    }

    /// Node volumes (m³; in 2D cell area × thickness), n: a read-only view.
    #[getter]
    fn volume<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let this = slf.get();
        let (ptr, len) = {
            let inner = this.lock()?;
            let v = inner.session.volumes();
            (v.as_ptr(), v.len())
        };
        // SAFETY: as `vector_view`: the reference data never changes nor moves.
        let array = unsafe {
            PyArray1::borrow_from_array(
                &ArrayView1::from_shape_ptr(len, ptr),
                slf.clone().into_any(),
            )
        };
        read_only(array)
    }

    /// Block (material region) of each node, n (uint32): a read-only view.
    #[getter]
    fn block<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let this = slf.get();
        let (ptr, len) = {
            let inner = this.lock()?;
            let v = inner.session.blocks();
            (v.as_ptr(), v.len())
        };
        // SAFETY: as `vector_view`.
        let array = unsafe {
            PyArray1::borrow_from_array(
                &ArrayView1::from_shape_ptr(len, ptr),
                slf.clone().into_any(),
            )
        };
        read_only(array)
    }

    /// Damage index per node (0 intact … 1 every bond broken), n: computed now (a new array).
    fn damage<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let d = py.detach(|| self.with(|s| Ok(s.damage())))?;
        Ok(PyArray1::from_vec(py, d))
    }

    /// Strain energy density per node (J/m³), n: computed now (a new array).
    fn strain_energy_density<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let w = py.detach(|| self.with(|s| Ok(s.energy_density())))?;
        Ok(PyArray1::from_vec(py, w))
    }

    /// Named node sets: name → node indices (int64 arrays, copies).
    #[getter]
    fn node_sets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sets = self.with(|s| Ok(s.node_sets()))?;
        let d = PyDict::new(py);
        for (name, nodes) in sets {
            let nodes: Vec<i64> = nodes.into_iter().map(i64::from).collect();
            d.set_item(name, PyArray1::from_vec(py, nodes))?;
        }
        Ok(d)
    }

    /// Energies now (J): kinetic, strain, external work, dissipated by damage, and the
    /// broken bonds.
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let e = py.detach(|| self.with(|s| Ok(s.energies())))?;
        let d = PyDict::new(py);
        d.set_item("kinetic_energy", e.kinetic)?;
        d.set_item("strain_energy", e.strain)?;
        d.set_item("external_work", e.external_work)?;
        d.set_item("damage_dissipation", e.damage_dissipation)?;
        d.set_item("broken_bonds", e.broken_bonds)?;
        Ok(d)
    }

    /// The history so far with the columns of `history.csv` (time, step, energies, broken
    /// bonds, dt, iterations, reactions and mean displacements of every node set, a staged
    /// deck's `stage`, …): a dict of numpy arrays (copies), rows where `history.csv` has
    /// them (step 0, every `history_interval` steps, each stage's last step, the deck's
    /// last).
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (header, columns) = self.with(|s| {
            let (header, rows) = s.history();
            let columns: Vec<Vec<f64>> = (0..header.len())
                .map(|k| rows.iter().map(|r| r[k]).collect())
                .collect();
            Ok((header, columns))
        })?;
        let d = PyDict::new(py);
        for (name, column) in header.into_iter().zip(columns) {
            d.set_item(name, PyArray1::from_vec(py, column))?;
        }
        Ok(d)
    }

    /// The history as a pandas DataFrame (needs pandas).
    fn history_frame<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let pandas = py.import("pandas").map_err(|_| {
            PyImportError::new_err("history_frame() needs pandas (pip install pandas); history() gives the same columns as a dict of numpy arrays")
        })?;
        pandas.call_method1("DataFrame", (self.history(py)?,))
    }

    /// Prescribes a constant displacement (m) or velocity (m/s) on one component ("x", "y",
    /// "z" or 0–2) of a node set from the next step on, replacing the deck's condition
    /// there, if any: a load driven from Python between steps.
    #[pyo3(signature = (set, kind, component, value))]
    fn prescribe(
        &self,
        set: &str,
        kind: &str,
        component: &Bound<'_, PyAny>,
        value: f64,
    ) -> PyResult<()> {
        let kind = match kind {
            "displacement" => Kinematic::Displacement,
            "velocity" => Kinematic::Velocity,
            other => {
                return Err(PyValueError::new_err(format!(
                    "kind {other:?}: expected \"displacement\" or \"velocity\""
                )))
            }
        };
        let k = self::component(component, self.dimension)?;
        self.with(|s| s.prescribe(set, kind, k, value).map_err(Failure::Value))
            .map_err(|f| match f {
                Failure::Value(m) if m.starts_with("no node set") => PyKeyError::new_err(m),
                other => to_py(other),
            })
    }

    /// Removes the prescribed conditions of a node set on `component` (default: every
    /// component), the deck's included; returns how many were removed.
    #[pyo3(signature = (set, component = None))]
    fn release(&self, set: &str, component: Option<&Bound<'_, PyAny>>) -> PyResult<usize> {
        let k = component
            .map(|c| self::component(c, self.dimension))
            .transpose()?;
        self.with(|s| s.release(set, k).map_err(Failure::Value))
            .map_err(|f| match f {
                Failure::Value(m) if m.starts_with("no node set") => PyKeyError::new_err(m),
                other => to_py(other),
            })
    }

    /// Writes displacements (m) of the nodes `nodes` (a set name, indices, or None for
    /// every node), `values` of shape (len(nodes), dimension); the forces are evaluated
    /// again. Unconstrained nodes then move on from there.
    #[pyo3(signature = (values, nodes = None))]
    fn set_displacement(
        &self,
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        nodes: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        self.write(py, NodeVectors::Displacement, values, nodes)
    }

    /// Writes velocities (m/s) of the nodes `nodes` (a set name, indices, or None for every
    /// node), `values` of shape (len(nodes), dimension).
    #[pyo3(signature = (values, nodes = None))]
    fn set_velocity(
        &self,
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        nodes: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        self.write(py, NodeVectors::Velocity, values, nodes)
    }

    /// Writes the current fields as `out_dir/fields/step_N.vtu` (in the series
    /// `out_dir/fields.pvd`) with the maps the deck's `[output]` asks for; returns the VTU
    /// file's path.
    fn snapshot(&self, py: Python<'_>, out_dir: PathBuf) -> PyResult<String> {
        let path = py.detach(|| self.with(|s| s.snapshot(&out_dir).map_err(Failure::from)))?;
        Ok(path.display().to_string())
    }

    /// Writes a checkpoint of the current state to `path` (the format of `peridyn run`'s
    /// `checkpoint.bin`: either continues the other).
    fn save_checkpoint(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        Ok(py.detach(|| self.with(|s| s.save_checkpoint(&path).map_err(Failure::from)))?)
    }

    /// Continues from a checkpoint of this deck (one `save_checkpoint` or `peridyn run`
    /// wrote) in the stage it was written in, as `peridyn run --restart` does; a refused one
    /// leaves the simulation as it was.
    fn load_checkpoint(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        Ok(py.detach(|| self.with(|s| s.load_checkpoint(&path).map_err(Failure::from)))?)
    }

    fn __repr__(&self) -> String {
        match self.with(|s| Ok((s.step(), s.steps(), s.time()))) {
            Ok((step, steps, time)) => format!(
                "<peridyn.Simulation {}D, {} nodes, step {step} of {steps}, t = {time:.4e} s>",
                self.dimension, self.nodes
            ),
            Err(_) => format!(
                "<peridyn.Simulation {}D, {} nodes>",
                self.dimension, self.nodes
            ),
        }
    }
}

impl Simulation {
    fn write(
        &self,
        py: Python<'_>,
        which: NodeVectors,
        values: &Bound<'_, PyAny>,
        nodes: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let nodes: Option<Vec<u32>> = match nodes {
            None => None,
            Some(n) if n.is_instance_of::<PyString>() => {
                let name: String = n.extract()?;
                let sets = self.with(|s| Ok(s.node_sets()))?;
                let set = sets
                    .into_iter()
                    .find(|(k, _)| *k == name)
                    .ok_or_else(|| PyKeyError::new_err(format!("no node set `{name}`")))?;
                Some(set.1)
            }
            Some(n) => {
                let numpy = py.import("numpy")?;
                let a = numpy
                    .call_method1("asarray", (n,))?
                    .call_method1("ravel", ())?;
                let list: Vec<i64> = a.call_method0("tolist")?.extract().map_err(|_| {
                    PyValueError::new_err("nodes: expected a node set's name or integer indices")
                })?;
                let max = self.nodes as i64;
                Some(
                    list.into_iter()
                        .map(|i| {
                            if (0..max).contains(&i) {
                                Ok(i as u32)
                            } else {
                                Err(PyValueError::new_err(format!(
                                    "node {i} does not exist (the model has {max} nodes)"
                                )))
                            }
                        })
                        .collect::<PyResult<Vec<u32>>>()?,
                )
            }
        };
        let count = nodes.as_ref().map_or(self.nodes, |n| n.len());
        let numpy = py.import("numpy")?;
        let array = numpy
            .call_method1("asarray", (values, "float64"))
            .map_err(|_| PyValueError::new_err("values: expected numbers"))?;
        let shape: Vec<usize> = array.getattr("shape")?.extract()?;
        let want = [count, self.dimension];
        if shape != want && !(shape.len() == 1 && shape[0] == count * self.dimension) {
            return Err(PyValueError::new_err(format!(
                "values of shape {shape:?}: expected ({count}, {}) for {count} nodes in {}D",
                self.dimension, self.dimension
            )));
        }
        let flat: Vec<f64> = array
            .call_method1("ravel", ())?
            .call_method0("tolist")?
            .extract()?;
        py.detach(|| {
            self.with(|s| {
                s.write_nodes(which, nodes.as_deref(), &flat)
                    .map_err(|e| match e {
                        peridyn::run::RunError::Io(io)
                            if io.kind() == std::io::ErrorKind::InvalidInput =>
                        {
                            Failure::Value(io.to_string())
                        }
                        other => Failure::from(other),
                    })
            })
        })?;
        Ok(())
    }
}
