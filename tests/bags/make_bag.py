#!/usr/bin/env python3
"""Writes a DRIVE logger CSV (the raw log `drive import --raw` reads) as a rosbag2 recording
in MCAP storage, with the independent `rosbags` library (no ROS needed): what the DRIVE
logger's subscriptions would have received during that run.

    python make_bag.py RAW.csv OUT_BAG_DIR [--variant logger|stamped-joints]

At every row of the log: the command (geometry_msgs/Twist on /doughnut_cmd_vel), both
encoder velocities (std_msgs/Float64 on /wheel_vel_left_measured and
/wheel_vel_right_measured) and the IMU (sensor_msgs/Imu on /imu_in); the odometry
(nav_msgs/Odometry on /odometry_in) when icp_index changes, i.e. at the localization's own
rate; calib_step (std_msgs/Int32), calib_state (std_msgs/String) and the joystick switch
(std_msgs/Bool on /drive/joy_switch) when they change. Each message's receive time is its
row's ros_time. The `stamped-joints` variant publishes the command as
geometry_msgs/TwistStamped on /cmd_vel and the encoders as one sensor_msgs/JointState on
/joint_states (joints left_wheel_joint, right_wheel_joint), as many robots do.

`drive import --bag OUT_BAG_DIR` must then cut the same windows as `drive import --raw
RAW.csv` (tests/integration/bags.rs, python/tests).
"""

import argparse
import csv
import sys

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore


def rows_of(path):
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            # The logger's placeholder row (all zeros before the first message) is skipped,
            # as drive import --raw skips it.
            if float(row["ros_time"]) == 0.0:
                continue
            yield row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("raw")
    parser.add_argument("out")
    parser.add_argument("--variant", choices=["logger", "stamped-joints"], default="logger")
    args = parser.parse_args()

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    Header, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    Vector3, Point = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Point"]
    Quaternion, Pose = T["geometry_msgs/msg/Quaternion"], T["geometry_msgs/msg/Pose"]
    Twist = T["geometry_msgs/msg/Twist"]

    def header(ns):
        return Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id="base_link")

    stamped = args.variant == "stamped-joints"
    topics = {
        "step": ("/calib_step", "std_msgs/msg/Int32"),
        "state": ("/calib_state", "std_msgs/msg/String"),
        "joy": ("/drive/joy_switch", "std_msgs/msg/Bool"),
        "odom": ("/odometry_in", "nav_msgs/msg/Odometry"),
        "imu": ("/imu_in", "sensor_msgs/msg/Imu"),
    }
    if stamped:
        topics["cmd"] = ("/cmd_vel", "geometry_msgs/msg/TwistStamped")
        topics["joints"] = ("/joint_states", "sensor_msgs/msg/JointState")
    else:
        topics["cmd"] = ("/doughnut_cmd_vel", "geometry_msgs/msg/Twist")
        topics["left"] = ("/wheel_vel_left_measured", "std_msgs/msg/Float64")
        topics["right"] = ("/wheel_vel_right_measured", "std_msgs/msg/Float64")

    with Writer(args.out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = {k: writer.add_connection(name, ty, typestore=ts) for k, (name, ty) in topics.items()}

        def write(key, ns, msg):
            writer.write(conn[key], ns, ts.serialize_cdr(msg, topics[key][1]))

        last = {}
        count = 0
        for row in rows_of(args.raw):
            ns = int(row["ros_time"])
            f = lambda c: float(row[c])
            for key, value, make in [
                ("step", int(float(row["calib_step"])), lambda v: T["std_msgs/msg/Int32"](data=v)),
                ("state", row["calib_state"], lambda v: T["std_msgs/msg/String"](data=v)),
                ("joy", row["joy_switch"] in ("True", "true", "1", "1.0"), lambda v: T["std_msgs/msg/Bool"](data=v)),
                ("odom", row["icp_index"], None),
            ]:
                if last.get(key) == value:
                    continue
                last[key] = value
                if key == "odom":
                    pose = Pose(
                        position=Point(x=f("icp_pos_x"), y=f("icp_pos_y"), z=f("icp_pos_z")),
                        orientation=Quaternion(x=f("icp_quat_x"), y=f("icp_quat_y"), z=f("icp_quat_z"), w=f("icp_quat_w")),
                    )
                    zero = Twist(linear=Vector3(x=0.0, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0))
                    msg = T["nav_msgs/msg/Odometry"](
                        header=header(ns),
                        child_frame_id="base_link",
                        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=zero, covariance=np.zeros(36)),
                    )
                else:
                    msg = make(value)
                write(key, ns, msg)
            accel = [float(row.get(f"imu_acceleration_{a}") or 0.0) for a in "xyz"]
            write("imu", ns, T["sensor_msgs/msg/Imu"](
                header=header(ns),
                orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.zeros(9),
                angular_velocity=Vector3(x=f("imu_x"), y=f("imu_y"), z=f("imu_z")),
                angular_velocity_covariance=np.zeros(9),
                linear_acceleration=Vector3(x=accel[0], y=accel[1], z=accel[2]),
                linear_acceleration_covariance=np.zeros(9),
            ))
            if stamped:
                write("joints", ns, T["sensor_msgs/msg/JointState"](
                    header=header(ns),
                    name=["left_wheel_joint", "right_wheel_joint"],
                    position=np.zeros(2),
                    velocity=np.array([f("meas_left_vel"), f("meas_right_vel")]),
                    effort=np.zeros(0),
                ))
            else:
                write("left", ns, T["std_msgs/msg/Float64"](data=f("meas_left_vel")))
                write("right", ns, T["std_msgs/msg/Float64"](data=f("meas_right_vel")))
            twist = Twist(linear=Vector3(x=f("cmd_vel_x"), y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=f("cmd_vel_omega")))
            if stamped:
                write("cmd", ns, T["geometry_msgs/msg/TwistStamped"](header=header(ns), twist=twist))
            else:
                write("cmd", ns, twist)
            count += 1
    print(f"{count} rows written to {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
