"""Launches the path follower (`ros2 run drive_ros track`): a fitted model inside the MPPI
controller of `drive track`, following the last nav_msgs/Path on path_in.

    ros2 launch drive_ros drive_track.launch.py model_file:=model.json robot:=husky speed:=0.5

The launch arguments below win over the parameters file (config/drive_track.yaml by
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
    "robot": ("husky", "a registered robot or a robot TOML file: its limits bound the commands"),
    "speed": ("0.5", "the speed along the path (m/s)"),
}

TOPIC_ARGUMENTS = {
    "path_topic": ("path_in", "/path", "the path to follow (nav_msgs/Path)"),
    "cmd_topic": ("cmd_vel", "/cmd_vel", "where the robot takes Twists"),
    "odometry_topic": ("odometry_in", "/odometry", "localization (nav_msgs/Odometry)"),
    "joint_states_topic": ("joint_states", "/joint_states", "wheel velocities (sensor_msgs/JointState)"),
    "imu_topic": ("imu_in", "/imu", "yaw rate (sensor_msgs/Imu)"),
    "joy_topic": ("joy_in", "/joy", "the joystick's Joy topic"),
}


def generate_launch_description():
    config = os.path.join(get_package_share_directory("drive_ros"), "config", "drive_track.yaml")
    arguments = [DeclareLaunchArgument("params_file", default_value=config, description="the parameters file")]
    arguments += [
        DeclareLaunchArgument(k, description=d) if v is None else DeclareLaunchArgument(k, default_value=v, description=d)
        for k, (v, d) in PARAMETER_ARGUMENTS.items()
    ]
    arguments += [DeclareLaunchArgument(k, default_value=v, description=d) for k, (_, v, d) in TOPIC_ARGUMENTS.items()]
    node = Node(
        package="drive_ros",
        executable="track",
        name="drive_track",
        output="screen",
        parameters=[LaunchConfiguration("params_file"), {k: LaunchConfiguration(k) for k in PARAMETER_ARGUMENTS}],
        remappings=[(topic, LaunchConfiguration(k)) for k, (topic, _, _) in TOPIC_ARGUMENTS.items()],
    )
    return LaunchDescription(arguments + [node])
