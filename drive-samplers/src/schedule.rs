//! The DRIVE command schedule (Sec. III-A step 2): each interval holds one sampled input
//! for one transient and two steady 2 s windows, with acceleration limits applied to what
//! is sent.

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

/// The command of the next tick towards the input `target`: the body velocity sent last
/// (`sent`, updated) steps towards the target's within the acceleration limits and is sent
/// as the vehicle's input; the target itself when the vehicle cannot be given that body
/// velocity.
pub fn next_command(robot: &RobotSpec, sent: &mut BodyVelocity, target: &Input) -> Input {
    let target_body = robot.vehicle.body_velocity(target);
    *sent = limit_acceleration(sent, &target_body, robot);
    robot.vehicle.input_for(sent).unwrap_or(*target)
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
    let mut out = Vec::with_capacity(intervals * WINDOWS_PER_INTERVAL * n);
    let mut sent = BodyVelocity::zeros();
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
    let [a, b] = robot.vehicle.axes();
    let mut s = format!(
        "t,interval,phase,{},{}\n",
        a.command_column, b.command_column
    );
    for r in rows {
        // Writing into a String cannot fail.
        let _ = writeln!(
            s,
            "{},{},{},{},{}",
            r.t,
            r.interval,
            r.phase.as_str(),
            r.command.x,
            r.command.y
        );
    }
    s
}
