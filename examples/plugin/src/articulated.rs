//! An articulated (frame-steered) vehicle: two bodies joined by a vertical hinge, steered by
//! the angle between them (wheel loaders, forestry forwarders, some mining and
//! agricultural robots). Inputs: the front axle's speed `v` (m/s) and the articulation
//! angle `gamma` (rad). The body frame is the front body's, at its axle centre, where the
//! rolling body has no lateral velocity; with the hinge `front` m behind the front axle and
//! `rear` m ahead of the rear axle, at a steady articulation (Corke and Ridley, "Steering
//! kinematics for a center-articulated mobile robot", IEEE T-RA 17(2), 2001, with the
//! articulation rate at zero):
//!
//! `f = [v, 0, v sin(gamma) / (front cos(gamma) + rear)]`
//!
//! Like a car it cannot turn in place and turns by steering, so it declares
//! `Steering::Wheels` (slip-BLR then uses its car basis), and its robot gives rate limits
//! per input (speed and articulation) instead of body accelerations.

use drive::serde::{Deserialize, Serialize};
use drive::traits::InvalidPart;
use drive::traits::{
    BodyVelocity, CommandModel, Input, InputAxis, InputSpace, Probe, ProbeResult, Steering, Tagged,
};
use drive::typetag;

/// The vehicle: where the hinge sits between the axles, and the articulation limit.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
pub struct Articulated {
    /// Front axle to hinge (m).
    pub front: f64,
    /// Hinge to rear axle (m).
    pub rear: f64,
    /// The manufacturer's articulation limit (rad), both ways.
    pub max_articulation: f64,
}

impl Tagged for Articulated {
    const TAG: &'static str = "articulated";
}

impl Articulated {
    /// The yaw rate per unit of speed at articulation `gamma` (1/m).
    fn curvature(&self, gamma: f64) -> f64 {
        gamma.sin() / (self.front * gamma.cos() + self.rear)
    }
}

/// The speed of the articulation probes, as a fraction of the top speed.
const ARTICULATION_PROBE_SPEED: f64 = 0.2;

#[typetag::serde(name = "articulated")]
impl CommandModel for Articulated {
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        BodyVelocity::new(u.x, 0.0, u.x * self.curvature(u.y))
    }

    /// The articulation of the curvature `w / v`, within +-90 degrees: `v sin(g) - w front
    /// cos(g) = w rear`, solved as `R sin(g + phi) = w rear`. `None` for a lateral
    /// velocity, for a turn in place, and for a curvature no articulation under 90 degrees
    /// gives.
    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        if v.y != 0.0 {
            return None;
        }
        if v.x == 0.0 {
            return (v.z == 0.0).then(Input::zeros);
        }
        // The articulation depends on the curvature only: solve driving forward.
        let k = v.z / v.x;
        let (a, b, c) = (1.0, -k * self.front, k * self.rear);
        let r = (a * a + b * b).sqrt();
        if c.abs() > r {
            return None;
        }
        let gamma = (c / r).asin() - b.atan2(a);
        let exact = (self.curvature(gamma) - k).abs() <= 1e-9 * (1.0 + k.abs());
        (gamma.abs() < std::f64::consts::FRAC_PI_2 && exact).then(|| Input::new(v.x, gamma, 0.0))
    }

    fn axes(&self) -> Vec<InputAxis> {
        vec![
            InputAxis {
                name: "speed",
                unit: "m/s",
                command_column: "cmd_speed",
                measured_column: "meas_speed",
            },
            InputAxis {
                name: "articulation",
                unit: "rad",
                command_column: "cmd_articulation",
                measured_column: "meas_articulation",
            },
        ]
    }

    /// `+-top_speed` by `+-max_articulation`.
    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        InputSpace::new(
            Input::new(-top_speed, -self.max_articulation, 0.0),
            Input::new(top_speed, self.max_articulation, 0.0),
        )
    }

    /// Forward and backward at twice the top speed, then left and right slowly at twice
    /// the articulation limit.
    fn probe(&self, index: usize, top_speed: f64, _done: &[ProbeResult]) -> Option<Probe> {
        let slow = ARTICULATION_PROBE_SPEED * top_speed;
        let (name, command) = match index {
            0 => ("forward", Input::new(2.0 * top_speed, 0.0, 0.0)),
            1 => ("backward", Input::new(-2.0 * top_speed, 0.0, 0.0)),
            2 => ("left", Input::new(slow, 2.0 * self.max_articulation, 0.0)),
            3 => ("right", Input::new(slow, -2.0 * self.max_articulation, 0.0)),
            _ => return None,
        };
        Some(Probe {
            name,
            command,
            needs_localization: false,
        })
    }

    fn check(&self) -> Result<(), InvalidPart> {
        if !(self.front.is_finite() && self.front > 0.0 && self.rear.is_finite() && self.rear > 0.0)
        {
            return Err(InvalidPart::from(format!(
                "articulated: front = {} and rear = {} must be positive lengths",
                self.front, self.rear
            )));
        }
        if !(self.max_articulation > 0.0 && self.max_articulation < std::f64::consts::FRAC_PI_2) {
            return Err(InvalidPart::from(format!(
                "articulated: max_articulation = {} is not an angle in (0, pi/2) rad",
                self.max_articulation
            )));
        }
        Ok(())
    }

    /// An articulation range strictly within +-90 degrees.
    fn check_input_space(&self, space: &InputSpace) -> Result<(), InvalidPart> {
        let half_turn = std::f64::consts::FRAC_PI_2;
        if space.min.y <= -half_turn || space.max.y >= half_turn {
            return Err(InvalidPart::from(format!(
                "the articulation range [{}, {}] rad reaches +-pi/2",
                space.min.y, space.max.y
            )));
        }
        Ok(())
    }

    fn geometry(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("front", self.front),
            ("rear", self.rear),
            ("max_articulation", self.max_articulation),
        ]
    }

    fn steering(&self) -> Steering {
        Steering::Wheels
    }

    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_articulation_of_a_body_velocity_gives_it_back() {
        let v = Articulated {
            front: 0.7,
            rear: 0.5,
            max_articulation: 0.7,
        };
        // A small articulation: w ~ v gamma / (front + rear).
        let f = v.body_velocity(&Input::new(1.0, 0.01, 0.0));
        assert!((f.z - 0.01 / 1.2).abs() < 1e-5, "{f:?}");
        for (speed, gamma) in [(1.0, 0.3), (-0.8, 0.5), (2.0, -0.6), (0.5, 0.0)] {
            let u = Input::new(speed, gamma, 0.0);
            let back = v.input_for(&v.body_velocity(&u)).unwrap();
            assert!((back - u).norm() < 1e-9, "{u:?} -> {back:?}");
        }
        // No turn in place, no sliding sideways, no curvature beyond 90 degrees.
        assert!(v.input_for(&BodyVelocity::new(0.0, 0.0, 0.5)).is_none());
        assert!(v.input_for(&BodyVelocity::new(1.0, 0.1, 0.0)).is_none());
        assert!(v.input_for(&BodyVelocity::new(1.0, 0.0, 5.0)).is_none());
    }
}
