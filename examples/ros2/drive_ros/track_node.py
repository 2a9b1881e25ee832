#!/usr/bin/env python3
"""A ROS 2 node that follows a nav_msgs/Path with a fitted motion model inside the MPPI
controller of `drive track`.

    pip install drive-ugv         # or ./python from the repository root, in ROS 2's Python
    drive train --data run.csv --model slip-blr --out model.json
    ros2 run drive_ros track --ros-args -p model_file:=model.json -p robot:=husky -p speed:=0.5
    ros2 launch drive_ros drive_track.launch.py model_file:=model.json

Subscribes (relative names; remap them to your robot's):
  path_in (nav_msgs/Path)                       the path to follow (a new one replaces it)
  joint_states (sensor_msgs/JointState)         wheel velocities by joint name (rad/s), or
  wheel_vel_left_measured, wheel_vel_right_measured (std_msgs/Float64) with use_joint_states:=false
  odometry_in (nav_msgs/Odometry)               localization (the frame the path is in)
  imu_in (sensor_msgs/Imu)                      yaw rate (for models fitted with the IMU)
  joy_in (sensor_msgs/Joy)                      dead-man button
Publishes:
  cmd_vel (geometry_msgs/Twist)                 the command, at the model's rate (20 Hz)
  track/cross_track (std_msgs/Float64)          distance from the path (m, positive left)

All the logic is in drive_ros.track_logic.TrackLogic (tested without ROS); this file only
wires it to topics, parameters and a timer. Spin it with the single-threaded executor (as
main() does): the tracker belongs to the thread that made it.
"""

import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState, Joy
from std_msgs.msg import Float64

from drive_ros.protocol_node import init, spin_then_stop
from drive_ros.track_logic import TrackLogic

# Parameters: name -> default.
PARAMETERS = {
    "model_file": "",
    "robot": "husky",
    "speed": 0.5,
    "start": "encoders+imu",
    "samples": 1024,
    "horizon": 40,
    "temperature": 0.1,
    "history": -1.0,
    "use_joint_states": True,
    "left_joint": "left_wheel",
    "right_joint": "right_wheel",
    "deadman_button": 0,
    "deadman_threshold": 0.5,
    "joy_timeout": 0.5,
    "stale_timeout": 0.5,
}


class DriveTrackNode(Node):
    def __init__(self):
        super().__init__("drive_track")
        p = {k: self.declare_parameter(k, v).value for k, v in PARAMETERS.items()}
        if not p["model_file"]:
            raise ValueError("parameter model_file is required (a `drive train` model file)")
        self.logic = TrackLogic(
            p["model_file"],
            p["robot"],
            p["speed"],
            left_joint=p["left_joint"],
            right_joint=p["right_joint"],
            start=p["start"],
            samples=p["samples"],
            horizon=p["horizon"],
            temperature=p["temperature"],
            history=p["history"],
            deadman_button=p["deadman_button"],
            deadman_threshold=p["deadman_threshold"],
            joy_timeout=p["joy_timeout"],
            stale_timeout=p["stale_timeout"],
        )
        self.create_subscription(Path, "path_in", self.logic.on_path, 1)
        if p["use_joint_states"]:
            self.create_subscription(JointState, "joint_states", self.on_joint_state, 100)
        else:
            self.create_subscription(Float64, "wheel_vel_left_measured", self.on_left, 100)
            self.create_subscription(Float64, "wheel_vel_right_measured", self.on_right, 100)
        self.create_subscription(Odometry, "odometry_in", self.on_odometry, 100)
        self.create_subscription(Imu, "imu_in", self.logic.on_imu, 100)
        self.create_subscription(Joy, "joy_in", self.on_joy, 10)
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.cross_pub = self.create_publisher(Float64, "track/cross_track", 10)
        self.timer = self.create_timer(1.0 / self.logic.rate_hz, self.on_timer)
        self.last_state = None
        self.get_logger().info(
            f"following paths on path_in with {self.logic.model.name} at {p['speed']} m/s: "
            "hold the dead-man button to move"
        )

    def now(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def on_joint_state(self, msg):
        self.logic.on_joint_state(msg, self.now())

    def on_left(self, msg):
        self.logic.on_left_wheel(msg, self.now())

    def on_right(self, msg):
        self.logic.on_right_wheel(msg, self.now())

    def on_odometry(self, msg):
        self.logic.on_odometry(msg, self.now())

    def on_joy(self, msg):
        self.logic.on_joy(msg, self.now())

    def on_timer(self):
        out = self.logic.on_timer(self.now())
        cmd = Twist()
        cmd.linear.x = out.linear
        cmd.angular.z = out.angular
        self.cmd_pub.publish(cmd)
        self.cross_pub.publish(Float64(data=out.cross_track_m))
        if out.state != self.last_state:
            self.last_state = out.state
            self.get_logger().info(f"{out.state} {self.logic.error or ''}".strip())


def main(args=None):
    init(args)
    spin_then_stop(DriveTrackNode())


if __name__ == "__main__":
    main()
