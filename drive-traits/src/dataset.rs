//! Dataset types: windows of DRIVE driving data and the robot that recorded them.

use crate::UnknownName;
use crate::{CommandModel, Input, Pose, StartState};
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
/// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
/// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "cmd_v", measured_column: "meas_v" },
/// #       InputAxis { name: "omega", unit: "rad/s", command_column: "cmd_omega", measured_column: "meas_omega" }] }
/// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(Unicycle) } }
/// let robot = RobotDescription::new("run-1", "my robot", 20.0, 40, Unicycle);
/// assert_eq!(robot.dt(), 0.05);
/// assert_eq!(robot.vehicle.axes()[0].command_column, "cmd_v");
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
// A model file holds one (drive-models' loader): a key it never writes is refused.
#[serde(deny_unknown_fields)]
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
    /// The frame each window's positions are expressed in (the sidecar's
    /// `position_frame`; [`PositionFrame::FirstSample`] when it says nothing).
    #[serde(default)]
    pub position_frame: PositionFrame,
    /// The ground the data was recorded on, free text (the sidecar's `terrain`; empty when
    /// it says nothing).
    #[serde(default)]
    pub terrain: String,
    /// The registered robot the data was recorded with, by its exact name (the sidecar's
    /// `registered_robot`, written by `drive simulate` and `drive import --robot`; empty
    /// when it says nothing): a benchmark pairs the runs of one robot by it.
    #[serde(default)]
    pub registered_robot: String,
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
            position_frame: PositionFrame::default(),
            terrain: String::new(),
            registered_robot: String::new(),
        }
    }

    /// The same description recorded with the registered robot `name`, when a sidecar can
    /// hold it (a part's name of at most 200 characters; otherwise left empty).
    ///
    /// ```
    /// # use drive_traits::{RobotDescription, vehicles::DifferentialDrive};
    /// let d = RobotDescription::new("run", "my rover", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
    /// assert_eq!(d.clone().with_registered_robot("my-rover").registered_robot, "my-rover");
    /// assert_eq!(d.with_registered_robot("my rover").registered_robot, "");
    /// ```
    pub fn with_registered_robot(mut self, name: &str) -> Self {
        self.registered_robot = if crate::is_part_name(name) && name.len() <= 200 {
            name.to_string()
        } else {
            String::new()
        };
        self
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
            && self.position_frame == other.position_frame
            && self.terrain == other.terrain
            && self.registered_robot == other.registered_robot
            && serde_json::to_value(self.vehicle.as_ref()).ok()
                == serde_json::to_value(other.vehicle.as_ref()).ok()
    }
}

/// One window of driving data: `window_len` samples at the command rate.
///
/// Poses are relative to the window's start pose, expressed in the robot's body frame at
/// the window start (x forward, y left).
///
/// Built with [`Window::new`] outside this crate (the type is `#[non_exhaustive]`: a field
/// added later is not a breaking change); its fields stay public to read and to set.
///
/// ```
/// use drive_traits::{Input, Phase, Pose, Window};
/// let w = Window::new(3, 1, Phase::Steady, vec![Input::new(1.0, 1.0, 0.0); 4], vec![Input::new(0.9, 1.1, 0.0); 4],
///     (0..4).map(|k| Pose::new(0.05 * k as f64, 0.0, 0.0)).collect(), vec![0.0; 4])
///     .with_start_velocity(Some([1.0, 0.0]));
/// assert_eq!((w.index, w.interval, w.len()), (3, 1, 4));
/// assert_eq!(w.start_velocity, Some([1.0, 0.0]));
/// ```
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
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
    /// IMU angular velocity about the vertical axis per sample (rad/s); NaN where it is not
    /// given to a model (the training windows of a model fitted for
    /// [`StartInfo::Encoders`] predictions).
    pub imu_yaw_rate: Vec<f64>,
    /// The body-frame velocity (x forward, y left; m/s) at the window start as the
    /// localization measured it before the window: set by [`Dataset::link_start_velocities`]
    /// from the preceding window when it runs on into this one, `None` otherwise. It is not
    /// a column of the window CSV: readers derive it.
    pub start_velocity: Option<[f64; 2]>,
}

