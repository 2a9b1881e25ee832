//! The closed loop's online path follower for a Python driver (a ROS 2 node): a fitted
//! model inside the MPPI controller, ticked with what the robot measured.

use crate::args::{number_of, type_name};
use crate::err;
use crate::evaluate::start_info_of;
use crate::model::Model;
use drive::control::{
    ControlSetup, InputMap, MakeController, Mppi, PathShape, ReferencePath, Tracker as RustTracker,
    TrackerConfig,
};
use drive::traits::{vehicle_tag, Pose};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Follows a path with a fitted model inside a model-predictive controller (MPPI), one tick
/// at a time: `tick` takes what the robot measured and returns the command to send.
///
/// A tracker belongs to the thread that made it (a ROS 2 node's executor thread).
#[pyclass(module = "drive._native", unsendable)]
pub(crate) struct Tracker {
    tracker: RustTracker,
    vehicle: std::sync::Arc<dyn drive::traits::CommandModel>,
    last_t: Option<f64>,
}

/// The path `obj`: an (N, 2) array of x, y points (m), or a preset name with its scale.
fn path_of(py: Python<'_>, obj: &Bound<'_, PyAny>, scale: f64) -> PyResult<ReferencePath> {
    if let Ok(name) = obj.extract::<String>() {
        let shape = PathShape::parse(&name).map_err(err)?;
        return shape.at_scale(scale).map_err(err);
    }
    let a = crate::args::float_array(py, "path", "(N, 2)", obj, 2)?;
    let a: PyReadonlyArray2<'_, f64> = a.extract()?;
    if a.shape()[1] != 2 {
        return Err(err(format!(
            "path must be an (N, 2) array of x, y points, got shape {:?}",
            a.shape()
        )));
    }
    let points: Vec<[f64; 2]> = a
        .as_array()
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1]])
        .collect();
    ReferencePath::new("path", points).map_err(err)
}

