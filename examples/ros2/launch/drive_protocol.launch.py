"""Launches the DRIVE protocol node (`ros2 run drive_ros protocol`) with its parameters file.

    ros2 launch drive_ros drive_protocol.launch.py robot:=husky sampler:=uniform seed:=0 \
        geofence:=20.0 params_file:=my_robot.yaml joy_topic:=/joy cmd_topic:=/doughnut_cmd_vel

The launch arguments below win over the parameters file (config/drive_protocol.yaml by
default: every parameter, documented). Record what the DRIVE logger records, then
`drive import --bag` (with remapped topics, record those and pass them with `--topic`):
    ros2 bag record -s mcap /calib_step /calib_state /drive/joy_switch /doughnut_cmd_vel \
        /odometry_in /wheel_vel_left_measured /wheel_vel_right_measured /imu_in
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

# Launch arguments that set a parameter: name -> (default, description). The defaults
# are config/drive_protocol.yaml's (checked by .ci/check-ros2).
PARAMETER_ARGUMENTS = {
    "robot": ("husky", "a registered robot (drive list) or a robot TOML file"),
    "sampler": ("uniform", "input sampler: uniform (DRIVE), grid, linear, angular, targeted"),
    "seed": ("0", "seed of the sampler"),
    "geofence": ("0.0", "stop beyond this distance from the start (m); 0 for none"),
}

# Launch arguments that remap a topic: name -> (node's topic, default, description).
TOPIC_ARGUMENTS = {
    "joy_topic": ("joy_in", "/joy", "the joystick's Joy topic"),
    "cmd_topic": ("doughnut_cmd_vel", "/doughnut_cmd_vel", "where the robot takes Twists"),
    "odometry_topic": ("odometry_in", "/odometry_in", "localization (nav_msgs/Odometry)"),
    "left_wheel_topic": ("wheel_vel_left_measured", "/wheel_vel_left_measured", "left wheel velocity (Float64)"),
    "right_wheel_topic": ("wheel_vel_right_measured", "/wheel_vel_right_measured", "right wheel velocity (Float64)"),
    "joint_states_topic": ("joint_states", "/joint_states", "wheel velocities (JointState, use_joint_states: true)"),
}


def generate_launch_description():
    config = os.path.join(get_package_share_directory("drive_ros"), "config", "drive_protocol.yaml")
    arguments = [DeclareLaunchArgument("params_file", default_value=config, description="the parameters file")]
    arguments += [DeclareLaunchArgument(k, default_value=v, description=d) for k, (v, d) in PARAMETER_ARGUMENTS.items()]
    arguments += [DeclareLaunchArgument(k, default_value=v, description=d) for k, (_, v, d) in TOPIC_ARGUMENTS.items()]
    node = Node(
        package="drive_ros",
        executable="protocol",
        name="drive_protocol",
        output="screen",
        parameters=[LaunchConfiguration("params_file"), {k: LaunchConfiguration(k) for k in PARAMETER_ARGUMENTS}],
        remappings=[(topic, LaunchConfiguration(k)) for k, (topic, _, _) in TOPIC_ARGUMENTS.items()],
    )
    return LaunchDescription(arguments + [node])
