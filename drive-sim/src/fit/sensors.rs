//! Stage 4, the localization's mount on the body: where its frame sits, from the steady
//! lateral speed regressed on yaw rate and speed.

use super::*;
use crate::{ICP_GAP_BINS, ICP_GAP_STEP_S};

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

/// The localization's noise (position m, yaw rad) and the jitter of its timestamps (s,
/// the width of [`Sensors::icp_jitter`](crate::Sensors::icp_jitter)'s uniform draw), from
/// the steady windows' updates (the samples where the pose changed: a held pose is the
/// update rate's, not noise).
///
/// A pose stamped `d` seconds off is off by `w d` in yaw and `v d` along the path, so the
/// updates' spread around each window's steady motion grows with its speed, as real
/// localizations' do (on the released Warthog runs, from under 0.01 rad turning slowly to
/// over 0.1 rad at 2 rad/s). Per window, the yaw's variance around a parabola in time (which
/// follows a motion still settling) is `s_yaw^2 + w^2 var(d)`: fitted non-negative by least
/// squares over the windows, then again without the windows more than three times above the
/// first fit (a localization's occasional jumps, which would otherwise set the noise of
/// every update). The position noise is the median,
/// over the windows that turn less than 0.5 rad (where a parabola in time follows the arc),
/// of what the timing leaves of the positions' variance around a parabola, `(var -
/// v^2 var(d)) / 2` per axis. The uniform draw's width is `sqrt(12 var(d))`.
pub(super) fn localization_noise(data: &Dataset) -> ([f64; 2], f64) {
    let dt = 1.0 / data.robot.rate_hz;
    // (yaw rate squared, the yaw's variance) and (speed squared, the positions' variance).
    let (mut yaw_rows, mut position_rows) = (Vec::new(), Vec::new());
    for w in data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() > 4)
    {
        let n = w.len();
        let mut unwrapped = vec![w.pose[0].z];
        for k in 1..n {
            let last = unwrapped[k - 1];
            unwrapped.push(last + drive_traits::wrap_angle(w.pose[k].z - w.pose[k - 1].z));
        }
        let fresh: Vec<usize> = (0..n)
            .filter(|&k| k == 0 || w.pose[k] != w.pose[k - 1])
            .collect();
        if fresh.len() < 6 {
            continue;
        }
        let t: Vec<f64> = fresh.iter().map(|&k| k as f64 * dt).collect();
        let at = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { fresh.iter().map(|&k| f(k)).collect() };
        let Some((yaw_var, rate)) = polynomial_fit(&t, &at(&|k| unwrapped[k]), 2) else {
            continue;
        };
        if !(rate.is_finite() && yaw_var.is_finite()) {
            continue;
        }
        yaw_rows.push((rate * rate, yaw_var));
        if (unwrapped[n - 1] - unwrapped[0]).abs() <= 0.5 {
            let xs = polynomial_fit(&t, &at(&|k| w.pose[k].x), 2);
            let ys = polynomial_fit(&t, &at(&|k| w.pose[k].y), 2);
            if let (Some((vx, _)), Some((vy, _))) = (xs, ys) {
                let [v, _] = window_motion(&w.pose, dt);
                if (v * v + vx + vy).is_finite() {
                    position_rows.push((v * v, vx + vy));
                }
            }
        }
    }
    let first = nonnegative_line(yaw_rows.iter().copied());
    let [yaw_var, timing_var] = nonnegative_line(
        yaw_rows
            .iter()
            .copied()
            .filter(|&(x, y)| y <= 3.0 * (first[0] + first[1] * x)),
    );
    let position_var = median_or_zero(
        position_rows
            .iter()
            .map(|&(x, y)| (y - timing_var * x).max(0.0) / 2.0)
            .collect(),
    );
    (
        [position_var.sqrt(), yaw_var.sqrt()],
        (12.0 * timing_var).sqrt(),
    )
}

