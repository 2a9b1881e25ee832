//! A vehicle whose lateral velocity depends on its yaw rate: a unicycle (v, omega) whose
//! reference point (where the localization is, and the poses are) sits `offset` m ahead of
//! its axle, so that turning moves that point sideways, v_y = offset * omega. No input
//! commands a body velocity with v_y = 0 while turning: its `input_for((v, 0, w))` is
//! `None`, and the framework reaches it through `input_for_twist` (the input of a forward
//! speed and a yaw rate, what a Twist asks), in the samplers, the schedule's acceleration
//! ramps, the import of its raw log and the controllers. Its inputs, columns, input space
//! and characterization are the unicycle's (`unicycle.rs`).

use crate::unicycle::Unicycle;
use drive::serde::{Deserialize, Serialize};
use drive::traits::InvalidPart;
use drive::traits::{
    BodyVelocity, CommandModel, Input, InputAxis, InputSpace, Probe, ProbeResult, Tagged,
};
use drive::typetag;

/// The vehicle: a unicycle and the reference point's offset ahead of the axle.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
pub struct OffsetUnicycle {
    /// The unicycle (its top yaw rate).
    pub unicycle: Unicycle,
    /// How far ahead of the axle the reference point is (m).
    pub offset: f64,
}

impl Tagged for OffsetUnicycle {
    const TAG: &'static str = "offset-unicycle";
}

#[typetag::serde(name = "offset-unicycle")]
impl CommandModel for OffsetUnicycle {
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        BodyVelocity::new(u.x, self.offset * u.y, u.y)
    }

    /// Exact only for the body velocities the vehicle has: v_y = offset * omega.
    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        ((v.y - self.offset * v.z).abs() <= 1e-12 * (1.0 + v.y.abs()))
            .then(|| Input::new(v.x, v.z, 0.0))
    }

    fn axes(&self) -> Vec<InputAxis> {
        self.unicycle.axes()
    }

    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        self.unicycle.nominal_input_space(top_speed)
    }

    fn probe(&self, index: usize, top_speed: f64, done: &[ProbeResult]) -> Option<Probe> {
        self.unicycle.probe(index, top_speed, done)
    }

    fn check(&self) -> Result<(), InvalidPart> {
        self.unicycle.check()?;
        if !(self.offset.is_finite() && self.offset.abs() <= 10.0) {
            return Err(InvalidPart::from(format!(
                "offset = {} m is not a plausible offset",
                self.offset
            )));
        }
        Ok(())
    }

    fn geometry(&self) -> Vec<(&'static str, f64)> {
        let mut g = self.unicycle.geometry();
        g.push(("offset", self.offset));
        g
    }

    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}
