use drive_traits::{FitError, Input, Powertrain, PowertrainLearner, WindowSet};
use serde::{Deserialize, Serialize};

/// The manufacturer's assumption: the wheels reach every command at once, unbounded
/// (`predicted[k] = commands[k]`). What the naive model uses.
///
/// ```
/// use drive_models::powertrain::IdealPowertrain;
/// use drive_traits::{Input, Powertrain};
/// let cmds = [Input::new(1.0, 2.0), Input::new(3.0, 4.0)];
/// assert_eq!(IdealPowertrain.predict(&Input::zeros(), &cmds), cmds.to_vec());
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct IdealPowertrain;

#[typetag::serde(name = "ideal")]
impl Powertrain for IdealPowertrain {
    fn predict_into(&self, _initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
        predicted.clear();
        predicted.extend_from_slice(commands);
    }

    fn clone_box(&self) -> Box<dyn Powertrain> {
        Box::new(*self)
    }
}

/// The learner of [`IdealPowertrain`]: nothing to fit.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Ideal;

impl PowertrainLearner for Ideal {
    type Fitted = IdealPowertrain;
    fn fit(&self, _train: &WindowSet<'_>) -> Result<IdealPowertrain, FitError> {
        Ok(IdealPowertrain)
    }
}
