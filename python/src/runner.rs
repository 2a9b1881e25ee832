//! The DRIVE protocol runner for a Python driver (a ROS 2 node): built from a robot, a
//! sampler name and a seed; `tick` takes what the robot measured and returns the command.

use crate::dataset::Dataset;
use crate::err;
use drive::samplers::{
    build_sampler, PauseReason, ProtocolRunner as RustRunner, RobotSpec, RunnerConfig, RunnerInput,
    RunnerState, SamplerContext, SamplerError, StopReason,
};
use drive::traits::{Input, InputSampler, Pose};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Arc, Mutex};

/// The command of one tick: the vehicle's inputs (wheel velocities, rad/s, for a
/// differential drive), the body velocity they command, and the sample being recorded.
#[pyclass(module = "drive._native", frozen)]
struct Command {
    /// One per input axis of the vehicle.
    inputs: Vec<f64>,
    linear: f64,
    angular: f64,
    interval: Option<usize>,
    window: Option<usize>,
    phase: Option<&'static str>,
}

#[pymethods]
impl Command {
    /// The vehicle's inputs, one per axis (left, right wheel velocity in rad/s for a
    /// differential drive; speed and steering for a car; v_x, v_y, w for an omnidirectional
    /// base).
    #[getter]
    fn inputs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        pyo3::types::PyTuple::new(py, &self.inputs)
    }

    /// The commanded linear body velocity (m/s): a Twist's linear.x.
    #[getter]
    fn linear(&self) -> f64 {
        self.linear
    }

    /// The commanded yaw rate (rad/s): a Twist's angular.z.
    #[getter]
    fn angular(&self) -> f64 {
        self.angular
    }

    /// Whether this tick is a sample of a DRIVE window (the logger's `calib` state).
    #[getter]
    fn recording(&self) -> bool {
        self.interval.is_some()
    }

    /// The interval being driven (the logger's `calib_step`), None outside one.
    #[getter]
    fn interval(&self) -> Option<usize> {
        self.interval
    }

    /// The window of the interval (0 transient, 1 and 2 steady), None outside one.
    #[getter]
    fn window(&self) -> Option<usize> {
        self.window
    }

    /// `"transient"` or `"steady"` while recording, None otherwise.
    #[getter]
    fn phase(&self) -> Option<&'static str> {
        self.phase
    }

    fn __len__(&self) -> usize {
        self.inputs.len()
    }

    fn __getitem__(&self, i: isize) -> PyResult<f64> {
        let n = self.inputs.len() as isize;
        let at = if i < 0 { i + n } else { i };
        if (0..n).contains(&at) {
            Ok(self.inputs[at as usize])
        } else {
            Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "a command has {n} inputs"
            )))
        }
    }

    fn __repr__(&self) -> String {
        let interval = self.interval.map_or("None".into(), |i| i.to_string());
        let phase = self.phase.map_or("None".into(), |p| format!("'{p}'"));
        let inputs: Vec<String> = self.inputs.iter().map(|v| v.to_string()).collect();
        format!(
            "Command(inputs=({}), linear={}, angular={}, interval={interval}, phase={phase})",
            inputs.join(", "),
            self.linear,
            self.angular
        )
    }
}

/// The DRIVE protocol as a state machine a robot driver ticks at the command rate: the
/// characterization of the input space (step 1), then intervals of 6 s commands drawn by
/// the sampler (step 2), paused by the dead-man switch or stale sensors, ended by the
/// interval count, the duration or the geofence.
///
/// A runner belongs to the thread that made it (a ROS 2 node's executor thread).
#[pyclass(module = "drive._native", unsendable)]
pub(crate) struct ProtocolRunner {
    runner: RustRunner,
    robot: RobotSpec,
    sampler: String,
    failure: Arc<Mutex<Option<SamplerError>>>,
    last_t: Option<f64>,
}

/// Stands in for a sampler that could not be built over the characterized space (the
/// runner then raises the reason).
struct HoldStill;

impl InputSampler for HoldStill {
    fn next_input(&mut self) -> Input {
        Input::zeros()
    }
}

fn positive(what: &str, v: Option<f64>) -> PyResult<Option<f64>> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => {
            Err(err(format!("{what} must be a positive number, got {x}")))
        }
        _ => Ok(v),
    }
}

