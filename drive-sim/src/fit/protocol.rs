//! Stage 5: the protocol the real run followed, the box it drew from in the geometry that
//! makes its draws fill their bounding box, the rectangle of body velocities they span, and
//! whether its commands stepped or ramped.

use super::*;

/// The protocol the real run followed: the box its sampler drew from, in the geometry that
/// makes the drawn wheel speeds independent, and whether its commands stepped or ramped.
///
/// Each interval's held command (the mean of its steady windows' commands) is one draw.
/// Drawn uniformly in a box, the two wheel speeds are independent; through a protocol
/// baseline `b_p` they are `(v -+ w b_p / 2) / r` for the recorded forward speed `v` and yaw
/// rate `w`, whose covariance `var v - b_p^2 var w / 4` vanishes at `b_p = 2 sd(v) / sd(w)`.
/// From there, the baseline whose draws fill their bounding box best (see
/// [`tightest_box`]). The box's bounds are the draws' extremes widened by one expected gap (range / (n - 1)),
/// the unbiased estimate of a uniform's bounds. The draws' body velocities, widened alike,
/// bound the draws too ([`TwinProtocol::body_limits`]): a protocol that drew body
/// velocities in a rectangle (or capped the forward speed and yaw rate) fills it, and the
/// twin draws in the box and the rectangle both; on a box's draws the rectangle cuts
/// only the box's corners. The commands step when, in most transient
/// windows whose command changed, one tick carries 90% of the change; otherwise they ramp,
/// at the largest body accelerations the transients show.
pub(super) fn fit_protocol(data: &Dataset, g: &DifferentialDrive) -> TwinProtocol {
    let dt = 1.0 / data.robot.rate_hz;
    let body = |u: Input| {
        [
            g.wheel_radius * (u.x + u.y) / 2.0,
            g.wheel_radius * (u.y - u.x) / g.baseline,
        ]
    };
    // One draw per interval: the mean command of its steady windows.
    let mut draws: Vec<Input> = Vec::new();
    let mut last: Option<(usize, Input, usize)> = None;
    for w in data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && !w.command.is_empty())
    {
        let c = w.command.iter().sum::<Input>() / w.command.len() as f64;
        match last.as_mut() {
            Some((i, sum, n)) if *i == w.interval => {
                *sum += c;
                *n += 1;
            }
            _ => {
                if let Some((_, sum, n)) = last {
                    draws.push(sum / n as f64);
                }
                last = Some((w.interval, c, 1));
            }
        }
    }
    if let Some((_, sum, n)) = last {
        draws.push(sum / n as f64);
    }
    let sd = |i: usize| {
        let m = mean(draws.iter().map(|&u| body(u)[i]));
        mean(draws.iter().map(|&u| (body(u)[i] - m).powi(2))).sqrt()
    };
    let moments = 2.0 * sd(0) / sd(1);
    // A run that barely turned (or barely drove) cannot tell its geometry: the nominal one.
    let baseline =
        if moments.is_finite() && moments > 0.1 * g.baseline && moments < 10.0 * g.baseline {
            tightest_box(&draws, g, moments)
        } else {
            g.baseline
        };
    let gain = g.baseline / baseline;
    let (mut lo, mut hi) = (
        Input::from_element(f64::INFINITY),
        Input::from_element(f64::NEG_INFINITY),
    );
    for &u in &draws {
        let p = scale_difference(u, 1.0 / gain);
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    let gap = (hi - lo) / (draws.len().max(2) - 1) as f64;
    let (lo, hi) = (lo - gap, hi + gap);
    // The rectangle of body velocities the draws span, widened alike: a protocol that drew
    // body velocities (or capped them) fills it, one that drew wheel speeds in a box spans
    // it only at the box's corners, where it cuts nothing.
    let mut rectangle = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
    for &u in &draws {
        for (axis, x) in body(u).into_iter().enumerate() {
            rectangle[axis] = [rectangle[axis][0].min(x), rectangle[axis][1].max(x)];
        }
    }
    let rectangle = rectangle.map(|[a, b]| {
        let gap = (b - a) / (draws.len().max(2) - 1) as f64;
        [a - gap, b + gap]
    });
    let body_limits = rectangle
        .iter()
        .all(|[a, b]| a.is_finite() && b.is_finite() && a < b)
        .then_some(rectangle);
    // Stepped or ramped: the share of a transient's change its largest tick carries.
    let (mut stepped, mut changed) = (0usize, 0usize);
    let (mut dv, mut dw) = (Vec::new(), Vec::new());
    for (i, w) in data.windows.iter().enumerate() {
        if w.phase != Phase::Transient || w.command.len() < 2 {
            continue;
        }
        let before = match i.checked_sub(1).map(|j| &data.windows[j]) {
            Some(p) if p.interval + 1 == w.interval && !p.command.is_empty() => {
                p.command[p.command.len() / 2]
            }
            _ => w.command[0],
        };
        let mut seq = vec![body(before)];
        seq.extend(w.command.iter().map(|&u| body(u)));
        let total = [
            seq[seq.len() - 1][0] - seq[0][0],
            seq[seq.len() - 1][1] - seq[0][1],
        ];
        let scale = [g.wheel_radius, g.wheel_radius * 2.0 / g.baseline];
        let size = (total[0] / scale[0]).hypot(total[1] / scale[1]);
        if size < 0.5 {
            continue;
        }
        changed += 1;
        let biggest = seq
            .windows(2)
            .map(|p| ((p[1][0] - p[0][0]) / scale[0]).hypot((p[1][1] - p[0][1]) / scale[1]))
            .fold(0.0, f64::max);
        if biggest >= 0.9 * size {
            stepped += 1;
        }
        for p in seq.windows(2) {
            dv.push((p[1][0] - p[0][0]).abs() / dt);
            dw.push((p[1][1] - p[0][1]).abs() / dt);
        }
    }
    let ramped = changed > 0 && 2 * stepped < changed;
    // The largest ramp seen; none when that axis never changed (nothing to tell).
    let largest = |v: Vec<f64>| Some(v.into_iter().fold(0.0, f64::max)).filter(|a| *a > 0.0);
    TwinProtocol {
        baseline,
        input_limits: [[lo.x, hi.x], [lo.y, hi.y]],
        max_linear_acceleration: if ramped { largest(dv) } else { None },
        max_angular_acceleration: if ramped { largest(dw) } else { None },
        body_limits,
        robot_wheel_radius: g.wheel_radius,
        robot_baseline: g.baseline,
    }
}

