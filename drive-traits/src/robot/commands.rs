//! What a robot may be sent tick by tick: its acceleration (or input rate) limits applied to
//! the commands (the protocol's schedule and the controllers both send through them).

use super::RobotSpec;
use crate::{BodyVelocity, Input};

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
/// [`CommandModel::input_for_twist`]: crate::CommandModel::input_for_twist
///
/// ```
/// use drive_traits::robot::{builtin_robots, next_command, SentCommand};
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
        for i in 0..robot.vehicle.input_dim().min(crate::MAX_INPUTS) {
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
    // neither, or the Twist would drop a crab, the input moves from the last one towards the target by the share of the
    // body ramp this step covers: the ramp is kept in the inputs, never skipped.
    let exact = if sent.body.y != 0.0 {
        robot.vehicle.input_for(&sent.body)
    } else {
        None
    };
    // A Twist keeps the target's lateral velocity only when that velocity follows from
    // its forward speed and yaw rate; a crab of its own (a four-wheel-steered rover's,
    // whose inverse covers no crab) is ramped in the inputs instead, never dropped.
    let twist_keeps_lateral = exact.is_some()
        || target_body.y == 0.0
        || robot
            .vehicle
            .input_for_twist(target_body.x, target_body.z)
            .is_some_and(|u| {
                let y = robot.vehicle.body_velocity(&u).y;
                (y - target_body.y).abs() <= 1e-6 * (1.0 + target_body.y.abs())
            });
    let u = exact
        .or_else(|| {
            twist_keeps_lateral
                .then(|| robot.vehicle.input_for_twist(sent.body.x, sent.body.z))
                .flatten()
        })
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