impl Window {
    /// A window of `phase`, the `index`-th of its recording and in its DRIVE `interval`, from
    /// its samples (one entry per sample in each vector; [`Dataset`] readers check that
    /// they agree), with no start velocity ([`Window::with_start_velocity`] sets one).
    pub fn new(
        index: usize,
        interval: usize,
        phase: Phase,
        command: Vec<Input>,
        measured: Vec<Input>,
        pose: Vec<Pose>,
        imu_yaw_rate: Vec<f64>,
    ) -> Self {
        Window {
            index,
            interval,
            phase,
            command,
            measured,
            pose,
            imu_yaw_rate,
            start_velocity: None,
        }
    }

    /// The same window with the body-frame velocity at its start (x forward, y left; m/s)
    /// as the localization measured it before the window, `None` when unknown.
    pub fn with_start_velocity(mut self, velocity: Option<[f64; 2]>) -> Self {
        self.start_velocity = velocity;
        self
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pose.len()
    }

    /// True if the window holds no sample.
    pub fn is_empty(&self) -> bool {
        self.pose.is_empty()
    }

    /// The angle (rad) between the paper parser's position frame and the first sample's:
    /// the mean of the first [`PAPER_FRAME_SAMPLES`] yaw values relative to the first, not
    /// wrapped; 0 for an empty window.
    ///
    /// Not wrapped because the parser is not: it averages the absolute Euler yaws, and its
    /// yaw column holds their plain differences, so a heading crossing +-pi in the first
    /// five samples puts jumps of 2 pi in both, and the frame the positions were rotated into
    /// is the plain mean (off the true heading by a multiple of 2 pi / 5).
    ///
    /// ```
    /// use drive_traits::{Phase, Pose, Window};
    /// let yaws = [0.0, 0.01, -6.27, -6.26, -6.25]; // the heading crosses pi after sample 1
    /// let w = Window::new(0, 0, Phase::Transient, vec![Default::default(); 5], vec![Default::default(); 5], yaws.iter().map(|y| Pose::new(0.0, 0.0, *y)).collect(), vec![0.0; 5]);
    /// assert!((w.paper_frame_angle() - (-18.77 / 5.0)).abs() < 1e-12);
    /// ```
    pub fn paper_frame_angle(&self) -> f64 {
        let n = self.pose.len().min(PAPER_FRAME_SAMPLES);
        if n == 0 {
            return 0.0;
        }
        let yaw0 = self.pose[0].z;
        self.pose[..n].iter().map(|q| q.z - yaw0).sum::<f64>() / n as f64
    }

