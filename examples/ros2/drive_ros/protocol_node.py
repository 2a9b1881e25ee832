#!/usr/bin/env python3
"""A ROS 2 node that runs the DRIVE protocol on a robot with the `drive` Python package.

    pip install drive-ugv         # or ./python from the repository root, in ROS 2's Python
    ros2 launch drive_ros drive_protocol.launch.py robot:=husky geofence:=20.0
    ros2 run drive_ros protocol --ros-args --params-file config/drive_protocol.yaml

Subscribes (relative names; remap them to your robot's):
  joy_in (sensor_msgs/Joy)                      dead-man button
  wheel_vel_left_measured (std_msgs/Float64)    left wheel velocity (rad/s)
  wheel_vel_right_measured (std_msgs/Float64)   right wheel velocity (rad/s)
  joint_states (sensor_msgs/JointState)         instead, with use_joint_states:=true
                                                (joints left_joint, right_joint)
  odometry_in (nav_msgs/Odometry)               localization (ICP)
Publishes what the DRIVE logger records (drive/pose_cmds_logger_node.py):
  doughnut_cmd_vel (geometry_msgs/Twist)        the command, at the robot's rate
  calib_step (std_msgs/Int32), calib_state (std_msgs/String), drive/joy_switch (std_msgs/Bool)

All the logic is in drive_ros.protocol_logic.ProtocolLogic (tested without ROS); this file
only wires it to topics, parameters and a timer. Spin it with the single-threaded executor
(as main() does): the protocol runner belongs to the thread that made it.

The characterization (step 1) drives straight forward then backward for 8 s each with
twice the robot's top speed commanded, then turns in place: the robot travels about
top speed x 8 s from its start, so a geofence must be larger than that (a Husky: about
8 m; a Warthog: about 40 m), or give the input space in the robot file and set
characterize:=false.
"""

import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import JointState, Joy
from std_msgs.msg import Bool, Float64, Int32, String

from drive_ros.protocol_logic import ProtocolLogic

# Parameters: name -> default (0 / 0.0 for an optional limit means none).
PARAMETERS = {
    "robot": "husky",
    "sampler": "uniform",
    "seed": 0,
    "geofence": 0.0,
    "max_intervals": 0,
    "max_duration": 0.0,
    "characterize": True,
    "stale_timeout": 0.5,
    "deadman_button": 0,
    "deadman_threshold": 0.5,
    "joy_timeout": 0.5,
    "use_joint_states": False,
    "left_joint": "left_wheel",
    "right_joint": "right_wheel",
}


class DriveProtocolNode(Node):
    def __init__(self):
        super().__init__("drive_protocol")
        p = {k: self.declare_parameter(k, v).value for k, v in PARAMETERS.items()}
        for key in ("geofence", "max_intervals", "max_duration"):
            if p[key] < 0:
                raise ValueError(f"parameter {key} must be 0 (none) or positive, got {p[key]}")
        options = {"characterize": p["characterize"], "stale_timeout": p["stale_timeout"]}
        if p["geofence"] > 0:
            options["geofence"] = p["geofence"]
        if p["max_intervals"] > 0:
            options["max_intervals"] = p["max_intervals"]
        if p["max_duration"] > 0:
            options["max_duration"] = p["max_duration"]
        self.logic = ProtocolLogic(
            p["robot"],
            p["sampler"],
            p["seed"],
            deadman_button=p["deadman_button"],
            deadman_threshold=p["deadman_threshold"],
            joy_timeout=p["joy_timeout"],
            left_joint=p["left_joint"],
            right_joint=p["right_joint"],
            **options,
        )
        self.create_subscription(Joy, "joy_in", self.on_joy, 10)
        if p["use_joint_states"]:
            self.create_subscription(JointState, "joint_states", self.logic.on_joint_state, 100)
        else:
            self.create_subscription(Float64, "wheel_vel_left_measured", self.logic.on_left_wheel, 100)
            self.create_subscription(Float64, "wheel_vel_right_measured", self.logic.on_right_wheel, 100)
        self.create_subscription(Odometry, "odometry_in", self.logic.on_odometry, 100)
        self.cmd_pub = self.create_publisher(Twist, "doughnut_cmd_vel", 10)
        self.step_pub = self.create_publisher(Int32, "calib_step", 10)
        self.state_pub = self.create_publisher(String, "calib_state", 10)
        self.joy_pub = self.create_publisher(Bool, "drive/joy_switch", 10)
        self.timer = self.create_timer(1.0 / self.logic.rate_hz, self.on_timer)
        self.last_state = None
        self.get_logger().info(
            f"DRIVE protocol on {self.logic.runner.robot} with the {p['sampler']} sampler "
            f"(seed {p['seed']}): hold the dead-man button to run"
        )

    def now(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def on_joy(self, msg):
        self.logic.on_joy(msg, self.now())

    def on_timer(self):
        out = self.logic.on_timer(self.now())
        cmd = Twist()
        cmd.linear.x = out.linear
        cmd.angular.z = out.angular
        self.cmd_pub.publish(cmd)
        self.step_pub.publish(Int32(data=out.calib_step))
        self.state_pub.publish(String(data=out.calib_state))
        self.joy_pub.publish(Bool(data=out.joy_switch))
        if out.state != self.last_state:
            self.last_state = out.state
            runner = self.logic.runner
            detail = runner.pause_reason or runner.stop_reason or self.logic.error or ""
            self.get_logger().info(f"{out.state} {detail}".strip())
        if self.logic.finished:
            # The zero command of the last tick has been sent.
            self.timer.cancel()
            self.get_logger().info(
                f"protocol ended after {self.logic.runner.completed_intervals} intervals"
            )


def init(args):
    """rclpy.init without rclpy's own SIGINT handler where the distribution allows it, so
    that Ctrl-C reaches main() with the context still valid and the last zero command can
    be published before shutdown."""
    try:
        from rclpy.signals import SignalHandlerOptions

        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except (ImportError, TypeError):
        rclpy.init(args=args)


def spin_then_stop(node, finished=lambda: False):
    """Spins `node` until `finished()` or Ctrl-C, then publishes a last zero Twist on its
    `cmd_pub`, whatever stopped it (when the context still allows it), and shuts down."""
    try:
        while rclpy.ok() and not finished():
            rclpy.spin_once(node, timeout_sec=0.1)
    except KeyboardInterrupt:
        node.get_logger().info("interrupted: stopping the robot")
    finally:
        if rclpy.ok():
            node.cmd_pub.publish(Twist())
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


def main(args=None):
    init(args)
    node = DriveProtocolNode()
    spin_then_stop(node, lambda: node.logic.finished)


if __name__ == "__main__":
    main()
