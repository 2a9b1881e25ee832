//! The motion model composed from parts: vehicle x powertrain x slip, rolled out by one
//! implementation of paper eq. 1-2.
//!
//! For a start state and a command sequence: the powertrain predicts the inputs the vehicle
//! reaches (eq. 3), the vehicle maps them to commanded body velocities `f` (eq. 4), the
//! slip model takes the slip off (`v = f - g`, eq. 2, 5) and eq. 1 integrates `v` into poses.
//! Each stage is one call per rollout over the whole horizon, so a composed model is as
//! fast as a hand-written one.

use crate::rollout::{integrate, integrate_into, integrate_with_covariance};
use drive_traits::InvalidPart;
use drive_traits::{
    BodyVelocity, CommandModel, FitError, FitPowertrain, FitSlip, Input, Learner, MotionError,
    MotionModel, Pose, PoseCovariance, Powertrain, PowertrainLearner, SlipData, SlipLearner,
    SlipModel, StartState, Tagged, WindowSet,
};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::sync::Arc;

/// The learner of a composed model: a powertrain learner and a slip learner; the vehicle
/// comes from the training data.
///
/// ```
/// use drive_models::{Composed, DifferentialDrive};
/// use drive_models::powertrain::Commanded;
/// use drive_models::slip::NoSlip;
/// use drive_traits::{Input, Learner, MotionModel, Phase, Pose, RobotDescription, StartState, Window, WindowSet};
/// // The naive model is the composed model with no slip on the commanded powertrain.
/// let naive = Composed::new(Commanded, NoSlip);
/// assert_eq!(naive.label(), "no-slip+commanded");
/// let robot = RobotDescription::new("toy", "", 10.0, 3, DifferentialDrive::new(0.1, 0.5));
/// let w = Window::new(0, 0, Phase::Transient, vec![Input::new(10.0, 10.0, 0.0); 3], vec![Input::zeros(); 3], vec![Pose::zeros(); 3], vec![0.0; 3]);
/// let windows = [w];
/// let model = naive.fit(&WindowSet::new(&robot, &windows)).unwrap();
/// let poses = model.predict(&StartState::at_rest(Pose::zeros()), &[Input::new(10.0, 10.0, 0.0); 3]);
/// assert!((poses[2].x - 0.2).abs() < 1e-12); // 1 m/s for two steps of 0.1 s
/// ```
#[derive(Clone)]
pub struct Composed {
    label: String,
    powertrain: Arc<dyn FitPowertrain>,
    slip: Arc<dyn FitSlip>,
}

impl std::fmt::Debug for Composed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Composed")
            .field("label", &self.label)
            .finish_non_exhaustive()
    }
}

impl Composed {
    /// A powertrain learner and a slip learner, labelled `slip-tag+powertrain-tag` after
    /// the tags of their fitted types.
    pub fn new<P, S>(powertrain: P, slip: S) -> Self
    where
        P: PowertrainLearner + Send + Sync + 'static,
        S: SlipLearner + Send + Sync + 'static,
    {
        Composed {
            label: format!(
                "{}+{}",
                <S::Fitted as Tagged>::TAG,
                <P::Fitted as Tagged>::TAG
            ),
            powertrain: Arc::new(powertrain),
            slip: Arc::new(slip),
        }
    }

    /// Registered parts under a label (the model name, `slip-blr+fopdt`).
    pub fn from_parts(
        label: impl Into<String>,
        powertrain: Arc<dyn FitPowertrain>,
        slip: Arc<dyn FitSlip>,
    ) -> Self {
        Composed {
            label: label.into(),
            powertrain,
            slip,
        }
    }

    /// The label the fitted model carries.
    pub fn label(&self) -> &str {
        &self.label
    }
}

impl Composed {
    /// A fit of this model that grows with the training data, when its slip learner fits
    /// online ([`drive_traits::SlipLearner::online`]); `None` otherwise. See [`GrowingFit`].
    ///
    /// ```
    /// use drive_models::{Composed, DifferentialDrive};
    /// use drive_models::powertrain::Commanded;
    /// use drive_models::slip::NoSlip;
    /// use drive_traits::{Input, Learner, MotionModel, Phase, Pose, RobotDescription, StartState, Window, WindowSet};
    /// let robot = RobotDescription::new("toy", "", 10.0, 3, DifferentialDrive::new(0.1, 0.5));
    /// let w = |i| Window::new(i, i, Phase::Transient, vec![Input::new(10.0, 10.0, 0.0); 3], vec![Input::zeros(); 3], vec![Pose::zeros(); 3], vec![0.0; 3]);
    /// let windows = [w(0), w(1)];
    /// let learner = Composed::new(Commanded, NoSlip);
    /// let mut fit = learner.growing(&robot).expect("no-slip fits online");
    /// // The windows arrive one by one.
    /// fit.grow(&WindowSet::new(&robot, &windows[..1]), 0).unwrap();
    /// fit.grow(&WindowSet::new(&robot, &windows), 1).unwrap();
    /// let online = fit.model(&robot).unwrap();
    /// let batch = learner.fit(&WindowSet::new(&robot, &windows)).unwrap();
    /// let (start, commands) = (StartState::at_rest(Pose::zeros()), [Input::new(10.0, 10.0, 0.0); 3]);
    /// assert_eq!(online.predict(&start, &commands), batch.predict(&start, &commands));
    /// ```
    pub fn growing(&self, robot: &drive_traits::RobotDescription) -> Option<GrowingFit> {
        let online = self.slip.online_boxed(robot)?;
        Some(GrowingFit {
            learner: self.clone(),
            empty: online.clone_box(),
            slip: online,
            powertrain: None,
            fitted_on: 0,
        })
    }
}

