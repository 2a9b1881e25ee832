use crate::learners::check_common;
use crate::rollout::integrate;
use crate::DifferentialDrive;
use drive_traits::{FitError, Input, Learner, MotionModel, Pose, StartState, WindowSet};
use serde::{Deserialize, Serialize};

/// The naive model's learner: nothing is learned, the robot geometry is taken from the data.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Naive;

/// The manufacturer's model: the ideal differential drive (eq. 4) on the commanded wheel
/// velocities, unbounded, rolled out with eq. 1.
///
/// ```
/// use drive_models::{learners::NaiveModel, DifferentialDrive};
/// use drive_traits::{Input, MotionModel, Pose, StartState};
/// let m = NaiveModel { vehicle: DifferentialDrive::new(0.1, 0.5), dt: 0.1 };
/// let poses = m.predict(&StartState::at_rest(Pose::zeros()), &[Input::new(10.0, 10.0); 3]);
/// assert!((poses[2].x - 0.2).abs() < 1e-12); // 1 m/s for two steps of 0.1 s
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NaiveModel {
    /// The vehicle's command model.
    pub vehicle: DifferentialDrive,
    /// Step (s).
    pub dt: f64,
}

impl Learner for Naive {
    type Fitted = NaiveModel;
    fn fit(&self, train: &WindowSet<'_>) -> Result<NaiveModel, FitError> {
        Ok(NaiveModel {
            vehicle: DifferentialDrive::from_robot(train.robot),
            dt: train.robot.dt(),
        })
    }
}

#[typetag::serde(name = "naive")]
impl MotionModel for NaiveModel {
    fn name(&self) -> &'static str {
        "naive"
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn check(&self) -> Result<(), String> {
        check_common(self.dt, &self.vehicle)
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        let v: Vec<_> = commands.iter().map(|u| self.vehicle.eq4(u)).collect();
        integrate(&start.pose, &v, self.dt, poses);
    }
}
