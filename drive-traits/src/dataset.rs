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

    /// The state at the window start with the default start information
    /// ([`StartInfo::EncodersImu`]): see [`Window::start_state_with`].
    pub fn start_state(&self, vehicle: &dyn CommandModel) -> StartState {
        self.start_state_with(vehicle, StartInfo::default())
    }

    /// The state at the window start, from what is measured at that instant only (nothing
    /// from later in the window leaks into a prediction): the first pose, the measured
    /// input, and the body velocity given by the measured input through the vehicle's
    /// command model, its angular velocity from the IMU with [`StartInfo::EncodersImu`].
    ///
    /// ```
    /// use drive_traits::{Input, InputAxis, BodyVelocity, CommandModel, Phase, Pose, StartInfo, Window};
    /// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
    /// # #[typetag::serde(name = "v-start-doc")] impl CommandModel for V {
    /// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
    /// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z)) }
    /// #   fn axes(&self) -> [InputAxis; 2] { [InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
    /// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
    /// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
    /// let w = Window { index: 0, interval: 0, phase: Phase::Steady, command: vec![Input::zeros(); 2],
    ///     measured: vec![Input::new(1.0, 0.5); 2], pose: vec![Pose::zeros(); 2], imu_yaw_rate: vec![0.3; 2] };
    /// assert_eq!(w.start_state_with(&V, StartInfo::Encoders).body_velocity.z, 0.5);
    /// assert_eq!(w.start_state_with(&V, StartInfo::EncodersImu).body_velocity.z, 0.3);
    /// ```
    pub fn start_state_with(&self, vehicle: &dyn CommandModel, info: StartInfo) -> StartState {
        let measured = self.measured[0];
        let from_encoders = vehicle.body_velocity(&measured);
        let yaw_rate = match info {
            StartInfo::Encoders => from_encoders.z,
            StartInfo::EncodersImu => self.imu_yaw_rate[0],
        };
        StartState {
            pose: self.pose[0],
            input: measured,
            body_velocity: BodyVelocity::new(from_encoders.x, from_encoders.y, yaw_rate),
        }
    }
}

/// What a prediction may use of the measurements at the window start (the same for every
/// model of a comparison). The pose and the measured input are always known; the body
/// velocity (used by models whose state is a velocity, such as acc-BLR) comes from the
/// encoders through the vehicle's eq. 4, with the IMU's yaw rate or without it.
///
/// ```
/// use drive_traits::StartInfo;
/// assert_eq!(StartInfo::default(), StartInfo::EncodersImu);
/// assert_eq!(StartInfo::parse("encoders").unwrap(), StartInfo::Encoders);
/// assert_eq!(StartInfo::EncodersImu.as_str(), "encoders+imu");
/// assert!(StartInfo::parse("gps").is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
pub enum StartInfo {
    /// The encoders only: the body velocity is eq. 4 on the measured wheel velocities.
    #[serde(rename = "encoders")]
    Encoders,
    /// The encoders and the IMU: the yaw rate is the IMU's (the default).
    #[default]
    #[serde(rename = "encoders+imu")]
    EncodersImu,
}

impl StartInfo {
    /// The names, as the command line takes them.
    pub const NAMES: [&'static str; 2] = ["encoders", "encoders+imu"];

    /// The start information of a name.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "encoders" => Ok(StartInfo::Encoders),
            "encoders+imu" => Ok(StartInfo::EncodersImu),
            other => Err(format!(
                "unknown start information {other:?}; known: {}",
                Self::NAMES.join(", ")
            )),
        }
    }

    /// The name.
    pub fn as_str(self) -> &'static str {
        match self {
            StartInfo::Encoders => "encoders",
            StartInfo::EncodersImu => "encoders+imu",
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

    /// The windows cut into `folds` contiguous blocks of DRIVE intervals (as equal in
    /// intervals as can be): for each block, `(the other windows, the block's windows)`,
    /// both in recording order; `None` for fewer than two folds or fewer intervals than
    /// folds.
    ///
    /// ```
    /// use drive_traits::{Dataset, Input, Phase, Pose, RobotDescription, Window};
    /// # use drive_traits::{BodyVelocity, CommandModel, InputAxis};
    /// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
    /// # #[typetag::serde(name = "v-folds-doc")] impl CommandModel for V {
    /// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
    /// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z)) }
    /// #   fn axes(&self) -> [InputAxis; 2] { [InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
    /// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
    /// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
    /// let window = |index, interval| Window { index, interval, phase: Phase::Steady, command: vec![], measured: vec![], pose: vec![], imu_yaw_rate: vec![] };
    /// let data = Dataset { robot: RobotDescription::new("toy", "", 20.0, 40, V),
    ///     windows: (0..10).map(|i| window(i, i / 2)).collect() };
    /// let folds = data.all().interval_folds(2).unwrap(); // 5 intervals: 2 and 3
    /// assert_eq!((folds[0].0.len(), folds[0].1.len()), (6, 4));
    /// assert_eq!((folds[1].0.len(), folds[1].1.len()), (4, 6));
    /// assert!(data.all().interval_folds(6).is_none());
    /// ```
    pub fn interval_folds(&self, folds: usize) -> Option<Vec<(WindowSet<'a>, WindowSet<'a>)>> {
        let mut intervals: Vec<usize> = self.windows.iter().map(|w| w.interval).collect();
        intervals.dedup();
        let m = intervals.len();
        if folds < 2 || m < folds {
            return None;
        }
        // Block j holds the intervals at positions [j m / folds, (j + 1) m / folds).
        let bounds: Vec<usize> = (0..=folds).map(|j| j * m / folds).collect();
        let block_of = |interval: usize| {
            let pos = intervals.partition_point(|&i| i < interval);
            bounds.partition_point(|&b| b <= pos) - 1
        };
        let blocks: Vec<usize> = self.windows.iter().map(|w| block_of(w.interval)).collect();
        Some(
            (0..folds)
                .map(|j| {
                    let pick = |inside: bool| WindowSet {
                        robot: self.robot,
                        windows: self
                            .windows
                            .iter()
                            .zip(&blocks)
                            .filter(|(_, b)| (**b == j) == inside)
                            .map(|(w, _)| *w)
                            .collect(),
                    };
                    (pick(false), pick(true))
                })
                .collect(),
        )
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