/// A composed model fitted as training windows arrive (e.g. interval by interval): the
/// slip posterior is updated recursively (online), and the powertrain is refitted, on every
/// window seen so far, each time the data has grown by [`GrowingFit::GROWTH`] since its last
/// fit, the slip statistics then rebuilt under it. The cost of following `n` windows is
/// `O(n)`, not `O(n^2)`; the model at any time depends on the windows seen so far only. Its
/// slip posterior equals the batch fit under the same powertrain; its powertrain is the one
/// fitted on at least `1 / GROWTH` of the windows seen.
pub struct GrowingFit {
    learner: Composed,
    empty: Box<dyn drive_traits::OnlineSlip>,
    slip: Box<dyn drive_traits::OnlineSlip>,
    powertrain: Option<Box<dyn Powertrain>>,
    fitted_on: usize,
}

impl Clone for GrowingFit {
    fn clone(&self) -> Self {
        GrowingFit {
            learner: self.learner.clone(),
            empty: self.empty.clone_box(),
            slip: self.slip.clone_box(),
            powertrain: self.powertrain.as_ref().map(|p| p.clone_box()),
            fitted_on: self.fitted_on,
        }
    }
}

impl GrowingFit {
    /// Growth of the data, since the powertrain was fitted, that refits it.
    pub const GROWTH: f64 = 1.5;

    /// Follows the data: `seen` holds every window so far, in arrival order, the ones from
    /// `new_from` on arrived since the last call.
    pub fn grow(&mut self, seen: &WindowSet<'_>, new_from: usize) -> Result<(), FitError> {
        let n = seen.windows.len();
        let refit = self.powertrain.is_none() || n as f64 >= Self::GROWTH * self.fitted_on as f64;
        if refit {
            self.powertrain = None;
            let powertrain = self.learner.powertrain.fit_boxed(seen)?;
            self.slip = self.empty.clone_box();
            self.slip.add(&SlipData::new(seen, powertrain.as_ref()));
            self.powertrain = Some(powertrain);
            self.fitted_on = n;
        } else if let Some(powertrain) = &self.powertrain {
            let new = WindowSet {
                robot: seen.robot,
                windows: seen.windows[new_from.min(n)..].to_vec(),
            };
            self.slip.add(&SlipData::new(&new, powertrain.as_ref()));
        }
        Ok(())
    }

    /// Refits the powertrain on every window of `seen` and rebuilds the slip statistics
    /// under it: the model is then the batch fit on `seen` (its slip posterior to rounding).
    pub fn settle(&mut self, seen: &WindowSet<'_>) -> Result<(), FitError> {
        self.powertrain = None;
        self.grow(seen, 0)
    }

    /// The model on the windows seen so far.
    pub fn model(&self, robot: &drive_traits::RobotDescription) -> Result<ComposedModel, FitError> {
        let powertrain = self
            .powertrain
            .as_ref()
            .ok_or(FitError::EmptyTrainingSet)?
            .clone_box();
        Ok(ComposedModel {
            label: self.learner.label.clone(),
            vehicle: Arc::clone(&robot.vehicle),
            powertrain,
            slip: self.slip.fitted()?,
            dt: robot.dt(),
        })
    }
}

impl Learner for Composed {
    type Fitted = ComposedModel;

    /// Fits the powertrain on the training windows (its transient windows, for the FOPDT),
    /// then the slip model on the commanded body velocities the powertrain and the vehicle
    /// predict.
    fn fit(&self, train: &WindowSet<'_>) -> Result<ComposedModel, FitError> {
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let powertrain = self.powertrain.fit_boxed(train)?;
        let data = SlipData::new(train, powertrain.as_ref());
        let slip = self.slip.fit_boxed(&data)?;
        Ok(ComposedModel {
            label: self.label.clone(),
            vehicle: Arc::clone(&train.robot.vehicle),
            powertrain,
            slip,
            dt: train.robot.dt(),
        })
    }
}

