//! Python values in and out.
//!
//! * Arrays in: anything `numpy.asarray` takes whose dtype is a real number
//!   type (floating point, signed or unsigned integers) is converted to
//!   float64; booleans, complex numbers, strings and objects are a
//!   `TypeError`. Any memory layout is accepted (non-contiguous, Fortran
//!   order, negative strides): the values are read through the strides in
//!   logical (C) order into an owned buffer, which is also what lets the
//!   batches run with the GIL released.
//! * Arrays out: new C-contiguous float64 (or bool) numpy arrays.
//! * Dicts in: the robot file's keys as nested dicts and lists of numbers
//!   and strings (numpy arrays and scalars too), written as TOML with the
//!   `toml` crate so that `robot-file` parses them exactly like a file.

use numpy::{PyArray1, PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyMapping, PyString, PyTuple};

/// A real array read from Python: its values in C order and its shape.
#[derive(Debug, Clone)]
pub struct Real {
    /// The values, row-major.
    pub data: Vec<f64>,
    /// The shape (empty for a scalar).
    pub shape: Vec<usize>,
}

impl Real {
    /// The shape as Python writes it, `(k, 6)`.
    pub fn shape_text(&self) -> String {
        shape_text(&self.shape)
    }
}

/// `(k, 6)`, `(6,)`, `()`.
pub fn shape_text(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!("({})", shape.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")),
    }
}

/// Reads `obj` as a real array named `what` in messages.
pub fn real_array(py: Python<'_>, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Real> {
    let np = py.import(intern!(py, "numpy"))?;
    let arr = np
        .call_method1(intern!(py, "asarray"), (obj,))
        .map_err(|e| PyValueError::new_err(format!("{what}: not an array of numbers ({e})")))?;
    let dtype = arr.getattr(intern!(py, "dtype"))?;
    let kind: String = dtype.getattr(intern!(py, "kind"))?.extract()?;
    if !matches!(kind.as_str(), "f" | "i" | "u") {
        let name: String = dtype.str()?.extract()?;
        let type_name = obj.get_type().name()?.to_string();
        return Err(PyTypeError::new_err(format!(
            "{what}: expected real numbers (float64; integer and floating-point arrays are converted), got {type_name} of dtype {name}"
        )));
    }
    let arr = arr.call_method1(intern!(py, "astype"), (intern!(py, "float64"),))?;
    let arr = arr
        .cast::<PyArrayDyn<f64>>()
        .map_err(|e| PyTypeError::new_err(format!("{what}: not a float64 array after conversion ({e})")))?;
    let view = arr
        .try_readonly()
        .map_err(|e| PyValueError::new_err(format!("{what}: the array cannot be read ({e})")))?;
    let view = view.as_array();
    Ok(Real { data: view.iter().copied().collect(), shape: view.shape().to_vec() })
}

/// Reads `obj` as a vector of exactly `n` numbers.
pub fn vector(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    what: &str,
    n: usize,
    meaning: &str,
) -> PyResult<Vec<f64>> {
    let a = real_array(py, obj, what)?;
    if a.shape != [n] {
        return Err(PyValueError::new_err(format!(
            "{what}: expected shape ({n},) ({meaning}), got shape {}",
            a.shape_text()
        )));
    }
    Ok(a.data)
}

/// A new float64 array of `shape` holding `data` (C order).
pub fn array_out<'py>(py: Python<'py>, data: Vec<f64>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let flat = PyArray1::from_vec(py, data);
    Ok(flat.reshape(shape.to_vec())?.into_any())
}

/// The robot dict as a TOML table (keys as the robot file's).
pub fn dict_to_toml(obj: &Bound<'_, PyAny>) -> PyResult<toml::Table> {
    let mapping = obj.cast::<PyMapping>().map_err(|_| {
        PyTypeError::new_err(format!(
            "Robot.from_dict: expected a dict with the robot file's keys, got {}",
            type_name(obj)
        ))
    })?;
    table(mapping, "")
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an object".into())
}

fn table(mapping: &Bound<'_, PyMapping>, at: &str) -> PyResult<toml::Table> {
    let mut out = toml::Table::new();
    for item in mapping.items()?.iter() {
        let (key, value): (Bound<'_, PyAny>, Bound<'_, PyAny>) = item.extract()?;
        let key: String = key.cast::<PyString>().map(|s| s.to_string()).map_err(|_| {
            PyTypeError::new_err(format!("Robot.from_dict: key {} of {} is not a string", key, where_(at)))
        })?;
        let path = if at.is_empty() { key.clone() } else { format!("{at}.{key}") };
        out.insert(key, value_to_toml(&value, &path)?);
    }
    Ok(out)
}

fn where_(at: &str) -> String {
    if at.is_empty() {
        "the dict".into()
    } else {
        format!("`{at}`")
    }
}

fn value_to_toml(value: &Bound<'_, PyAny>, at: &str) -> PyResult<toml::Value> {
    let py = value.py();
    if value.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(value.extract()?));
    }
    if value.is_instance_of::<PyInt>() {
        let v: i64 = value.extract().map_err(|_| {
            PyValueError::new_err(format!("Robot.from_dict: `{at}` = {value} does not fit 64 bits"))
        })?;
        return Ok(toml::Value::Integer(v));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(value.extract()?));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_string()));
    }
    if let Ok(m) = value.cast::<PyDict>() {
        return Ok(toml::Value::Table(table(m.as_mapping(), at)?));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, item) in value.try_iter()?.enumerate() {
            items.push(value_to_toml(&item?, &format!("{at}[{i}]"))?);
        }
        return Ok(toml::Value::Array(items));
    }
    // numpy arrays and scalars (and anything else with `tolist`).
    if let Ok(tolist) = value.getattr(intern!(py, "tolist")) {
        if let Ok(plain) = tolist.call0() {
            if !plain.is(value) && !plain.get_type().is(value.get_type()) {
                return value_to_toml(&plain, at);
            }
        }
    }
    if let Ok(m) = value.cast::<PyMapping>() {
        return Ok(toml::Value::Table(table(m, at)?));
    }
    Err(PyTypeError::new_err(format!(
        "Robot.from_dict: `{at}` holds {}, not a number, string, list or dict",
        type_name(value)
    )))
}
