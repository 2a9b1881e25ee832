//! Fitted motion models: poses over a horizon from a start state and an input sequence.

use crate::step::{ReplayStepper, StepOptions, Stepper};
use crate::InvalidPart;
use crate::{BodyVelocity, Input, MotionError, Pose, PoseCovariance, Powertrain};

/// Checks a prediction step read from a file: a positive number of seconds.
///
/// ```
/// assert!(drive_traits::check_step(0.05).is_ok());
/// assert!(drive_traits::check_step(0.0).unwrap_err().contains("dt = 0"));
/// ```
pub fn check_step(dt: f64) -> Result<(), InvalidPart> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(InvalidPart::from(format!(
            "dt = {} is not a positive number of seconds",
            crate::limits::Short(dt)
        )))
    }
}

/// What is known at the start of a prediction: measured at that instant only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartState {
    /// Start pose.
    pub pose: Pose,
    /// Measured input at the start (encoder wheel velocities for a skid-steer).
    pub input: Input,
    /// Measured body velocity at the start (used by models whose state is a velocity, such
    /// as acceleration-based BLR).
    pub body_velocity: BodyVelocity,
    /// The yaw rate measured at the start by a sensor of the body's own rotation (the IMU),
    /// when the start information includes one (`StartInfo::EncodersImu`); `None` when only
    /// the encoders are known. Unlike `body_velocity`, never derived from the input: a model
    /// may read it as evidence of how the body turns beyond what the commands explain
    /// (slip-ipem's yaw disturbance).
    pub yaw_rate: Option<f64>,
    /// The body-frame velocity (x forward, y left; m/s) at the start as the localization
    /// measured it just before (`StartInfo::EncodersImuLocalization`); `None` when it is
    /// not known. Like `yaw_rate`, never derived from the input: a model whose state is a
    /// velocity may start from it (slip-ipem's lagging body velocity).
    pub velocity: Option<[f64; 2]>,
    /// The body's motion measured later than the start, at a step of the commands: a
    /// controller's now, after the commands still in flight that it replays from a while
    /// back ([`ObservedMotion`]); `None` for a prediction from its start alone.
    pub observed: Option<ObservedMotion>,
}

/// The body's motion measured at step `step` of a prediction's commands, later than its
/// start: where a controller is now, its rollouts starting a while back so that the
/// commands still in flight (a dead time, a lagging powertrain) act in them.
///
/// A model whose state holds the body's velocity takes what is measured there as its state
/// at that step (slip-ipem's lagging body velocity: the yaw rate the IMU measures, the
/// velocity the localization measures), as it does at a start; a model whose velocity
/// follows from its inputs alone ignores it. Without it such a state runs free through
/// the replayed commands, and a controller's prediction of now turns at a rate the body
/// is not turning at (docs/closed-loop.md measures the weaving it causes).
///
/// ```
/// use drive_traits::{ObservedMotion, Pose, StartState};
/// let s = StartState::at_rest(Pose::zeros()).with_observed(20, Some(0.3), None);
/// assert_eq!(s.observed, Some(ObservedMotion { step: 20, yaw_rate: Some(0.3), velocity: None }));
/// // Nothing measured, or measured at the start itself: the start says it already.
/// assert_eq!(StartState::at_rest(Pose::zeros()).with_observed(20, None, None).observed, None);
/// assert_eq!(StartState::at_rest(Pose::zeros()).with_observed(0, Some(0.3), None).observed, None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservedMotion {
    /// The step of the commands it is measured at: the state after `step` commands,
    /// before `commands[step]` acts (at least 1).
    pub step: usize,
    /// The yaw rate the IMU measures there (rad/s), when known.
    pub yaw_rate: Option<f64>,
    /// The body-frame velocity `[x, y]` (m/s) the localization measures there, when known.
    pub velocity: Option<[f64; 2]>,
}

impl ObservedMotion {
    /// The finite measurements of this observation: `None` when none is left.
    ///
    /// ```
    /// use drive_traits::ObservedMotion;
    /// let o = ObservedMotion { step: 3, yaw_rate: Some(f64::NAN), velocity: Some([1.0, 0.0]) };
    /// assert_eq!(o.finite(), Some(ObservedMotion { yaw_rate: None, ..o }));
    /// assert_eq!(ObservedMotion { velocity: Some([f64::INFINITY, 0.0]), ..o }.finite(), None);
    /// ```
    pub fn finite(&self) -> Option<ObservedMotion> {
        let o = ObservedMotion {
            step: self.step,
            yaw_rate: self.yaw_rate.filter(|w| w.is_finite()),
            velocity: self.velocity.filter(|v| v.iter().all(|x| x.is_finite())),
        };
        (o.step > 0 && (o.yaw_rate.is_some() || o.velocity.is_some())).then_some(o)
    }
}

