//! The conformal scores and what they are computed with: chi-square quantiles, the
//! pose errors, the ellipse and interval scores, the floored covariances, the steps pooled
//! per horizon step, and the errors' own shape along and across the predicted heading.

use super::*;

/// The chi-square quantile of 2 degrees of freedom at `level`: `-2 ln(1 - level)`.
///
/// ```
/// assert!((drive_models::calibration::chi2_2(0.95) - 5.991464547107979).abs() < 1e-12);
/// ```
pub fn chi2_2(level: f64) -> f64 {
    -2.0 * (1.0 - level).ln()
}

/// The chi-square quantile of 1 degree of freedom at `level` (the square of the standard
/// normal quantile at `(1 + level) / 2`), by bisection on the error function.
///
/// ```
/// assert!((drive_models::calibration::chi2_1(0.95) - 3.841458820694124).abs() < 1e-9);
/// ```
pub fn chi2_1(level: f64) -> f64 {
    // P(|Z| <= z) = erf(z / sqrt 2); increasing in z.
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if erf(mid / std::f64::consts::SQRT_2) < level {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let z = 0.5 * (lo + hi);
    z * z
}

/// The error function: its Maclaurin series below 2.5, the continued fraction of `erfc`
/// above (both to about 1e-15).
pub(super) fn erf(x: f64) -> f64 {
    if x < 0.0 {
        return -erf(-x);
    }
    if x < 2.5 {
        // Maclaurin series: sum (-1)^n x^(2n+1) / (n! (2n+1)), converges fast for x < 2.5.
        let (mut term, mut sum, x2) = (x, x, x * x);
        let mut n = 0.0;
        loop {
            n += 1.0;
            term *= -x2 / n;
            let add = term / (2.0 * n + 1.0);
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        sum * 2.0 / std::f64::consts::PI.sqrt()
    } else {
        // Continued fraction of erfc (Lentz), accurate for x >= 2.5.
        let mut f = x;
        for k in (1..60).rev() {
            f = x + (k as f64 / 2.0) / f;
        }
        1.0 - (-x * x).exp() / (f * std::f64::consts::PI.sqrt())
    }
}

/// The steps pooled with step `k >= 1` of `n`: those within 10% of it (at least one each
/// side), as many on each side (errors grow along a window: steps on one side only would
/// bias the step's quantile), the start excluded.
pub(super) fn pooled_steps(k: usize, n: usize) -> (usize, usize) {
    let r = ((k as f64) * 0.1).round().max(1.0) as usize;
    let r = r.min(k - 1).min(n - 1 - k);
    (k - r, k + r)
}

/// The steps whose held-out errors shape the difficulty and the heading shape of step
/// `k >= 1` of `n`: those within 10% of it (at least one each side), the start excluded.
/// Unlike [`pooled_steps`], not as many on each side: a difficulty and a shape are relative
/// (the step's quantile sets the size), and the last step gets its neighbours' errors.
pub(super) fn neighbour_steps(k: usize, n: usize) -> (usize, usize) {
    let r = ((k as f64) * 0.1).round().max(1.0) as usize;
    ((k - r).max(1), (k + r).min(n - 1))
}

/// A calibration's difficulty per step, and per step and held-out row its score over its
/// out-of-fold difficulty and that difficulty as applied (tempered: the score's divisor).
pub(super) struct Difficulties {
    pub(super) difficulty: Vec<StepDifficulty>,
    pub(super) scores: Vec<Vec<f64>>,
    pub(super) multipliers: Vec<Vec<f64>>,
}

/// Per step, the mean over the held-out rows of the calibrated region's area over
/// `pi chi2` (scale times out-of-fold difficulty times the root determinant of the shape,
/// `size`), with `power` 1; with `power` 1/2, of a yaw interval's half-width over the
/// root of the chi-square quantile (`size` the yaw's standard deviation); NaN at a step
/// without rows.
pub(super) fn mean_areas(
    rows: &[Vec<Row>],
    fit: &Difficulties,
    scale: &[f64],
    power: f64,
    size: impl Fn(&Row) -> f64,
) -> Vec<f64> {
    rows.iter()
        .zip(&fit.multipliers)
        .zip(scale)
        .map(|((step, m), s)| {
            // x^1 is x to the bit (a correctly rounded power of an exact result).
            let sum: f64 = if power == 1.0 {
                step.iter().zip(m).map(|(r, m)| s * m * size(r)).sum()
            } else {
                step.iter()
                    .zip(m)
                    .map(|(r, m)| (s * m).powf(power) * size(r))
                    .sum()
            };
            sum / step.len() as f64
        })
        .collect()
}

/// The unit shape `[a, b, d]` (the symmetric 2x2 `[[a, b], [b, d]]`, determinant 1).
pub(super) const UNIT_SHAPE: [f64; 3] = [1.0, 0.0, 1.0];

/// A position error `e` in the frame of the heading `yaw`: `[along, across]`.
pub(super) fn heading_frame(e: &Pose, yaw: f64) -> [f64; 2] {
    let (s, c) = yaw.sin_cos();
    [c * e.x + s * e.y, -s * e.x + c * e.y]
}

/// `u^T S^-1 u` for the shape `s` (`[a, b, d]`).
pub(super) fn shape_score(u: &[f64; 2], s: &[f64; 3]) -> f64 {
    let [a, b, d] = *s;
    let det = a * d - b * b;
    (d * u[0] * u[0] - 2.0 * b * u[0] * u[1] + a * u[1] * u[1]) / det
}

/// The shape of the errors `u` whatever their sizes: Tyler's M-estimator of scatter (Tyler
/// 1987, "A distribution-free M-estimator of multivariate scatter"), the fixed point of
/// `S = 2 mean(u u^T / u^T S^-1 u)`, scaled to determinant 1, its smaller eigenvalue raised
/// to at least `floor` times the larger. Each error counts by its direction only, so a few
/// large errors (the hard windows, sized by the difficulty) do not set the shape of all.
/// `None` with fewer than 3 non-zero errors or all along one line.
pub(super) fn error_shape<'a>(
    u: impl Iterator<Item = &'a [f64; 2]>,
    floor: f64,
) -> Option<[f64; 3]> {
    let nonzero =
        move |u: &&[f64; 2]| u[0].is_finite() && u[1].is_finite() && u[0].hypot(u[1]) > 1e-12;
    // The errors counted, picked once (the iterations visit them in the same order), their
    // two components apart so that each error's weighted products are computed side by side.
    let (u0, u1): (Vec<f64>, Vec<f64>) = u.filter(nonzero).map(|u| (u[0], u[1])).unzip();
    if u0.len() < 3 {
        return None;
    }
    // `m` counted one by one as a float is the count itself (exact below 2^53 errors).
    let m = u0.len() as f64;
    let (mut wa, mut wb, mut wd) = (
        vec![0.0; m as usize],
        vec![0.0; m as usize],
        vec![0.0; m as usize],
    );
    let mut s = UNIT_SHAPE;
    for _ in 0..100 {
        // Each error's weighted products: independent of the others, so computed as one
        // vectorizable pass, with the operations of `shape_score` in its order.
        let [sa, sb, sd] = s;
        let det = sa * sd - sb * sb;
        for ((((u0, u1), wa), wb), wd) in u0.iter().zip(&u1).zip(&mut wa).zip(&mut wb).zip(&mut wd)
        {
            let w = 1.0 / ((sd * u0 * u0 - 2.0 * sb * u0 * u1 + sa * u1 * u1) / det);
            *wa = w * u0 * u0;
            *wb = w * u0 * u1;
            *wd = w * u1 * u1;
        }
        // The sums in the errors' order (the same rounding as one running sum each).
        let (mut a, mut b, mut d) = (0.0, 0.0, 0.0);
        for ((wa, wb), wd) in wa.iter().zip(&wb).zip(&wd) {
            a += wa;
            b += wb;
            d += wd;
        }
        let det = (a * d - b * b) / (m * m);
        if !(det > 1e-300 && det.is_finite()) {
            return None;
        }
        let root = det.sqrt();
        let next = [a / m / root, b / m / root, d / m / root];
        let change = next
            .iter()
            .zip(&s)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        s = next;
        if change < 1e-10 {
            break;
        }
    }
    // The eigenvalue floor, then determinant 1 again.
    let [a, b, d] = s;
    let mean = 0.5 * (a + d);
    let spread = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let lift = (floor * (mean + spread) - (mean - spread)).max(0.0);
    let (a, d) = (a + lift, d + lift);
    let root = (a * d - b * b).sqrt();
    Some([a / root, b / root, d / root])
}

/// The split-conformal quantile of `scores` at `level`: the `ceil((n + 1) level)`-th
/// smallest (the largest when that rank exceeds `n`); `None` for no score. Reorders
/// `scores` (a selection, not a sort: the same order statistic in linear time).
///
/// ```
/// let mut s: Vec<f64> = (1..=19).map(f64::from).collect();
/// assert_eq!(drive_models::calibration::conformal_quantile(&mut s, 0.95), Some(19.0));
/// let mut s: Vec<f64> = (1..=99).map(f64::from).collect();
/// assert_eq!(drive_models::calibration::conformal_quantile(&mut s, 0.9), Some(90.0));
/// ```
pub fn conformal_quantile(scores: &mut [f64], level: f64) -> Option<f64> {
    if scores.is_empty() {
        return None;
    }
    let n = scores.len();
    let rank = (((n + 1) as f64) * level).ceil() as usize;
    let (_, q, _) = scores.select_nth_unstable_by(rank.clamp(1, n) - 1, f64::total_cmp);
    Some(*q)
}

/// Where the `ceil((n + 1) level)`-th smallest of `n` scores is found by walking in from
/// the nearer end: `(true, m)` for the m-th largest, `(false, m)` for the m-th smallest.
fn conformal_walk(n: usize, level: f64) -> (bool, usize) {
    let rank = ((((n + 1) as f64) * level).ceil() as usize).clamp(1, n);
    if rank > n / 2 {
        (true, n - rank + 1)
    } else {
        (false, rank)
    }
}

/// [`conformal_quantile`] of each pool `(lo, hi)` of the steps' `scores` (the steps `lo` to
/// `hi` pooled; NaN left out): the same order statistics, found by walking in from the
/// nearer end of each pool (a few dozen scores at the usual levels) over the steps' scores
/// sorted at the ends the walks reach, instead of selecting over every pool.
pub(super) fn pooled_conformal_quantiles(
    scores: &[Vec<f64>],
    pools: &[(usize, usize)],
    level: f64,
) -> Vec<Option<f64>> {
    // The scores as keys ordered as `f64::total_cmp` orders them (integer comparisons).
    let mut lists: Vec<Vec<i64>> = scores
        .iter()
        .map(|step| {
            step.iter()
                .filter(|s| !s.is_nan())
                .map(|s| total_order_key(*s))
                .collect()
        })
        .collect();
    // How far in from each end of each step's scores the walks of its pools reach.
    let (mut top, mut bottom) = (vec![0usize; lists.len()], vec![0usize; lists.len()]);
    for &(lo, hi) in pools {
        let n = lists[lo..=hi].iter().map(Vec::len).sum();
        if n == 0 {
            continue;
        }
        let (from_top, m) = conformal_walk(n, level);
        let reach = if from_top { &mut top } else { &mut bottom };
        for r in &mut reach[lo..=hi] {
            *r = (*r).max(m);
        }
    }
    for ((list, top), bottom) in lists.iter_mut().zip(&top).zip(&bottom) {
        let len = list.len();
        let (t, b) = ((*top).min(len), (*bottom).min(len));
        if t + b >= len {
            list.sort_unstable();
            continue;
        }
        // The t largest at the end, sorted; the b smallest at the start, sorted.
        if t > 0 {
            list.select_nth_unstable(len - t);
            list[len - t..].sort_unstable();
        }
        if b > 0 {
            let rest = &mut list[..len - t];
            rest.select_nth_unstable(b - 1);
            rest[..b].sort_unstable();
        }
    }
    pools
        .iter()
        .map(|&(lo, hi)| walk_pool(&lists[lo..=hi], level).map(from_total_order_key))
        .collect()
}

/// The walk of [`pooled_conformal_quantiles`] over one pool of keys: each list sorted at
/// least as far in from the end walked as the walk reaches.
fn walk_pool(lists: &[Vec<i64>], level: f64) -> Option<i64> {
    let n: usize = lists.iter().map(Vec::len).sum();
    if n == 0 {
        return None;
    }
    let (from_top, m) = conformal_walk(n, level);
    let at = |i: usize, taken: usize| {
        let list = &lists[i];
        if from_top {
            list[list.len() - 1 - taken]
        } else {
            list[taken]
        }
    };
    // Each list's next key (negated, `!`, when walking up from the smallest): the walk
    // takes the largest head; `i64::MIN`, the key of no score that is not NaN, once a list
    // is used up.
    let head = |i: usize, taken: usize| -> i64 {
        if taken >= lists[i].len() {
            i64::MIN
        } else if from_top {
            at(i, taken)
        } else {
            !at(i, taken)
        }
    };
    let mut taken = vec![0usize; lists.len()];
    let mut heads: Vec<i64> = (0..lists.len()).map(|i| head(i, 0)).collect();
    let mut last = None;
    for _ in 0..m {
        let (p, _) = heads.iter().enumerate().max_by_key(|(_, h)| **h)?;
        if heads[p] == i64::MIN {
            // Unreachable: fewer than n scores have been taken.
            return None;
        }
        last = Some(at(p, taken[p]));
        taken[p] += 1;
        heads[p] = head(p, taken[p]);
    }
    last
}

/// The measured minus the predicted pose at each step (yaw unwrapped along the measurement
/// and the difference wrapped to `[-pi, pi]`, as in eq. 8).
///
/// ```
/// use drive_traits::Pose;
/// let e = drive_models::calibration::pose_errors(
///     &[Pose::zeros(), Pose::new(1.0, 0.0, 3.1)],
///     &[Pose::zeros(), Pose::new(1.5, 0.5, -3.1)],
/// );
/// assert!((e[1].x - 0.5).abs() < 1e-12 && (e[1].z - (2.0 * std::f64::consts::PI - 6.2)).abs() < 1e-9);
/// ```
pub fn pose_errors(predicted: &[Pose], measured: &[Pose]) -> Vec<Pose> {
    let n = predicted.len().min(measured.len());
    let mut yaw: Vec<f64> = measured[..n].iter().map(|p| p.z).collect();
    drive_traits::unwrap_angles(&mut yaw);
    (0..n)
        .map(|k| {
            let (p, m) = (&predicted[k], &measured[k]);
            Pose::new(m.x - p.x, m.y - p.y, wrap_angle(yaw[k] - p.z))
        })
        .collect()
}

/// `e^T C^-1 e` of the position error `e` under the 2x2 position block of `c` (infinite
/// when that block is not positive definite).
///
/// ```
/// use drive_traits::{Pose, PoseCovariance};
/// let c = PoseCovariance::from_diagonal(&drive_traits::BodyVelocity::new(4.0, 1.0, 1.0));
/// assert_eq!(drive_models::calibration::position_score(&Pose::new(2.0, 1.0, 0.0), &c), 2.0);
/// ```
pub fn position_score(e: &Pose, c: &PoseCovariance) -> f64 {
    let (a, b, d) = (c[(0, 0)], c[(0, 1)], c[(1, 1)]);
    let det = a * d - b * b;
    if !(a > 0.0 && det > 0.0 && det.is_finite()) {
        return f64::INFINITY;
    }
    (d * e.x * e.x - 2.0 * b * e.x * e.y + a * e.y * e.y) / det
}

/// `c` with its position block's smaller eigenvalue raised to at least `ratio` times the
/// larger (by adding a multiple of the identity) and its variances to at least 1e-12.
pub(super) fn floored(c: &PoseCovariance, ratio: f64) -> PoseCovariance {
    let (a, b, d) = (c[(0, 0)], c[(0, 1)], c[(1, 1)]);
    let mean = 0.5 * (a + d);
    let spread = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let (large, small) = (mean + spread, mean - spread);
    let lift = (ratio * large - small).max(TINY_VARIANCE - small).max(0.0);
    let mut out = *c;
    out[(0, 0)] += lift;
    out[(1, 1)] += lift;
    out[(2, 2)] = out[(2, 2)].max(TINY_VARIANCE);
    out
}
