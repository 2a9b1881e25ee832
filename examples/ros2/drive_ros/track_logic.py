"""The logic of the path-following node, without ROS: a fitted model (a `drive train` file)
inside the MPPI controller of `drive track`, following the last nav_msgs/Path received.
Kept free of rclpy so that it is tested with fake messages and a fake clock
(python/tests/test_ros2.py).

Messages are read by attribute, as the ROS 2 message classes lay them out:
  Path (nav_msgs)        .poses[i].pose.position.{x,y}    the path to follow
  JointState (sensor_msgs) .name, .velocity               wheel velocities (rad/s), by joint name
  Float64 (std_msgs)     .data                            one wheel's velocity (rad/s)
  Odometry (nav_msgs)    .pose.pose.position.{x,y}, .pose.pose.orientation.{x,y,z,w}
  Imu (sensor_msgs)      .angular_velocity.z              yaw rate (rad/s)
  Joy (sensor_msgs)      .buttons                         the dead-man switch

Safety: the command is zero unless the dead-man button is held and a joystick message
arrived within `joy_timeout` seconds, the wheel velocities and the localization are fresh
(within `stale_timeout`), and a path is being followed; at the end of the path the tracker
stops the robot. A measurement that is not finite is dropped (counted in `dropped`); a
tracker error stops the robot with the reason in `error` until a new path arrives.
"""

import math
from dataclasses import dataclass

import drive

from drive_ros.protocol_logic import joint_velocities, yaw_of


@dataclass(frozen=True)
class TrackOutput:
    """What the node publishes at one timer tick."""

    linear: float  # Twist linear.x (m/s)
    angular: float  # Twist angular.z (rad/s)
    inputs: tuple  # the two inputs (wheel velocities, rad/s, for a differential drive)
    state: str  # "idle" (no path), "following", "held" (a safety stop), "done", "error"
    progress_m: float  # arc length reached on the path
    cross_track_m: float  # distance from the path (positive to its left)


def path_points(msg):
    """The (x, y) points of a nav_msgs/Path."""
    return [(float(p.pose.position.x), float(p.pose.position.y)) for p in msg.poses]


