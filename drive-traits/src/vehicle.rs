//! Vehicle command models: how an input vector maps to a commanded body velocity.

use crate::{BodyVelocity, Input};
use serde::{Deserialize, Serialize};

/// The input space J of a vehicle: a box of inputs `min <= u <= max` (Sec. III-A).
///
/// ```
/// use drive_traits::{Input, InputSpace};
/// let j = InputSpace::new(Input::new(-6.8, -6.8), Input::new(6.8, 6.8)).unwrap();
/// assert!(j.contains(&Input::new(1.0, -2.0)));
/// assert!(!j.contains(&Input::new(7.0, 0.0)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InputSpace {
    /// Lower corner.
    pub min: Input,
    /// Upper corner.
    pub max: Input,
}

impl InputSpace {
    /// A box; `None` if a bound is not finite or `min > max` on some axis.
    pub fn new(min: Input, max: Input) -> Option<Self> {
        let ok =
            min.iter().chain(max.iter()).all(|v| v.is_finite()) && min.x <= max.x && min.y <= max.y;
        ok.then_some(InputSpace { min, max })
    }

    /// True if `u` lies inside the box (bounds included).
    pub fn contains(&self, u: &Input) -> bool {
        (0..2).all(|i| u[i] >= self.min[i] && u[i] <= self.max[i])
    }

    /// `u` clamped into the box, per axis.
    pub fn clamp(&self, u: &Input) -> Input {
        Input::new(
            u.x.clamp(self.min.x, self.max.x),
            u.y.clamp(self.min.y, self.max.y),
        )
    }
}

/// A vehicle command model: the map from an input vector to the commanded body velocity
/// `f(u)` of paper eq. 2 (for a skid-steer robot, the ideal differential drive of eq. 4).
///
/// Implemented by `drive_models::DifferentialDrive`; an Ackermann vehicle (speed, steering
/// angle) implements the same trait with its own geometry. Serialized as a trait object
/// (`"vehicle": "<name>"` tag) inside fitted model files.
#[typetag::serde(tag = "vehicle")]
pub trait CommandModel: std::fmt::Debug + Send + Sync {
    /// Commanded body velocity `f(u)` for input `u`.
    fn body_velocity(&self, u: &Input) -> BodyVelocity;

    /// The input that commands body velocity `v`, where one exists (a skid-steer cannot
    /// command a lateral velocity: `v.y` must be zero).
    fn input_for(&self, v: &BodyVelocity) -> Option<Input>;

    /// The vehicle's input space J, when known (from characterization or the manufacturer).
    fn input_space(&self) -> Option<InputSpace>;
}
