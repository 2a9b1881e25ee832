//! Dataset types: windows of DRIVE driving data and the robot that recorded them.

use crate::{BodyVelocity, CommandModel, Input, Pose, StartState};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Duration of a DRIVE window (s, Sec. III-A).
pub const WINDOW_S: f64 = 2.0;
/// Windows per DRIVE interval: one transient, two steady (6 s in all).
pub const WINDOWS_PER_INTERVAL: usize = 3;

/// The phase of a window inside a DRIVE training interval (Sec. III-A): one transient window
/// (the command just changed) followed by steady windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// First 2 s window after a new command.
    Transient,
    /// A window where the command has been held for at least one window.
    Steady,
}

impl Phase {
    /// The name used in the window CSV (`transient` or `steady`).
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Transient => "transient",
            Phase::Steady => "steady",
        }
    }
}

/// The robot description that comes with a dataset: its vehicle (with the geometry) and
/// rates.
///
/// ```
/// use drive_traits::{CommandModel, RobotDescription};
/// # use drive_traits::{BodyVelocity, Input, InputAxis};
/// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct Unicycle;
/// # #[typetag::serde(name = "unicycle-robot-doc")] impl CommandModel for Unicycle {
/// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
/// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z)) }
/// #   fn axes(&self) -> [InputAxis; 2] { [InputAxis { name: "v", unit: "m/s", command_column: "cmd_v", measured_column: "meas_v" },
/// #       InputAxis { name: "omega", unit: "rad/s", command_column: "cmd_omega", measured_column: "meas_omega" }] }
/// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(Unicycle) } }
/// let robot = RobotDescription::new("run-1", "my robot", 20.0, 40, Unicycle);
/// assert_eq!(robot.dt(), 0.05);
/// assert_eq!(robot.vehicle.axes()[0].command_column, "cmd_v");
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RobotDescription {
    /// Dataset name (from the sidecar).
    pub name: String,
    /// Robot name, free text.
    pub robot: String,
    /// Command and sample rate (Hz).
    pub rate_hz: f64,
    /// Samples per window.
    pub window_len: usize,
    /// The vehicle: its command model (eq. 2, eq. 4) with its geometry.
    pub vehicle: Arc<dyn CommandModel>,
}

impl RobotDescription {
    /// A description of `vehicle`.
    pub fn new(
        name: &str,
        robot: &str,
        rate_hz: f64,
        window_len: usize,
        vehicle: impl CommandModel + 'static,
    ) -> Self {
        RobotDescription {
            name: name.to_string(),
            robot: robot.to_string(),
            rate_hz,
            window_len,
            vehicle: Arc::new(vehicle),
        }
    }

    /// Sample period (s).
    pub fn dt(&self) -> f64 {
        1.0 / self.rate_hz
    }
}

impl PartialEq for RobotDescription {
    fn eq(&self, other: &Self) -> bool {
        // Vehicles are compared by their saved form (type and geometry).
        self.name == other.name
            && self.robot == other.robot
            && self.rate_hz == other.rate_hz
            && self.window_len == other.window_len
            && serde_json::to_value(self.vehicle.as_ref()).ok()
                == serde_json::to_value(other.vehicle.as_ref()).ok()
    }
}

/// One window of driving data: `window_len` samples at the command rate.
///
/// Poses are relative to the window's start pose, expressed in the robot's body frame at
/// the window start (x forward, y left).
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    /// Window index in recording order.
    pub index: usize,
    /// DRIVE interval this window belongs to (a transient window starts a new interval).
    pub interval: usize,
    /// Transient or steady.
    pub phase: Phase,
    /// Commanded input per sample (wheel angular velocities for a skid-steer).
    pub command: Vec<Input>,
    /// Measured input per sample (encoder wheel velocities for a skid-steer).
    pub measured: Vec<Input>,
    /// Localization pose per sample.
    pub pose: Vec<Pose>,
    /// IMU angular velocity about the vertical axis per sample (rad/s).
    pub imu_yaw_rate: Vec<f64>,
}

impl Window {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pose.len()
    }

    /// True if the window holds no sample.
    pub fn is_empty(&self) -> bool {
        self.pose.is_empty()
    }

    /// The state at the window start, from what is measured at that instant only (nothing
    /// from later in the window leaks into a prediction): the first pose, the measured
    /// input, and the body velocity given by the measured input through the vehicle's
    /// command model with the IMU yaw rate as angular velocity.
    pub fn start_state(&self, vehicle: &dyn CommandModel) -> StartState {
        let measured = self.measured[0];
        let from_encoders = vehicle.body_velocity(&measured);
        StartState {
            pose: self.pose[0],
            input: measured,
            body_velocity: BodyVelocity::new(
                from_encoders.x,
                from_encoders.y,
                self.imu_yaw_rate[0],
            ),
        }
    }
}

/// A borrowed selection of windows with the robot that recorded them: what learners fit on
/// and what metrics evaluate.
#[derive(Debug, Clone)]
pub struct WindowSet<'a> {
    /// The robot description.
    pub robot: &'a RobotDescription,
    /// The selected windows, in recording order.
    pub windows: Vec<&'a Window>,
}

impl<'a> WindowSet<'a> {
    /// A selection of all the given windows.
    pub fn new(robot: &'a RobotDescription, windows: &'a [Window]) -> Self {
        WindowSet {
            robot,
            windows: windows.iter().collect(),
        }
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.windows.len()
    }

    /// True when no window is selected.
    pub fn is_empty(&self) -> bool {
        self.windows.is_empty()
    }

    /// Iterates over the windows of one phase.
    pub fn of_phase(&self, phase: Phase) -> impl Iterator<Item = &'a Window> + '_ {
        self.windows
            .iter()
            .copied()
            .filter(move |w| w.phase == phase)
    }
}

/// A whole dataset: the robot description and its windows in recording order.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// The robot and rates (from the sidecar).
    pub robot: RobotDescription,
    /// The windows, in recording order, with their interval numbers assigned.
    pub windows: Vec<Window>,
}

impl Dataset {
    /// All windows as a [`WindowSet`].
    pub fn all(&self) -> WindowSet<'_> {
        WindowSet::new(&self.robot, &self.windows)
    }

    /// Number of DRIVE intervals (a transient window and the steady windows that follow it).
    pub fn interval_count(&self) -> usize {
        self.windows.last().map_or(0, |w| w.interval + 1)
    }
}

/// Numbers the DRIVE intervals of windows in recording order: a transient window starts a
/// new interval, steady windows belong to the interval before them (steady windows at the
/// very start form interval 0). Returns the number of intervals.
///
/// ```
/// use drive_traits::{assign_intervals, Phase};
/// let phases = [Phase::Transient, Phase::Steady, Phase::Steady, Phase::Transient, Phase::Steady];
/// let mut intervals = vec![0; phases.len()];
/// assert_eq!(assign_intervals(&phases, &mut intervals), 2);
/// assert_eq!(intervals, vec![0, 0, 0, 1, 1]);
/// ```
pub fn assign_intervals(phases: &[Phase], intervals: &mut [usize]) -> usize {
    let mut current: Option<usize> = None;
    for (phase, slot) in phases.iter().zip(intervals.iter_mut()) {
        let next = match (current, phase) {
            (None, _) => 0,
            (Some(c), Phase::Transient) => c + 1,
            (Some(c), Phase::Steady) => c,
        };
        current = Some(next);
        *slot = next;
    }
    current.map_or(0, |c| c + 1)
}
