//! The held body-velocity bias whose variance matches the validation windows' pose errors
//! (part of the rollouts' pose covariance).

use super::*;

/// The variance of a body-velocity bias (x, y, yaw) held over each rollout that makes the
/// predicted squared pose errors match the measured ones on `tracks`, on average over
/// their steps: least squares of `e_i^2 ~ sum_d q_d (de_i / db_d)^2`, clamped at zero
/// (yaw first, which only the yaw bias moves; then one variance for x and y). `limits`
/// bound the start velocity and the yaw disturbance (see [`dynamics_of`]).
pub(super) fn bias_variance(
    tracks: &[&Track],
    theta: &[f64; PARAMETERS],
    limits: [f64; 2],
    dt: f64,
) -> [f64; 3] {
    let theta_d: [DualSVec64<3>; PARAMETERS] = theta.map(DualSVec64::from);
    let dynamics = dynamics_of(theta, limits).constant::<DualSVec64<3>>();
    // The bias enters as slip: its derivative is the slip's with respect to the bias.
    let bias: [DualSVec64<3>; 3] = std::array::from_fn(|d| DualSVec64::from(0.0).derivative(d));
    // Sums for the yaw regression and the translational one.
    let (mut yy, mut ye) = (0.0, 0.0);
    let (mut tt, mut te) = (0.0, 0.0);
    let mut rows = Vec::new();
    for t in tracks {
        let slip = |k: usize| {
            let g = slip_of(&theta_d, &t.features[k]);
            split([g[0] + bias[0], g[1] + bias[1], g[2] + bias[2]])
        };
        t.rollout(dt, &dynamics, slip, |k, xy, yaw| {
            let m = &t.target[k];
            let p = [xy[0], xy[1], *yaw];
            let g = |i: usize| p[i].eps.unwrap_generic(Const::<3>, U1);
            let (gx, gy, gz) = (g(0), g(1), g(2));
            let ez = wrap_angle(p[2].re - m.z);
            yy += gz[2].powi(4);
            ye += gz[2].powi(2) * ez * ez;
            let et2 = (p[0].re - m.x).powi(2) + (p[1].re - m.y).powi(2);
            // Translational sensitivity to the x and y biases together, and to the yaw bias.
            let st = gx[0].powi(2) + gx[1].powi(2) + gy[0].powi(2) + gy[1].powi(2);
            let sw = gx[2].powi(2) + gy[2].powi(2);
            rows.push((st, sw, et2));
        });
    }
    let q_yaw = if yy > 0.0 { (ye / yy).max(0.0) } else { 0.0 };
    for (st, sw, et2) in rows {
        let rest = et2 - q_yaw * sw;
        tt += st * st;
        te += st * rest;
    }
    let q_xy = if tt > 0.0 { (te / tt).max(0.0) } else { 0.0 };
    [q_xy, q_xy, q_yaw]
}
