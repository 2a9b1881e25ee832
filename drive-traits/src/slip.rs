//! Slip: the difference between the commanded and the actual body velocity (paper eq. 2,
//! `v = f - g`), its models (eq. 5-7 and others) and their learners.
//!
//! A slip learner does not redo the rest of the motion model: the framework fits the
//! powertrain, applies the vehicle's eq. 4 to the predicted inputs and hands the learner a
//! [`SlipData`] (commanded body velocities per window, and the windows' measured poses for
//! labels or rollouts); the fitted [`SlipModel`] is then rolled out with the vehicle and the
//! powertrain by one composed model (eq. 1).

use crate::InvalidPart;
use crate::{
    BodyVelocity, BodyVelocityEstimator, CommandModel, FitError, Input, PartTag, PoseCovariance,
    Powertrain, RegistryItem, RobotDescription, StartState, Tagged, Window, WindowSet,
};

/// A fitted slip model: the slip velocity `g` (eq. 2, 5) at a commanded body velocity `f`.
///
/// Saved as a trait object inside model files (`"type": "<tag>"`): an implementation needs
/// `#[typetag::serde(name = "...")]` and [`Tagged`] with the same name.
///
/// ```
/// use drive_traits::{BodyVelocity, SlipModel, Tagged};
/// use serde::{Deserialize, Serialize};
///
/// /// Skid only: the vehicle turns at a fraction of the commanded yaw rate.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Skid { lost: f64 }
///
/// #[typetag::serde(name = "skid-doc")]
/// impl SlipModel for Skid {
///     fn slip(&self, f: &BodyVelocity) -> BodyVelocity { BodyVelocity::new(0.0, 0.0, self.lost * f.z) }
///     fn clone_box(&self) -> Box<dyn SlipModel> { Box::new(self.clone()) }
/// }
/// impl Tagged for Skid { const TAG: &'static str = "skid-doc"; }
///
/// let mut v = Vec::new();
/// Skid { lost: 0.75 }.body_velocities_into(&[BodyVelocity::new(1.0, 0.0, 2.0)], &mut v);
/// assert_eq!(v[0], BodyVelocity::new(1.0, 0.0, 0.5)); // eq. 2: v = f - g
/// ```
#[typetag::serde(tag = "type")]
pub trait SlipModel: std::fmt::Debug + Send + Sync {
    /// The slip velocity `g(f)` (its mean, for a probabilistic model).
    fn slip(&self, f: &BodyVelocity) -> BodyVelocity;

