use crate::{BodyVelocity, Input, RobotDescription, Window, WindowSet};

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

    /// Whether its inputs depend on the windows it observes ([`InputSampler::observe`]):
    /// a schedule planned offline (`drive protocol`), which observes none, holds what it
    /// draws before it has seen any, and says so. False by default.
    fn learns_from_windows(&self) -> bool {
        false
    }
}

/// What a sampler that aims at the model's uncertainty asks of a model: fitted on the windows
/// driven so far, how unsure it is of the slip at each commanded body velocity (the paper's
/// future work, Sec. V). Samplers see models only through this trait; the paper's slip-BLR
/// provides it in drive-models (`drive_models::slip::SlipBlrLeverage`).
///
/// ```
/// use drive_traits::{BodyVelocity, SlipLeverage, WindowSet};
/// /// Unsure in proportion to the speed, whatever was driven.
/// struct BySpeed;
/// impl SlipLeverage for BySpeed {
///     fn leverage(&self, _: &WindowSet<'_>, at: &[BodyVelocity]) -> Option<Vec<f64>> {
///         Some(at.iter().map(|v| v.x.abs()).collect())
///     }
/// }
/// ```
pub trait SlipLeverage: Send + Sync {
    /// The weight-uncertainty share of the predictive slip variance (eq. 7) at each of
    /// `at`, of a slip model fitted on `windows`; `None` when no model can be fitted on them
    /// (too little or degenerate data).
    fn leverage(&self, windows: &WindowSet<'_>, at: &[BodyVelocity]) -> Option<Vec<f64>>;
}
