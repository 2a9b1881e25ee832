"""Launches the prediction display (`ros2 run drive_ros predict`): a fitted model's
predicted path and 95% regions for the command being sent, for RViz or Foxglove.

    ros2 launch drive_ros drive_predict.launch.py model_file:=model.json cmd_topic:=/cmd_vel

The launch arguments below win over the parameters file (config/drive_predict.yaml by
default: every parameter, documented).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PARAMETER_ARGUMENTS = {
    "model_file": (None, "a model file of drive train (required: no default)"),
    "horizon": ("2.0", "how far ahead to predict (s)"),
}

TOPIC_ARGUMENTS = {
    "cmd_topic": ("cmd_vel_in", "/cmd_vel", "the command being sent (geometry_msgs/Twist)"),
    "odometry_topic": ("odometry_in", "/odometry", "localization (nav_msgs/Odometry)"),
    "joint_states_topic": ("joint_states", "/joint_states", "wheel velocities (sensor_msgs/JointState)"),
    "imu_topic": ("imu_in", "/imu", "yaw rate (sensor_msgs/Imu)"),
}


def generate_launch_description():
    config = os.path.join(get_package_share_directory("drive_ros"), "config", "drive_predict.yaml")
    arguments = [DeclareLaunchArgument("params_file", default_value=config, description="the parameters file")]
    arguments += [
        DeclareLaunchArgument(k, description=d) if v is None else DeclareLaunchArgument(k, default_value=v, description=d)
        for k, (v, d) in PARAMETER_ARGUMENTS.items()
    ]
    arguments += [DeclareLaunchArgument(k, default_value=v, description=d) for k, (_, v, d) in TOPIC_ARGUMENTS.items()]
    node = Node(
        package="drive_ros",
        executable="predict",
        name="drive_predict",
        output="screen",
        parameters=[LaunchConfiguration("params_file"), {k: LaunchConfiguration(k) for k in PARAMETER_ARGUMENTS}],
        remappings=[(topic, LaunchConfiguration(k)) for k, (topic, _, _) in TOPIC_ARGUMENTS.items()],
    )
    return LaunchDescription(arguments + [node])