    /// The body velocities `v = f - g(f)` (eq. 2) of every commanded body velocity in `f`,
    /// into `out` (cleared first): one call per rollout. Override it to hoist work out of
    /// the loop.
    fn body_velocities_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) {
        out.clear();
        out.extend(f.iter().map(|f| f - self.slip(f)));
    }

    /// The body velocities of a rollout from `start` through the commanded body velocities
    /// `f`, into `out` (cleared first): what the composed model integrates (eq. 1). A slip
    /// model with a state of its own (a body lag, a disturbance seen at the start, such as
    /// slip-ipem's) reads what was measured at the start here; the default ignores the start
    /// and calls [`SlipModel::body_velocities_into`].
    ///
    /// ```
    /// # use drive_traits::{BodyVelocity, Pose, SlipModel, StartState, Tagged};
    /// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct Skid { lost: f64 }
    /// # #[typetag::serde(name = "skid-rollout-doc")]
    /// # impl SlipModel for Skid {
    /// #     fn slip(&self, f: &BodyVelocity) -> BodyVelocity { BodyVelocity::new(0.0, 0.0, self.lost * f.z) }
    /// #     fn clone_box(&self) -> Box<dyn SlipModel> { Box::new(self.clone()) }
    /// # }
    /// # impl Tagged for Skid { const TAG: &'static str = "skid-rollout-doc"; }
    /// let start = StartState::at_rest(Pose::zeros()).with_yaw_rate(0.3);
    /// let mut v = Vec::new();
    /// // A slip model without a state of its own: the start changes nothing.
    /// Skid { lost: 0.75 }.rollout_velocities_into(&start, &[BodyVelocity::new(1.0, 0.0, 2.0)], &mut v);
    /// assert_eq!(v[0], BodyVelocity::new(1.0, 0.0, 0.5));
    /// ```
    fn rollout_velocities_into(
        &self,
        start: &StartState,
        f: &[BodyVelocity],
        out: &mut Vec<BodyVelocity>,
    ) {
        let _ = start;
        self.body_velocities_into(f, out)
    }

    /// The predictive variance of the slip at `f`, per body dimension (eq. 7 for a BLR);
    /// `None` for a model without uncertainty.
    fn slip_variance(&self, f: &BodyVelocity) -> Option<BodyVelocity> {
        let _ = f;
        None
    }

    /// The predictive variances of the slip at every commanded body velocity of `f`, into
    /// `out` (cleared first): one call per rollout. `false` (and `out` unspecified) for a
    /// model without uncertainty.
    fn slip_variances_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) -> bool {
        out.clear();
        for f in f {
            match self.slip_variance(f) {
                Some(v) => out.push(v),
                None => return false,
            }
        }
        // An empty horizon says nothing of the model: ask it at rest.
        !f.is_empty() || self.slip_variance(&BodyVelocity::zeros()).is_some()
    }

    /// The pose covariance at every step of a rollout from `start` through the commanded
    /// body velocities `f` (step `dt`), into `out` (cleared first, one per sample, the first
    /// zero), for a model whose slip errors are correlated along the horizon (uncertain
    /// parameters shared by every step, a velocity bias held over the rollout): the
    /// step-by-step propagation of [`SlipModel::slip_variances_into`] assumes them
    /// independent (eq. 7). The rollout is the one of [`SlipModel::rollout_velocities_into`]
    /// from the same start. `false` (the default, `out` unspecified): the model has no such
    /// covariance, and a composed model propagates its slip variances instead.
    fn rollout_covariances_into(
        &self,
        start: &StartState,
        f: &[BodyVelocity],
        dt: f64,
        out: &mut Vec<PoseCovariance>,
    ) -> bool {
        let _ = (start, f, dt, out);
        false
    }

    /// Checks the parameters read from a file; `Err` says what is wrong.
    fn check(&self) -> Result<(), InvalidPart> {
        Ok(())
    }

    /// The slip model stepped one commanded body velocity at a time ([`crate::step`]),
    /// when it has a stepper: a composed model steps its slip model through it. `None`, the
    /// default: a composed model with this slip model is stepped by replaying its
    /// prediction ([`crate::step::ReplayStepper`]). A slip map without a state of its own
    /// (one that overrides neither [`SlipModel::rollout_velocities_into`] nor
    /// [`SlipModel::rollout_covariances_into`]) returns [`StatelessSlip`].
    fn stepper(&self) -> Option<Box<dyn SlipStepper + '_>> {
        None
    }

    /// The pose covariance of a model whose slip errors are correlated along the horizon
    /// ([`SlipModel::rollout_covariances_into`]) stepped one commanded body velocity at a
    /// time, at step `dt`. `None`, the default: a model with such covariances is stepped by
    /// replay; one with per-step variances ([`SlipModel::slip_variance`]) needs none, the
    /// composed model propagates them.
    fn covariance_stepper(&self, dt: f64) -> Option<Box<dyn SlipCovarianceStepper + '_>> {
        let _ = dt;
        None
    }

    /// The command period (s) the slip model's own dynamics were fitted at (a lag per
    /// step), when they depend on it; a composed model checks that it is its own. `None` by
    /// default (a slip map without dynamics).
    fn step(&self) -> Option<f64> {
        None
    }

    /// The fitted parameters by name, for reports (slip-BLR's `longitudinal slip: w[f_x]`, ...).
    /// None by default.
    fn parameters(&self) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// Boxed clone.
    fn clone_box(&self) -> Box<dyn SlipModel>;
}

/// A slip model stepped one commanded body velocity at a time: its own state (a lagging
/// body velocity, a disturbance seen at the start) in [`SlipStepper::state_len`] numbers.
/// From [`SlipStepper::init`], the body velocities returned by `k` calls of
/// [`SlipStepper::step`] are the first `k` of [`SlipModel::rollout_velocities_into`] from
/// the same start through the same commanded body velocities.
pub trait SlipStepper: Send + Sync {
    /// The numbers of the slip model's state (0 for a slip map).
    fn state_len(&self) -> usize;
    /// Writes the state at `start` (what was measured then).
    fn init(&self, start: &StartState, state: &mut [f64]);
    /// The body velocity `v = f - g` (eq. 2) of this step at the commanded body velocity
    /// `f`, the state moved to the next step.
    fn step(&self, state: &mut [f64], f: &BodyVelocity) -> BodyVelocity;

