//! Powertrains: commanded -> actually reached inputs over a horizon (paper eq. 3 and
//! others), and their learners.

use crate::InvalidPart;
use crate::{FitError, Input, PartTag, RegistryItem, Tagged, WindowSet};

/// A fitted powertrain model: predicts the inputs the vehicle actually reaches (wheel
/// velocities for a skid-steer) over a horizon, from the measured input at the start and
/// the commanded sequence.
///
/// Saved as a trait object inside model files (`"type": "<tag>"`): an implementation needs
/// `#[typetag::serde(name = "...")]` and [`Tagged`] with the same name.
///
/// ```
/// use drive_traits::{Input, Powertrain, Tagged};
/// use serde::{Deserialize, Serialize};
///
/// /// A user's powertrain: the vehicle reaches a fixed fraction of every command at once.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Efficiency { gain: f64 }
///
/// #[typetag::serde(name = "efficiency-doc")]
/// impl Powertrain for Efficiency {
///     fn predict_into(&self, _initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
///         predicted.clear();
///         predicted.extend(commands.iter().map(|u| u * self.gain));
///     }
///     fn clone_box(&self) -> Box<dyn Powertrain> { Box::new(self.clone()) }
/// }
/// impl Tagged for Efficiency { const TAG: &'static str = "efficiency-doc"; }
///
/// let w = Efficiency { gain: 0.5 }.predict(&Input::zeros(), &[Input::new(2.0, 4.0, 0.0)]);
/// assert_eq!(w, vec![Input::new(1.0, 2.0, 0.0)]);
/// ```
#[typetag::serde(tag = "type")]
pub trait Powertrain: std::fmt::Debug + Send + Sync {
    /// Fills `predicted` (cleared first) with one predicted input per command:
    /// `predicted[k]` is the input reached at sample k, used during step k. `initial` is the
    /// input measured at the start; a model with dynamics returns it as `predicted[0]`, the
    /// commanded powertrain (inputs reached at once) ignores it.
    fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>);

    /// Convenience wrapper of [`Powertrain::predict_into`] returning a new vector.
    fn predict(&self, initial: &Input, commands: &[Input]) -> Vec<Input> {
        let mut out = Vec::with_capacity(commands.len());
        self.predict_into(initial, commands, &mut out);
        out
    }

    /// The command period (s) the powertrain's dynamics were fitted at, when they depend
    /// on it; a model checks that it is its own. `None` by default (no dynamics).
    fn step(&self) -> Option<f64> {
        None
    }

    /// Checks the parameters read from a file (finite, physically meaningful); `Err` says
    /// what is wrong.
    fn check(&self) -> Result<(), InvalidPart> {
        Ok(())
    }

    /// The number of input axes the powertrain models (one response per axis), when it
    /// has a fixed number: a model checks that it is its vehicle's. `None` by default (a
    /// powertrain that passes every axis through).
    fn input_dim(&self) -> Option<usize> {
        None
    }

    /// The fitted parameters by name, for reports (`left time constant [s]`, ...).
    fn parameters(&self) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// The powertrain stepped one command at a time ([`crate::step`]), when it has a
    /// stepper: a composed model steps its powertrain through it. `None`, the default: a
    /// composed model with this powertrain is stepped by replaying its prediction
    /// ([`crate::step::ReplayStepper`]).
    fn stepper(&self) -> Option<Box<dyn PowertrainStepper + '_>> {
        None
    }

    /// Boxed clone (fitted models that embed a powertrain are cloneable).
    fn clone_box(&self) -> Box<dyn Powertrain>;
}

