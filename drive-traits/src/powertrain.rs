//! Powertrain models: commanded -> actually reached actuator velocities (paper eq. 3).

use crate::{FitError, Input, WindowSet};

/// A fitted powertrain model: predicts the actuator (wheel) velocities over a horizon, per
/// side, from the measured velocities at the start and the commanded sequence.
///
/// Serialized as a trait object (`"powertrain": "<name>"` tag) inside fitted model files.
#[typetag::serde(tag = "powertrain")]
pub trait Powertrain: std::fmt::Debug + Send + Sync {
    /// Fills `predicted` (cleared first) with one predicted actuator velocity per command:
    /// `predicted[k]` is the velocity at sample k, used during step k. `initial` is the
    /// velocity measured at the start; a model with dynamics returns it as `predicted[0]`,
    /// the ideal powertrain (wheels reach every command at once) ignores it.
    fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>);

    /// Convenience wrapper of [`Powertrain::predict_into`] returning a new vector.
    fn predict(&self, initial: &Input, commands: &[Input]) -> Vec<Input> {
        let mut out = Vec::with_capacity(commands.len());
        self.predict_into(initial, commands, &mut out);
        out
    }

    /// Checks the parameters read from a file (finite, physically meaningful); `Err` says
    /// what is wrong.
    fn check(&self) -> Result<(), String> {
        Ok(())
    }

    /// Boxed clone (fitted models that embed a powertrain are cloneable).
    fn clone_box(&self) -> Box<dyn Powertrain>;
}

impl Clone for Box<dyn Powertrain> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// An unfitted powertrain configuration (validated hyperparameters) that fits a
/// [`Powertrain`] on training windows.
pub trait PowertrainLearner {
    /// The fitted powertrain type.
    type Fitted: Powertrain + 'static;

    /// Fits on the training windows.
    fn fit(&self, train: &WindowSet<'_>) -> Result<Self::Fitted, FitError>;
}