fn state_name(s: &RunnerState) -> &'static str {
    match s {
        RunnerState::Idle => "idle",
        RunnerState::Characterizing { .. } => "characterizing",
        RunnerState::Driving { .. } => "driving",
        RunnerState::Paused { .. } => "paused",
        RunnerState::Done(_) => "done",
    }
}

#[pymethods]
impl ProtocolRunner {
    #[new]
    #[pyo3(signature = (
        robot, sampler="uniform", seed=0, *, characterize=true, geofence=None,
        max_intervals=None, max_duration=None, localization=true, stale_timeout=0.5,
        characterization_time=8.0
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        robot: &str,
        sampler: &str,
        seed: u64,
        characterize: bool,
        geofence: Option<f64>,
        max_intervals: Option<usize>,
        max_duration: Option<f64>,
        localization: bool,
        stale_timeout: f64,
        characterization_time: f64,
    ) -> PyResult<Self> {
        let registries = crate::registries();
        let mut spec = registries.robot(robot).map_err(err)?;
        positive("geofence", geofence)?;
        positive("max_duration", max_duration)?;
        positive("stale_timeout", Some(stale_timeout))?;
        positive("characterization_time", Some(characterization_time))?;
        if max_intervals == Some(0) {
            return Err(err("max_intervals must be at least 1"));
        }
        if geofence.is_some() && !localization {
            return Err(err(
                "a geofence needs localization (localization=False turns it off)",
            ));
        }
        if !characterize && spec.input_limits.is_none() {
            // The robot's nominal input space, as `drive protocol` samples it.
            spec.input_limits = Some(spec.input_space());
        }
        // Fail early on a name or limits that cannot work over the nominal input space.
        build_sampler(
            &registries.samplers,
            sampler,
            &SamplerContext::new(&spec, seed),
        )
        .map_err(err)?;
        let failure: Arc<Mutex<Option<SamplerError>>> = Arc::default();
        let (samplers, robot_for, slot, name) = (
            registries.samplers.clone(),
            spec.clone(),
            failure.clone(),
            sampler.to_string(),
        );
        let factory = move |space| match build_sampler(
            &samplers,
            &name,
            &SamplerContext::new(&robot_for, seed).over(space),
        ) {
            Ok(s) => s,
            Err(e) => {
                *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                Box::new(HoldStill) as Box<dyn InputSampler>
            }
        };
        let config = RunnerConfig {
            stale_timeout_s: stale_timeout,
            geofence_radius_m: geofence,
            max_intervals,
            max_duration_s: max_duration,
            characterization_s: characterization_time,
            localization,
            ..RunnerConfig::default()
        };
        let mut runner = RustRunner::new(spec.clone(), config, factory);
        runner.start();
        Ok(ProtocolRunner {
            runner,
            robot: spec,
            sampler: sampler.to_string(),
            failure,
            last_t: None,
        })
    }

    /// One command tick: `t` the time (s), `encoder` the wheel velocities measured since
    /// the last tick (None when none arrived), `pose` the localization (x, y, yaw) received
    /// since the last tick (None when none arrived), `deadman` True while the operator
    /// holds the dead-man switch. Returns the command to send now (zero while paused or
    /// done).
    #[pyo3(signature = (t, encoder=None, pose=None, deadman=false))]
    fn tick(
        &mut self,
        t: f64,
        encoder: Option<&Bound<'_, PyAny>>,
        pose: Option<[f64; 3]>,
        deadman: bool,
    ) -> PyResult<Command> {
        if !t.is_finite() {
            return Err(err(format!("t must be a finite time in seconds, got {t}")));
        }
        if let Some(last) = self.last_t {
            if t < last {
                return Err(err(format!(
                    "time went backwards: t = {t} s after t = {last} s (restart the runner after a clock reset)"
                )));
            }
        }
        let dim = self.robot.vehicle.input_dim();
        let encoder = encoder
            .filter(|e| !e.is_none())
            .map(|e| crate::args::input_of("encoder", Some(e), dim))
            .transpose()?;
        if let Some(e) = &encoder {
            crate::args::finite("encoder", &e.as_slice()[..dim])?;
        }
        if let Some(p) = pose {
            crate::args::finite("pose", &p)?;
        }
        self.last_t = Some(t);
        let out = self.runner.tick(&RunnerInput {
            t,
            encoder,
            pose: pose.map(|p| Pose::new(p[0], p[1], p[2])),
            deadman,
        });
        if let Some(e) = self
            .failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
        {
            return Err(err(format!("sampler {}: {e}", self.sampler)));
        }
        let body = self.robot.vehicle.body_velocity(&out.command);
        Ok(Command {
            inputs: out.command.iter().take(dim).copied().collect(),
            linear: body.x,
            angular: body.z,
            interval: out.sample.map(|s| s.interval),
            window: out.sample.map(|s| s.window),
            phase: out.sample.map(|s| s.phase.as_str()),
        })
    }

    /// Hands the windows recorded during the interval that just ended to the sampler (what
    /// the `targeted` sampler learns from); other samplers ignore them.
    fn observe(&mut self, interval: &Dataset) {
        self.runner
            .observe(&interval.inner.robot, &interval.inner.windows);
    }

    /// `"characterizing"`, `"driving"`, `"paused"` or `"done"`.
    #[getter]
    fn state(&self) -> &'static str {
        state_name(self.runner.state())
    }

    /// True once the protocol has ended (see `stop_reason`).
    #[getter]
    fn done(&self) -> bool {
        matches!(self.runner.state(), RunnerState::Done(_))
    }

    /// Why the runner is paused (`"deadman released"`, `"encoders stale"`, `"localization
    /// stale"`), None when it is not.
    #[getter]
    fn pause_reason(&self) -> Option<&'static str> {
        match self.runner.state() {
            RunnerState::Paused { reason, .. } => Some(match reason {
                PauseReason::DeadmanReleased => "deadman released",
                PauseReason::EncodersStale => "encoders stale",
                PauseReason::LocalizationStale => "localization stale",
            }),
            _ => None,
        }
    }

    /// Why the protocol ended (`"intervals"`, `"duration"`, `"geofence: ..."`,
    /// `"converged"`, `"characterization failed: ..."`), None while it runs.
    #[getter]
    fn stop_reason(&self) -> Option<String> {
        match self.runner.state() {
            RunnerState::Done(r) => Some(match r {
                StopReason::Intervals => "intervals".into(),
                StopReason::Duration => "duration".into(),
                StopReason::Geofence { distance } => {
                    format!("geofence: {distance:.2} m from the start")
                }
                StopReason::Converged => "converged".into(),
                StopReason::CharacterizationFailed(why) => {
                    format!("characterization failed: {why}")
                }
            }),
            _ => None,
        }
    }

    /// Intervals driven to their end.
    #[getter]
    fn completed_intervals(&self) -> usize {
        self.runner.completed_intervals()
    }

    /// The input space J being sampled, ((min, max) of the first input, (min, max) of the
    /// second), once known (given, or found by the characterization).
    #[getter]
    fn input_space(&self) -> Option<((f64, f64), (f64, f64))> {
        self.runner.characterization().map(|c| {
            (
                (c.space.min.x, c.space.max.x),
                (c.space.min.y, c.space.max.y),
            )
        })
    }

    /// The effective geometry the characterization identified (name -> value; empty when
    /// the input space was given).
    #[getter]
    fn geometry<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        if let Some(c) = self.runner.characterization() {
            for (k, v) in c.geometry {
                d.set_item(k, v)?;
            }
        }
        Ok(d)
    }

    /// The robot's name.
    #[getter]
    fn robot(&self) -> String {
        self.robot.name.clone()
    }

    /// The command rate (Hz): tick at this rate.
    #[getter]
    fn rate_hz(&self) -> f64 {
        self.robot.rate_hz
    }

    /// The names of the vehicle's inputs (`("left", "right")` for a differential drive,
    /// `("v_x", "v_y", "w")` for an omnidirectional base).
    #[getter]
    fn inputs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        pyo3::types::PyTuple::new(py, self.robot.vehicle.axes().iter().map(|a| a.name))
    }

    fn __repr__(&self) -> String {
        format!(
            "ProtocolRunner(robot={:?}, sampler={:?}, state={:?}, completed_intervals={})",
            self.robot.name,
            self.sampler,
            state_name(self.runner.state()),
            self.runner.completed_intervals()
        )
    }
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<ProtocolRunner>()?;
    m.add_class::<Command>()?;
    Ok(())
}
