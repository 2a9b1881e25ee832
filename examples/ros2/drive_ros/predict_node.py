#!/usr/bin/env python3
"""A ROS 2 node that shows what a fitted motion model predicts for the command being sent:
the predicted path over the next seconds and the 95% region of each predicted position,
for RViz or Foxglove.

    pip install drive-ugv         # or ./python from the repository root, in ROS 2's Python
    drive train --data run.csv --model slip-blr --out model.json
    ros2 run drive_ros predict --ros-args -p model_file:=model.json
    ros2 launch drive_ros drive_predict.launch.py model_file:=model.json

Subscribes (relative names; remap them to your robot's):
  odometry_in (nav_msgs/Odometry)               localization: the start pose and frame
  joint_states (sensor_msgs/JointState)         wheel velocities by joint name (rad/s), or
  wheel_vel_left_measured, wheel_vel_right_measured (std_msgs/Float64) with use_joint_states:=false
  imu_in (sensor_msgs/Imu)                      yaw rate (for models fitted with the IMU)
  cmd_vel_in (geometry_msgs/Twist)              the command being sent to the robot
Publishes, at `rate` Hz:
  predicted_path (nav_msgs/Path)                poses at 0, dt, ..., horizon s ahead
  predicted_ellipses (visualization_msgs/MarkerArray)  95% regions, one closed line each

All the logic is in drive_ros.predict_logic.PredictLogic (tested without ROS); this file
only wires it to topics, parameters and a timer.
"""

import math

import rclpy
from geometry_msgs.msg import Point, PoseStamped, Twist
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Float64
from visualization_msgs.msg import Marker, MarkerArray

from drive_ros.predict_logic import PredictLogic

# Parameters: name -> default.
PARAMETERS = {
    "model_file": "",
    "horizon": 2.0,
    "rate": 10.0,
    "ellipse_every": 5,
    "use_joint_states": True,
    "left_joint": "left_wheel",
    "right_joint": "right_wheel",
    "stale_timeout": 0.5,
    "command_timeout": 0.5,
    "frame_id": "",
}


class DrivePredictNode(Node):
    def __init__(self):
        super().__init__("drive_predict")
        p = {k: self.declare_parameter(k, v).value for k, v in PARAMETERS.items()}
        if not p["model_file"]:
            raise ValueError("parameter model_file is required (a `drive train` model file)")
        if not (p["rate"] > 0 and math.isfinite(p["rate"])):
            raise ValueError(f"parameter rate must be a positive number of Hz, got {p['rate']}")
        self.logic = PredictLogic(
            p["model_file"],
            horizon=p["horizon"],
            ellipse_every=p["ellipse_every"],
            left_joint=p["left_joint"],
            right_joint=p["right_joint"],
            stale_timeout=p["stale_timeout"],
            command_timeout=p["command_timeout"],
        )
        self.frame_id = p["frame_id"]
        self.create_subscription(Odometry, "odometry_in", self.on_odometry, 100)
        if p["use_joint_states"]:
            self.create_subscription(JointState, "joint_states", self.on_joint_state, 100)
        else:
            self.create_subscription(Float64, "wheel_vel_left_measured", self.on_left, 100)
            self.create_subscription(Float64, "wheel_vel_right_measured", self.on_right, 100)
        self.create_subscription(Imu, "imu_in", self.on_imu, 100)
        self.create_subscription(Twist, "cmd_vel_in", self.on_cmd_vel, 10)
        self.path_pub = self.create_publisher(Path, "predicted_path", 10)
        self.ellipse_pub = self.create_publisher(MarkerArray, "predicted_ellipses", 10)
        self.timer = self.create_timer(1.0 / p["rate"], self.on_timer)
        self.get_logger().info(
            f"predicting {p['horizon']} s ahead with {self.logic.model.name} "
            f"({'with' if self.logic.has_covariance else 'without'} 95% regions)"
        )

    def now(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def on_odometry(self, msg):
        self.logic.on_odometry(msg, self.now())

    def on_joint_state(self, msg):
        self.logic.on_joint_state(msg, self.now())

    def on_left(self, msg):
        self.logic.on_left_wheel(msg, self.now())

    def on_right(self, msg):
        self.logic.on_right_wheel(msg, self.now())

    def on_imu(self, msg):
        self.logic.on_imu(msg, self.now())

    def on_cmd_vel(self, msg):
        self.logic.on_cmd_vel(msg, self.now())

    def on_timer(self):
        prediction = self.logic.on_timer(self.now())
        if prediction is None:
            return
        stamp = self.get_clock().now().to_msg()
        frame = self.frame_id or prediction.frame_id
        path = Path()
        path.header.frame_id = frame
        path.header.stamp = stamp
        for x, y, yaw in prediction.poses:
            pose = PoseStamped()
            pose.header.frame_id = frame
            pose.header.stamp = stamp
            pose.pose.position.x, pose.pose.position.y = x, y
            pose.pose.orientation.z, pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            path.poses.append(pose)
        self.path_pub.publish(path)
        markers = MarkerArray()
        clear = Marker()
        clear.action = Marker.DELETEALL
        markers.markers.append(clear)
        for i, ellipse in enumerate(prediction.ellipses):
            m = Marker()
            m.header.frame_id = frame
            m.header.stamp = stamp
            m.ns = "drive_95"
            m.id = i
            m.type = Marker.LINE_STRIP
            m.action = Marker.ADD
            m.pose.orientation.w = 1.0
            m.scale.x = 0.02
            m.color.r, m.color.g, m.color.b, m.color.a = 1.0, 0.5, 0.0, 0.9
            m.points = [Point(x=px, y=py, z=0.0) for px, py in ellipse.outline()]
            markers.markers.append(m)
        self.ellipse_pub.publish(markers)


def main(args=None):
    rclpy.init(args=args)
    node = DrivePredictNode()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == "__main__":
    main()
