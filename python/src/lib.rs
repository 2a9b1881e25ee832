//! Python bindings of the DRIVE framework (`pip install ./python`): datasets, evaluation,
//! fitted models with numpy predictions, the protocol runner a ROS 2 node drives a robot with,
//! and the path follower that puts a fitted model inside a model-predictive controller, and the
//! command line itself (the `drive` console command). The Python package `drive` (py/drive)
//! wraps this module; every user error raises `drive.DriveError` with the command line's
//! message.

use drive::Registries;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

mod args;
mod dataset;
mod evaluate;
mod model;
mod runner;
mod step;
mod tracker;

create_exception!(
    _native,
    DriveError,
    PyValueError,
    "A user error (bad data, unknown name, a fit that cannot be made): the command line's message."
);

pub(crate) fn err(e: impl std::fmt::Display) -> PyErr {
    DriveError::new_err(e.to_string())
}

/// Runs the `drive` command line in this process on `args` (the program name first) and
/// returns its exit status: what the `drive` console command of the Python package runs.
#[pyfunction]
fn run_cli(py: Python<'_>, args: Vec<std::ffi::OsString>) -> u8 {
    py.detach(|| drive::cli::run_status(args, &Registries::builtin()))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("DriveError", m.py().get_type::<DriveError>())?;
    m.add_class::<dataset::Dataset>()?;
    m.add_class::<model::Model>()?;
    m.add_function(wrap_pyfunction!(dataset::load_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::evaluate_json, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::bench_json, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::adapt_json, m)?)?;
    m.add_function(wrap_pyfunction!(model::fit, m)?)?;
    m.add_function(wrap_pyfunction!(model::load_model, m)?)?;
    m.add_function(wrap_pyfunction!(model::_model_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::columns_for_sidecar, m)?)?;
    m.add_function(wrap_pyfunction!(run_cli, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::import_recording, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::per_window_columns, m)?)?;
    runner::register(m)?;
    step::register(m)?;
    tracker::register(m)?;
    Ok(())
}
