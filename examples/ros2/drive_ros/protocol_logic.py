"""The logic of the DRIVE protocol node, without ROS: what `protocol_node.py` wires to
topics and a timer. Kept free of rclpy so that it can be tested with fake messages and a
fake clock (python/tests/test_ros2.py).

Messages are read by attribute, as the ROS 2 message classes lay them out:
  Joy (sensor_msgs)      .buttons, .axes          the dead-man switch
  JointState (sensor_msgs) .name, .velocity       the wheels' measured velocities (rad/s)
  Float64 (std_msgs)     .data                    one wheel's measured velocity (rad/s)
  Odometry (nav_msgs)    .pose.pose.position.{x,y}, .pose.pose.orientation.{x,y,z,w}

Safety: the command is zero unless the dead-man button is held *and* a joystick message
arrived within `joy_timeout` seconds (a silent joystick counts as released); the runner
also stops the robot when encoders or localization go stale and, with a geofence, ends
the protocol beyond `geofence` metres from the start. A measurement that is not finite is
dropped (counted in `dropped`), so stale-sensor protection takes over if it persists; any
other runner error ends the protocol with a zero command and the reason in `error`.
"""

import math
from dataclasses import dataclass

import drive


@dataclass(frozen=True)
class Output:
    """What the node publishes at one timer tick."""

    linear: float  # Twist linear.x (m/s), on cmd_vel_out (the logger's /doughnut_cmd_vel)
    angular: float  # Twist angular.z (rad/s)
    calib_step: int  # Int32 on calib_step: the interval being driven
    calib_state: str  # String on calib_state: "calib" while an interval runs, else "idle"
    joy_switch: bool  # Bool on drive/joy_switch: True while the operator has taken over
    state: str  # the runner's state: characterizing, driving, paused, done, error


def joint_velocities(msg, left_joint, right_joint):
    """(left, right) velocities of the two joints named in a JointState, or None when one
    is missing from it."""
    names = list(msg.name)
    velocity = list(msg.velocity)
    values = []
    for joint in (left_joint, right_joint):
        if joint not in names or names.index(joint) >= len(velocity):
            return None
        values.append(velocity[names.index(joint)])
    return values[0], values[1]


def yaw_of(q):
    """Yaw (rad) of a quaternion with attributes x, y, z, w."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class ProtocolLogic:
    """The DRIVE protocol for one robot: feed it messages as they arrive and call
    `on_timer(now)` at `rate_hz`; publish what it returns.

    `robot`, `sampler`, `seed` and `options` (geofence, max_intervals, max_duration,
    characterize, stale_timeout, ...) go to `drive.ProtocolRunner`. The dead-man switch is
    `buttons[deadman_button] >= deadman_threshold` of the last Joy message.
    """

    def __init__(
        self,
        robot,
        sampler="uniform",
        seed=0,
        *,
        deadman_button=0,
        deadman_threshold=0.5,
        joy_timeout=0.5,
        left_joint="left_wheel",
        right_joint="right_wheel",
        **options,
    ):
        if not (joy_timeout > 0 and math.isfinite(joy_timeout)):
            raise ValueError(f"joy_timeout must be a positive number of seconds, got {joy_timeout}")
        if deadman_button < 0:
            raise ValueError(f"deadman_button must be a button index (>= 0), got {deadman_button}")
        self.runner = drive.ProtocolRunner(robot, sampler, seed, **options)
        self.rate_hz = self.runner.rate_hz
        self.deadman_button = int(deadman_button)
        self.deadman_threshold = float(deadman_threshold)
        self.joy_timeout = float(joy_timeout)
        self.left_joint, self.right_joint = str(left_joint), str(right_joint)
        self.error = None
        self.dropped = 0
        self._pressed = False
        self._joy_time = None
        self._left = None
        self._right = None
        self._wheels_new = False
        self._pose = None
        self._step = 0
        self._driven = False

    # Subscriptions --------------------------------------------------------------------

    def on_joy(self, msg, now):
        """A Joy message received at `now` (s)."""
        buttons = list(msg.buttons)
        self._pressed = (
            self.deadman_button < len(buttons)
            and buttons[self.deadman_button] >= self.deadman_threshold
        )
        self._joy_time = now

    def on_joint_state(self, msg):
        """Both wheels' measured velocities from a JointState, by joint name (`left_joint`,
        `right_joint`); a message without them is ignored."""
        values = joint_velocities(msg, self.left_joint, self.right_joint)
        if values is not None and self._finite(*values):
            self._left, self._right = float(values[0]), float(values[1])
            self._wheels_new = True

    def on_left_wheel(self, msg):
        """The left wheel's measured velocity (Float64, rad/s)."""
        if self._finite(msg.data):
            self._left = float(msg.data)
            self._wheels_new = True

    def on_right_wheel(self, msg):
        """The right wheel's measured velocity (Float64, rad/s)."""
        if self._finite(msg.data):
            self._right = float(msg.data)
            self._wheels_new = True

    def on_odometry(self, msg):
        """The localization (Odometry): x, y and the yaw of its orientation."""
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        if self._finite(p.x, p.y, q.x, q.y, q.z, q.w) and (q.x, q.y, q.z, q.w) != (0, 0, 0, 0):
            self._pose = (float(p.x), float(p.y), yaw_of(q))

    def _finite(self, *values):
        ok = all(math.isfinite(v) for v in values)
        if not ok:
            self.dropped += 1
        return ok

    # Timer ----------------------------------------------------------------------------

    def deadman(self, now):
        """The dead-man switch is held and the joystick is alive."""
        return (
            self._pressed
            and self._joy_time is not None
            and 0.0 <= now - self._joy_time <= self.joy_timeout
        )

    @property
    def finished(self):
        """The protocol has ended (see `runner.stop_reason`, or `error`)."""
        return self.error is not None or self.runner.done

    def on_timer(self, now):
        """One command tick at time `now` (s): the messages to publish."""
        held = self.deadman(now)
        if self.error is not None:
            return self._output(0.0, 0.0, "idle", held, "error")
        encoder = None
        if self._wheels_new and self._left is not None and self._right is not None:
            encoder = (self._left, self._right)
        self._wheels_new = False
        pose, self._pose = self._pose, None
        try:
            cmd = self.runner.tick(t=now, encoder=encoder, pose=pose, deadman=held)
        except drive.DriveError as e:
            self.error = str(e)
            return self._output(0.0, 0.0, "idle", held, "error")
        state = self.runner.state
        if cmd.recording:
            self._step, self._driven = cmd.interval, True
            calib = "calib"
        elif state == "paused" and self.runner.pause_reason == "deadman released" and self._driven:
            # A dead-man pause suspends the interval under way, as the DRIVE logger records it.
            calib = "calib"
        else:
            calib = "idle"
        return self._output(cmd.linear, cmd.angular, calib, held, state)

    def _output(self, linear, angular, calib, held, state):
        return Output(
            linear=float(linear),
            angular=float(angular),
            calib_step=int(self._step),
            calib_state=calib,
            joy_switch=not held,
            state=state,
        )
