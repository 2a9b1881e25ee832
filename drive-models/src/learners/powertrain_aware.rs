use crate::learners::check_common;
use crate::powertrain::Fopdt;
use crate::rollout::integrate;
use crate::DifferentialDrive;
use drive_traits::{
    FitError, Input, Learner, MotionModel, Pose, Powertrain, PowertrainLearner, StartState,
    WindowSet,
};
use serde::{Deserialize, Serialize};

/// The powertrain-aware model's learner (Sec. III-B.1): fits a powertrain (by default the
/// FOPDT of eq. 3) and applies eq. 4 to the predicted wheel velocities.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PowertrainAware<P = Fopdt> {
    /// The powertrain learner.
    pub powertrain: P,
}

/// Fitted powertrain-aware model: predicted wheel velocities, then eq. 4 and eq. 1.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PowertrainAwareModel {
    /// The vehicle's command model.
    pub vehicle: DifferentialDrive,
    /// The fitted powertrain.
    pub powertrain: Box<dyn Powertrain>,
    /// Step (s).
    pub dt: f64,
}

impl<P: PowertrainLearner> Learner for PowertrainAware<P> {
    type Fitted = PowertrainAwareModel;
    fn fit(&self, train: &WindowSet<'_>) -> Result<PowertrainAwareModel, FitError> {
        let powertrain = Box::new(self.powertrain.fit(train)?);
        Ok(PowertrainAwareModel {
            vehicle: DifferentialDrive::from_robot(train.robot),
            powertrain,
            dt: train.robot.dt(),
        })
    }
}

#[typetag::serde(name = "powertrain")]
impl MotionModel for PowertrainAwareModel {
    fn name(&self) -> &'static str {
        "powertrain"
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn check(&self) -> Result<(), String> {
        check_common(self.dt, &self.vehicle)?;
        self.powertrain.check()
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        let wheels = self.powertrain.predict(&start.input, commands);
        let v: Vec<_> = wheels.iter().map(|u| self.vehicle.eq4(u)).collect();
        integrate(&start.pose, &v, self.dt, poses);
    }
}
