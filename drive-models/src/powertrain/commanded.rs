use drive_traits::{
    FitError, Input, Powertrain, PowertrainLearner, PowertrainStepper, Tagged, WindowSet,
};
use serde::{Deserialize, Serialize};

/// The manufacturer's assumption: the vehicle reaches every command at once, unbounded
/// (`predicted[k] = commands[k]`). What the naive model uses.
///
/// ```
/// use drive_models::powertrain::CommandedPowertrain;
/// use drive_traits::{Input, Powertrain};
/// let cmds = [Input::new(1.0, 2.0, 0.0), Input::new(3.0, 4.0, 0.0)];
/// assert_eq!(CommandedPowertrain.predict(&Input::zeros(), &cmds), cmds.to_vec());
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct CommandedPowertrain;

impl Tagged for CommandedPowertrain {
    const TAG: &'static str = "commanded";
}

#[typetag::serde(name = "commanded")]
impl Powertrain for CommandedPowertrain {
    fn predict_into(&self, _initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
        predicted.clear();
        predicted.extend_from_slice(commands);
    }

    /// No state: the input reached at a sample is its command.
    fn stepper(&self) -> Option<Box<dyn PowertrainStepper + '_>> {
        Some(Box::new(CommandedStepper))
    }

    fn clone_box(&self) -> Box<dyn Powertrain> {
        Box::new(*self)
    }
}

/// The commanded powertrain stepped: no state.
struct CommandedStepper;

impl PowertrainStepper for CommandedStepper {
    fn state_len(&self) -> usize {
        0
    }
    fn init(&self, _initial: &Input, _history: &[Input], _state: &mut [f64]) {}
    #[inline]
    fn step(&self, _state: &mut [f64], command: &Input) -> Input {
        *command
    }
}

/// The learner of [`CommandedPowertrain`]: nothing to fit.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Commanded;

impl PowertrainLearner for Commanded {
    type Fitted = CommandedPowertrain;
    fn fit(&self, _train: &WindowSet<'_>) -> Result<CommandedPowertrain, FitError> {
        Ok(CommandedPowertrain)
    }
}