    /// Rotates positions written in the paper parser's frame
    /// ([`PositionFrame::PaperMean5`]) into the first sample's frame: `p' = R(a) p`, with
    /// `a` the [`Window::paper_frame_angle`]. Yaw is unchanged (it is already relative to the
    /// first sample); the origin stays at the first sample's position.
    ///
    /// ```
    /// use drive_traits::{Input, Phase, Pose, Window};
    /// // Driving straight along the robot's x axis while the yaw reads 0.1 rad for the first
    /// // five samples: the paper's frame holds the positions rotated by -0.1 rad.
    /// let a: f64 = 0.1;
    /// let pose: Vec<Pose> = (0..6)
    ///     .map(|k| {
    ///         let d = 0.1 * k as f64;
    ///         Pose::new(d * a.cos(), -d * a.sin(), if k == 0 { 0.0 } else { 0.125 })
    ///     })
    ///     .collect();
    /// let mut w = Window::new(0, 0, Phase::Transient, vec![Input::zeros(); 6], vec![Input::zeros(); 6], pose, vec![0.0; 6]);
    /// assert!((w.paper_frame_angle() - a).abs() < 1e-12);
    /// w.to_first_sample_frame();
    /// assert!((w.pose[5].x - 0.5).abs() < 1e-12 && w.pose[5].y.abs() < 1e-12);
    /// assert_eq!(w.pose[5].z, 0.125);
    /// ```
    pub fn to_first_sample_frame(&mut self) {
        let (s, c) = self.paper_frame_angle().sin_cos();
        for q in &mut self.pose {
            let (x, y) = (q.x, q.y);
            q.x = c * x - s * y;
            q.y = s * x + c * y;
        }
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
    /// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
    /// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
    /// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
    /// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
    /// let w = Window::new(0, 0, Phase::Steady, vec![Input::zeros(); 2], vec![Input::new(1.0, 0.5, 0.0); 2], vec![Pose::zeros(); 2], vec![0.3; 2]);
    /// assert_eq!(w.start_state_with(&V, StartInfo::Encoders).body_velocity.z, 0.5);
    /// assert_eq!(w.start_state_with(&V, StartInfo::EncodersImu).body_velocity.z, 0.3);
    /// assert_eq!(w.start_state_with(&V, StartInfo::EncodersImu).yaw_rate, Some(0.3));
    /// assert_eq!(w.start_state_with(&V, StartInfo::Encoders).yaw_rate, None);
    /// ```
    pub fn start_state_with(&self, vehicle: &dyn CommandModel, info: StartInfo) -> StartState {
        let start = StartState::measured(self.pose[0], self.measured[0], vehicle);
        match info {
            StartInfo::Encoders => start,
            StartInfo::EncodersImu => start.with_yaw_rate(self.imu_yaw_rate[0]),
            StartInfo::EncodersImuLocalization => {
                let start = start.with_yaw_rate(self.imu_yaw_rate[0]);
                match self.start_velocity {
                    Some(v) => start.with_velocity(v),
                    None => start,
                }
            }
        }
    }

    /// The body-frame velocity (x forward, y left; m/s) at this window's last sample from
    /// its localization: the displacement over the last `span` samples, turned into the body
    /// frame of the last sample and divided by their time (`span` steps of `dt`). Positions
    /// are read in `frame`. `None` when the window is shorter than `span + 1` samples, `span`
    /// is 0 or a value is not finite.
    ///
    /// ```
    /// use drive_traits::{Input, Phase, Pose, PositionFrame, Window};
    /// // Driving at 2 m/s along the world's y axis while heading along it (yaw pi/2).
    /// let h = std::f64::consts::FRAC_PI_2;
    /// let pose = (0..6).map(|k| Pose::new(0.0, 0.1 * k as f64, if k == 0 { 0.0 } else { h })).collect();
    /// let w = Window::new(0, 0, Phase::Steady, vec![Input::zeros(); 6], vec![Input::zeros(); 6], pose, vec![0.0; 6]);
    /// let [vx, vy] = w.end_velocity(4, 0.05, PositionFrame::FirstSample).unwrap();
    /// assert!((vx - 2.0).abs() < 1e-12 && vy.abs() < 1e-12);
    /// assert!(w.end_velocity(6, 0.05, PositionFrame::FirstSample).is_none());
    /// ```
    pub fn end_velocity(&self, span: usize, dt: f64, frame: PositionFrame) -> Option<[f64; 2]> {
        let n = self.pose.len();
        if span == 0 || n < span + 1 {
            return None;
        }
        let (a, b) = (self.pose[n - 1 - span], self.pose[n - 1]);
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        // The positions' frame is turned by `offset` from the first sample's; the body frame
        // of the last sample by its yaw.
        let offset = match frame {
            PositionFrame::FirstSample => 0.0,
            PositionFrame::PaperMean5 => self.paper_frame_angle(),
        };
        let (s, c) = (offset - b.z).sin_cos();
        let t = span as f64 * dt;
        let v = [(c * dx - s * dy) / t, (s * dx + c * dy) / t];
        v.iter().all(|x| x.is_finite()).then_some(v)
    }

    /// Whether `next` runs on from this window without a gap: its index is the next one and,
    /// for each measured input and the IMU's yaw rate, the step from this window's last
    /// sample to `next`'s first is no larger than the largest step between two samples
    /// inside either window (a gap in the recording shows as a jump the robot cannot make
    /// in one step).
    ///
    /// ```
    /// use drive_traits::{Input, Phase, Pose, Window};
    /// let w = |index, wheel: [f64; 3]| Window::new(index, 0, Phase::Steady, vec![Input::zeros(); 3], wheel.iter().map(|&u| Input::new(u, u, 0.0)).collect(), vec![Pose::zeros(); 3], vec![0.0; 3]);
    /// assert!(w(0, [1.0, 1.1, 1.2]).continued_by(&w(1, [1.3, 1.4, 1.5])));
    /// assert!(!w(0, [1.0, 1.1, 1.2]).continued_by(&w(1, [3.0, 3.1, 3.2]))); // a jump of 1.8
    /// assert!(!w(0, [1.0, 1.1, 1.2]).continued_by(&w(2, [1.3, 1.4, 1.5]))); // a window missing
    /// ```
    pub fn continued_by(&self, next: &Window) -> bool {
        let len = |w: &Window| w.measured.len().min(w.imu_yaw_rate.len());
        let (n, m) = (len(self), len(next));
        if next.index != self.index + 1 || n == 0 || m == 0 {
            return false;
        }
        let channels: [fn(&Window, usize) -> f64; 3] = [
            |w, k| w.measured[k].x,
            |w, k| w.measured[k].y,
            |w, k| w.imu_yaw_rate[k],
        ];
        channels.iter().all(|value| {
            let largest_step = |w: &Window| {
                (1..len(w))
                    .map(|k| (value(w, k) - value(w, k - 1)).abs())
                    .fold(0.0, f64::max)
            };
            // A NaN anywhere makes this false: no link.
            (value(next, 0) - value(self, n - 1)).abs()
                <= largest_step(self).max(largest_step(next))
        })
    }
}

/// What a prediction may use of the measurements at the window start (the same for every
/// model of a comparison). The pose and the measured input are always known; the body
/// velocity (used by models whose state is a velocity, such as acc-BLR) comes from the
/// encoders through the vehicle's eq. 4, with the IMU's yaw rate or without it, and with
/// the localization's velocity just before the window or without it.
///
/// ```
/// use drive_traits::StartInfo;
/// assert_eq!(StartInfo::default(), StartInfo::EncodersImu);
/// assert_eq!(StartInfo::parse("encoders").unwrap(), StartInfo::Encoders);
/// assert_eq!(StartInfo::EncodersImu.as_str(), "encoders+imu");
/// assert_eq!(
///     StartInfo::parse("encoders+imu+localization").unwrap(),
///     StartInfo::EncodersImuLocalization
/// );
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
    /// The encoders, the IMU and the localization: besides the IMU's yaw rate, the body
    /// velocity's x and y are the localization's just before the window
    /// ([`Window::start_velocity`]) where the data has it, what a robot running a
    /// model-predictive controller knows. The paper's models do not use it.
    #[serde(rename = "encoders+imu+localization")]
    EncodersImuLocalization,
}

