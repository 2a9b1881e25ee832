//! Following a path with a controller, one tick at a time: the [`Tracker`] keeps where the
//! robot is on the path, estimates its state from what its sensors report, asks the
//! controller for a command and holds that command to the robot's limits.
//!
//! The state estimate: the last localization fix, carried forward from when it was measured
//! ([`Observation::pose_time`], its stamp) to the tick's time with the body velocity the
//! fixes of the last half second show (the localization often runs slower than the
//! commands, 10 Hz against 20 Hz, and late); the measured inputs as they are; the
//! IMU's yaw rate and the localization's velocity only when the model was fitted to start
//! from them ([`StartInfo`]), as `drive eval --start` gives them.

use crate::controller::{
    stop_input, ControlError, ControlSetup, ControlState, Controller, InputMap, MakeController,
};
use crate::path::{ReferencePath, CONTINUITY};
use drive_traits::robot::{next_command, RobotSpec, SentCommand};
use drive_traits::{
    euler_step, wrap_angle, BodyVelocity, CommandModel, Input, Pose, StartInfo, StartState,
};
use std::collections::VecDeque;
use std::sync::Arc;

/// What the robot's sensors report at a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Time (s).
    pub t: f64,
    /// Measured inputs (encoder wheel velocities for a skid-steer), in the vehicle's (the
    /// model's) coordinates.
    pub input: Input,
    /// A new localization fix, when one arrived at this tick.
    pub pose: Option<Pose>,
    /// The IMU's yaw rate (rad/s), when the robot has one.
    pub imu_yaw_rate: Option<f64>,
    /// When the fix in `pose` was measured (s, on `t`'s clock: a ROS pose message's header
    /// stamp), when known: the fix is carried forward from then, and a fix published again
    /// with the same stamp is no new fix. `None`: measured at `t` (no latency).
    pub pose_time: Option<f64>,
}

/// How far after the tick's time a localization fix's stamp may be (s) and still be taken
/// as measured now: clocks a little apart (a stamp a few milliseconds ahead) are; one a
/// second or more ahead is on another clock ([`ControlError::PoseFromTheFuture`]).
pub const MAX_FUTURE_STAMP_S: f64 = 1.0;

/// Settings of a [`Tracker`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerConfig {
    /// Speed along the path (m/s).
    pub speed: f64,
    /// What the model's predictions start from (as it was fitted).
    pub start: StartInfo,
    /// The path is done when the robot is this close to its end (m); default
    /// `max(0.2 m, speed x 0.5 s)`.
    pub goal_tolerance: Option<f64>,
    /// How far back the controller's predictions start (s): from the state this long ago
    /// through the commands sent since, so that the commands still in flight (dead time,
    /// lag) act in them ([`ControlState::past`]); 0 starts them from now. `None`: the
    /// model's powertrain's settling time ([`settling_history_s`](crate::settling_history_s)).
    pub history_s: Option<f64>,
    /// The reference's timing. `Some(lead_s)`: a schedule along the path advancing at
    /// `speed` every tick, the reference starting where the schedule is, held within
    /// `lead_s` seconds of travel of the robot's progress (ahead of the robot, it pulls;
    /// behind, it holds back): a model that under- or over-predicts the speed is corrected
    /// towards `speed` by the loop. `None`: the reference starts where the robot is at
    /// every tick, and the speed driven is what the model makes of it.
    pub schedule_s: Option<f64>,
}

impl TrackerConfig {
    /// At `speed` (m/s), the predictions starting from the encoders and the IMU, as far
    /// back as the model's powertrain takes to settle.
    ///
    /// ```
    /// let c = drive_control::TrackerConfig::new(0.5);
    /// assert_eq!((c.speed, c.history_s), (0.5, None));
    /// ```
    pub fn new(speed: f64) -> Self {
        TrackerConfig {
            speed,
            start: StartInfo::EncodersImu,
            goal_tolerance: None,
            history_s: None,
            schedule_s: None,
        }
    }

