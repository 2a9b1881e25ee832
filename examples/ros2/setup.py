"""The drive_ros ROS 2 package (ament_python): colcon build, then `ros2 run drive_ros
protocol|track|predict` and `ros2 launch drive_ros drive_<node>.launch.py`. The `drive`
Python package it runs on is installed with pip (pip install drive-ugv)."""

from glob import glob

from setuptools import setup

package_name = "drive_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=[package_name],
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml", "README.md"]),
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="DRIVE framework maintainers",
    maintainer_email="drive@example.org",
    description="The DRIVE protocol, a path follower and a prediction display as ROS 2 nodes",
    license="MIT OR Apache-2.0",
    entry_points={
        "console_scripts": [
            "protocol = drive_ros.protocol_node:main",
            "track = drive_ros.track_node:main",
            "predict = drive_ros.predict_node:main",
        ],
    },
)
