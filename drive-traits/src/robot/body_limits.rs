//! The low-level controller's limits on the commanded body velocity.

use crate::{CommandModel, Input};
use std::sync::Arc;

/// The low-level controller's body limits: a sample whose commanded body velocity exceeds
/// them is redrawn (as the paper's own code does), and the schedule steers within them.
///
/// ```
/// use drive_traits::robot::BodyLimits;
/// use drive_traits::Input;
/// let car = drive_traits::vehicles::Ackermann::new(0.5, 0.4);
/// let limits = BodyLimits {
///     vehicle: std::sync::Arc::new(car),
///     max_linear: f64::INFINITY,
///     max_angular: f64::INFINITY,
///     max_lateral_acceleration: 4.0,
/// };
/// // 2 m/s at 0.3 rad: 4 m^2/s^2 x tan(0.3) / 0.5 m = 2.5 m/s^2 of lateral acceleration.
/// assert!(limits.allows(&Input::new(2.0, 0.3, 0.0)));
/// assert!(!limits.allows(&Input::new(4.0, 0.3, 0.0))); // 10.1 m/s^2
/// ```
#[derive(Debug, Clone)]
pub struct BodyLimits {
    /// The vehicle's command model (input -> body velocity).
    pub vehicle: Arc<dyn CommandModel>,
    /// Linear speed limit (m/s).
    pub max_linear: f64,
    /// Angular speed limit (rad/s).
    pub max_angular: f64,
    /// Lateral (centripetal) acceleration limit `|v_x w|` (m/s^2).
    pub max_lateral_acceleration: f64,
}

impl BodyLimits {
    /// Whether the commanded body velocity of `u` is within the limits.
    pub fn allows(&self, u: &Input) -> bool {
        let f = self.vehicle.body_velocity(u);
        f.x.abs() <= self.max_linear
            && f.z.abs() <= self.max_angular
            && (f.x * f.z).abs() <= self.max_lateral_acceleration
    }

    /// The yaw rate `w` limited to what the angular and lateral acceleration limits allow
    /// at the forward speed `v`.
    pub fn turn_within(&self, v: f64, w: f64) -> f64 {
        let bound = self
            .max_angular
            .min(self.max_lateral_acceleration / v.abs().max(1e-9));
        w.clamp(-bound, bound)
    }
}