    /// The speed and the goal tolerance checked, and `path` against them: what
    /// [`Tracker::new`] refuses before it builds a controller, to be asked before any other
    /// work. Returns the goal tolerance (m).
    ///
    /// ```
    /// use drive_control::{ReferencePath, TrackerConfig};
    /// let path = ReferencePath::from_csv("short", "x,y\n0,0\n0.1,0\n").unwrap();
    /// let err = TrackerConfig::new(0.5).check_path(&path).unwrap_err();
    /// assert!(err.to_string().contains("give a longer path"));
    /// let metre = ReferencePath::from_csv("metre", "x,y\n0,0\n1,0\n").unwrap();
    /// assert_eq!(TrackerConfig::new(1.0).check_path(&metre).unwrap(), 0.5);
    /// ```
    pub fn check_path(&self, path: &ReferencePath) -> Result<f64, ControlError> {
        let speed = self.speed;
        if !(speed.is_finite() && speed > 0.0) {
            return Err(ControlError::BadSetting {
                field: "speed",
                message: format!("{speed} m/s is not a positive speed"),
            });
        }
        if let Some(l) = self.schedule_s.filter(|l| !(l.is_finite() && *l > 0.0)) {
            return Err(ControlError::BadSetting {
                field: "schedule_s",
                message: format!("{l} s is not a positive time"),
            });
        }
        let goal_tolerance = match self.goal_tolerance {
            Some(g) if !(g.is_finite() && g > 0.0) => {
                return Err(ControlError::BadSetting {
                    field: "goal_tolerance",
                    message: format!("{g} m is not a positive distance"),
                })
            }
            Some(g) => g,
            None => (speed * 0.5).max(0.2),
        };
        if path.length() <= goal_tolerance {
            return Err(ControlError::BadSetting {
                field: "path",
                message: format!(
                    "'{}' is {} m long, no longer than the distance within which its end counts as reached ({} m): give a longer path",
                    path.name(),
                    drive_traits::limits::Short(path.length()),
                    drive_traits::limits::Short(goal_tolerance)
                ),
            });
        }
        Ok(goal_tolerance)
    }
}

/// What one tick did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick {
    /// The command to send, in the vehicle's coordinates.
    pub command: Input,
    /// The same in the controller's coordinates.
    pub controller_input: Input,
    /// The estimated pose the tick planned from.
    pub estimate: Pose,
    /// Arc length reached on the path (m).
    pub progress_m: f64,
    /// Signed distance of the estimate from the path (m, positive to its left).
    pub cross_track_m: f64,
    /// Heading of the estimate against the path's (rad).
    pub heading_error_rad: f64,
    /// The end of the path is reached (the command then stops the robot).
    pub done: bool,
}

/// Longest the localization's velocity is measured over (s), as a window's start velocity.
const VELOCITY_SPAN_S: f64 = 0.5;

