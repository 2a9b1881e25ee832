//! A vehicle: a robot commanded in body velocity, (v, omega), as a ROS `cmd_vel` interface
//! is. Its window CSV columns are `cmd_v, cmd_omega, meas_v, meas_omega`; the simulator
//! drives it with its kinematic plant (no physics registered for it).

use drive::serde::{Deserialize, Serialize};
use drive::traits::InvalidPart;
use drive::traits::{
    BodyVelocity, CommandModel, Input, InputAxis, InputSpace, Probe, ProbeResult, Tagged,
};
use drive::typetag;

/// The vehicle, with its top yaw rate (its speed range comes from the robot's top speed).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
pub struct Unicycle {
    /// Top yaw rate (rad/s).
    pub max_yaw_rate: f64,
}

impl Tagged for Unicycle {
    const TAG: &'static str = "unicycle";
}

#[typetag::serde(name = "unicycle")]
impl CommandModel for Unicycle {
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        BodyVelocity::new(u.x, 0.0, u.y)
    }

    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        (v.y == 0.0).then(|| Input::new(v.x, v.z, 0.0))
    }

    fn axes(&self) -> Vec<InputAxis> {
        vec![
            InputAxis {
                name: "v",
                unit: "m/s",
                command_column: "cmd_v",
                measured_column: "meas_v",
            },
            InputAxis {
                name: "omega",
                unit: "rad/s",
                command_column: "cmd_omega",
                measured_column: "meas_omega",
            },
        ]
    }

    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        InputSpace::new(
            Input::new(-top_speed, -self.max_yaw_rate, 0.0),
            Input::new(top_speed, self.max_yaw_rate, 0.0),
        )
    }

    /// Forward and backward at twice the top speed, then turning both ways at twice the top
    /// yaw rate: both axes get their range.
    fn probe(&self, index: usize, top_speed: f64, _done: &[ProbeResult]) -> Option<Probe> {
        let (name, command) = match index {
            0 => ("forward", Input::new(2.0 * top_speed, 0.0, 0.0)),
            1 => ("backward", Input::new(-2.0 * top_speed, 0.0, 0.0)),
            2 => ("left", Input::new(0.0, 2.0 * self.max_yaw_rate, 0.0)),
            3 => ("right", Input::new(0.0, -2.0 * self.max_yaw_rate, 0.0)),
            _ => return None,
        };
        Some(Probe {
            name,
            command,
            needs_localization: false,
        })
    }

    fn check(&self) -> Result<(), InvalidPart> {
        if self.max_yaw_rate.is_finite() && self.max_yaw_rate > 0.0 {
            Ok(())
        } else {
            Err(InvalidPart::from(format!(
                "max_yaw_rate = {} is not a positive rate",
                self.max_yaw_rate
            )))
        }
    }

    fn geometry(&self) -> Vec<(&'static str, f64)> {
        vec![("max_yaw_rate", self.max_yaw_rate)]
    }

    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}