/// A fitted composed model: vehicle, powertrain and slip model (eq. 1-5).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComposedModel {
    /// The model's name (`slip-blr+fopdt`).
    pub label: String,
    /// The vehicle (eq. 4).
    pub vehicle: Arc<dyn CommandModel>,
    /// The fitted powertrain (eq. 3).
    pub powertrain: Box<dyn Powertrain>,
    /// The fitted slip model (eq. 5-7).
    pub slip: Box<dyn SlipModel>,
    /// Step (s).
    pub dt: f64,
}

impl Tagged for ComposedModel {
    const TAG: &'static str = "composed";
}

/// The per-rollout buffers: predicted inputs, commanded and actual body velocities, slip
/// variances.
#[derive(Default)]
struct Scratch {
    inputs: Vec<Input>,
    commanded: Vec<BodyVelocity>,
    velocities: Vec<BodyVelocity>,
    variances: Vec<BodyVelocity>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Runs `f` with this thread's scratch buffers (fresh ones if they are in use, as when a
/// part's prediction itself calls a composed model).
fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    SCRATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut s) => f(&mut s),
        Err(_) => f(&mut Scratch::default()),
    })
}

impl ComposedModel {
    /// Eq. 3, 4 and 2 over the horizon: the body velocities into `s.velocities` (and the
    /// commanded ones into `s.commanded`).
    #[inline]
    fn velocities(&self, start: &StartState, commands: &[Input], s: &mut Scratch) {
        self.powertrain
            .predict_into(&start.input, commands, &mut s.inputs);
        self.vehicle
            .body_velocities_into(&s.inputs, &mut s.commanded);
        self.slip
            .rollout_velocities_into(start, &s.commanded, &mut s.velocities);
    }
}

#[typetag::serde(name = "composed")]
impl MotionModel for ComposedModel {
    fn name(&self) -> String {
        self.label.clone()
    }

    fn dt(&self) -> f64 {
        self.dt
    }

    fn check(&self) -> Result<(), InvalidPart> {
        drive_traits::check_step(self.dt)?;
        self.vehicle.check()?;
        self.powertrain.check()?;
        crate::powertrain::check_vehicle_axes(self.powertrain.as_ref(), self.vehicle.as_ref())?;
        crate::check_same_step("powertrain", self.powertrain.step(), self.dt)?;
        self.slip.check()?;
        crate::check_same_step("slip model", self.slip.step(), self.dt)
    }

    /// The powertrain's parameters (`powertrain: ...`), then the slip model's.
    fn parameters(&self) -> Vec<(String, f64)> {
        prefixed_parameters(self.powertrain.as_ref())
            .chain(self.slip.parameters())
            .collect()
    }

    fn powertrain(&self) -> Option<&dyn Powertrain> {
        Some(self.powertrain.as_ref())
    }

    /// The parts' steppers one after the other when they all have one (every built-in part
    /// does), otherwise the replay of the prediction.
    fn stepper(
        &self,
        options: drive_traits::step::StepOptions,
    ) -> Result<Box<dyn drive_traits::step::Stepper + '_>, MotionError> {
        crate::stepping::composed_stepper(self, options)
    }

    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        with_scratch(|s| {
            self.velocities(start, commands, s);
            integrate(&start.pose, &s.velocities, self.dt, poses);
        })
    }

    fn predict_batch_into(
        &self,
        starts: &[StartState],
        commands: &[Input],
        horizon: usize,
        poses: &mut [Pose],
    ) -> Result<(), MotionError> {
        MotionError::check_batch(starts.len(), horizon, commands.len(), poses.len())?;
        with_scratch(|s| {
            for (i, start) in starts.iter().enumerate() {
                let range = i * horizon..(i + 1) * horizon;
                self.velocities(start, &commands[range.clone()], s);
                integrate_into(&start.pose, &s.velocities, self.dt, &mut poses[range]);
            }
        });
        Ok(())
    }

    /// The slip model's rollout covariances when it has them
    /// ([`SlipModel::rollout_covariances_into`]), otherwise its predictive variances (eq. 7)
    /// propagated through eq. 1; an error for a slip model without uncertainty.
    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        with_scratch(|s| {
            self.velocities(start, commands, s);
            if self
                .slip
                .rollout_covariances_into(start, &s.commanded, self.dt, covariances)
            {
                integrate(&start.pose, &s.velocities, self.dt, poses);
                return Ok(());
            }
            if !self
                .slip
                .slip_variances_into(&s.commanded, &mut s.variances)
            {
                return Err(MotionError::NoUncertainty { model: self.name() });
            }
            integrate_with_covariance(
                &start.pose,
                &s.velocities,
                &s.variances,
                self.dt,
                poses,
                covariances,
            );
            Ok(())
        })
    }
}

/// A powertrain's parameters named `powertrain: <name>`, as a model lists them beside its
/// other parts'.
pub(crate) fn prefixed_parameters(
    powertrain: &dyn Powertrain,
) -> impl Iterator<Item = (String, f64)> {
    powertrain
        .parameters()
        .into_iter()
        .map(|(name, v)| (format!("powertrain: {name}"), v))
}