impl StartState {
    /// At rest at `pose`.
    pub fn at_rest(pose: Pose) -> Self {
        StartState {
            pose,
            input: Input::zeros(),
            body_velocity: BodyVelocity::zeros(),
            yaw_rate: None,
            velocity: None,
            observed: None,
        }
    }

    /// The same start with the yaw rate `yaw_rate` measured by the IMU: also the body
    /// velocity's yaw rate.
    ///
    /// ```
    /// use drive_traits::{Pose, StartState};
    /// let s = StartState::at_rest(Pose::zeros()).with_yaw_rate(0.4);
    /// assert_eq!((s.yaw_rate, s.body_velocity.z), (Some(0.4), 0.4));
    /// ```
    pub fn with_yaw_rate(mut self, yaw_rate: f64) -> Self {
        self.yaw_rate = Some(yaw_rate);
        self.body_velocity.z = yaw_rate;
        self
    }

    /// The same start with the body's motion measured at step `step` of the commands
    /// ([`ObservedMotion`]): none when nothing is measured or `step` is 0 (the start's own
    /// measurements say that).
    pub fn with_observed(
        mut self,
        step: usize,
        yaw_rate: Option<f64>,
        velocity: Option<[f64; 2]>,
    ) -> Self {
        self.observed =
            (step > 0 && (yaw_rate.is_some() || velocity.is_some())).then_some(ObservedMotion {
                step,
                yaw_rate,
                velocity,
            });
        self
    }

    /// The same start with the body-frame velocity `[x, y]` (m/s) measured by the
    /// localization just before it: also the body velocity's x and y.
    ///
    /// ```
    /// use drive_traits::{Pose, StartState};
    /// let s = StartState::at_rest(Pose::zeros()).with_velocity([1.5, -0.2]);
    /// assert_eq!(s.velocity, Some([1.5, -0.2]));
    /// assert_eq!((s.body_velocity.x, s.body_velocity.y), (1.5, -0.2));
    /// ```
    pub fn with_velocity(mut self, velocity: [f64; 2]) -> Self {
        self.velocity = Some(velocity);
        self.body_velocity.x = velocity[0];
        self.body_velocity.y = velocity[1];
        self
    }

    /// At `pose` with the measured input `input`: the body velocity from the encoders
    /// through the vehicle (eq. 4 for a differential drive), as `drive predict` starts.
    ///
    /// ```
    /// use drive_traits::{CommandModel, Input, Pose, StartState};
    /// # fn demo(vehicle: &dyn CommandModel) {
    /// let s = StartState::measured(Pose::zeros(), Input::new(2.0, 3.0, 0.0), vehicle);
    /// assert_eq!(s.body_velocity, vehicle.body_velocity(&Input::new(2.0, 3.0, 0.0)));
    /// # }
    /// ```
    pub fn measured(pose: Pose, input: Input, vehicle: &dyn crate::CommandModel) -> Self {
        StartState {
            pose,
            input,
            body_velocity: vehicle.body_velocity(&input),
            yaw_rate: None,
            velocity: None,
            observed: None,
        }
    }
}