/// A powertrain stepped one command at a time: its state (the inputs reached, the commands
/// still inside its dead time) in [`PowertrainStepper::state_len`] numbers. From
/// [`PowertrainStepper::init`] with no history, the inputs returned by `k + 1` calls of
/// [`PowertrainStepper::step`] are the first `k + 1` of [`Powertrain::predict_into`]
/// through the same commands.
///
/// ```
/// use drive_traits::{Input, Powertrain, PowertrainStepper, Tagged};
/// # use serde::{Deserialize, Serialize};
/// /// The input reached is the command of the step before (one step of dead time).
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct OneStepLate;
/// #[typetag::serde(name = "one-step-late-doc")]
/// impl Powertrain for OneStepLate {
///     fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
///         predicted.clear();
///         predicted.extend(std::iter::once(*initial).chain(commands.iter().copied()).take(commands.len()));
///     }
///     fn stepper(&self) -> Option<Box<dyn PowertrainStepper + '_>> { Some(Box::new(LateStepper)) }
///     fn clone_box(&self) -> Box<dyn Powertrain> { Box::new(OneStepLate) }
/// }
/// # impl Tagged for OneStepLate { const TAG: &'static str = "one-step-late-doc"; }
/// struct LateStepper;
/// impl PowertrainStepper for LateStepper {
///     fn state_len(&self) -> usize { 3 }
///     fn init(&self, initial: &Input, _history: &[Input], state: &mut [f64]) {
///         state.copy_from_slice(initial.as_slice());
///     }
///     fn step(&self, state: &mut [f64], command: &Input) -> Input {
///         let reached = Input::from_column_slice(state);
///         state.copy_from_slice(command.as_slice());
///         reached
///     }
/// }
/// let commands = [Input::new(1.0, 2.0, 0.0), Input::new(3.0, 4.0, 0.0)];
/// let predicted = OneStepLate.predict(&Input::zeros(), &commands);
/// let stepper = OneStepLate.stepper().unwrap();
/// let mut state = vec![0.0; stepper.state_len()];
/// stepper.init(&Input::zeros(), &[], &mut state);
/// assert_eq!(stepper.step(&mut state, &commands[0]), predicted[0]);
/// assert_eq!(stepper.step(&mut state, &commands[1]), predicted[1]);
/// ```
pub trait PowertrainStepper: Send + Sync {
    /// The numbers of the powertrain's state.
    fn state_len(&self) -> usize;

    /// Writes the state at the start: `initial` the input measured then, `history` the
    /// commands sent before it (oldest first; without them, the commands before the start
    /// are taken to be `initial`, as [`Powertrain::predict_into`] takes them).
    fn init(&self, initial: &Input, history: &[Input], state: &mut [f64]);

    /// The input reached at this sample (what the vehicle turns into a body velocity during
    /// this step), then the state moved to the next sample under `command`.
    fn step(&self, state: &mut [f64], command: &Input) -> Input;

    /// [`PowertrainStepper::step`] for many states at once: state `i` is
    /// `states[i * stride..i * stride + state_len]` (the powertrain's part of consecutive
    /// states of `stride` numbers), its command `commands[i]`, its input reached written
    /// to `reached[i]`. One call per batch: the default loops over the states with the
    /// implementation's own `step`, which the compiler inlines.
    fn step_many(
        &self,
        states: &mut [f64],
        stride: usize,
        commands: &[Input],
        reached: &mut [Input],
    ) {
        let len = self.state_len();
        for (i, (u, r)) in commands.iter().zip(reached.iter_mut()).enumerate() {
            *r = self.step(&mut states[i * stride..i * stride + len], u);
        }
    }

    /// [`PowertrainStepper::step`] through a sequence of commands: `reached[k]` the input
    /// reached at step k. The default loops with the implementation's own `step`, which
    /// the compiler inlines.
    fn step_seq(&self, state: &mut [f64], commands: &[Input], reached: &mut [Input]) {
        for (u, r) in commands.iter().zip(reached.iter_mut()) {
            *r = self.step(state, u);
        }
    }
}