/// Follows a path with a controller and a fitted model, tick by tick: the online use of a
/// model (a ROS node calls [`Tracker::tick`] at the command rate).
///
/// ```
/// use drive_control::{builtin_controllers, ControlSetup, InputMap, Mppi, Observation, PathShape, Tracker, TrackerConfig};
/// use drive_models::{ComposedModel, DifferentialDrive, powertrain::CommandedPowertrain, slip::NoSlipModel};
/// use drive_traits::{Input, Pose, StartInfo};
/// use std::sync::Arc;
/// let husky = drive_traits::robot::builtin_robots().get("husky").unwrap().part().as_ref().clone();
/// let model = Arc::new(ComposedModel { label: "naive".into(), vehicle: husky.vehicle.clone(),
///     powertrain: Box::new(CommandedPowertrain), slip: Box::new(NoSlipModel), dt: 0.05 });
/// let setup = ControlSetup { model, robot: husky.clone(), to_vehicle: InputMap::identity(), speed: 0.5, seed: 0 };
/// let path = PathShape::Line.at_scale(1.0).unwrap();
/// let config = TrackerConfig { start: StartInfo::Encoders, ..TrackerConfig::new(0.5) };
/// let mut tracker = Tracker::new(&Mppi { samples: 64, ..Mppi::default() }, &setup, path, config, husky.vehicle.clone()).unwrap();
/// let mut input = Input::zeros();
/// for k in 0..10 {
///     // (A robot on a stand: its wheels follow the commands, it stays where it is.)
///     let tick = tracker.tick(&Observation { t: 0.05 * k as f64, input, pose: Some(Pose::zeros()), imu_yaw_rate: None, pose_time: None }).unwrap();
///     input = tick.command;
/// }
/// // Starting on the path, at rest: it drives forward (both wheels ahead), within the
/// // acceleration limit (1 m/s^2 for half a second: at most 0.5 m/s on 0.165 m wheels).
/// assert!(input.x > 0.5 && input.y > 0.5 && input.x <= 0.5 / 0.165 + 1e-9);
/// ```
pub struct Tracker {
    controller: Box<dyn Controller>,
    robot: RobotSpec,
    to_vehicle: InputMap,
    vehicle: Arc<dyn CommandModel>,
    path: ReferencePath,
    config: TrackerConfig,
    dt: f64,
    progress: f64,
    /// Where the schedule is along the path (m; [`TrackerConfig::schedule_s`]).
    scheduled: f64,
    sent: SentCommand,
    fixes: VecDeque<(f64, Pose)>,
    /// The start states of the last ticks, and the commands sent at them (the vehicle's).
    past_states: VecDeque<StartState>,
    past_commands: VecDeque<Input>,
    history: usize,
    reference: Vec<Pose>,
    goal_tolerance: f64,
    window: f64,
    done: bool,
    stop: Input,
}

impl std::fmt::Debug for Tracker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tracker")
            .field("controller", &self.controller.name())
            .field("path", &self.path.name())
            .field("progress", &self.progress)
            .finish_non_exhaustive()
    }
}

impl Tracker {
    /// A tracker of `path` with the controller `make` builds for `setup`; `vehicle` is the
    /// model's vehicle (what the measured inputs mean as a body velocity).
    pub fn new(
        make: &dyn MakeController,
        setup: &ControlSetup,
        path: ReferencePath,
        config: TrackerConfig,
        vehicle: Arc<dyn CommandModel>,
    ) -> Result<Self, ControlError> {
        let goal_tolerance = config.check_path(&path)?;
        let speed = config.speed;
        let dt = 1.0 / setup.robot.rate_hz;
        let history_s = match config.history_s {
            Some(h) if h.is_finite() && (0.0..=10.0).contains(&h) => h,
            Some(h) => {
                return Err(ControlError::BadSetting {
                    field: "history_s",
                    message: format!("{h} s is not in [0, 10]"),
                })
            }
            None => {
                // Half the way up the input space, from its centre: a step in the model's
                // (the vehicle's) inputs.
                let space = setup.robot.input_space();
                let centre = space.center();
                let step = setup
                    .to_vehicle
                    .apply(&(centre + (space.max - centre) * 0.5));
                crate::settling_history_s(setup.model.as_ref(), &step)
            }
        };
        let history = (history_s / dt).round() as usize;
        let controller = make.make(setup)?;
        let stop = stop_input(&setup.robot);
        Ok(Tracker {
            reference: Vec::with_capacity(controller.horizon()),
            controller,
            robot: setup.robot.clone(),
            to_vehicle: setup.to_vehicle.clone(),
            vehicle,
            path,
            config,
            dt,
            progress: 0.0,
            scheduled: 0.0,
            sent: SentCommand::default(),
            fixes: VecDeque::new(),
            past_states: VecDeque::with_capacity(history + 1),
            past_commands: VecDeque::with_capacity(history + 1),
            history,
            goal_tolerance,
            // Where the robot is searched on the path around its last progress: two
            // seconds of travel ahead, one behind, at least a metre.
            window: (2.0 * speed).max(1.0),
            done: false,
            stop,
        })
    }

