"""The logic of the prediction node, without ROS: what `predict_node.py` wires to topics
and a timer. A fitted model (a `drive train` model file) predicts where the robot will be
over the next seconds if it keeps the current command, from what it measures now, with
the 95% region of each predicted position: what a planner or an operator looks at in
RViz or Foxglove to see how far to trust the model.

Messages are read by attribute, as the ROS 2 message classes lay them out:
  Odometry (nav_msgs)      .header.frame_id, .pose.pose.position/orientation,
                           .twist.twist.linear (the body velocity, for models fitted with
                           the localization's start velocity)
  JointState (sensor_msgs) .name, .velocity; or Float64 (std_msgs) .data per wheel
  Imu (sensor_msgs)        .angular_velocity.z
  Twist (geometry_msgs)    .linear.x, .angular.z: the command being sent to the robot
"""

import math
from dataclasses import dataclass, field

import numpy as np

import drive
from drive_ros.protocol_logic import joint_velocities, yaw_of

# The 95% quantile of the chi-square distribution with 2 degrees of freedom: a position
# error d with covariance S lies inside d' S^-1 d <= this with probability 0.95.
CHI2_2_95 = 5.991464547107979


@dataclass(frozen=True)
class Ellipse:
    """The 95% region of one predicted position."""

    t: float  # time ahead of now (s)
    x: float  # centre (m), in the odometry's frame
    y: float
    major: float  # semi-axes (m)
    minor: float
    angle: float  # direction of the major axis (rad, from x)

    def outline(self, points=24):
        """(x, y) points around the ellipse, the first repeated last (a closed line)."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        out = []
        for k in range(points + 1):
            a = 2.0 * math.pi * k / points
            u, v = self.major * math.cos(a), self.minor * math.sin(a)
            out.append((self.x + c * u - s * v, self.y + s * u + c * v))
        return out


@dataclass(frozen=True)
class Prediction:
    """What the node publishes at one timer tick."""

    frame_id: str
    poses: list  # (x, y, yaw) at 0, dt, ..., horizon s ahead: row 0 is the pose now
    dt: float
    ellipses: list = field(default_factory=list)  # at every `ellipse_every` step and the last
    command: tuple = (0.0, 0.0)  # the inputs held over the horizon


def ellipse_of(t, x, y, cov):
    """The 95% ellipse of a position with 2x2 covariance `cov`."""
    values, vectors = np.linalg.eigh(np.asarray(cov, dtype=float))
    values = np.clip(values, 0.0, None)
    major_axis = vectors[:, 1]
    return Ellipse(
        t=float(t),
        x=float(x),
        y=float(y),
        major=float(math.sqrt(CHI2_2_95 * values[1])),
        minor=float(math.sqrt(CHI2_2_95 * values[0])),
        angle=float(math.atan2(major_axis[1], major_axis[0])),
    )


class PredictLogic:
    """Predictions of a fitted model for the command being sent: feed it messages as they
    arrive and call `on_timer(now)`; publish what it returns (None while the pose, the
    wheels or, for a model fitted with them, the IMU or the localization's velocity are
    missing or older than `stale_timeout` s).

    The command is the last Twist on cmd_vel, held for `horizon` s (zero once it is older
    than `command_timeout` s, as a robot driver stops on a silent command topic).
    """

    def __init__(
        self,
        model_file,
        *,
        horizon=2.0,
        ellipse_every=5,
        left_joint="left_wheel",
        right_joint="right_wheel",
        stale_timeout=0.5,
        command_timeout=0.5,
    ):
        for name, value in (
            ("horizon", horizon),
            ("stale_timeout", stale_timeout),
            ("command_timeout", command_timeout),
        ):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if not (isinstance(ellipse_every, int) and ellipse_every >= 1):
            raise ValueError(f"ellipse_every must be a whole number of steps, at least 1, got {ellipse_every!r}")
        self.model = drive.load_model(model_file)
        self.steps = max(1, int(round(horizon / self.model.dt)))
        self.ellipse_every = ellipse_every
        self.left_joint, self.right_joint = str(left_joint), str(right_joint)
        self.stale_timeout = float(stale_timeout)
        self.command_timeout = float(command_timeout)
        self.uses_imu = self.model.start in ("encoders+imu", "encoders+imu+localization")
        self.uses_velocity = self.model.start == "encoders+imu+localization"
        try:
            self.model.predict(np.zeros((2, 2)), return_cov=True)
            self.has_covariance = True
        except drive.DriveError:
            self.has_covariance = False
        self.error = None
        self.dropped = 0
        self._pose = self._pose_time = self._velocity = None
        self._frame_id = ""
        self._wheels = self._wheel_time = None
        self._left = self._right = None
        self._yaw_rate = self._imu_time = None
        self._command = (0.0, 0.0)
        self._command_time = None

    def _finite(self, *values):
        ok = all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)
        if not ok:
            self.dropped += 1
        return ok

    # Subscriptions --------------------------------------------------------------------

    def on_odometry(self, msg, now):
        """The localization: pose, frame, and body velocity."""
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        if not (self._finite(p.x, p.y, q.x, q.y, q.z, q.w) and (q.x, q.y, q.z, q.w) != (0, 0, 0, 0)):
            return
        self._pose = (float(p.x), float(p.y), yaw_of(q))
        self._pose_time = now
        self._frame_id = str(getattr(getattr(msg, "header", None), "frame_id", "") or "")
        twist = getattr(getattr(msg, "twist", None), "twist", None)
        if twist is not None and self._finite(twist.linear.x, twist.linear.y):
            self._velocity = (float(twist.linear.x), float(twist.linear.y))

    def on_joint_state(self, msg, now):
        """Both wheels' velocities from a JointState, by joint name."""
        values = joint_velocities(msg, self.left_joint, self.right_joint)
        if values is not None and self._finite(*values):
            self._wheels, self._wheel_time = (float(values[0]), float(values[1])), now

    def on_left_wheel(self, msg, now):
        """The left wheel's velocity (Float64, rad/s)."""
        if self._finite(msg.data):
            self._left = float(msg.data)
            self._pair(now)

    def on_right_wheel(self, msg, now):
        """The right wheel's velocity (Float64, rad/s)."""
        if self._finite(msg.data):
            self._right = float(msg.data)
            self._pair(now)

    def _pair(self, now):
        if self._left is not None and self._right is not None:
            self._wheels, self._wheel_time = (self._left, self._right), now

    def on_imu(self, msg, now):
        """The IMU's yaw rate (Imu.angular_velocity.z)."""
        if self._finite(msg.angular_velocity.z):
            self._yaw_rate, self._imu_time = float(msg.angular_velocity.z), now

    def on_cmd_vel(self, msg, now):
        """The command sent to the robot (Twist: linear.x m/s, angular.z rad/s)."""
        if self._finite(msg.linear.x, msg.angular.z):
            try:
                self._command = self.model.input_for(float(msg.linear.x), float(msg.angular.z))
                self._command_time = now
            except drive.DriveError as e:
                self.error = str(e)

    # Timer ----------------------------------------------------------------------------

    def _fresh(self, when, now):
        return when is not None and 0.0 <= now - when <= self.stale_timeout

    def on_timer(self, now):
        """The prediction from the measurements at `now` (s), or None when they are
        missing or stale."""
        if not (self._fresh(self._pose_time, now) and self._fresh(self._wheel_time, now)):
            return None
        if self.uses_imu and not self._fresh(self._imu_time, now):
            return None
        if self.uses_velocity and self._velocity is None:
            return None
        command = self._command
        if self._command_time is None or not (0.0 <= now - self._command_time <= self.command_timeout):
            command = (0.0, 0.0)
        # steps + 1 commands give the poses at 0, dt, ..., steps * dt (row k follows
        # commands 0..k-1; the last command changes no row).
        commands = np.tile(np.asarray(command, dtype=float), (self.steps + 1, 1))
        kwargs = {"start": self._pose, "start_wheels": self._wheels}
        if self.uses_imu:
            kwargs["start_yaw_rate"] = self._yaw_rate
        if self.uses_velocity:
            kwargs["start_velocity"] = self._velocity
        try:
            if self.has_covariance:
                poses, cov = self.model.predict(commands, return_cov=True, **kwargs)
            else:
                poses, cov = self.model.predict(commands, **kwargs), None
        except drive.DriveError as e:
            self.error = str(e)
            return None
        self.error = None
        dt = self.model.dt
        ellipses = []
        if cov is not None:
            last = len(poses) - 1
            for k in range(1, len(poses)):
                if k % self.ellipse_every == 0 or k == last:
                    ellipses.append(ellipse_of(k * dt, poses[k, 0], poses[k, 1], cov[k, :2, :2]))
        return Prediction(
            frame_id=self._frame_id,
            poses=[tuple(float(v) for v in row) for row in poses],
            dt=dt,
            ellipses=ellipses,
            command=tuple(float(c) for c in command),
        )
