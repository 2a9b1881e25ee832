use crate::{mrmse, score_uncertainty, Mrmse, Summary, UncertaintyReport};
use drive_traits::{MotionModel, Phase, StartInfo, WindowSet};
use serde::Serialize;

/// The errors of one model on one evaluation window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WindowErrors {
    /// Window index.
    pub window: usize,
    /// Interval index.
    pub interval: usize,
    /// Phase of the window.
    pub phase: Phase,
    /// Eq. 8 errors.
    pub error: Mrmse,
}

/// A model's errors over an evaluation set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelReport {
    /// Model name.
    pub name: String,
    /// Per-window errors, in evaluation order.
    pub windows: Vec<WindowErrors>,
    /// The calibration of its pose covariance, for a model that predicts one.
    pub uncertainty: Option<UncertaintyReport>,
}

impl ModelReport {
    /// Summary of the translational errors, optionally of one phase only.
    pub fn translational(&self, phase: Option<Phase>) -> Option<Summary> {
        Summary::of(self.select(phase).map(|w| w.error.translational))
    }

    /// Summary of the rotational errors, optionally of one phase only.
    pub fn rotational(&self, phase: Option<Phase>) -> Option<Summary> {
        Summary::of(self.select(phase).map(|w| w.error.rotational))
    }

    fn select(&self, phase: Option<Phase>) -> impl Iterator<Item = &WindowErrors> {
        self.windows
            .iter()
            .filter(move |w| phase.is_none_or(|p| w.phase == p))
    }
}

/// Predicts every evaluation window with `model` from the window's start state (measured
/// through the data's vehicle, with the default [`StartInfo`]) and its commands, and scores
/// it with eq. 8 against the measured poses (and its covariance, when it has one).
pub fn evaluate_model(model: &dyn MotionModel, eval: &WindowSet<'_>) -> ModelReport {
    evaluate_model_from(model, eval, StartInfo::default())
}

/// [`evaluate_model`] with the predictions starting from what `start` allows.
pub fn evaluate_model_from(
    model: &dyn MotionModel,
    eval: &WindowSet<'_>,
    start: StartInfo,
) -> ModelReport {
    ModelReport {
        uncertainty: score_uncertainty(model, eval, start),
        ..evaluate_errors(model, eval, start)
    }
}

/// [`evaluate_model_from`] without the uncertainty's scoring: eq. 8 errors only.
pub fn evaluate_errors(
    model: &dyn MotionModel,
    eval: &WindowSet<'_>,
    start: StartInfo,
) -> ModelReport {
    let vehicle = eval.robot.vehicle.as_ref();
    let mut poses = Vec::new();
    let windows = eval
        .windows
        .iter()
        .map(|w| {
            model.predict_into(&w.start_state_with(vehicle, start), &w.command, &mut poses);
            WindowErrors {
                window: w.index,
                interval: w.interval,
                phase: w.phase,
                error: mrmse(&poses, &w.pose),
            }
        })
        .collect();
    ModelReport {
        name: model.name(),
        windows,
        uncertainty: None,
    }
}