    /// [`SlipStepper::step`] for many states at once: state `i` is
    /// `states[i * stride..i * stride + state_len]`, its commanded body velocity `f[i]`, its
    /// body velocity written to `v[i]`. The default loops with the implementation's own
    /// `step`, which the compiler inlines.
    fn step_many(
        &self,
        states: &mut [f64],
        stride: usize,
        f: &[BodyVelocity],
        v: &mut [BodyVelocity],
    ) {
        let len = self.state_len();
        for (i, (f, v)) in f.iter().zip(v.iter_mut()).enumerate() {
            *v = self.step(&mut states[i * stride..i * stride + len], f);
        }
    }

    /// [`SlipStepper::step`] through a sequence of commanded body velocities: `v[k]` the
    /// body velocity of step k. The default loops with the implementation's own `step`.
    fn step_seq(&self, state: &mut [f64], f: &[BodyVelocity], v: &mut [BodyVelocity]) {
        for (f, v) in f.iter().zip(v.iter_mut()) {
            *v = self.step(state, f);
        }
    }
}

/// The stepper of a slip map without a state of its own: `v = f - g(f)` (eq. 2) each step,
/// through [`SlipModel::slip`].
///
/// ```
/// use drive_traits::{BodyVelocity, Pose, SlipModel, SlipStepper, StartState, StatelessSlip, Tagged};
/// # use serde::{Deserialize, Serialize};
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Skid { lost: f64 }
/// #[typetag::serde(name = "skid-stepper-doc")]
/// impl SlipModel for Skid {
///     fn slip(&self, f: &BodyVelocity) -> BodyVelocity { BodyVelocity::new(0.0, 0.0, self.lost * f.z) }
///     // A slip map: one line makes it step natively.
///     fn stepper(&self) -> Option<Box<dyn drive_traits::SlipStepper + '_>> { Some(Box::new(StatelessSlip(self))) }
///     fn clone_box(&self) -> Box<dyn SlipModel> { Box::new(self.clone()) }
/// }
/// # impl Tagged for Skid { const TAG: &'static str = "skid-stepper-doc"; }
/// let skid = Skid { lost: 0.75 };
/// let stepper = skid.stepper().unwrap();
/// let mut state = vec![0.0; stepper.state_len()];
/// stepper.init(&StartState::at_rest(Pose::zeros()), &mut state);
/// assert_eq!(stepper.step(&mut state, &BodyVelocity::new(1.0, 0.0, 2.0)), BodyVelocity::new(1.0, 0.0, 0.5));
/// ```
pub struct StatelessSlip<'a, S: ?Sized>(pub &'a S);

impl<S: SlipModel + ?Sized> SlipStepper for StatelessSlip<'_, S> {
    fn state_len(&self) -> usize {
        0
    }
    fn init(&self, _start: &StartState, _state: &mut [f64]) {}
    #[inline]
    fn step(&self, _state: &mut [f64], f: &BodyVelocity) -> BodyVelocity {
        f - self.0.slip(f)
    }
}

/// The pose covariance of a slip model with correlated errors
/// ([`SlipModel::rollout_covariances_into`]) stepped one commanded body velocity at a time,
/// its state in [`SlipCovarianceStepper::state_len`] numbers: from
/// [`SlipCovarianceStepper::init`], the `k`-th call of [`SlipCovarianceStepper::step`]
/// returns covariance `k` of `rollout_covariances_into` from the same start.
pub trait SlipCovarianceStepper: Send + Sync {
    /// The numbers of the covariance's state.
    fn state_len(&self) -> usize;
    /// Writes the state at `start`.
    fn init(&self, start: &StartState, state: &mut [f64]);
    /// The pose covariance at the next sample after a step at the commanded body velocity
    /// `f`, the state moved to it.
    fn step(&self, state: &mut [f64], f: &BodyVelocity) -> PoseCovariance;
}

impl Clone for Box<dyn SlipModel> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// One training window as a slip learner sees it.
#[derive(Debug, Clone)]
pub struct SlipWindow<'a> {
    /// The window (commands, measured inputs, poses, IMU).
    pub window: &'a Window,
    /// The input the powertrain predicts at each sample (eq. 3), from the measured input at
    /// the window start.
    pub input: Vec<Input>,
    /// The commanded body velocity `f` at each sample: the vehicle's command model (eq. 4)
    /// on `input`.
    pub commanded: Vec<BodyVelocity>,
}

/// A commanded body velocity with the body velocity measured at the same sample: one
/// one-step slip label `g = f - v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipSample {
    /// Commanded body velocity f.
    pub commanded: BodyVelocity,
    /// Measured body velocity v.
    pub measured: BodyVelocity,
    /// Position of the window in [`SlipData::windows`].
    pub window: usize,
    /// Sample index in the window.
    pub k: usize,
}

