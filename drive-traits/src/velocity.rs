//! Measured body velocities from the localization poses of a window.
//!
//! The ICP localization runs at about 10 Hz while samples come at the command rate, so the
//! pose repeats between updates: a one-sample difference alternates between zero and
//! twice the velocity. The estimator takes a central difference over a span of
//! `span_s` seconds (default 0.2 s, two ICP periods): `v_k = R(yaw_k)^T (p_{k+h} -
//! p_{k-h}) / (2 h dt)` and `omega_k = (yaw_{k+h} - yaw_{k-h}) / (2 h dt)` on the unwrapped
//! yaw, with `h = round(span / (2 dt))` (at least 1). It is centred, so it adds no lag;
//! samples closer than h to either end of the window get no estimate (windows are
//! independent frames and are never differenced across).

use crate::{unwrap_angles, BodyVelocity, FitError, Window};

/// Central-difference body velocity estimator over the window poses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyVelocityEstimator {
    /// Time span of the central difference (s).
    pub span_s: f64,
}

impl Default for BodyVelocityEstimator {
    fn default() -> Self {
        BodyVelocityEstimator { span_s: 0.2 }
    }
}

impl BodyVelocityEstimator {
    /// Checks the span.
    pub fn validate(&self) -> Result<(), FitError> {
        if self.span_s.is_finite() && self.span_s > 0.0 {
            Ok(())
        } else {
            Err(FitError::InvalidHyperparameter {
                name: "velocity span",
                value: self.span_s,
                expected: "a positive number of seconds",
            })
        }
    }

    /// Half width h in samples at sample period `dt`.
    pub fn half_width(&self, dt: f64) -> usize {
        ((self.span_s / (2.0 * dt)).round() as usize).max(1)
    }

    /// Fills `out` (cleared first) with one estimate per sample, `None` near the window ends.
    ///
    /// ```
    /// use drive_traits::{BodyVelocityEstimator, Input, Phase, Pose, Window};
    /// // Straight line at 1 m/s, 20 Hz, poses held in pairs as a 10 Hz ICP gives them.
    /// let pose: Vec<Pose> = (0..40).map(|k| Pose::new(0.05 * (k / 2 * 2) as f64, 0.0, 0.0)).collect();
    /// let w = Window::new(0, 0, Phase::Steady, vec![Input::zeros(); 40], vec![Input::zeros(); 40], pose, vec![0.0; 40]);
    /// let mut v = Vec::new();
    /// BodyVelocityEstimator::default().estimate(&w, 0.05, &mut v);
    /// assert!(v[0].is_none() && v[1].is_none());
    /// assert!((v[2].unwrap().x - 1.0).abs() < 1e-12 && (v[3].unwrap().x - 1.0).abs() < 1e-12);
    /// ```
    pub fn estimate(&self, window: &Window, dt: f64, out: &mut Vec<Option<BodyVelocity>>) {
        let n = window.len();
        let h = self.half_width(dt);
        out.clear();
        out.resize(n, None);
        if n <= 2 * h {
            return;
        }
        let mut yaw: Vec<f64> = window.pose.iter().map(|p| p.z).collect();
        unwrap_angles(&mut yaw);
        let scale = 1.0 / (2.0 * h as f64 * dt);
        for k in h..n - h {
            let (a, b) = (&window.pose[k - h], &window.pose[k + h]);
            let (dx, dy) = ((b.x - a.x) * scale, (b.y - a.y) * scale);
            let (s, c) = yaw[k].sin_cos();
            out[k] = Some(BodyVelocity::new(
                c * dx + s * dy,
                -s * dx + c * dy,
                (yaw[k + h] - yaw[k - h]) * scale,
            ));
        }
    }
}
