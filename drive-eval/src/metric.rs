use drive_traits::{unwrap_angles, wrap_angle, Pose};
use serde::Serialize;

/// Translational and rotational multi-step RMSE of one prediction window (paper eq. 8).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Mrmse {
    /// `Sigma = diag(1, 1, 0)`: mean position error norm (m).
    pub translational: f64,
    /// `Sigma = diag(0, 0, 1)`: mean absolute yaw error (rad).
    pub rotational: f64,
}

/// Eq. 8 over one window: the mean over the predicted steps `k = 1..n-1` of the error norm
/// `sqrt(e_k^T Sigma e_k)` (a mean of norms; `k = 0` is the known start). The measured yaw
/// is unwrapped along the window and the yaw error wrapped to `[-pi, pi]`.
///
/// Both slices hold one pose per sample and must have the same length (>= 2); shorter
/// input gives zero errors.
pub fn mrmse(predicted: &[Pose], measured: &[Pose]) -> Mrmse {
    let n = predicted.len().min(measured.len());
    if n < 2 {
        return Mrmse {
            translational: 0.0,
            rotational: 0.0,
        };
    }
    let mut yaw: Vec<f64> = measured[..n].iter().map(|p| p.z).collect();
    unwrap_angles(&mut yaw);
    let (mut t, mut r) = (0.0, 0.0);
    for k in 1..n {
        let (p, m) = (&predicted[k], &measured[k]);
        t += (p.x - m.x).hypot(p.y - m.y);
        r += wrap_angle(yaw[k] - p.z).abs();
    }
    let h = (n - 1) as f64;
    Mrmse {
        translational: t / h,
        rotational: r / h,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn yaw_error_is_wrapped_and_measured_yaw_unwrapped() {
        // Measured yaw crosses +pi (stored wrapped); the prediction follows it unwrapped.
        let truth = [3.0, 3.1, 3.2, 3.3];
        let measured: Vec<Pose> = truth
            .iter()
            .map(|a| Pose::new(0.0, 0.0, wrap_angle(*a)))
            .collect();
        let predicted: Vec<Pose> = truth.iter().map(|a| Pose::new(0.0, 0.0, *a)).collect();
        let e = mrmse(&predicted, &measured);
        assert!(e.rotational < 1e-12);
        // A prediction off by 2 pi + 0.1 counts as 0.1.
        let off: Vec<Pose> = truth
            .iter()
            .map(|a| Pose::new(0.0, 0.0, *a + 2.0 * PI + 0.1))
            .collect();
        assert!((mrmse(&off, &measured).rotational - 0.1).abs() < 1e-9);
    }

    #[test]
    fn start_sample_is_excluded() {
        let measured = vec![Pose::new(5.0, 5.0, 1.0), Pose::new(0.0, 0.0, 0.0)];
        let predicted = vec![Pose::zeros(), Pose::new(3.0, 4.0, 0.0)];
        let e = mrmse(&predicted, &measured);
        assert_eq!(e.translational, 5.0);
        assert_eq!(e.rotational, 0.0);
    }
}
