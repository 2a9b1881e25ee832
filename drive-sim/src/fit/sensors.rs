//! Stage 4, the localization's mount on the body: where its frame sits, from the steady
//! lateral speed regressed on yaw rate and speed.

use super::*;

/// Where the localization sits on the body: the steady windows' lateral speed regressed on
/// the yaw rate, the forward speed and their product (the last is the body's own sideslip,
/// what the ground gives); a frame `x` ahead of the centre the body turns about sees a
/// lateral speed `x w`, a frame yawed by `d` sees `-d v`. The left offset is not told
/// apart from slip (it moves the forward speed with the yaw rate): 0.
pub(super) fn localization_mount(data: &Dataset) -> [f64; 3] {
    use drive_traits::nalgebra::{DMatrix, DVector};
    let dt = 1.0 / data.robot.rate_hz;
    let rows: Vec<[f64; 4]> = data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() >= 3)
        .map(|w| {
            let [v, yaw_rate] = window_motion(&w.pose, dt);
            [yaw_rate, v, v * yaw_rate, window_lateral(&w.pose, dt)]
        })
        .collect();
    if rows.len() < 12 {
        return [0.0; 3];
    }
    let x = DMatrix::from_fn(rows.len(), 3, |i, j| rows[i][j]);
    let y = DVector::from_iterator(rows.len(), rows.iter().map(|r| r[3]));
    match x.svd(true, true).solve(&y, 1e-10) {
        Ok(c) if c.iter().all(|v| v.is_finite()) => [
            c[0].clamp(-MOUNT_RANGE.0, MOUNT_RANGE.0),
            0.0,
            (-c[1]).clamp(-MOUNT_RANGE.1, MOUNT_RANGE.1),
        ],
        _ => [0.0; 3],
    }
}
