//! Pose rollout (paper eq. 1) and first-order propagation of the pose covariance.

use drive_traits::{BodyVelocity, Pose, PoseCovariance};

/// Explicit Euler integration of eq. 1, `q[k+1] = q[k] + T(yaw_k) v_k dt`, carrying the
/// cosine and sine of the yaw instead of recomputing them: each step rotates them by the
/// yaw increment `w dt`, whose sine and cosine come from their Taylor series (exact to
/// double precision for increments up to 0.1 rad) or from `sin_cos` beyond. Every model
/// integrates through it, so single and batched rollouts give the same poses.
///
/// ```
/// use drive_models::rollout::Integrator;
/// use drive_traits::{BodyVelocity, Pose};
/// let mut it = Integrator::new(&Pose::new(0.0, 0.0, 0.0), 0.1);
/// it.step(&BodyVelocity::new(1.0, 0.0, 2.0));
/// it.step(&BodyVelocity::new(1.0, 0.0, 2.0));
/// let q = it.pose();
/// assert!((q.x - (0.1 + 0.1 * 0.2f64.cos())).abs() < 1e-15 && (q.y - 0.1 * 0.2f64.sin()).abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Integrator {
    pose: Pose,
    cos: f64,
    sin: f64,
    dt: f64,
}

impl Integrator {
    /// Starts at `start` with step `dt`.
    #[inline]
    pub fn new(start: &Pose, dt: f64) -> Self {
        let (sin, cos) = start.z.sin_cos();
        Integrator {
            pose: *start,
            cos,
            sin,
            dt,
        }
    }

    /// Resumes a rollout at `pose` whose heading's cosine and sine were carried as `cos`
    /// and `sin` (what [`Integrator::heading`] gave): the same steps as the integrator that
    /// was interrupted.
    ///
    /// ```
    /// use drive_models::rollout::Integrator;
    /// use drive_traits::{BodyVelocity, Pose};
    /// let v = BodyVelocity::new(1.0, 0.0, 2.0);
    /// let mut whole = Integrator::new(&Pose::zeros(), 0.1);
    /// whole.step(&v);
    /// let (cos, sin) = whole.heading();
    /// let mut resumed = Integrator::resume(&whole.pose(), cos, sin, 0.1);
    /// whole.step(&v);
    /// resumed.step(&v);
    /// assert_eq!(whole.pose(), resumed.pose());
    /// ```
    #[inline]
    pub fn resume(pose: &Pose, cos: f64, sin: f64, dt: f64) -> Self {
        Integrator {
            pose: *pose,
            cos,
            sin,
            dt,
        }
    }

    /// The cosine and sine of the heading, as carried.
    #[inline]
    pub fn heading(&self) -> (f64, f64) {
        (self.cos, self.sin)
    }

    /// The current pose.
    #[inline]
    pub fn pose(&self) -> Pose {
        self.pose
    }

    /// One step of eq. 1 with body velocity `v`.
    #[inline]
    pub fn step(&mut self, v: &BodyVelocity) {
        let (c, s, dt) = (self.cos, self.sin, self.dt);
        self.pose.x += (c * v.x - s * v.y) * dt;
        self.pose.y += (s * v.x + c * v.y) * dt;
        let d = v.z * dt;
        self.pose.z += d;
        let (sd, cd) = small_sin_cos(d);
        self.cos = c * cd - s * sd;
        self.sin = s * cd + c * sd;
    }
}

/// `(sin x, cos x)`: Taylor polynomials (sin to x^9, cos to x^10, in multiply-add form)
/// for |x| <= 0.1, where the first omitted term is below 3e-19; `sin_cos` otherwise.
#[inline]
fn small_sin_cos(x: f64) -> (f64, f64) {
    const S: [f64; 4] = [-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362_880.0];
    const C: [f64; 5] = [
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
    ];
    if x.abs() > 0.1 {
        return x.sin_cos();
    }
    let x2 = x * x;
    let sin = x + x * x2 * (S[0] + x2 * (S[1] + x2 * (S[2] + x2 * S[3])));
    let cos = 1.0 + x2 * (C[0] + x2 * (C[1] + x2 * (C[2] + x2 * (C[3] + x2 * C[4]))));
    (sin, cos)
}

/// Integrates body velocities into poses with eq. 1 (see [`Integrator`]): `poses[0] =
/// start`, `poses[k+1] = poses[k] + T(yaw_k) v_k dt`; one pose per velocity.
pub fn integrate(start: &Pose, velocities: &[BodyVelocity], dt: f64, poses: &mut Vec<Pose>) {
    poses.clear();
    let mut it = Integrator::new(start, dt);
    for (k, v) in velocities.iter().enumerate() {
        poses.push(it.pose());
        if k + 1 < velocities.len() {
            it.step(v);
        }
    }
}

/// Like [`integrate`] into a slice: `out[k]` for every `k < out.len()` (one pose per
/// velocity; `out` no longer than `velocities`). What batched rollouts write into their
/// caller's buffer.
#[inline]
pub fn integrate_into(start: &Pose, velocities: &[BodyVelocity], dt: f64, out: &mut [Pose]) {
    let mut it = Integrator::new(start, dt);
    let n = out.len();
    for (k, (slot, v)) in out.iter_mut().zip(velocities).enumerate() {
        *slot = it.pose();
        if k + 1 < n {
            it.step(v);
        }
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
        p = covariance_step(&p, &poses[k], &velocities[k], &variances[k], dt);
        out.push(p);
    }
}

/// One step of [`propagate_covariance`]: the covariance after a step from `pose` (whose
/// covariance is `p`) at body velocity `v` with variances `variance`.
#[inline]
pub fn covariance_step(
    p: &PoseCovariance,
    pose: &Pose,
    v: &BodyVelocity,
    variance: &BodyVelocity,
    dt: f64,
) -> PoseCovariance {
    let (s, c) = pose.z.sin_cos();
    let mut f = PoseCovariance::identity();
    f[(0, 2)] = -(s * v.x + c * v.y) * dt;
    f[(1, 2)] = (c * v.x - s * v.y) * dt;
    let g = PoseCovariance::new(c * dt, -s * dt, 0.0, s * dt, c * dt, 0.0, 0.0, 0.0, dt);
    let sv = PoseCovariance::from_diagonal(variance);
    f * p * f.transpose() + g * sv * g.transpose()
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
    use drive_traits::euler_step;

    #[test]
    fn small_angle_series_matches_sin_cos() {
        for i in -1000..=1000 {
            let x = i as f64 * 1e-4;
            let (s, c) = small_sin_cos(x);
            assert!(
                (s - x.sin()).abs() <= 2e-17 && (c - x.cos()).abs() <= 2e-16,
                "x = {x}"
            );
        }
    }

    #[test]
    fn integrator_matches_direct_euler_steps() {
        let mut q = Pose::new(0.3, -0.2, 3.0);
        let mut it = Integrator::new(&q, 0.05);
        for k in 0..400 {
            let v = BodyVelocity::new(1.0 + 0.01 * k as f64, 0.1, 2.5 - 0.02 * k as f64);
            q = euler_step(&q, &v, 0.05);
            it.step(&v);
            assert!((it.pose() - q).norm() < 1e-12, "step {k}");
        }
    }

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
