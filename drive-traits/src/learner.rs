//! Whole motion-model learners: the composed vehicle x powertrain x slip learner, and the
//! baselines that are not built from a slip model (acc-BLR).

use crate::{FitError, FitPowertrain, MotionModel, PartTag, RegistryItem, Tagged, WindowSet};

/// An unfitted motion-model configuration: validated hyperparameters that `fit` a training
/// set and return a separate fitted [`MotionModel`] (the linfa split: configuring and
/// predicting are different types).
///
/// ```
/// use drive_traits::{FitError, Input, Learner, MotionModel, Pose, StartState, Tagged, WindowSet};
/// # use serde::{Deserialize, Serialize};
/// # #[derive(Debug, Clone, Serialize, Deserialize)]
/// # struct StandStill { dt: f64 }
/// # #[typetag::serde(name = "stand-still-doc")]
/// # impl MotionModel for StandStill {
/// #     fn name(&self) -> String { "stand-still".into() }
/// #     fn dt(&self) -> f64 { self.dt }
/// #     fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) { p.clear(); p.resize(c.len(), s.pose); }
/// # }
/// # impl Tagged for StandStill { const TAG: &'static str = "stand-still-doc"; }
/// /// The robot never moves: the step comes from the data.
/// struct StandStillLearner;
///
/// impl Learner for StandStillLearner {
///     type Fitted = StandStill;
///     fn fit(&self, train: &WindowSet<'_>) -> Result<StandStill, FitError> {
///         if train.is_empty() {
///             return Err(FitError::EmptyTrainingSet);
///         }
///         Ok(StandStill { dt: train.robot.dt() })
///     }
/// }
/// # use drive_traits::{BodyVelocity, CommandModel, InputAxis, RobotDescription};
/// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
/// # #[typetag::serde(name = "v-learner-doc")] impl CommandModel for V {
/// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
/// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
/// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
/// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
/// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
/// let robot = RobotDescription::new("none", "", 20.0, 40, V);
/// let empty = WindowSet { robot: &robot, windows: vec![] };
/// assert_eq!(StandStillLearner.fit(&empty).unwrap_err(), FitError::EmptyTrainingSet);
/// ```
pub trait Learner {
    /// The fitted model type.
    type Fitted: MotionModel + 'static;

    /// Fits on the training windows.
    fn fit(&self, train: &WindowSet<'_>) -> Result<Self::Fitted, FitError>;
}

/// A whole-model learner as the baseline registry holds it: fitted on the training windows,
/// with the learner of a powertrain when it is built on one (acc-BLR's commanded body
/// velocity comes from a powertrain; the naive model's from the commands).
///
/// Every [`Learner`] whose fitted type is [`Tagged`] is a baseline that takes no powertrain.
///
/// ```
/// use drive_traits::{Baseline, FitError, FitPowertrain, MotionModel, PartTag, WindowSet};
///
/// /// A baseline on any powertrain (here: it only fits the powertrain, and fails).
/// struct PowertrainOnly;
///
/// impl Baseline for PowertrainOnly {
///     fn fit_with(&self, train: &WindowSet<'_>, powertrain: Option<&dyn FitPowertrain>)
///         -> Result<Box<dyn MotionModel>, FitError> {
///         let _fitted = powertrain.expect("uses a powertrain").fit_boxed(train)?;
///         Err(FitError::EmptyTrainingSet)
///     }
///     fn default_powertrain(&self) -> Option<&str> { Some("fopdt") }
///     fn fitted_tag(&self) -> Option<PartTag> { None }
/// }
/// assert_eq!(PowertrainOnly.default_powertrain(), Some("fopdt"));
/// ```
pub trait Baseline: Send + Sync {
    /// Fits on `train` with `powertrain`, the learner of the powertrain asked for (always
    /// given to a baseline with a default powertrain, never to one without).
    fn fit_with(
        &self,
        train: &WindowSet<'_>,
        powertrain: Option<&dyn FitPowertrain>,
    ) -> Result<Box<dyn MotionModel>, FitError>;

    /// The powertrain used when none is named (a powertrain registry name); `None` for a
    /// baseline that takes no powertrain.
    fn default_powertrain(&self) -> Option<&str> {
        None
    }

    /// The tag of the fitted type, when it is [`Tagged`].
    fn fitted_tag(&self) -> Option<PartTag>;
}

impl<L> Baseline for L
where
    L: Learner + Send + Sync,
    L::Fitted: Tagged,
{
    fn fit_with(
        &self,
        train: &WindowSet<'_>,
        _powertrain: Option<&dyn FitPowertrain>,
    ) -> Result<Box<dyn MotionModel>, FitError> {
        Ok(Box::new(Learner::fit(self, train)?))
    }
    fn fitted_tag(&self) -> Option<PartTag> {
        Some(PartTag::of::<L::Fitted, Box<dyn MotionModel>>(
            "MotionModel",
        ))
    }
}

impl RegistryItem for dyn Baseline {
    fn part_tag(&self) -> Option<PartTag> {
        self.fitted_tag()
    }
}