class TrackLogic:
    """Follows the last path received with `model_file` on `robot`, at `speed` m/s; feed it
    messages as they arrive and call `on_timer(now)` at the robot's rate (20 Hz).

    `left_joint`, `right_joint`: the JointState names of the wheels (their velocities are
    read by name); `start`: what the model was fitted to start from; `samples`, `horizon`,
    `temperature`, `history`: the controller's settings (`drive.Tracker`; a `history` of
    None or below 0 is the model's powertrain's settling time, `drive track`'s default).
    """

    def __init__(
        self,
        model_file,
        robot,
        speed,
        *,
        left_joint="left_wheel",
        right_joint="right_wheel",
        start="encoders+imu",
        samples=1024,
        horizon=40,
        temperature=0.1,
        history=None,
        deadman_button=0,
        deadman_threshold=0.5,
        joy_timeout=0.5,
        stale_timeout=0.5,
    ):
        for name, value in (("joy_timeout", joy_timeout), ("stale_timeout", stale_timeout)):
            if not (value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be a positive number of seconds, got {value}")
        if not (speed > 0 and math.isfinite(speed)):
            raise ValueError(f"speed must be a positive speed in m/s, got {speed}")
        self.model = drive.load_model(model_file)
        self.robot = robot
        self.speed = float(speed)
        self.rate_hz = 1.0 / self.model.dt
        if history is not None and history < 0:
            history = None
        self.options = dict(
            start=start, samples=samples, horizon=horizon, temperature=temperature, history=history
        )
        self.left_joint, self.right_joint = left_joint, right_joint
        self.deadman_button = int(deadman_button)
        self.deadman_threshold = float(deadman_threshold)
        self.joy_timeout = float(joy_timeout)
        self.stale_timeout = float(stale_timeout)
        self.tracker = None
        self.error = None
        self.done = False
        self.dropped = 0
        self._pressed = False
        self._joy_time = None
        self._left = self._right = None
        self._wheel_time = None
        self._pose = None
        self._pose_time = None
        self._pose_stamp = None
        self._yaw_rate = None
        self._last = (0.0, 0.0, 0.0)
        self._held = False

    # Subscriptions --------------------------------------------------------------------

    def on_path(self, msg):
        """A new path (nav_msgs/Path) to follow, from where the robot is: replaces the one
        followed; an unusable path (fewer than two distinct points, not finite) is an error
        that stops the robot."""
        try:
            points = path_points(msg)
            self.tracker = drive.Tracker(
                self.model, self.robot, points, self.speed, **self.options
            )
            self.error = None
            self.done = False
        except (drive.DriveError, TypeError, ValueError) as e:
            self.tracker = None
            self.error = f"path refused: {e}"

    def on_joint_state(self, msg, now):
        """Wheel velocities from a JointState, by joint name."""
        values = joint_velocities(msg, self.left_joint, self.right_joint)
        if values is not None and self._finite(*values):
            self._left, self._right = float(values[0]), float(values[1])
            self._wheel_time = now

    def on_left_wheel(self, msg, now):
        """The left wheel's velocity (Float64, rad/s)."""
        if self._finite(msg.data):
            self._left, self._wheel_time = float(msg.data), now

    def on_right_wheel(self, msg, now):
        """The right wheel's velocity (Float64, rad/s)."""
        if self._finite(msg.data):
            self._right, self._wheel_time = float(msg.data), now

    def on_odometry(self, msg, now):
        """The localization (Odometry): x, y and the yaw of its orientation."""
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        if self._finite(p.x, p.y, q.x, q.y, q.z, q.w) and (q.x, q.y, q.z, q.w) != (0, 0, 0, 0):
            self._pose = (float(p.x), float(p.y), yaw_of(q))
            self._pose_time = now
            # When the pose was measured (its header's stamp, on the node's clock), when
            # it says: the tracker carries a late fix forward from then. A stamp of zero,
            # in the future or over a second old is not used.
            stamp = getattr(getattr(msg, "header", None), "stamp", None)
            seconds = None
            if stamp is not None:
                seconds = float(getattr(stamp, "sec", 0)) + 1e-9 * float(getattr(stamp, "nanosec", 0))
            self._pose_stamp = seconds if seconds and now - 1.0 <= seconds <= now else None

    def on_imu(self, msg):
        """The IMU's yaw rate (Imu.angular_velocity.z)."""
        if self._finite(msg.angular_velocity.z):
            self._yaw_rate = float(msg.angular_velocity.z)

    def on_joy(self, msg, now):
        """A Joy message received at `now` (s)."""
        buttons = list(msg.buttons)
        self._pressed = (
            self.deadman_button < len(buttons)
            and buttons[self.deadman_button] >= self.deadman_threshold
        )
        self._joy_time = now

    def _finite(self, *values):
        ok = all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)
        if not ok:
            self.dropped += 1
        return ok

    # Timer ----------------------------------------------------------------------------

    def _fresh(self, when, now):
        return when is not None and 0.0 <= now - when <= self.stale_timeout

    def deadman(self, now):
        """The dead-man switch is held and the joystick is alive."""
        return (
            self._pressed
            and self._joy_time is not None
            and 0.0 <= now - self._joy_time <= self.joy_timeout
        )

    def on_timer(self, now):
        """One command tick at time `now` (s): what to publish."""
        if self.tracker is None:
            return self._stop("error" if self.error else "idle")
        safe = (
            self.deadman(now)
            and self._left is not None
            and self._fresh(self._wheel_time, now)
            and self._fresh(self._pose_time, now)
        )
        if not safe:
            self._held = True
            return self._stop("held")
        if self._held:
            # The robot was stopped: its next commands ramp up from rest.
            self.tracker.reset()
            self._held = False
        pose, self._pose = self._pose, None
        try:
            tick = self.tracker.tick(
                now,
                (self._left, self._right),
                pose=pose,
                imu_yaw_rate=self._yaw_rate,
                pose_time=self._pose_stamp if pose is not None else None,
            )
        except drive.DriveError as e:
            self.tracker = None
            self.error = str(e)
            return self._stop("error")
        self.done = tick["done"]
        self._last = (tick["progress_m"], tick["cross_track_m"], 0.0)
        return TrackOutput(
            linear=float(tick["linear"]),
            angular=float(tick["angular"]),
            inputs=tuple(tick["command"]),
            state="done" if tick["done"] else "following",
            progress_m=float(tick["progress_m"]),
            cross_track_m=float(tick["cross_track_m"]),
        )

    def _stop(self, state):
        return TrackOutput(
            linear=0.0,
            angular=0.0,
            inputs=(0.0, 0.0),
            state=state,
            progress_m=float(self._last[0]),
            cross_track_m=float(self._last[1]),
        )
