//! # cdpr-py: the Python package `cdpr`
//!
//! The extension module `cdpr._native` (PyO3, abi3: one wheel for every
//! CPython >= 3.9), re-exported by `cdpr/__init__.py`. It adds no numerics
//! of its own: robots come from `robot-file`'s parser (a dict is written as
//! TOML and parsed like a file), and every computation goes through the
//! `cdpr` host tool's library, whose [`cdpr::robot::Model`] dispatches the
//! run-time (degrees of freedom, cables) to `tension-core`'s const-generic
//! robots, exactly as `cdpr solve` / `cdpr workspace` / `cdpr forward` do.
//!
//! * [`robot::Robot`]: the Python class (`from_toml`, `from_dict`,
//!   accessors, `wrench_matrix`, `cable_lengths`, `required_wrench`,
//!   `forward`, `solve`, `motor_torques`, `workspace`).
//! * [`convert`]: numpy arrays in (any real dtype converted to float64, any
//!   memory layout read through its strides), dicts to TOML.
//! * [`errors`]: the exception classes, one per status word of
//!   `docs/conventions.md`.
//!
//! Nothing here panics on input: every bad argument is a Python exception
//! (`ValueError` for shapes and values, `TypeError` for types), every
//! failure of the core is its typed exception for one pose and its status
//! word in a batch.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod convert;
mod errors;
mod robot;

use pyo3::prelude::*;
use tension_core::Method;

/// Tension distribution, kinematics and workspace of cable-driven parallel
/// robots, from the Rust `tension-core` (see the package `cdpr`).
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<robot::Robot>()?;
    let methods: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
    m.add("METHODS", pyo3::types::PyTuple::new(m.py(), methods)?)?;
    m.add("STATUSES", pyo3::types::PyTuple::new(m.py(), errors::SOLVE_STATUSES)?)?;
    m.add("FORWARD_STATUSES", pyo3::types::PyTuple::new(m.py(), errors::FORWARD_STATUSES)?)?;
    m.add("SHAPES", pyo3::types::PyTuple::new(m.py(), cdpr::robot::SHAPES)?)?;
    errors::register(m)?;
    Ok(())
}