/// A fitted motion model (the linfa "fitted" side): it predicts, and it is saved and loaded
/// as a trait object through typetag (`"type": "<tag>"`). Most models are the composed
/// vehicle x powertrain x slip model of `drive_models`; a whole-model baseline (acc-BLR)
/// implements this trait directly.
///
/// Convention: `commands[k]` is applied during step k; the prediction has one pose per
/// command, `poses[0]` the start pose and `poses[k+1] = poses[k] + T(yaw_k) v_k dt` (eq. 1).
///
/// ```
/// use drive_traits::{BodyVelocity, Input, MotionModel, Pose, StartState, Tagged, euler_step};
/// use serde::{Deserialize, Serialize};
///
/// /// Keeps the body velocity measured at the start, whatever the commands.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct ConstantVelocity { dt: f64 }
///
/// #[typetag::serde(name = "constant-velocity-doc")]
/// impl MotionModel for ConstantVelocity {
///     fn name(&self) -> String { "constant-velocity".into() }
///     fn dt(&self) -> f64 { self.dt }
///     fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
///         poses.clear();
///         let mut q = start.pose;
///         for _ in commands {
///             poses.push(q);
///             q = euler_step(&q, &start.body_velocity, self.dt);
///         }
///     }
/// }
/// impl Tagged for ConstantVelocity { const TAG: &'static str = "constant-velocity-doc"; }
///
/// let start = StartState { body_velocity: BodyVelocity::new(1.0, 0.0, 0.0), ..StartState::at_rest(Pose::zeros()) };
/// let poses = ConstantVelocity { dt: 0.5 }.predict(&start, &[Input::zeros(); 3]);
/// assert_eq!(poses[2], Pose::new(1.0, 0.0, 0.0));
/// ```
#[typetag::serde(tag = "type")]
pub trait MotionModel: std::fmt::Debug + Send + Sync {
    /// The model's name (`slip-blr+fopdt`, `acc-blr+commanded`, ...).
    fn name(&self) -> String;

    /// Prediction step (s).
    fn dt(&self) -> f64;

    /// Checks the model's parameters (finite values, matching dimensions, positive step):
    /// what a model file must pass before it is used. `Err` says what is wrong.
    fn check(&self) -> Result<(), InvalidPart> {
        check_step(self.dt())
    }

    /// Fills `poses` (cleared first) with the predicted mean poses.
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>);

    /// Predicted mean poses, as a new vector.
    fn predict(&self, start: &StartState, commands: &[Input]) -> Vec<Pose> {
        let mut poses = Vec::with_capacity(commands.len());
        self.predict_into(start, commands, &mut poses);
        poses
    }

    /// Rolls out many command sequences at once (the MPPI case) into a caller-provided
    /// buffer: sequence `i` starts at `starts[i]`, its commands are
    /// `commands[i * horizon..(i + 1) * horizon]` and its poses go to the same range of
    /// `poses`. Gives exactly the poses of [`MotionModel::predict_into`] for each sequence.
    ///
    /// The default runs `predict_into` per sequence through one scratch buffer; models
    /// override it with an allocation-free kernel.
    fn predict_batch_into(
        &self,
        starts: &[StartState],
        commands: &[Input],
        horizon: usize,
        poses: &mut [Pose],
    ) -> Result<(), MotionError> {
        MotionError::check_batch(starts.len(), horizon, commands.len(), poses.len())?;
        let mut scratch = Vec::with_capacity(horizon);
        for (i, start) in starts.iter().enumerate() {
            let range = i * horizon..(i + 1) * horizon;
            self.predict_into(start, &commands[range.clone()], &mut scratch);
            poses[range].copy_from_slice(&scratch);
        }
        Ok(())
    }

    /// Fills `poses` and `covariances` (one 3x3 pose covariance per step, zero at the start)
    /// for models that carry an uncertainty; the default says the model has none.
    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        let _ = (start, commands, poses, covariances);
        Err(MotionError::NoUncertainty { model: self.name() })
    }

    /// The model stepped one command at a time, its whole internal state a flat vector of
    /// numbers ([`crate::step`]): what a sampling-based controller's `dynamics(state,
    /// action)` calls. Stepping `k` times from a start equals row `k` of
    /// [`MotionModel::predict_into`] (and of its covariance, with `options.covariance`).
    ///
    /// The default replays the prediction ([`ReplayStepper`]: exact, but each step costs a
    /// prediction as long as the steps so far, and no command history); a model with a
    /// state of its own overrides it with a stepper of that state.
    fn stepper(&self, options: StepOptions) -> Result<Box<dyn Stepper + '_>, MotionError> {
        Ok(Box::new(ReplayStepper::new(self, options)?))
    }

    /// The fitted parameters by name, for reports: a composed model's are its powertrain's
    /// ([`Powertrain::parameters`]) then its slip model's
    /// ([`crate::SlipModel::parameters`]). None by default.
    fn parameters(&self) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// The fitted powertrain (eq. 3) the model runs its commands through, when it has one:
    /// what a report draws the powertrain's response with. `None` by default.
    fn powertrain(&self) -> Option<&dyn Powertrain> {
        None
    }
}
