//! A model that adapts to the ground inside the loop (`drive track --adapt`): the
//! controller predicts with the model the [`AdaptiveFit`] holds now, and every window the
//! run drives is fed to it as it completes.

use crate::AdaptiveFit;
use drive_models::ComposedModel;
use drive_traits::{
    Input, MotionError, MotionModel, Pose, PoseCovariance, Powertrain, StartState, Window,
};
use serde::{Deserialize, Serialize};
use std::sync::RwLock;

/// The model a controller holds while the run adapts it: the adapted model now, behind a
/// lock the run updates between ticks. Its powertrain (what the controller's history is
/// set from, once) is the prior's.
#[derive(Debug, Serialize, Deserialize)]
pub(super) struct LoopModel {
    prior: ComposedModel,
    now: RwLock<ComposedModel>,
}

impl LoopModel {
    pub(super) fn new(prior: ComposedModel) -> Self {
        LoopModel {
            now: RwLock::new(prior.clone()),
            prior,
        }
    }

    /// Predicts with the adapted model from now on.
    pub(super) fn set(&self, model: ComposedModel) {
        // A poisoned lock only means a reader panicked; the model itself is whole.
        *self.now.write().unwrap_or_else(|e| e.into_inner()) = model;
    }

    fn now(&self) -> std::sync::RwLockReadGuard<'_, ComposedModel> {
        self.now.read().unwrap_or_else(|e| e.into_inner())
    }
}

#[typetag::serde(name = "loop-adaptive")]
impl MotionModel for LoopModel {
    fn name(&self) -> String {
        self.now().name()
    }
    fn dt(&self) -> f64 {
        self.prior.dt()
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        self.now().predict_into(start, commands, poses)
    }
    fn predict_batch_into(
        &self,
        starts: &[StartState],
        commands: &[Input],
        horizon: usize,
        poses: &mut [Pose],
    ) -> Result<(), MotionError> {
        self.now()
            .predict_batch_into(starts, commands, horizon, poses)
    }
    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        self.now()
            .predict_with_covariance_into(start, commands, poses, covariances)
    }
    fn powertrain(&self) -> Option<&dyn Powertrain> {
        self.prior.powertrain()
    }
}

/// The adaptation of one run: the fit the windows driven feed, and the model the
/// controller predicts with.
pub(super) struct InLoop {
    pub(super) fit: AdaptiveFit,
    pub(super) model: std::sync::Arc<LoopModel>,
}

impl InLoop {
    /// Learns from a window just driven; the controller predicts with the result from the
    /// next tick on.
    pub(super) fn add(&mut self, window: &Window) {
        self.fit.add(window);
        self.model.set(self.fit.model());
    }
}