impl StartInfo {
    /// The names, as the command line takes them.
    pub const NAMES: [&'static str; 3] = ["encoders", "encoders+imu", "encoders+imu+localization"];

    /// The start information of a name.
    pub fn parse(name: &str) -> Result<Self, UnknownName> {
        match name {
            "encoders" => Ok(StartInfo::Encoders),
            "encoders+imu" => Ok(StartInfo::EncodersImu),
            "encoders+imu+localization" => Ok(StartInfo::EncodersImuLocalization),
            other => Err(UnknownName::from(format!(
                "unknown start information {other:?}; known: {}",
                Self::NAMES.join(", ")
            ))),
        }
    }

    /// The name.
    pub fn as_str(self) -> &'static str {
        match self {
            StartInfo::Encoders => "encoders",
            StartInfo::EncodersImu => "encoders+imu",
            StartInfo::EncodersImuLocalization => "encoders+imu+localization",
        }
    }
}

/// The time over which [`Window::end_velocity`] measures the localization's velocity at a
/// window's end (s): long enough to span several localization updates (lidar ICP runs at
/// about 10 Hz), short enough to be the velocity of that instant.
pub const END_VELOCITY_SPAN_S: f64 = 0.5;

/// The frame a window's positions (`x`, `y`) are expressed in. Yaw is always relative to
/// the window's first sample.
///
/// The paper's own parser (norlab-ulaval/DRIVE, `model_training/data_utils/dataset_parser.py`)
/// re-bases each window's positions with a transform built from the **mean orientation of
/// its first five samples**, while its yaw column is relative to the **first** sample: the
/// published datasets (and the bundled one) are [`PositionFrame::PaperMean5`]. The
/// project's own raw import and simulator use the first sample for both
/// ([`PositionFrame::FirstSample`]). [`Window::to_first_sample_frame`] converts.
///
/// ```
/// use drive_traits::PositionFrame;
/// assert_eq!(PositionFrame::parse("paper-mean5").unwrap(), PositionFrame::PaperMean5);
/// assert_eq!(PositionFrame::default().as_str(), "first-sample");
/// assert!(PositionFrame::parse("map").is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
pub enum PositionFrame {
    /// Positions in the frame of the window's first sample, like its yaw (the default).
    #[default]
    #[serde(rename = "first-sample")]
    FirstSample,
    /// Positions in the frame of the mean orientation of the window's first five samples
    /// (origin at the first sample), as the paper's parser writes them.
    #[serde(rename = "paper-mean5")]
    PaperMean5,
}

