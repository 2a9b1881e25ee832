//! Fitted motion models: poses over a horizon from a start state and an input sequence.

use crate::{BodyVelocity, Input, MotionError, Pose, PoseCovariance};

/// What is known at the start of a prediction: measured at that instant only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartState {
    /// Start pose.
    pub pose: Pose,
    /// Measured input (encoder wheel velocities) at the start.
    pub input: Input,
    /// Measured body velocity at the start (used by models whose state is a velocity, such
    /// as acceleration-based BLR).
    pub body_velocity: BodyVelocity,
}

impl StartState {
    /// At rest at `pose`.
    pub fn at_rest(pose: Pose) -> Self {
        StartState {
            pose,
            input: Input::zeros(),
            body_velocity: BodyVelocity::zeros(),
        }
    }
}

/// A fitted motion model (the linfa "fitted" side): it predicts, and it is saved and loaded
/// as a trait object through typetag (`"model": "<name>"` tag).
///
/// Convention: `commands[k]` is applied during step k; the prediction has one pose per
/// command, `poses[0]` the start pose and `poses[k+1] = poses[k] + T(yaw_k) v_k dt` (eq. 1).
#[typetag::serde(tag = "model")]
pub trait MotionModel: std::fmt::Debug + Send + Sync {
    /// The model's name (`naive`, `powertrain`, `slip-blr`, `acc-blr`, ...).
    fn name(&self) -> &'static str;

    /// Prediction step (s).
    fn dt(&self) -> f64;

    /// Fills `poses` (cleared first) with the predicted mean poses.
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>);

    /// Predicted mean poses, as a new vector.
    fn predict(&self, start: &StartState, commands: &[Input]) -> Vec<Pose> {
        let mut poses = Vec::with_capacity(commands.len());
        self.predict_into(start, commands, &mut poses);
        poses
    }

    /// Fills `poses` and `covariances` (one 3x3 pose covariance per step, zero at the start)
    /// for models that carry an uncertainty; the default says the model has none.
    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        let _ = (start, commands, poses, covariances);
        Err(MotionError::NoUncertainty { model: self.name() })
    }
}