#[pymethods]
impl Tracker {
    /// A tracker of `path` (an (N, 2) array of x, y in the localization's frame, or a preset
    /// name, "line", "circle", "figure8" or "zigzag", of size `scale` m starting at the
    /// origin along +x) at `speed` m/s, with `model` (a `drive.Model`) predicting for the
    /// MPPI controller (`samples` candidates of `horizon` steps, `temperature`,
    /// `uncertainty_weight` on the model's predicted variance; the defaults of `drive
    /// track`), on `robot` (a registered name or a robot TOML file: its
    /// input space and acceleration limits bound the commands). `start` is what the
    /// model's predictions start from, as it was fitted ("encoders+imu" by default);
    /// `history` (s) how far back the predictions start, through the commands sent since
    /// (by default the model's powertrain's settling time: its dead time plus one time
    /// constant for the FOPDT of eq. 3, at least 0.5 s); `observe_now` whether the
    /// body's motion measured now (the IMU's yaw rate) is the model's state after them
    /// (True by default, as in `drive track`; slip-ipem's lagging body velocity);
    /// `schedule` (s) holds the robot to a schedule at `speed` along the path, within
    /// that many seconds of travel (`drive track --schedule`; by default the reference
    /// starts where the robot is).
    #[new]
    #[pyo3(signature = (model, robot, path, speed, *, scale=4.0, start=None, samples=None, horizon=None, temperature=None, history=None, uncertainty_weight=None, observe_now=None, schedule=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        model: &Bound<'_, PyAny>,
        robot: &Bound<'_, PyAny>,
        path: &Bound<'_, PyAny>,
        speed: &Bound<'_, PyAny>,
        scale: f64,
        start: Option<&Bound<'_, PyAny>>,
        samples: Option<usize>,
        horizon: Option<usize>,
        temperature: Option<f64>,
        history: Option<f64>,
        uncertainty_weight: Option<f64>,
        observe_now: Option<bool>,
        schedule: Option<f64>,
    ) -> PyResult<Self> {
        let model = model.extract::<PyRef<'_, Model>>().map_err(|_| {
            err(format!(
                "model must be a drive.Model (drive.fit or drive.load_model), got {}",
                type_name(model)
            ))
        })?;
        let robot_name: String = robot.extract().map_err(|_| {
            err(format!(
                "robot must be a robot name or a robot TOML file, got {}",
                type_name(robot)
            ))
        })?;
        let robot = crate::registries()
            .robot(&robot_name)
            .map_err(|e| crate::args::read_error(py, &robot_name, e))?;
        let (a, b) = (
            vehicle_tag(model.robot.vehicle.as_ref()),
            vehicle_tag(robot.vehicle.as_ref()),
        );
        if a != b {
            return Err(err(format!(
                "the model is of a '{}' vehicle; robot '{}' is a '{}'",
                a.unwrap_or_default(),
                robot.name,
                b.unwrap_or_default()
            )));
        }
        // Another geometry (another robot of the type, another calibration): driven as it
        // is, with the difference said, as `drive track --models FILE` notes it.
        let json = |v: &dyn drive::traits::CommandModel| serde_json::to_value(v).ok();
        if let (Some(ours), Some(theirs)) = (
            json(model.robot.vehicle.as_ref()),
            json(robot.vehicle.as_ref()),
        ) {
            if !drive::studies::same_geometry(&ours, &theirs) {
                let note = format!(
                    "the model was fitted for the geometry of '{}', not for that of the robot '{}' ({}): it is driven as it is",
                    model.robot.robot,
                    robot.name,
                    drive::studies::geometry_difference(&ours, &theirs)
                );
                let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
                // The names come from a sidecar and a robot file, checked for NUL on load.
                let message = std::ffi::CString::new(note).unwrap_or_default();
                PyErr::warn(py, &category, &message, 1)?;
            }
        }
        if (model.model.dt() * robot.rate_hz - 1.0).abs() > 1e-6 {
            return Err(err(format!(
                "the model predicts at steps of {} s; robot '{}' is commanded at {} Hz",
                model.model.dt(),
                robot.name,
                robot.rate_hz
            )));
        }
        let speed = number_of("speed", "a positive speed in m/s", speed)?;
        let path = path_of(py, path, scale)?;
        let start = start_info_of(start)?;
        let d = Mppi::default();
        let mppi = Mppi {
            samples: samples.unwrap_or(d.samples),
            horizon: horizon.unwrap_or(d.horizon),
            temperature: temperature.unwrap_or(d.temperature),
            uncertainty_weight: uncertainty_weight.unwrap_or(d.uncertainty_weight),
            observe_now: observe_now.unwrap_or(d.observe_now),
            ..d
        };
        let setup = ControlSetup {
            model: model.model.clone(),
            robot: robot.clone(),
            to_vehicle: InputMap::identity(),
            speed,
            seed: 0,
        };
        let config = TrackerConfig {
            start,
            history_s: history,
            schedule_s: schedule,
            ..TrackerConfig::new(speed)
        };
        // Checked by the tracker (settings, speed).
        let _ = mppi.make(&setup).map_err(err)?;
        let tracker = RustTracker::new(&mppi, &setup, path, config, model.robot.vehicle.clone())
            .map_err(err)?;
        Ok(Tracker {
            tracker,
            vehicle: robot.vehicle.clone(),
            last_t: None,
        })
    }

    /// One tick: `t` the time (s, increasing); `inputs` the measured inputs (left, right
    /// wheel velocities, rad/s, for a differential drive); `pose` a new localization fix
    /// (x, y, yaw) when one arrived, else None; `imu_yaw_rate` the IMU's yaw rate (rad/s)
    /// or None; `pose_time` when the fix was measured (s, on `t`'s clock: the pose
    /// message's header stamp), so that it is carried forward from then, or None (measured
    /// at `t`). Returns a dict: `command` (the two inputs to send), `done` (the end of
    /// the path is reached; the command then stops the robot), `linear` and `angular` (the
    /// body velocity the command asks for: a Twist's linear.x and angular.z), `progress_m`,
    /// `cross_track_m` (positive left of the path), `heading_error_rad` and `estimate`
    /// (x, y, yaw the tick planned from).
    #[pyo3(signature = (t, inputs, pose=None, imu_yaw_rate=None, pose_time=None))]
    fn tick<'py>(
        &mut self,
        py: Python<'py>,
        t: &Bound<'py, PyAny>,
        inputs: &Bound<'py, PyAny>,
        pose: Option<&Bound<'py, PyAny>>,
        imu_yaw_rate: Option<&Bound<'py, PyAny>>,
        pose_time: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let t = number_of("t", "a time in s", t)?;
        if let Some(last) = self.last_t {
            if t.partial_cmp(&last) != Some(std::cmp::Ordering::Greater) {
                return Err(err(format!(
                    "t = {t} does not come after the last tick's {last}"
                )));
            }
        }
        let dim = self.vehicle.input_dim();
        let input = crate::args::input_of("inputs", Some(inputs), dim)?;
        let pose: Option<[f64; 3]> = pose
            .filter(|p| !p.is_none())
            .map(|p| crate::args::numbers_of("pose", Some(p)))
            .transpose()?;
        let imu = imu_yaw_rate
            .filter(|w| !w.is_none())
            .map(|w| number_of("imu_yaw_rate", "a number (rad/s)", w))
            .transpose()?;
        let pose_time = pose_time
            .filter(|s| !s.is_none())
            .map(|s| number_of("pose_time", "a time in s", s))
            .transpose()?;
        let obs = drive::control::Observation {
            t,
            input,
            pose: pose.map(|p| Pose::new(p[0], p[1], p[2])),
            imu_yaw_rate: imu,
            pose_time,
        };
        let tick = py.detach(|| self.tracker.tick(&obs)).map_err(err)?;
        self.last_t = Some(t);
        let d = PyDict::new(py);
        let body = self.vehicle.body_velocity(&tick.command);
        d.set_item("command", crate::args::input_tuple(py, &tick.command, dim)?)?;
        d.set_item("linear", body.x)?;
        d.set_item("angular", body.z)?;
        d.set_item("done", tick.done)?;
        d.set_item("progress_m", tick.progress_m)?;
        d.set_item("cross_track_m", tick.cross_track_m)?;
        d.set_item("heading_error_rad", tick.heading_error_rad)?;
        d.set_item(
            "estimate",
            (tick.estimate.x, tick.estimate.y, tick.estimate.z),
        )?;
        Ok(d)
    }

    /// Tells the tracker the robot was stopped by something else (a safety stop, an
    /// operator taking over): its next commands ramp up from rest; the progress along the
    /// path is kept.
    fn reset(&mut self) {
        self.tracker.reset();
    }

    /// The path's length (m).
    #[getter]
    fn length(&self) -> f64 {
        self.tracker.path().length()
    }

    fn __repr__(&self) -> String {
        format!(
            "Tracker(path of {:.1} m, progress {:.1} m)",
            self.tracker.path().length(),
            self.tracker.progress()
        )
    }
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Tracker>()
}