impl Clone for Box<dyn Powertrain> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// An unfitted powertrain configuration (validated hyperparameters) that fits a
/// [`Powertrain`] on training windows (the linfa split: configuring and predicting are
/// different types).
///
/// ```
/// use drive_traits::{FitError, Input, Powertrain, PowertrainLearner, Tagged, WindowSet};
/// # use serde::{Deserialize, Serialize};
/// # #[derive(Debug, Clone, Serialize, Deserialize)]
/// # struct Efficiency { gain: f64 }
/// # #[typetag::serde(name = "efficiency-learner-doc")]
/// # impl Powertrain for Efficiency {
/// #     fn predict_into(&self, _i: &Input, c: &[Input], p: &mut Vec<Input>) { p.clear(); p.extend(c.iter().map(|u| u * self.gain)); }
/// #     fn clone_box(&self) -> Box<dyn Powertrain> { Box::new(self.clone()) }
/// # }
/// # impl Tagged for Efficiency { const TAG: &'static str = "efficiency-learner-doc"; }
/// /// Fits the gain as the least-squares ratio of measured to commanded inputs.
/// #[derive(Clone, Copy)]
/// struct EfficiencyLearner;
///
/// impl PowertrainLearner for EfficiencyLearner {
///     type Fitted = Efficiency;
///     fn fit(&self, train: &WindowSet<'_>) -> Result<Efficiency, FitError> {
///         let (mut num, mut den) = (0.0, 0.0);
///         for w in &train.windows {
///             for (c, m) in w.command.iter().zip(&w.measured) {
///                 num += c.dot(m);
///                 den += c.dot(c);
///             }
///         }
///         if den == 0.0 {
///             return Err(FitError::EmptyTrainingSet);
///         }
///         Ok(Efficiency { gain: num / den })
///     }
/// }
/// # use drive_traits::{BodyVelocity, CommandModel, InputAxis, RobotDescription};
/// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
/// # #[typetag::serde(name = "v-pt-doc")] impl CommandModel for V {
/// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
/// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
/// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
/// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
/// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
/// let robot = RobotDescription::new("none", "", 20.0, 40, V);
/// let empty = WindowSet { robot: &robot, windows: vec![] };
/// assert_eq!(EfficiencyLearner.fit(&empty).unwrap_err(), FitError::EmptyTrainingSet);
/// ```
pub trait PowertrainLearner {
    /// The fitted powertrain type.
    type Fitted: Powertrain + Tagged + 'static;

    /// Fits on the training windows.
    fn fit(&self, train: &WindowSet<'_>) -> Result<Self::Fitted, FitError>;
}

/// A [`PowertrainLearner`] as a trait object (what the powertrain registry holds);
/// implemented for every powertrain learner.
///
/// ```
/// use drive_traits::{FitError, FitPowertrain, Input, Powertrain, PowertrainLearner, Tagged, WindowSet};
/// # use serde::{Deserialize, Serialize};
/// # #[derive(Debug, Clone, Serialize, Deserialize)] struct Instant;
/// # #[typetag::serde(name = "instant-fit-doc")]
/// # impl Powertrain for Instant {
/// #     fn predict_into(&self, _i: &Input, c: &[Input], p: &mut Vec<Input>) { p.clear(); p.extend_from_slice(c); }
/// #     fn clone_box(&self) -> Box<dyn Powertrain> { Box::new(self.clone()) }
/// # }
/// # impl Tagged for Instant { const TAG: &'static str = "instant-fit-doc"; }
/// struct InstantLearner;
/// impl PowertrainLearner for InstantLearner {
///     type Fitted = Instant;
///     fn fit(&self, _train: &WindowSet<'_>) -> Result<Instant, FitError> { Ok(Instant) }
/// }
/// // Any powertrain learner is one: the registry holds it as `Arc<dyn FitPowertrain>`.
/// let learner: std::sync::Arc<dyn FitPowertrain> = std::sync::Arc::new(InstantLearner);
/// assert_eq!(learner.fitted_tag().tag, "instant-fit-doc");
/// ```
pub trait FitPowertrain: Send + Sync {
    /// Fits on the training windows, boxed.
    fn fit_boxed(&self, train: &WindowSet<'_>) -> Result<Box<dyn Powertrain>, FitError>;
    /// The tag of the fitted type.
    fn fitted_tag(&self) -> PartTag;
}

impl<L> FitPowertrain for L
where
    L: PowertrainLearner + Send + Sync,
{
    fn fit_boxed(&self, train: &WindowSet<'_>) -> Result<Box<dyn Powertrain>, FitError> {
        Ok(Box::new(self.fit(train)?))
    }
    fn fitted_tag(&self) -> PartTag {
        PartTag::of::<L::Fitted, Box<dyn Powertrain>>("Powertrain")
    }
}

impl RegistryItem for dyn FitPowertrain {
    fn part_tag(&self) -> Option<PartTag> {
        Some(self.fitted_tag())
    }
}
