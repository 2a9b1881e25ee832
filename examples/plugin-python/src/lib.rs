//! A researcher's parts from Python: the DRIVE bindings built into a module of one's own
//! with the registries that hold them. Here, the plug-in example's tracked robot and its
//! simulator (examples/plugin/src/tracked.rs). Built with `pip wheel ./examples/plugin-python`
//! and installed beside `drive-ugv`; `DRIVE_NATIVE_MODULE=drive_plugin_parts` then makes
//! `import drive` (and its `drive` console command) run with these parts.

use pyo3::prelude::*;
use std::sync::Arc;

#[path = "../../plugin/src/tracked.rs"]
mod tracked;

/// The built-in parts and the tracked robot with its simulator.
fn registries() -> Result<drive::Registries, drive::traits::RegistryError> {
    let mut r = drive::Registries::builtin();
    let vehicle = tracked::TrackedVw { max_yaw_rate: 1.2 };
    r.vehicles.register(
        "tracked-vw",
        "a tracked robot commanded in body velocity (v, omega)",
        Arc::new(vehicle.clone()),
    )?;
    r.simulators.register(
        "tracked-vw",
        "tracks that lose a terrain share of the speed and skid more the harder they turn",
        Arc::new(tracked::TrackedPlant::make),
    )?;
    let mut robot = r.robot("husky").expect("the husky preset is registered");
    robot.name = "tracked-robot".into();
    robot.nominal_input_space = {
        use drive::traits::CommandModel;
        // A positive top speed and yaw rate (literals): the box is valid.
        vehicle
            .nominal_input_space(robot.max_speed)
            .expect("positive limits")
    };
    robot.vehicle = Arc::new(vehicle);
    r.robots.register(
        "tracked-robot",
        "a 75 kg tracked robot commanded in (v, omega), 1 m/s, 1.2 rad/s",
        Arc::new(robot),
    )?;
    Ok(r)
}

#[pymodule]
fn drive_plugin_parts(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let registries =
        registries().map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
    drive_python::add_to_module(m, registries)
}
