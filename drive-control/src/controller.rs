//! The controller plug-in point: a [`Controller`] turns the robot's start state and a
//! reference over its horizon into the command to send now; a [`MakeController`] builds one
//! for a fitted model and a robot, and is what the controller registry holds (`mppi` built
//! in; a researcher's own is one file and one `register` call).

use crate::mppi::Mppi;
use drive_traits::robot::{RobotSpec, SentCommand};
use drive_traits::{Input, MotionError, MotionModel, Pose, Registry, RegistryItem, StartState};
use std::sync::Arc;
use thiserror::Error;

/// Why a controller could not be built or could not give a command.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ControlError {
    /// A setting is out of its range.
    #[error("controller setting '{field}': {message}")]
    BadSetting {
        /// The setting.
        field: &'static str,
        /// What is expected.
        message: String,
    },
    /// The model could not roll the candidates out.
    #[error("the model's rollout failed: {0}")]
    Model(#[from] MotionError),
    /// The start state holds a value that is not a finite number.
    #[error(
        "the robot's state is not finite numbers ({0}); is the localization or an encoder broken?"
    )]
    BadState(String),
    /// An observation holds a value beyond what the command line's readers take (a
    /// measurement over 1e9, a time over 1e10 s).
    #[error("the robot's state is {0}")]
    BeyondReaders(String),
    /// A localization fix stamped later than the tick by more than
    /// [`crate::MAX_FUTURE_STAMP_S`]: its stamp on another clock than the tick's
    /// (it was taken as measured now, its latency unseen, without a word).
    #[error(
        "the localization fix is stamped {} s, {} s after the tick's t = {}: its stamp (pose_time) on another clock than t's?",
        drive_traits::limits::Short(*pose_time),
        drive_traits::limits::Short(*ahead),
        drive_traits::limits::Short(*t)
    )]
    PoseFromTheFuture {
        /// The fix's stamp.
        pose_time: f64,
        /// The tick's time.
        t: f64,
        /// How far after the tick's time the stamp is.
        ahead: f64,
    },
    /// No localization has arrived yet: the robot's pose is unknown.
    #[error("no localization yet: the robot's pose is unknown")]
    NoLocalization,
    /// Every candidate's cost was infinite or not a number (the model's predictions left
    /// the numbers).
    #[error(
        "no candidate has a finite cost: the model's predictions are not finite from this state"
    )]
    NoFiniteCost,
    /// A plug-in controller's own reason.
    #[error("{0}")]
    Controller(String),
}

/// How the controller's inputs become the vehicle's (what the plant and the model take):
/// the identity, or a map such as a twin's protocol geometry (whose box of wheel speeds is
/// recorded with their difference scaled, see `drive_sim::TwinProtocol`).
///
/// ```
/// use drive_control::InputMap;
/// use drive_traits::Input;
/// let double = InputMap::new(|u: &Input| 2.0 * u);
/// assert_eq!(double.apply(&Input::new(1.0, -1.0, 0.0)), Input::new(2.0, -2.0, 0.0));
/// assert_eq!(InputMap::identity().apply(&Input::new(1.0, 3.0, 0.0)), Input::new(1.0, 3.0, 0.0));
/// ```
#[derive(Clone, Default)]
pub struct InputMap(Option<Arc<MapFn>>);

/// A map of inputs.
type MapFn = dyn Fn(&Input) -> Input + Send + Sync;

impl std::fmt::Debug for InputMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() {
            "InputMap(custom)"
        } else {
            "InputMap(identity)"
        })
    }
}

impl InputMap {
    /// The controller commands the vehicle's own inputs.
    pub fn identity() -> Self {
        InputMap(None)
    }

    /// A map from the controller's inputs to the vehicle's.
    pub fn new(map: impl Fn(&Input) -> Input + Send + Sync + 'static) -> Self {
        InputMap(Some(Arc::new(map)))
    }

    /// The vehicle's input for the controller's `u`.
    #[inline]
    pub fn apply(&self, u: &Input) -> Input {
        match &self.0 {
            Some(f) => f(u),
            None => *u,
        }
    }
}

/// The input that stops `robot` (its zero body velocity; the input space's centre for a
/// vehicle without an exact input for it), within its input space.
///
/// ```
/// let husky = drive_traits::robot::builtin_robots().get("husky").unwrap().part().as_ref().clone();
/// assert_eq!(drive_control::stop_input(&husky), drive_traits::Input::zeros());
/// ```
pub fn stop_input(robot: &RobotSpec) -> Input {
    let space = robot.input_space();
    space.clamp(
        &robot
            .vehicle
            .input_for_twist(0.0, 0.0)
            .unwrap_or_else(|| space.center()),
    )
}

/// What a controller is built for.
#[derive(Clone)]
pub struct ControlSetup {
    /// The fitted motion model it predicts with (its inputs are the vehicle's).
    pub model: Arc<dyn MotionModel>,
    /// The robot as the controller commands it: its input space
    /// ([`RobotSpec::input_space`]) bounds every command, its acceleration (or input-rate)
    /// limits bound how fast commands change ([`drive_traits::robot::next_command`]), its
    /// vehicle maps the controller's inputs to body velocities.
    pub robot: RobotSpec,
    /// The controller's inputs to the vehicle's (the model's).
    pub to_vehicle: InputMap,
    /// The path-following speed (m/s); a controller may take its length scale from it.
    pub speed: f64,
    /// The run's seed: a controller that samples (MPPI) seeds its generator with it and its
    /// own settings' seed, so that runs of different seeds differ in the controller's
    /// sampling as well as in the plant's noise (0: its settings' seed alone).
    pub seed: u64,
}

