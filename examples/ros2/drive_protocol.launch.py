"""Launches the DRIVE protocol node (drive_protocol_node.py beside this file).

    ros2 launch examples/ros2/drive_protocol.launch.py robot:=husky sampler:=uniform \
        seed:=0 geofence:=20.0 joy_topic:=/joy cmd_topic:=/doughnut_cmd_vel

Record what the DRIVE logger records (then `drive import --bag`; with remapped topics,
record those and pass them with `--topic`):
    ros2 bag record -s mcap /calib_step /calib_state /drive/joy_switch /doughnut_cmd_vel \
        /odometry_in /wheel_vel_left_measured /wheel_vel_right_measured /imu_in
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration

HERE = os.path.dirname(os.path.abspath(__file__))

ARGUMENTS = {
    "robot": ("husky", "a registered robot (drive list) or a robot TOML file"),
    "sampler": ("uniform", "input sampler: uniform (DRIVE), grid, linear, angular, targeted"),
    "seed": ("0", "seed of the sampler"),
    "geofence": ("20.0", "stop beyond this distance from the start (m); 0 for none"),
    "max_intervals": ("0", "stop after this many 6 s intervals; 0 for none"),
    "max_duration": ("0.0", "stop after this many seconds; 0 for none"),
    "characterize": ("true", "find the input space first (false: the robot file's, or its nominal one)"),
    "stale_timeout": ("0.5", "pause when encoders or odometry are older than this (s)"),
    "deadman_button": ("0", "index of the dead-man button in the Joy message"),
    "deadman_threshold": ("0.5", "the button counts as held at or above this value"),
    "joy_timeout": ("0.5", "a joystick silent this long (s) counts as released"),
    "joy_topic": ("/joy", "the joystick's Joy topic"),
    "cmd_topic": ("/doughnut_cmd_vel", "where the robot (or its command mux) takes Twists"),
    "odometry_topic": ("/odometry_in", "localization (nav_msgs/Odometry)"),
    "left_wheel_topic": ("/wheel_vel_left_measured", "left wheel velocity (Float64, rad/s)"),
    "right_wheel_topic": ("/wheel_vel_right_measured", "right wheel velocity (Float64, rad/s)"),
}

PARAMETERS = ["robot", "sampler", "seed", "geofence", "max_intervals", "max_duration",
              "characterize", "stale_timeout", "deadman_button", "deadman_threshold",
              "joy_timeout"]


def generate_launch_description():
    arg = LaunchConfiguration
    node = ExecuteProcess(
        cmd=[
            "python3", os.path.join(HERE, "drive_protocol_node.py"), "--ros-args",
            *[x for name in PARAMETERS for x in ("-p", [name, ":=", arg(name)])],
            "-r", ["joy_in:=", arg("joy_topic")],
            "-r", ["doughnut_cmd_vel:=", arg("cmd_topic")],
            "-r", ["odometry_in:=", arg("odometry_topic")],
            "-r", ["wheel_vel_left_measured:=", arg("left_wheel_topic")],
            "-r", ["wheel_vel_right_measured:=", arg("right_wheel_topic")],
        ],
        output="screen",
    )
    return LaunchDescription(
        [DeclareLaunchArgument(k, default_value=v, description=d) for k, (v, d) in ARGUMENTS.items()]
        + [node]
    )
