//! The DRIVE command schedule (Sec. III-A step 2): each interval holds one sampled input
//! for one transient and two steady 2 s windows, with acceleration (or input rate) limits
//! applied to what is sent.

use crate::RobotSpec;
use drive_traits::{BodyVelocity, Input, InputSampler, Phase};
pub use drive_traits::{WINDOWS_PER_INTERVAL, WINDOW_S};
use std::fmt::Write as _;

/// One command of the schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScheduledCommand {
    /// Time since the start (s).
    pub t: f64,
    /// Interval index.
    pub interval: usize,
    /// Transient or steady window.
    pub phase: Phase,
    /// The input sent (after the acceleration limits).
    pub command: Input,
    /// The sampled input the interval holds.
    pub target: Input,
}

/// What was sent last: the state of the command limits (at rest by default).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SentCommand {
    /// The body velocity sent last (the body acceleration limits step it).
    pub body: BodyVelocity,
    /// The input sent last (the per-axis rate limits step it).
    pub input: Input,
}

/// Steps a body velocity towards a target within the acceleration limits of one step.
pub fn limit_acceleration(
    previous: &BodyVelocity,
    target: &BodyVelocity,
    robot: &RobotSpec,
) -> BodyVelocity {
    let dt = 1.0 / robot.rate_hz;
    let (dv, dw) = (
        robot.max_linear_acceleration * dt,
        robot.max_angular_acceleration * dt,
    );
    BodyVelocity::new(
        previous.x + (target.x - previous.x).clamp(-dv, dv),
        previous.y + (target.y - previous.y).clamp(-dv, dv),
        previous.z + (target.z - previous.z).clamp(-dw, dw),
    )
}

/// The command of the next tick towards the input `target`, from what was sent last
/// (`sent`, updated). With per-axis input rate limits (a car's speed and steering rates),
/// each input steps towards the target's within its rate and as far as the controller's
/// body limits allow ([`RobotSpec::body_limits`]); otherwise the body velocity steps
/// towards the target's within the body acceleration limits and is sent as the vehicle's
/// input for its forward speed and yaw rate ([`CommandModel::input_for_twist`]; where the
/// vehicle has none, the input steps towards the target by the share of the body ramp the
/// step covers).
///
/// [`CommandModel::input_for_twist`]: drive_traits::CommandModel::input_for_twist
///
/// ```
/// use drive_samplers::{builtin_robots, next_command, SentCommand};
/// use drive_traits::Input;
/// let car = builtin_robots().get("autorally").unwrap().part().as_ref().clone();
/// let rates = car.input_rate_limits.unwrap();
/// let mut sent = SentCommand::default();
/// let u = next_command(&car, &mut sent, &Input::new(5.0, 0.3, 0.0));
/// // One tick at 20 Hz: the speed and the steering move by their rates over 0.05 s at most.
/// assert!((u.x - rates.x * 0.05).abs() < 1e-12);
/// assert!((u.y - (rates.y * 0.05).min(0.3)).abs() < 1e-12);
/// ```
pub fn next_command(robot: &RobotSpec, sent: &mut SentCommand, target: &Input) -> Input {
    let dt = 1.0 / robot.rate_hz;
    if let Some(rates) = robot.input_rate_limits {
        let limits = robot.body_limits();
        let mut u = sent.input;
        // Axis by axis (a car's speed first, then its steering), each as far as its rate
        // and the controller's body limits allow.
        for i in 0..robot.vehicle.input_dim().min(drive_traits::MAX_INPUTS) {
            let step = (target[i] - u[i]).clamp(-rates[i] * dt, rates[i] * dt);
            let moved = |fraction: f64| {
                let mut c = u;
                c[i] += fraction * step;
                c
            };
            let fraction = match &limits {
                Some(l) if l.allows(&u) && !l.allows(&moved(1.0)) => {
                    let (mut lo, mut hi) = (0.0, 1.0);
                    for _ in 0..40 {
                        let mid = 0.5 * (lo + hi);
                        if l.allows(&moved(mid)) {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    lo
                }
                _ => 1.0,
            };
            u = moved(fraction);
        }
        sent.input = u;
        sent.body = robot.vehicle.body_velocity(&u);
        return u;
    }
    let target_body = robot.vehicle.body_velocity(target);
    let previous = sent.body;
    sent.body = limit_acceleration(&previous, &target_body, robot);
    // The input of the ramped body velocity where the vehicle has one (an omnidirectional
    // base's lateral speed ramps too), else of its forward speed and yaw rate (a Twist:
    // solved for a vehicle whose lateral velocity follows from them). Where the vehicle has
    // neither, the input moves from the last one towards the target by the share of the
    // body ramp this step covers: the ramp is kept in the inputs, never skipped.
    let exact = if sent.body.y != 0.0 {
        robot.vehicle.input_for(&sent.body)
    } else {
        None
    };
    let u = exact
        .or_else(|| robot.vehicle.input_for_twist(sent.body.x, sent.body.z))
        .unwrap_or_else(|| {
            let whole = (target_body - previous).norm();
            let share = if whole > 0.0 {
                ((sent.body - previous).norm() / whole).clamp(0.0, 1.0)
            } else {
                1.0
            };
            sent.input + (target - sent.input) * share
        });
    sent.input = u;
    u
}

/// Samples per window at the robot's rate.
pub fn window_len(robot: &RobotSpec) -> usize {
    (WINDOW_S * robot.rate_hz).round().max(1.0) as usize
}

/// The schedule of `intervals` DRIVE intervals from a sampler, starting at rest.
pub fn schedule(
    robot: &RobotSpec,
    sampler: &mut dyn InputSampler,
    intervals: usize,
) -> Vec<ScheduledCommand> {
    let n = window_len(robot);
    // Grown as needed beyond a million rows: a mistaken count fails as it grows, not in
    // one impossible allocation.
    let rows = intervals
        .saturating_mul(WINDOWS_PER_INTERVAL)
        .saturating_mul(n);
    let mut out = Vec::with_capacity(rows.min(1 << 20));
    let mut sent = SentCommand::default();
    for interval in 0..intervals {
        let target = sampler.next_input();
        for w in 0..WINDOWS_PER_INTERVAL {
            let phase = if w == 0 {
                Phase::Transient
            } else {
                Phase::Steady
            };
            for _ in 0..n {
                let command = next_command(robot, &mut sent, &target);
                out.push(ScheduledCommand {
                    t: out.len() as f64 / robot.rate_hz,
                    interval,
                    phase,
                    command,
                    target,
                });
            }
        }
    }
    out
}

/// The schedule as CSV: `t,interval,phase` and the vehicle's command columns
/// (`cmd_left,cmd_right` for a differential drive).
pub fn schedule_csv(robot: &RobotSpec, rows: &[ScheduledCommand]) -> String {
    let axes = robot.vehicle.axes();
    let mut s = String::from("t,interval,phase");
    for a in &axes {
        s.push(',');
        s.push_str(a.command_column);
    }
    s.push('\n');
    for r in rows {
        // Writing into a String cannot fail.
        let _ = write!(s, "{},{},{}", r.t, r.interval, r.phase.as_str());
        for i in 0..axes.len().min(drive_traits::MAX_INPUTS) {
            let _ = write!(s, ",{}", r.command[i]);
        }
        s.push('\n');
    }
    s
}
