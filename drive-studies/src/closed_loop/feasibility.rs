//! Whether a path can be driven at a speed on this ground: the yaw rate its sharpest turn
//! needs against the one the robot reaches turning as hard as it can at that speed, both
//! measured (the reached one on the plant, as the top speed is).

use super::*;

/// The span of travel over which a path's turn is measured (s at the speed): the yaw rate a
/// turn needs is its heading change over one second of travel. A corner (the zigzag's) is
/// then the turn a controller looking ahead spreads it over, not an infinite curvature.
pub const TURN_SPAN_S: f64 = 1.0;

/// Whether a path can be driven at a speed on the study's ground.
#[derive(Debug, Clone, Serialize)]
pub struct Feasibility {
    /// The path.
    pub path: String,
    /// Speed as a fraction of the top speed.
    pub speed_fraction: f64,
    /// Speed (m/s).
    pub speed_m_s: f64,
    /// The yaw rate the path's sharpest turn needs at this speed (rad/s): the largest
    /// heading change over [`TURN_SPAN_S`] of travel, per second.
    pub yaw_rate_needed_rad_s: f64,
    /// The lateral acceleration that turn needs (m/s^2): the speed times that yaw rate.
    pub lateral_acceleration_needed_m_s2: f64,
    /// The yaw rate the robot reaches at this speed turning as hard as its input space
    /// allows (the smaller of left and right, rad/s), held for 6 s on the plant and
    /// measured over the last 2 s; `None` where the vehicle has no input for that speed.
    pub yaw_rate_reached_rad_s: Option<f64>,
    /// The lateral acceleration of that turn (m/s^2).
    pub lateral_acceleration_reached_m_s2: Option<f64>,
    /// Whether the reached yaw rate covers the needed one; `None` when unknown.
    pub feasible: Option<bool>,
}

/// The yaw rate `path` needs at `speed` (m/s): its largest heading change over
/// [`TURN_SPAN_S`] of travel, per second (rad/s).
///
/// ```
/// # use drive_studies::closed_loop::yaw_rate_needed;
/// let circle = drive_control::PathShape::Circle.at_scale(4.0).unwrap();
/// // A circle of radius r at speed v turns at v / r.
/// let radius = circle.length() / (2.0 * std::f64::consts::PI);
/// let w = yaw_rate_needed(&circle, 1.0);
/// assert!((w - 1.0 / radius).abs() < 0.05 / radius, "{w} {radius}");
/// ```
pub fn yaw_rate_needed(path: &ReferencePath, speed: f64) -> f64 {
    /// Steps per span.
    const STEPS: usize = 20;
    let span = speed * TURN_SPAN_S;
    let length = path.length();
    if !(span > 0.0 && length > span) {
        return 0.0;
    }
    // The heading every twentieth of the span along the path, unwrapped (a span may turn by
    // more than pi): the turn over a span is the difference of two of them.
    let step = span / STEPS as f64;
    let n = (length / step).floor() as usize;
    let mut unwrapped = Vec::with_capacity(n + 1);
    let mut last = path.point_at(0.0).heading;
    let mut total = 0.0;
    for k in 0..=n {
        let h = path.point_at(k as f64 * step).heading;
        total += wrap_angle(h - last);
        last = h;
        unwrapped.push(total);
    }
    let turn = unwrapped
        .windows(STEPS + 1)
        .map(|w| (w[STEPS] - w[0]).abs())
        .fold(0.0, f64::max);
    turn / TURN_SPAN_S
}

/// The input of the controller's space with forward speed `speed` and the largest yaw rate
/// of sign `sign` the space allows (bisection on the yaw rate); `None` where no input gives
/// that speed.
fn hardest_turn(robot: &RobotSpec, speed: f64, sign: f64) -> Option<Input> {
    let space = robot.input_space();
    let within = |w: f64| {
        robot
            .vehicle
            .input_for_twist(speed, sign * w)
            .filter(|u| space.contains(u))
    };
    within(0.0)?;
    let mut hi = 1.0;
    while within(hi).is_some() {
        hi *= 2.0;
        if hi > 1e4 {
            return within(hi / 2.0);
        }
    }
    let mut lo = 0.0;
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if within(mid).is_some() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    within(lo)
}

/// The yaw rate the plant reaches holding `input` (the controller's) for [`PROBE_S`],
/// measured over the last [`PROBE_SPAN_S`] (rad/s, signed).
fn reached_yaw_rate(
    registries: &Registries,
    d: &Driven,
    terrain: &Terrain,
    seed: u64,
    input: Input,
) -> Result<f64, TrackError> {
    let poses = probe(registries, d, terrain, seed, input)?;
    let (ticks, span) = probe_ticks(d);
    let turned: f64 = poses[ticks - span..]
        .windows(2)
        .map(|p| wrap_angle(p[1].z - p[0].z))
        .sum();
    Ok(turned / PROBE_SPAN_S)
}

/// The feasibility of every path at every speed.
pub(super) fn feasibility(
    registries: &Registries,
    d: &Driven,
    terrain: &Terrain,
    seed: u64,
    paths: &[(String, ReferencePath)],
    speeds: &[f64],
    top: f64,
) -> Result<Vec<Feasibility>, TrackError> {
    let mut out = Vec::new();
    for &fraction in speeds {
        let speed = fraction * top;
        // What the robot reaches at this speed, the smaller of its two turns.
        let mut reached: Option<f64> = Some(f64::INFINITY);
        for sign in [1.0, -1.0] {
            reached = match (reached, hardest_turn(&d.controller, speed, sign)) {
                (Some(r), Some(u)) => {
                    Some(r.min(sign * reached_yaw_rate(registries, d, terrain, seed, u)?))
                }
                _ => None,
            };
        }
        let reached = reached.filter(|r| r.is_finite()).map(|r| r.max(0.0));
        for (name, path) in paths {
            let needed = yaw_rate_needed(path, speed);
            out.push(Feasibility {
                path: name.clone(),
                speed_fraction: fraction,
                speed_m_s: speed,
                yaw_rate_needed_rad_s: needed,
                lateral_acceleration_needed_m_s2: needed * speed,
                yaw_rate_reached_rad_s: reached,
                lateral_acceleration_reached_m_s2: reached.map(|r| r * speed),
                feasible: reached.map(|r| r >= needed),
            });
        }
    }
    Ok(out)
}
