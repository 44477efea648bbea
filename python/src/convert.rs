//! Values between TOML (decks, reports) and Python (dicts, lists, numbers), and the study
//! table as columns.

use numpy::PyArray1;
use peridyn::deck::study::LoadedStudy;
use peridyn::run::ModelReport;
use peridyn::study_run::StudyReport;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// A TOML value as the Python value a reader expects: tables as dicts, arrays as lists.
pub fn toml_to_py<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => PyString::new(py, s).into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => PyFloat::new(py, *f).into_any(),
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Datetime(d) => PyString::new(py, &d.to_string()).into_any(),
        toml::Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| toml_to_py(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, toml_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// A dict written as deck text; a value TOML cannot hold raises `TypeError` naming its key.
pub fn toml_from_py(data: &Bound<'_, PyDict>) -> PyResult<String> {
    let value = value_from_py(data.as_any(), "")?;
    toml::to_string(&value)
        .map_err(|e| PyTypeError::new_err(format!("the dict cannot be written as a deck: {e}")))
}

fn value_from_py(x: &Bound<'_, PyAny>, at: &str) -> PyResult<toml::Value> {
    let key = |k: &str| {
        if at.is_empty() {
            k.to_string()
        } else {
            format!("{at}.{k}")
        }
    };
    if let Ok(d) = x.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, v) in d.iter() {
            let k: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!("deck keys are str; `{at}` has the key {k:?}"))
            })?;
            let v = value_from_py(&v, &key(&k))?;
            t.insert(k, v);
        }
        return Ok(toml::Value::Table(t));
    }
    if x.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(x.extract()?));
    }
    if x.is_instance_of::<PyInt>() {
        return Ok(toml::Value::Integer(x.extract()?));
    }
    if x.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(x.extract()?));
    }
    if let Ok(s) = x.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_cow()?.into_owned()));
    }
    if x.is_instance_of::<PyList>() || x.is_instance_of::<PyTuple>() {
        let items = x
            .try_iter()?
            .enumerate()
            .map(|(i, v)| value_from_py(&v?, &format!("{at}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    // numpy arrays and scalars: as the Python values they hold.
    if x.hasattr("tolist")? {
        return value_from_py(&x.call_method0("tolist")?, at);
    }
    Err(PyTypeError::new_err(format!(
        "`{at}` holds a {}, which a deck cannot hold (str, int, float, bool, list, dict)",
        x.get_type().name()?
    )))
}

/// `check`'s report as a dict: every number of `resolved.toml`'s `[derived]` table, and
/// `text`, the report as `peridyn check` prints it.
pub fn report_dict<'py>(py: Python<'py>, report: &ModelReport) -> PyResult<Bound<'py, PyDict>> {
    let value = toml::Value::try_from(report)
        .map_err(|e| PyTypeError::new_err(format!("the report cannot be converted: {e}")))?;
    let d = toml_to_py(py, &value)?.cast_into::<PyDict>()?;
    d.set_item("text", report.to_string())?;
    Ok(d)
}

/// The study's `runs.csv` as columns.
pub fn study_table<'py>(
    py: Python<'py>,
    ls: &LoadedStudy,
    report: &StudyReport,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let runs: Vec<i64> = (0..report.runs.len() as i64).collect();
    d.set_item("run", PyArray1::from_vec(py, runs))?;
    for (k, name) in report.factors.iter().enumerate() {
        let column: Vec<f64> = report.runs.iter().map(|r| r.values[k]).collect();
        d.set_item(name, PyArray1::from_vec(py, column))?;
    }
    for (k, output) in ls.study.outputs.iter().enumerate() {
        let column: Vec<f64> = report
            .runs
            .iter()
            .map(|r| r.outputs.get(k).copied().flatten().unwrap_or(f64::NAN))
            .collect();
        d.set_item(&output.name, PyArray1::from_vec(py, column))?;
    }
    let status: Vec<&str> = report.runs.iter().map(|r| r.status.as_str()).collect();
    d.set_item("status", PyList::new(py, status)?)?;
    Ok(d)
}
