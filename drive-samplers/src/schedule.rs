//! The DRIVE command schedule (Sec. III-A step 2): each interval holds one sampled input
//! for one transient and two steady 2 s windows, with acceleration (or input rate) limits
//! applied to what is sent.

use crate::RobotSpec;
pub use drive_traits::robot::{limit_acceleration, next_command, SentCommand};
use drive_traits::{Input, InputSampler, Phase};
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