impl SlipSample {
    /// The slip label `g = f - v`.
    pub fn slip(&self) -> BodyVelocity {
        self.commanded - self.measured
    }
}

/// What a slip learner fits on: the training windows with the commanded body velocity the
/// powertrain and the vehicle predict at each sample.
#[derive(Debug, Clone)]
pub struct SlipData<'a> {
    /// The robot (rate, vehicle).
    pub robot: &'a RobotDescription,
    /// The windows, in recording order.
    pub windows: Vec<SlipWindow<'a>>,
}

impl<'a> SlipData<'a> {
    /// The slip data of `train` under a fitted `powertrain` and the robot's vehicle.
    pub fn new(train: &WindowSet<'a>, powertrain: &dyn Powertrain) -> Self {
        let vehicle = train.robot.vehicle.as_ref();
        let windows = train
            .windows
            .iter()
            .map(|w| {
                let mut input = Vec::with_capacity(w.len());
                powertrain.predict_into(&w.measured[0], &w.command, &mut input);
                let mut commanded = Vec::with_capacity(w.len());
                vehicle.body_velocities_into(&input, &mut commanded);
                SlipWindow {
                    window: w,
                    input,
                    commanded,
                }
            })
            .collect();
        SlipData {
            robot: train.robot,
            windows,
        }
    }

    /// Sample period (s).
    pub fn dt(&self) -> f64 {
        self.robot.dt()
    }

    /// The vehicle.
    pub fn vehicle(&self) -> &dyn CommandModel {
        self.robot.vehicle.as_ref()
    }

    /// Every sample with a measured body velocity (from the poses, by `estimator`): the
    /// one-step slip labels, in window and sample order.
    pub fn samples(&self, estimator: &BodyVelocityEstimator) -> Vec<SlipSample> {
        let mut out = Vec::new();
        self.for_each_sample(estimator, |s| out.push(s));
        out
    }

    /// Calls `visit` with every sample of [`SlipData::samples`], in the same order, without
    /// collecting them.
    pub fn for_each_sample(
        &self,
        estimator: &BodyVelocityEstimator,
        mut visit: impl FnMut(SlipSample),
    ) {
        let dt = self.dt();
        let mut measured = Vec::new();
        for (i, w) in self.windows.iter().enumerate() {
            estimator.estimate(w.window, dt, &mut measured);
            for (k, (f, v)) in w.commanded.iter().zip(&measured).enumerate() {
                if let Some(v) = v {
                    visit(SlipSample {
                        commanded: *f,
                        measured: *v,
                        window: i,
                        k,
                    });
                }
            }
        }
    }
}

/// An unfitted slip model configuration that fits a [`SlipModel`] on [`SlipData`].
///
/// ```
/// use drive_traits::{BodyVelocity, BodyVelocityEstimator, FitError, SlipData, SlipLearner, SlipModel, Tagged};
/// # use serde::{Deserialize, Serialize};
/// # #[derive(Debug, Clone, Serialize, Deserialize)]
/// # struct Skid { lost: f64 }
/// # #[typetag::serde(name = "skid-learner-doc")]
/// # impl SlipModel for Skid {
/// #     fn slip(&self, f: &BodyVelocity) -> BodyVelocity { BodyVelocity::new(0.0, 0.0, self.lost * f.z) }
/// #     fn clone_box(&self) -> Box<dyn SlipModel> { Box::new(self.clone()) }
/// # }
/// # impl Tagged for Skid { const TAG: &'static str = "skid-learner-doc"; }
/// /// Least squares of the yaw-rate slip on the commanded yaw rate.
/// struct SkidLearner;
///
/// impl SlipLearner for SkidLearner {
///     type Fitted = Skid;
///     fn fit(&self, data: &SlipData<'_>) -> Result<Skid, FitError> {
///         let (mut num, mut den) = (0.0, 0.0);
///         for s in data.samples(&BodyVelocityEstimator::default()) {
///             num += s.slip().z * s.commanded.z;
///             den += s.commanded.z * s.commanded.z;
///         }
///         if den == 0.0 {
///             return Err(FitError::DegenerateInputs { what: "skid".into(), detail: "no turn".into() });
///         }
///         Ok(Skid { lost: num / den })
///     }
/// }
/// # use drive_traits::{CommandModel, Input, InputAxis, RobotDescription, WindowSet, Powertrain};
/// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
/// # #[typetag::serde(name = "v-slip-doc")] impl CommandModel for V {
/// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
/// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
/// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
/// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
/// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
/// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct Same;
/// # #[typetag::serde(name = "same-slip-doc")] impl Powertrain for Same {
/// #   fn predict_into(&self, _i: &Input, c: &[Input], p: &mut Vec<Input>) { p.clear(); p.extend_from_slice(c); }
/// #   fn clone_box(&self) -> Box<dyn Powertrain> { Box::new(Same) } }
/// // Without a turn there is nothing to learn from: a reason, not a NaN model.
/// let robot = RobotDescription::new("none", "", 20.0, 40, V);
/// let set = WindowSet { robot: &robot, windows: vec![] };
/// assert!(SkidLearner.fit(&SlipData::new(&set, &Same)).is_err());
/// ```
pub trait SlipLearner {
    /// The fitted slip model type.
    type Fitted: SlipModel + Tagged + 'static;