impl PositionFrame {
    /// The names, as sidecars declare them.
    pub const NAMES: [&'static str; 2] = ["first-sample", "paper-mean5"];

    /// The frame of a name.
    pub fn parse(name: &str) -> Result<Self, UnknownName> {
        match name {
            "first-sample" => Ok(PositionFrame::FirstSample),
            "paper-mean5" => Ok(PositionFrame::PaperMean5),
            other => Err(UnknownName::from(format!(
                "unknown position frame {other:?}; known: {}",
                Self::NAMES.join(", ")
            ))),
        }
    }

    /// The name.
    pub fn as_str(self) -> &'static str {
        match self {
            PositionFrame::FirstSample => "first-sample",
            PositionFrame::PaperMean5 => "paper-mean5",
        }
    }
}

/// Samples whose orientation the paper's parser averages to re-base a window's positions.
pub const PAPER_FRAME_SAMPLES: usize = 5;

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
    /// intervals as can be, or, where a block would hold under half its share of the
    /// driven intervals (a command other than zero: a long stop), as equal in driven
    /// intervals): for each block, `(the other windows, the block's windows)`,
    /// both in recording order; `None` for fewer than two folds or fewer intervals than
    /// folds.
    ///
    /// ```
    /// use drive_traits::{Dataset, Input, Phase, Pose, RobotDescription, Window};
    /// # use drive_traits::{BodyVelocity, CommandModel, InputAxis};
    /// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
    /// # #[typetag::serde(name = "v-folds-doc")] impl CommandModel for V {
    /// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
    /// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
    /// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
    /// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
    /// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
    /// let window = |index, interval| Window::new(index, interval, Phase::Steady, vec![], vec![], vec![], vec![]);
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
        let mut bounds: Vec<usize> = (0..=folds).map(|j| j * m / folds).collect();
        // Unless a block would hold under half its share of the driven intervals (those
        // with a command other than zero): a block of a robot at rest (a long stop) fits a
        // model of no motion, whose predictions of the other block are meaningless (its
        // calibration scaled the regions 1e12-fold). The blocks are then cut as equal in
        // driven intervals as can be.
        let driven: Vec<bool> = intervals
            .iter()
            .map(|&i| {
                self.windows
                    .iter()
                    .filter(|w| w.interval == i)
                    .any(|w| w.command.iter().any(|c| c.iter().any(|v| *v != 0.0)))
            })
            .collect();
        let total = driven.iter().filter(|d| **d).count();
        let starved = bounds.windows(2).any(|b| {
            let held = driven[b[0]..b[1]].iter().filter(|d| **d).count();
            2 * held * folds < total
        });
        if starved && total >= folds {
            let mut seen = 0;
            let mut next = 1;
            for (pos, d) in driven.iter().enumerate() {
                seen += usize::from(*d);
                // The block boundary after the interval that completes block `next`'s share.
                while next < folds && seen * folds >= next * total && *d {
                    bounds[next] = pos + 1;
                    next += 1;
                }
            }
        }
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

    /// Sets every window's [`Window::start_velocity`]: the localization's velocity at the
    /// end of the preceding window ([`Window::end_velocity`] over
    /// [`END_VELOCITY_SPAN_S`]) when that window runs on into it
    /// ([`Window::continued_by`]), `None` otherwise (the first window, after a gap, or
    /// with a non-finite value). Readers of window data call it; call it again after
    /// building or editing windows by hand.
    ///
    /// ```
    /// use drive_traits::{Dataset, Input, Phase, Pose, RobotDescription, Window};
    /// # use drive_traits::{BodyVelocity, CommandModel, InputAxis};
    /// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
    /// # #[typetag::serde(name = "v-link-doc")] impl CommandModel for V {
    /// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
    /// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
    /// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
    /// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
    /// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
    /// // Two windows of 40 samples at 20 Hz, driving straight at 1 m/s.
    /// let window = |index| Window::new(index, 0, Phase::Steady, vec![Input::new(1.0, 0.0, 0.0); 40], vec![Input::new(1.0, 0.0, 0.0); 40], (0..40).map(|k| Pose::new(0.05 * k as f64, 0.0, 0.0)).collect(), vec![0.0; 40]);
    /// let mut data = Dataset { robot: RobotDescription::new("toy", "", 20.0, 40, V),
    ///     windows: vec![window(0), window(1)] };
    /// data.link_start_velocities();
    /// assert_eq!(data.windows[0].start_velocity, None);
    /// let [vx, vy] = data.windows[1].start_velocity.unwrap();
    /// assert!((vx - 1.0).abs() < 1e-12 && vy.abs() < 1e-12);
    /// ```
    pub fn link_start_velocities(&mut self) {
        let dt = self.robot.dt();
        let span = (END_VELOCITY_SPAN_S / dt).round().max(1.0) as usize;
        let frame = self.robot.position_frame;
        let mut before: Option<[f64; 2]> = None;
        for i in 0..self.windows.len() {
            let start = match i.checked_sub(1) {
                Some(p) if self.windows[p].continued_by(&self.windows[i]) => before,
                _ => None,
            };
            before = self.windows[i].end_velocity(span, dt, frame);
            self.windows[i].start_velocity = start;
        }
    }

    /// Expresses every window's positions in its first sample's frame (see
    /// [`PositionFrame`]): windows declared [`PositionFrame::PaperMean5`] are rotated by
    /// [`Window::to_first_sample_frame`]; data already in that frame is unchanged. Returns
    /// the frame the data was in.
    pub fn to_first_sample_frame(&mut self) -> PositionFrame {
        let was = self.robot.position_frame;
        if was == PositionFrame::PaperMean5 {
            for w in &mut self.windows {
                w.to_first_sample_frame();
            }
            self.robot.position_frame = PositionFrame::FirstSample;
        }
        was
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