    /// What the controller says a reader of its results should know
    /// ([`Controller::notes`](crate::Controller::notes)).
    pub fn notes(&self) -> Vec<String> {
        self.controller.notes()
    }

    /// How far back the controller's predictions start (s): the configured history, or the
    /// model's settling time when none was configured, in whole ticks.
    pub fn history_s(&self) -> f64 {
        self.history as f64 * self.dt
    }

    /// The path followed.
    pub fn path(&self) -> &ReferencePath {
        &self.path
    }

    /// Arc length reached (m).
    pub fn progress(&self) -> f64 {
        self.progress
    }

    /// The robot was stopped by something else (a safety stop, an operator taking over):
    /// forgets the commands sent (the next ones ramp up from rest within the acceleration
    /// limits), their history and the controller's plan; keeps the progress along the
    /// path and the localization fixes; a schedule ([`TrackerConfig::schedule_s`]) starts
    /// again from where the robot is.
    pub fn reset(&mut self) {
        self.sent = SentCommand::default();
        self.scheduled = self.progress;
        self.past_states.clear();
        self.past_commands.clear();
        self.controller.reset();
    }

    /// The body velocity `[x, y]` (body frame of the last fix) and yaw rate the fixes of
    /// the last half second show; zero with fewer than two.
    fn fix_velocity(&self) -> (f64, f64, f64) {
        let (Some(&(tb, b)), Some(&(ta, a))) = (self.fixes.back(), self.fixes.front()) else {
            return (0.0, 0.0, 0.0);
        };
        let span = tb - ta;
        if self.fixes.len() < 2 || span <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        let (s, c) = b.z.sin_cos();
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        (
            (c * dx + s * dy) / span,
            (-s * dx + c * dy) / span,
            wrap_angle(b.z - a.z) / span,
        )
    }