/// The non-negative intercept and slope `[a, b]` of the least-squares line `y = a + b x`
/// through `points`; zeros without points.
fn nonnegative_line(points: impl Iterator<Item = (f64, f64)>) -> [f64; 2] {
    let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (x, y) in points {
        n += 1.0;
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    if n == 0.0 {
        return [0.0; 2];
    }
    let det = n * sxx - sx * sx;
    let (a, b) = if det > 1e-12 * n * sxx.max(1e-300) {
        ((sxx * sy - sx * sxy) / det, (n * sxy - sx * sy) / det)
    } else {
        (sy / n, 0.0)
    };
    if a >= 0.0 && b >= 0.0 {
        [a, b]
    } else if b < 0.0 || sxx == 0.0 {
        // The slope would be negative: the mean alone.
        [(sy / n).max(0.0), 0.0]
    } else {
        // The intercept would be negative: a line through the origin.
        [0.0, (sxy / sxx).max(0.0)]
    }
}

/// The residual variance (sum of squares over `n - degree - 1`) of `y`'s least-squares
/// polynomial of `degree` (1 or 2) in `t`, and its slope at the mean `t`; `None` with too
/// few points or a singular fit.
fn polynomial_fit(t: &[f64], y: &[f64], degree: usize) -> Option<(f64, f64)> {
    use drive_traits::nalgebra::{DMatrix, DVector};
    let n = t.len();
    let cols = degree + 1;
    if n <= cols {
        return None;
    }
    let t0 = t.iter().sum::<f64>() / n as f64;
    let a = DMatrix::from_fn(n, cols, |i, j| (t[i] - t0).powi(j as i32));
    let b = DVector::from_column_slice(y);
    let sol = a.clone().svd(true, true).solve(&b, 1e-12).ok()?;
    let r = b - &a * &sol;
    Some((r.norm_squared() / (n - cols) as f64, sol[1]))
}

/// When the localization's pose changes ([`Sensors::icp_gaps`](crate::Sensors::icp_gaps)):
/// the gaps between the samples at which each window's pose changed, binned by
/// [`ICP_GAP_STEP_S`] (the last bin: that far or more), as shares. A window sees a gap
/// whole only when both its ends fall inside it, the more rarely the longer the gap (in a
/// window spanning `n` ticks, a gap of `g` ticks fits in `n - g` places): each is counted
/// `n / (n - g)` times (a gap as long as the window is never seen: the last bin is a lower
/// bound of the long holds). All zero with fewer than 100 gaps, or when every gap is one
/// length (a localization whose period is a whole number of ticks is its rate's; one of
/// 15 Hz sampled at 20 Hz gets its gaps of one and two ticks).
pub(super) fn localization_gaps(data: &Dataset) -> [f64; ICP_GAP_BINS] {
    let dt = 1.0 / data.robot.rate_hz;
    let (mut shares, mut seen) = ([0.0; ICP_GAP_BINS], 0usize);
    for w in &data.windows {
        let span = w.len().saturating_sub(1);
        let mut last: Option<usize> = None;
        for k in 1..w.len() {
            if w.pose[k] != w.pose[k - 1] {
                if let Some(j) = last {
                    let gap = k - j;
                    let bin = ((gap as f64 * dt / ICP_GAP_STEP_S).round() as usize)
                        .clamp(1, ICP_GAP_BINS);
                    // gap < span: both ends are changes after the window's first sample.
                    shares[bin - 1] += span as f64 / (span - gap) as f64;
                    seen += 1;
                }
                last = Some(k);
            }
        }
    }
    let total: f64 = shares.iter().sum();
    if seen < 100 || shares.iter().filter(|&&c| c > 0.0).count() < 2 {
        return [0.0; ICP_GAP_BINS];
    }
    shares.map(|c| c / total)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 150-interval run of the Husky on gravel with the localization's `sensors`.
    fn run(sensors: Sensors) -> Dataset {
        let terrain = Terrain {
            sensors: Some(sensors),
            ..Terrain::preset("gravel").unwrap()
        };
        husky_run(terrain, 150, 5)
    }

    #[test]
    fn the_timestamps_jitter_is_told_from_the_noise() {
        let quiet = Sensors {
            icp_noise: [0.01, 0.004],
            ..Sensors::default()
        };
        // Without jitter, next to none; the noise is the generator's.
        let ([position, yaw], jitter) = localization_noise(&run(quiet));
        assert!(jitter < 0.04, "{jitter}");
        assert!((position - 0.01).abs() < 0.003, "{position}");
        assert!((yaw - 0.004).abs() < 0.0015, "{yaw}");
        // With a 0.3 s jitter the spread grows with the speed, and the noise stays.
        let jittery = Sensors {
            icp_jitter: 0.3,
            ..quiet
        };
        let ([position, yaw], jitter) = localization_noise(&run(jittery));
        assert!((jitter - 0.3).abs() < 0.06, "{jitter}");
        assert!((position - 0.01).abs() < 0.005, "{position}");
        // The Husky turns slowly: some of the timing's spread goes to the yaw's noise.
        assert!(yaw < 0.015, "{yaw}");
    }

    #[test]
    fn the_localizations_update_gaps_are_recovered_and_a_regular_one_has_none() {
        let regular = Sensors {
            icp_noise: [0.01, 0.004],
            ..Sensors::default()
        };
        assert_eq!(localization_gaps(&run(regular)), [0.0; ICP_GAP_BINS]);
        // 70% of the updates 0.1 s apart, 20% 0.3 s, 10% 0.8 s (held, then caught up).
        let mut gaps = [0.0; ICP_GAP_BINS];
        (gaps[1], gaps[5], gaps[15]) = (0.7, 0.2, 0.1);
        let data = run(Sensors {
            icp_gaps: gaps,
            ..regular
        });
        // Published at 10 Hz all along, the runner's watchdog (0.5 s) never paused it.
        assert_eq!(data.windows.len(), 450);
        let fitted = localization_gaps(&data);
        for (bin, want) in [(1, 0.7), (5, 0.2), (15, 0.1)] {
            assert!((fitted[bin] - want).abs() < 0.03, "{bin}: {fitted:?}");
        }
        // Nothing lands elsewhere.
        let elsewhere: f64 = (0..ICP_GAP_BINS)
            .filter(|b| ![1, 5, 15].contains(b))
            .map(|b| fitted[b])
            .sum();
        assert!(elsewhere < 1e-12, "{fitted:?}");
    }

    #[test]
    fn a_nonnegative_line_falls_back_to_a_mean_or_the_origin() {
        let line = |p: &[(f64, f64)]| nonnegative_line(p.iter().copied());
        assert_eq!(line(&[(0.0, 1.0), (1.0, 3.0)]), [1.0, 2.0]);
        // A falling line: the mean alone.
        assert_eq!(line(&[(0.0, 3.0), (1.0, 1.0)]), [2.0, 0.0]);
        // A negative intercept: through the origin, (1 * 1 + 2 * 3) / (1 + 4).
        let [a, b] = line(&[(1.0, 1.0), (2.0, 3.0)]);
        assert_eq!(a, 0.0);
        assert!((b - 1.4).abs() < 1e-12);
        assert_eq!(line(&[]), [0.0, 0.0]);
    }
}
