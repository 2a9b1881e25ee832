use crate::{FitError, MotionModel, WindowSet};

/// An unfitted motion-model configuration: validated hyperparameters that `fit` a training
/// set and return a separate fitted [`MotionModel`] (the linfa split: configuring and
/// predicting are different types).
pub trait Learner {
    /// The fitted model type.
    type Fitted: MotionModel + 'static;

    /// Fits on the training windows.
    fn fit(&self, train: &WindowSet<'_>) -> Result<Self::Fitted, FitError>;
}