/// The protocol baseline within a factor of two of `start` under which the draws' bounding
/// box in wheel speeds is smallest for the area they cover: the draws of a box fill it, and
/// a wrong baseline shears the box into a parallelogram whose bounding box is larger (the
/// covered area grows as the baseline, the map from body velocity to wheel speeds having
/// determinant `b_p / r^2`). The extremes make it sharper than the moments with ~200 draws.
pub(super) fn tightest_box(draws: &[Input], g: &DifferentialDrive, start: f64) -> f64 {
    let r = g.wheel_radius;
    let body: Vec<[f64; 2]> = draws
        .iter()
        .map(|u| [r * (u.x + u.y) / 2.0, r * (u.y - u.x) / g.baseline])
        .collect();
    let cost = |b: f64| {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for [v, w] in &body {
            for (side, u) in [(v - w * b / 2.0) / r, (v + w * b / 2.0) / r]
                .into_iter()
                .enumerate()
            {
                lo[side] = lo[side].min(u);
                hi[side] = hi[side].max(u);
            }
        }
        (hi[0] - lo[0]) * (hi[1] - lo[1]) / b
    };
    // A fine grid in log space (the cost is piecewise smooth, with kinks).
    let steps = 2000;
    (0..=steps)
        .map(|i| start * (2.0f64).powf(2.0 * i as f64 / steps as f64 - 1.0))
        .map(|b| (cost(b), b))
        .fold(
            (f64::INFINITY, start),
            |best, c| if c.0 < best.0 { c } else { best },
        )
        .1
}
