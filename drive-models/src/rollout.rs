//! Pose rollout (paper eq. 1) and first-order propagation of the pose covariance.

use drive_traits::{euler_step, BodyVelocity, Pose, PoseCovariance};

/// Integrates body velocities into poses with explicit Euler (eq. 1): `poses[0] = start`,
/// `poses[k+1] = poses[k] + T(yaw_k) v_k dt`; one pose per velocity.
pub fn integrate(start: &Pose, velocities: &[BodyVelocity], dt: f64, poses: &mut Vec<Pose>) {
    poses.clear();
    if velocities.is_empty() {
        return;
    }
    let mut q = *start;
    poses.push(q);
    for v in &velocities[..velocities.len() - 1] {
        q = euler_step(&q, v, dt);
        poses.push(q);
    }
}

/// Propagates the pose covariance along a rollout: `P_{k+1} = F P_k F^T + G S_k G^T`, with
/// `F` the Jacobian of eq. 1 with respect to the pose, `G = T(yaw_k) dt` and `S_k` the
/// covariance of the body velocity at step k (here diagonal: the slip dimensions are
/// independent regressions). `P_0 = 0`.
pub fn propagate_covariance(
    poses: &[Pose],
    velocities: &[BodyVelocity],
    variances: &[BodyVelocity],
    dt: f64,
    out: &mut Vec<PoseCovariance>,
) {
    out.clear();
    if poses.is_empty() {
        return;
    }
    let mut p = PoseCovariance::zeros();
    out.push(p);
    for k in 0..poses.len() - 1 {
        let (s, c) = poses[k].z.sin_cos();
        let v = &velocities[k];
        let mut f = PoseCovariance::identity();
        f[(0, 2)] = -(s * v.x + c * v.y) * dt;
        f[(1, 2)] = (c * v.x - s * v.y) * dt;
        let g = PoseCovariance::new(c * dt, -s * dt, 0.0, s * dt, c * dt, 0.0, 0.0, 0.0, dt);
        let sv = PoseCovariance::from_diagonal(&variances[k]);
        p = f * p * f.transpose() + g * sv * g.transpose();
        out.push(p);
    }
}

/// Integrates the mean poses and propagates their covariance (see [`integrate`] and
/// [`propagate_covariance`]): what every model with an uncertainty does for its prediction.
pub fn integrate_with_covariance(
    start: &Pose,
    velocities: &[BodyVelocity],
    variances: &[BodyVelocity],
    dt: f64,
    poses: &mut Vec<Pose>,
    covariances: &mut Vec<PoseCovariance>,
) {
    integrate(start, velocities, dt, poses);
    propagate_covariance(poses, velocities, variances, dt, covariances);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_turn_and_covariance_growth() {
        let v = vec![BodyVelocity::new(1.0, 0.0, 0.0); 5];
        let mut poses = Vec::new();
        integrate(&Pose::new(0.0, 0.0, 0.0), &v, 0.1, &mut poses);
        assert_eq!(poses.len(), 5);
        assert!((poses[4].x - 0.4).abs() < 1e-12);
        let var = vec![BodyVelocity::new(0.01, 0.0, 0.0); 5];
        let mut cov = Vec::new();
        propagate_covariance(&poses, &v, &var, 0.1, &mut cov);
        // Straight x with independent steps: var_x = k * 0.01 * dt^2.
        assert!((cov[4][(0, 0)] - 4.0 * 0.01 * 0.01).abs() < 1e-15);
        assert_eq!(cov[0], PoseCovariance::zeros());
    }
}