    /// Fits on the slip data of the training windows.
    fn fit(&self, data: &SlipData<'_>) -> Result<Self::Fitted, FitError>;

    /// A recursive (online) fit of this learner for `robot`'s data, when the learner has
    /// one: windows are added as they arrive and the fitted model is available at any time
    /// at a cost that does not grow with the data seen (see [`OnlineSlip`]). `None`, the
    /// default: the learner fits in batch only.
    fn online(&self, robot: &RobotDescription) -> Option<Box<dyn OnlineSlip>> {
        let _ = robot;
        None
    }
}

/// A slip learner's recursive fit: [`OnlineSlip::add`] the slip data of windows as they
/// arrive, [`OnlineSlip::fitted`] the model on everything added so far, which equals the
/// learner's batch fit on the same windows.
pub trait OnlineSlip: Send {
    /// Adds the samples of more training windows.
    fn add(&mut self, data: &SlipData<'_>);
    /// The slip model fitted on every window added, or why it cannot be fitted yet.
    fn fitted(&self) -> Result<Box<dyn SlipModel>, FitError>;
    /// A copy of the fit so far (to branch it, e.g. per training order).
    fn clone_box(&self) -> Box<dyn OnlineSlip>;
}

/// A [`SlipLearner`] as a trait object (what the slip-learner registry holds); implemented
/// for every slip learner.
///
/// ```
/// use drive_traits::{BodyVelocity, FitError, FitSlip, SlipData, SlipLearner, SlipModel, Tagged};
/// # use serde::{Deserialize, Serialize};
/// # #[derive(Debug, Clone, Serialize, Deserialize)] struct Still;
/// # #[typetag::serde(name = "still-fit-doc")]
/// # impl SlipModel for Still {
/// #     fn slip(&self, _f: &BodyVelocity) -> BodyVelocity { BodyVelocity::zeros() }
/// #     fn clone_box(&self) -> Box<dyn SlipModel> { Box::new(self.clone()) }
/// # }
/// # impl Tagged for Still { const TAG: &'static str = "still-fit-doc"; }
/// struct StillLearner;
/// impl SlipLearner for StillLearner {
///     type Fitted = Still;
///     fn fit(&self, _data: &SlipData<'_>) -> Result<Still, FitError> { Ok(Still) }
/// }
/// let learner: std::sync::Arc<dyn FitSlip> = std::sync::Arc::new(StillLearner);
/// assert_eq!(learner.fitted_tag().tag, "still-fit-doc");
/// assert_eq!(learner.fitted_tag().family, "SlipModel");
/// ```
pub trait FitSlip: Send + Sync {
    /// Fits, boxed.
    fn fit_boxed(&self, data: &SlipData<'_>) -> Result<Box<dyn SlipModel>, FitError>;
    /// The tag of the fitted type.
    fn fitted_tag(&self) -> PartTag;
    /// The learner's recursive fit, when it has one ([`SlipLearner::online`]).
    fn online_boxed(&self, robot: &RobotDescription) -> Option<Box<dyn OnlineSlip>>;
}

impl<L> FitSlip for L
where
    L: SlipLearner + Send + Sync,
{
    fn fit_boxed(&self, data: &SlipData<'_>) -> Result<Box<dyn SlipModel>, FitError> {
        Ok(Box::new(self.fit(data)?))
    }
    fn fitted_tag(&self) -> PartTag {
        PartTag::of::<L::Fitted, Box<dyn SlipModel>>("SlipModel")
    }
    fn online_boxed(&self, robot: &RobotDescription) -> Option<Box<dyn OnlineSlip>> {
        self.online(robot)
    }
}

impl RegistryItem for dyn FitSlip {
    fn part_tag(&self) -> Option<PartTag> {
        Some(self.fitted_tag())
    }
}
