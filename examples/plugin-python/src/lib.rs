//! A researcher's parts from Python: the DRIVE bindings built into a module of one's own
//! with the registries that hold them. Here, the plug-in example's tracked robot and its
//! simulator (examples/plugin/src/tracked.rs). Built with `pip wheel ./examples/plugin-python`
//! and installed beside `drive-ugv`; `DRIVE_NATIVE_MODULE=drive_plugin_parts` then makes
//! `import drive` (and its `drive` console command) run with these parts.

use pyo3::prelude::*;

#[path = "../../plugin/src/tracked.rs"]
mod tracked;

/// The built-in parts and the tracked robot with its simulator.
fn registries() -> Result<drive::Registries, drive::traits::RegistryError> {
    let mut r = drive::Registries::builtin();
    tracked::register(&mut r)?;
    Ok(r)
}

#[pymodule]
fn drive_plugin_parts(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let registries =
        registries().map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
    drive_python::add_to_module(m, registries)
}
