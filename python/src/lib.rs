//! Python bindings of the DRIVE framework (`pip install ./python`): datasets, evaluation,
//! fitted models with numpy predictions, the protocol runner a ROS 2 node drives a robot with,
//! and the path follower that puts a fitted model inside a model-predictive controller, and the
//! command line itself (the `drive` console command). The Python package `drive` (py/drive)
//! wraps this module; every user error raises `drive.DriveError` with the command line's
//! message.
//!
//! The bindings are also a library: a researcher's crate builds its own Python module with
//! its parts by calling [`add_to_module`] with its `Registries` (docs/python.md, "Your own
//! parts from Python"); the `drive` package then runs it when `DRIVE_NATIVE_MODULE` names it.

use drive::Registries;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::OnceLock;

mod adaptive;
mod args;
mod dataset;
mod evaluate;
mod interrupt;
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

/// The parts every call of this module uses: the ones [`add_to_module`] was given.
static REGISTRIES: OnceLock<Registries> = OnceLock::new();

/// The parts the module was built with (the built-in ones until [`add_to_module`] says
/// otherwise).
pub(crate) fn registries() -> &'static Registries {
    REGISTRIES.get_or_init(Registries::builtin)
}

/// Runs the `drive` command line in this process on `args` (the program name first) and
/// returns its exit status: what the `drive` console command of the Python package runs.
/// Ctrl-C raises `KeyboardInterrupt` at once, and the command, stopped at its next unit of
/// work or before it writes, leaves no output. `progress(done, total)` as the command's
/// units of work end (`drive report`'s).
#[pyfunction]
#[pyo3(signature = (args, progress=None))]
fn run_cli(
    py: Python<'_>,
    args: Vec<std::ffi::OsString>,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<u8> {
    let progress = progress.filter(|p| !p.is_none());
    interrupt::interruptible(py, progress, move |ticker| {
        let observer = std::sync::Arc::new(interrupt::Observer(ticker.clone()));
        drive::cli::run_status_observed(args, registries(), observer)
    })
}

/// Adds the bindings (datasets, evaluation, models, the step API, the protocol runner, the
/// tracker and the command line) to the Python module `m`, every call of them with the parts
/// of `registries`: how a researcher's crate builds a Python module holding its own vehicles,
/// learners, samplers, simulators and robots. One set of parts per process: a second call
/// with other parts is an error.
///
/// ```ignore
/// // A researcher's crate: `[lib] crate-type = ["cdylib"]`, depending on `drive-python`
/// // with `default-features = false` (no module of its own) and on its parts.
/// use pyo3::prelude::*;
/// #[pymodule]
/// fn my_parts(m: &Bound<'_, PyModule>) -> PyResult<()> {
///     drive_python::add_to_module(m, my_crate::registries()?)
/// }
/// // In Python: DRIVE_NATIVE_MODULE=my_parts python -c "import drive; ..."
/// ```
pub fn add_to_module(m: &Bound<'_, PyModule>, registries: Registries) -> PyResult<()> {
    if REGISTRIES.set(registries).is_err() {
        return Err(err(
            "the DRIVE bindings were already given their parts in this process: one module of parts per process",
        ));
    }
    add_bindings(m)
}

/// The built-in parts' module, `drive._native` (the `module` feature, on by default; a
/// researcher's crate that builds its own module turns it off).
#[cfg(feature = "module")]
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    add_bindings(m)
}

fn add_bindings(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("DriveError", m.py().get_type::<DriveError>())?;
    m.add_class::<dataset::Dataset>()?;
    m.add_class::<model::Model>()?;
    m.add_class::<adaptive::AdaptiveModel>()?;
    m.add_function(wrap_pyfunction!(dataset::load_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::evaluate_json, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::bench_json, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::adapt_json, m)?)?;
    m.add_function(wrap_pyfunction!(model::fit, m)?)?;
    m.add_function(wrap_pyfunction!(model::load_model, m)?)?;
    m.add_function(wrap_pyfunction!(model::_model_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::columns_for_sidecar, m)?)?;
    m.add_function(wrap_pyfunction!(run_cli, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::_refuse_useless, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::import_recording, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::per_window_columns, m)?)?;
    runner::register(m)?;
    step::register(m)?;
    tracker::register(m)?;
    Ok(())
}
