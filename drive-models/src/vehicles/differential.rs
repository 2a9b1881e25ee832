use drive_traits::{BodyVelocity, CommandModel, Input, InputSpace, RobotDescription};
use serde::{Deserialize, Serialize};

/// The ideal differential drive of a skid-steer robot (paper eq. 4):
/// `f = r [ (w_l + w_r) / 2, 0, (w_r - w_l) / b ]`.
///
/// ```
/// use drive_models::DifferentialDrive;
/// use drive_traits::{CommandModel, Input};
/// let husky = DifferentialDrive::new(0.165, 0.55);
/// let f = husky.body_velocity(&Input::new(2.0, 4.0));
/// assert!((f.x - 0.495).abs() < 1e-12);    // 0.165 * 3
/// assert!(f.y == 0.0);
/// assert!((f.z - 0.6).abs() < 1e-12);      // 0.165 * 2 / 0.55
/// let u = husky.input_for(&f).unwrap();
/// assert!((u - Input::new(2.0, 4.0)).norm() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DifferentialDrive {
    /// Wheel or sprocket radius r (m).
    pub wheel_radius: f64,
    /// Vehicle width b (m).
    pub baseline: f64,
    /// The input space J (wheel velocity limits), when known.
    #[serde(default)]
    pub input_space: Option<InputSpace>,
}

impl DifferentialDrive {
    /// A differential drive with radius `r` and width `b`, input space unknown.
    pub fn new(wheel_radius: f64, baseline: f64) -> Self {
        DifferentialDrive {
            wheel_radius,
            baseline,
            input_space: None,
        }
    }

    /// The differential drive of a robot description.
    pub fn from_robot(robot: &RobotDescription) -> Self {
        Self::new(robot.wheel_radius, robot.baseline)
    }

    /// Eq. 4 without the trait-object indirection.
    #[inline]
    pub fn eq4(&self, u: &Input) -> BodyVelocity {
        let r = self.wheel_radius;
        BodyVelocity::new(r * 0.5 * (u.x + u.y), 0.0, r * (u.y - u.x) / self.baseline)
    }
}

#[typetag::serde(name = "differential-drive")]
impl CommandModel for DifferentialDrive {
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        self.eq4(u)
    }

    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        if v.y != 0.0 {
            return None;
        }
        let r = self.wheel_radius;
        let half = 0.5 * v.z * self.baseline;
        Some(Input::new((v.x - half) / r, (v.x + half) / r))
    }

    fn input_space(&self) -> Option<InputSpace> {
        self.input_space
    }
}