impl std::fmt::Debug for ControlSetup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ControlSetup")
            .field("model", &self.model.name())
            .field("robot", &self.robot.name)
            .field("speed", &self.speed)
            .field("seed", &self.seed)
            .finish_non_exhaustive()
    }
}

/// What a controller knows at a tick.
#[derive(Debug, Clone, Copy)]
pub struct ControlState<'a> {
    /// The robot now: its estimated pose, measured inputs and what else the model was
    /// fitted to start from.
    pub now: StartState,
    /// What was sent last: every command is held to the robot's input space and
    /// acceleration limits from there by the caller ([`crate::Tracker`]), so a controller
    /// that plans within them is sent what it planned.
    pub sent: SentCommand,
    /// The robot's state `commands.len()` ticks ago and the commands sent since, oldest
    /// first (in the vehicle's coordinates): a model rolled out from there through them
    /// reaches now with the commands still in flight (a powertrain's dead time and lag)
    /// accounted for, which a rollout from `now` alone cannot know. `None` at the first
    /// tick.
    pub past: Option<(StartState, &'a [Input])>,
}

impl ControlState<'_> {
    /// A state with no history, at rest as far as the limits go.
    pub fn at(now: StartState) -> Self {
        ControlState {
            now,
            sent: SentCommand::default(),
            past: None,
        }
    }
}

/// A controller, ticked at the robot's command rate.
///
/// What it is given, precisely:
/// - **Coordinates.** Its commands are in the coordinates of [`ControlSetup::robot`]: its
///   input space, its vehicle. For a twin whose real run drew its commands in another
///   geometry (`drive_sim::TwinProtocol`), that robot has the protocol's geometry and box,
///   and [`ControlSetup::to_vehicle`] maps the commands to the vehicle's (the plant's and
///   the model's); use `setup.robot.vehicle` to turn a body velocity into an input
///   (`input_for`), [`stop_input`] to stop.
/// - **Limits.** The caller ([`crate::Tracker`]) clamps the command to the input space and
///   holds it to the robot's acceleration (or input-rate) limits from
///   [`ControlState::sent`] before sending it.
/// - **The state.** [`ControlState::now`]`.pose` is the last localization fix carried
///   forward to the tick (noisy as the localization is; its yaw is not wrapped: compare
///   angles with `drive_traits::wrap_angle`).
/// - **The reference.** `reference[k]` is the point of the path at the arc length where the
///   robot's estimate projects onto it, plus `speed x (k + 1)` ticks of travel (clamped at
///   the path's end), its heading the path's direction there: where the robot should be
///   after `k + 1` ticks if it drove the path at the asked speed from where it is. There
///   are [`Controller::horizon`] of them, a tick being `1 / setup.robot.rate_hz` s.
///
/// ```
/// use drive_control::{ControlError, ControlState, Controller};
/// use drive_traits::{Input, Pose, StartState};
///
/// /// Drives straight at a fixed input, whatever the reference (a baseline to beat).
/// struct Straight(Input);
/// impl Controller for Straight {
///     fn name(&self) -> String { "straight".into() }
///     fn horizon(&self) -> usize { 1 }
///     fn command(&mut self, _: &ControlState<'_>, _: &[Pose]) -> Result<Input, ControlError> {
///         Ok(self.0)
///     }
/// }
/// let mut c = Straight(Input::new(1.0, 1.0, 0.0));
/// let u = c.command(&ControlState::at(StartState::at_rest(Pose::zeros())), &[Pose::zeros()]);
/// assert_eq!(u.unwrap(), Input::new(1.0, 1.0, 0.0));
/// ```
pub trait Controller: Send {
    /// The controller's name (`mppi`).
    fn name(&self) -> String;

    /// How many steps ahead it wants the reference.
    fn horizon(&self) -> usize;

    /// The command to send now (in the controller's input coordinates), from `state`,
    /// towards `reference[k]`, where the robot should be after `k + 1` steps (pose `[x, y,
    /// heading]`; as many as [`Controller::horizon`]).
    fn command(
        &mut self,
        state: &ControlState<'_>,
        reference: &[Pose],
    ) -> Result<Input, ControlError>;

    /// Forgets any plan (the robot was stopped or taken over).
    fn reset(&mut self) {}

    /// What a reader of its results should know about how it controls with this model (a
    /// setting it cannot apply to it, ...); none by default.
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
}

/// Builds a controller for a model and a robot: what the controller registry holds.
///
/// ```
/// use drive_control::{builtin_controllers, MakeController, Mppi};
/// use std::sync::Arc;
/// let mut controllers = builtin_controllers();
/// // MPPI with a longer horizon and fewer samples, as a controller of its own.
/// controllers
///     .register("mppi-long", "MPPI over 3 s with 256 samples",
///         Arc::new(Mppi { horizon: 60, samples: 256, ..Mppi::default() }))
///     .unwrap();
/// assert_eq!(controllers.names(), ["mppi", "mppi-long"]);
/// ```
pub trait MakeController: Send + Sync {
    /// A controller for `setup`; an error for settings it cannot work with.
    fn make(&self, setup: &ControlSetup) -> Result<Box<dyn Controller>, ControlError>;
}

impl RegistryItem for dyn MakeController {}

/// The controllers of this project: `mppi`, the sampling-based model-predictive
/// controller of Williams et al. with its default settings ([`Mppi`]).
pub fn builtin_controllers() -> Registry<dyn MakeController> {
    let mut r: Registry<dyn MakeController> = Registry::new("controller");
    // One built-in name.
    r.register_trusted(
        "mppi",
        "model-predictive path integral control (Williams et al. 2017): 1024 input sequences sampled around the previous plan within the input space and acceleration limits, rolled out with the model over 2 s, averaged with weights exp(-cost / temperature)",
        Arc::new(Mppi::default()),
    )
    .expect("one built-in controller");
    r
}