    /// One tick: takes the sensors' report, returns the command to send now.
    pub fn tick(&mut self, obs: &Observation) -> Result<Tick, ControlError> {
        let finite = obs.t.is_finite()
            && obs.input.iter().all(|v| v.is_finite())
            && obs.pose.is_none_or(|p| p.iter().all(|v| v.is_finite()))
            && obs.imu_yaw_rate.is_none_or(f64::is_finite)
            && obs.pose_time.is_none_or(f64::is_finite);
        if !finite {
            return Err(ControlError::BadState(format!(
                "t {}, inputs {:?}, pose {:?}, IMU {:?}, pose time {:?}",
                obs.t,
                obs.input.as_slice(),
                obs.pose.map(|p| [p.x, p.y, p.z]),
                obs.imu_yaw_rate,
                obs.pose_time
            )));
        }
        // Within what the readers take (1e9 for a measurement, an epoch clock's seconds for
        // a time): a pose of 1e12 m, a wheel at 1e12 rad/s gave a command without a word.
        use drive_traits::limits::{MAX_ABS_MEASUREMENT, MAX_ABS_TIME_S};
        let beyond = obs
            .input
            .iter()
            .chain(obs.pose.iter().flat_map(|p| p.iter()))
            .chain(obs.imu_yaw_rate.iter())
            .any(|v| v.abs() > MAX_ABS_MEASUREMENT)
            || obs.t.abs() > MAX_ABS_TIME_S
            || obs.pose_time.is_some_and(|s| s.abs() > MAX_ABS_TIME_S);
        if beyond {
            return Err(ControlError::BeyondReaders(format!(
                "beyond what the readers take (measurements within {}, times within {} s): t {}, inputs {:?}, pose {:?}, IMU {:?}, pose time {:?}; in the robot's units?",
                drive_traits::limits::Short(MAX_ABS_MEASUREMENT),
                drive_traits::limits::Short(MAX_ABS_TIME_S),
                obs.t,
                obs.input.as_slice(),
                obs.pose.map(|p| [p.x, p.y, p.z]),
                obs.imu_yaw_rate,
                obs.pose_time
            )));
        }
        if let Some(s) = obs.pose_time.filter(|&s| s > obs.t + MAX_FUTURE_STAMP_S) {
            return Err(ControlError::PoseFromTheFuture {
                pose_time: s,
                t: obs.t,
                ahead: s - obs.t,
            });
        }
        if let Some(p) = obs.pose {
            // Stamped when it was measured (never later than now); the same fix published
            // again adds nothing (it would read as the robot standing still).
            let stamp = obs.pose_time.map_or(obs.t, |s| s.min(obs.t));
            if self.fixes.back().is_some_and(|&(t, _)| stamp <= t) {
                if let Some(last) = self.fixes.back_mut().filter(|(t, _)| stamp == *t) {
                    last.1 = p;
                }
            } else {
                self.fixes.push_back((stamp, p));
            }
            while self.fixes.len() > 2
                && self.fixes.back().map_or(0.0, |b| b.0) - self.fixes[1].0 >= VELOCITY_SPAN_S
            {
                self.fixes.pop_front();
            }
        }
        let &(t_fix, fix) = self.fixes.back().ok_or(ControlError::NoLocalization)?;
        let (vx, vy, w_fix) = self.fix_velocity();
        let yaw_rate = obs.imu_yaw_rate.unwrap_or(w_fix);
        // The last fix carried forward to now.
        let estimate = euler_step(
            &fix,
            &BodyVelocity::new(vx, vy, yaw_rate),
            (obs.t - t_fix).clamp(0.0, 1.0),
        );
        let near = self.path.project_near(
            [estimate.x, estimate.y],
            self.progress - self.window / 2.0,
            self.progress + self.window,
            self.progress,
            CONTINUITY,
        );
        self.progress = near.point.s;
        let heading_error = wrap_angle(estimate.z - near.point.heading);
        let end = self.path.point_at(self.path.length());
        if !self.done
            && self.path.length() - self.progress <= self.goal_tolerance
            && (estimate.x - end.x).hypot(estimate.y - end.y) <= self.goal_tolerance
        {
            self.done = true;
            self.controller.reset();
        }
        let mut start = StartState::measured(estimate, obs.input, self.vehicle.as_ref());
        if self.config.start != StartInfo::Encoders {
            if let Some(w) = obs.imu_yaw_rate {
                start = start.with_yaw_rate(w);
            }
        }
        if self.config.start == StartInfo::EncodersImuLocalization && self.fixes.len() >= 2 {
            start = start.with_velocity([vx, vy]);
        }
        let wanted = if self.done {
            self.stop
        } else {
            self.reference.clear();
            let step = self.config.speed * self.dt;
            let from = match self.config.schedule_s {
                Some(lead_s) => {
                    let lead = lead_s * self.config.speed;
                    let at = self
                        .scheduled
                        .clamp(self.progress - lead, self.progress + lead);
                    self.scheduled = at + step;
                    at
                }
                None => self.progress,
            };
            for k in 1..=self.controller.horizon() {
                let s = from + step * k as f64;
                self.reference.push(self.path.point_at(s).pose());
            }
            let state = ControlState {
                now: start,
                sent: self.sent,
                past: self
                    .past_states
                    .front()
                    .map(|s| (*s, &*self.past_commands.make_contiguous())),
            };
            self.controller.command(&state, &self.reference)?
        };
        let space = self.robot.input_space();
        let u = space.clamp(&next_command(
            &self.robot,
            &mut self.sent,
            &space.clamp(&wanted),
        ));
        let command = self.to_vehicle.apply(&u);
        if self.history > 0 {
            self.past_states.push_back(start);
            self.past_commands.push_back(command);
            if self.past_states.len() > self.history {
                self.past_states.pop_front();
                self.past_commands.pop_front();
            }
        }
        Ok(Tick {
            command,
            controller_input: u,
            estimate,
            progress_m: self.progress,
            cross_track_m: near.cross_track,
            heading_error_rad: heading_error,
            done: self.done,
        })
    }
}
