use crate::{Input, RobotDescription, Window};

/// A sampler of protocol inputs: each call draws the input held for the next DRIVE
/// interval. Implementations are seeded at construction and deterministic.
///
/// A sampler that learns from what was measured (a targeted sampler) also implements
/// [`observe`](InputSampler::observe); the protocol runner passes it every completed
/// interval's windows before it asks for the next input.
///
/// ```
/// use drive_traits::{Input, InputSampler};
/// /// Alternates between full forward and full reverse.
/// struct BackAndForth(bool);
/// impl InputSampler for BackAndForth {
///     fn next_input(&mut self) -> Input {
///         self.0 = !self.0;
///         if self.0 { Input::new(5.0, 5.0, 0.0) } else { Input::new(-5.0, -5.0, 0.0) }
///     }
/// }
/// let mut s = BackAndForth(false);
/// assert_eq!(s.next_input(), Input::new(5.0, 5.0, 0.0));
/// assert_eq!(s.next_input(), Input::new(-5.0, -5.0, 0.0));
/// ```
pub trait InputSampler {
    /// The next input to hold.
    fn next_input(&mut self) -> Input;

    /// The windows (one transient, two steady) recorded during the interval that just
    /// ended, for the robot `robot`. Ignored by default.
    fn observe(&mut self, robot: &RobotDescription, interval: &[Window]) {
        let _ = (robot, interval);
    }
}
