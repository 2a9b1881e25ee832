"""The closed loop from Python: `drive.Tracker` (a fitted model inside the MPPI controller of
`drive track`) on a small simulated robot, its errors, and the ROS 2 path-following node
(examples/ros2/drive_ros/track_*.py) with fake messages and a fake rclpy."""

import importlib
import math
import sys
import types
from pathlib import Path as FsPath
from types import SimpleNamespace as NS

import numpy as np
import pytest

import drive

ROS2 = FsPath(__file__).resolve().parents[2] / "examples" / "ros2"


sys.path.insert(0, str(ROS2))


def load(name):
    """The module drive_ros.NAME of the ROS 2 package, executed afresh (with the fake ROS
    modules of the test that asks, if any)."""
    for module in [m for m in sys.modules if m.startswith("drive_ros.")]:
        del sys.modules[module]
    return importlib.import_module(f"drive_ros.{name}")


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    """The naive model of the bundled Husky run (the stand-in robot below has no slip),
    saved as `drive train` saves it."""
    path = tmp_path_factory.mktemp("track") / "naive.json"
    drive.fit(drive.load_dataset(), "naive", split=0.5).save(path)
    return path


class Wheels:
    """A Husky-like skid-steer on a stand-in ground: each wheel follows its command with a
    first-order lag; the body moves as the ideal differential drive (radius 0.165 m,
    baseline 0.55 m, the bundled data's geometry)."""

    r, b, dt = 0.165, 0.55, 0.05

    def __init__(self):
        self.wl = self.wr = 0.0
        self.x = self.y = self.yaw = 0.0

    def advance(self, left, right):
        self.wl += 0.4 * (left - self.wl)
        self.wr += 0.4 * (right - self.wr)
        v = self.r * (self.wl + self.wr) / 2
        w = self.r * (self.wr - self.wl) / self.b
        self.x += v * math.cos(self.yaw) * self.dt
        self.y += v * math.sin(self.yaw) * self.dt
        self.yaw += w * self.dt

    @property
    def yaw_rate(self):
        return self.r * (self.wr - self.wl) / self.b


def circle(radius, n=100):
    a = np.linspace(0.0, 2 * math.pi, n)
    return np.stack([radius * np.sin(a), radius * (1 - np.cos(a))], axis=1)


def test_the_tracker_follows_a_circle_to_its_end(model_file):
    model = drive.load_model(model_file)
    tracker = drive.Tracker(model, "husky", circle(2.0), 0.4, samples=256)
    assert tracker.length == pytest.approx(4 * math.pi, rel=1e-3)
    robot = Wheels()
    worst = 0.0
    for k in range(1200):
        fix = (robot.x, robot.y, robot.yaw) if k % 2 == 0 else None
        tick = tracker.tick(k * 0.05, (robot.wl, robot.wr), pose=fix, imu_yaw_rate=robot.yaw_rate)
        if tick["done"]:
            break
        left, right = tick["command"]
        # The body velocity the command asks for, as a Twist would carry it.
        assert tick["linear"] == pytest.approx(0.165 * (left + right) / 2)
        assert tick["angular"] == pytest.approx(0.165 * (right - left) / 0.55)
        robot.advance(left, right)
        worst = max(worst, abs(math.hypot(robot.x, robot.y - 2.0) - 2.0))
    assert tick["done"], f"not done after {k} ticks at {tick['progress_m']} m"
    assert worst < 0.25
    # Done: the commands stop the robot within its acceleration limit (1 m/s^2: 0.05 m/s,
    # about 0.3 rad/s of wheel speed, per tick).
    speeds = []
    for j in range(40):
        tick = tracker.tick((k + 1 + j) * 0.05, (robot.wl, robot.wr), pose=None)
        assert tick["done"]
        speeds.append(tick["linear"])
        robot.advance(*tick["command"])
    assert all(b <= a + 1e-9 for a, b in zip(speeds, speeds[1:]))
    assert all(a - b <= 0.05 + 1e-9 for a, b in zip(speeds, speeds[1:]))
    assert tick["command"] == pytest.approx((0.0, 0.0), abs=1e-9)


def test_a_tracker_of_another_geometry_warns_with_the_difference(model_file):
    """A Husky model driving the Warthog is driven as it is, with the geometries' difference
    said (drive track --models FILE notes it); on its own robot, no warning."""
    import warnings

    model = drive.load_model(model_file)
    with pytest.warns(UserWarning, match=r"fitted for the geometry of .*, not for that of the robot 'warthog' \(.*baseline 0.55 -> "):
        drive.Tracker(model, "warthog", "line", 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        drive.Tracker(model, "husky", "line", 0.5)


def test_a_fix_stamped_on_another_clock_is_a_drive_error(model_file):
    """A pose_time a second or more after the tick's t (another clock) was taken as now."""
    tracker = drive.Tracker(drive.load_model(model_file), "husky", "line", 0.5)
    tracker.tick(10.0, (0.0, 0.0), pose=(0.0, 0.0, 0.0), pose_time=9.95)
    with pytest.raises(drive.DriveError, match=r"100 s after the tick's t = 10"):
        tracker.tick(10.05, (0.0, 0.0), pose=(0.0, 0.0, 0.0), pose_time=110.05)


def test_tracker_errors_are_drive_errors(model_file):
    model = drive.load_model(model_file)
    # Issue 63, a fourth sweep: a pose, wheels or IMU beyond 1e9 gave a command without a
    # word; they are refused as the readers refuse them, and a plausible tick still runs.
    tracker = drive.Tracker(model, "husky", "line", 0.5, samples=64)
    for bad in [dict(pose=(1e12, 0.0, 0.0)), dict(inputs=(1e12, 0.0)), dict(imu_yaw_rate=1e12)]:
        tick = dict(t=0.05, inputs=(0.0, 0.0), pose=(0.0, 0.0, 0.0))
        tick.update(bad)
        with pytest.raises(drive.DriveError, match="beyond what the readers take"):
            tracker.tick(**tick)
    tracker.tick(t=0.05, inputs=(0.0, 0.0), pose=(0.0, 0.0, 0.0))
    with pytest.raises(drive.DriveError, match="distinct point"):
        drive.Tracker(model, "husky", np.array([[1.0, 1.0], [1.0, 1.0]]), 0.5)
    with pytest.raises(drive.DriveError, match="finite"):
        drive.Tracker(model, "husky", np.array([[0.0, 0.0], [np.nan, 1.0]]), 0.5)
    with pytest.raises(drive.DriveError, match=r"\(N, 2\)"):
        drive.Tracker(model, "husky", np.zeros((4, 3)), 0.5)
    with pytest.raises(drive.DriveError, match="unknown path"):
        drive.Tracker(model, "husky", "spiral", 0.5)
    with pytest.raises(drive.DriveError, match="speed"):
        drive.Tracker(model, "husky", "line", -1.0)
    with pytest.raises(drive.DriveError, match="'ackermann'"):
        drive.Tracker(model, "autorally", "line", 0.5)
    with pytest.raises(drive.DriveError, match="drive.Model"):
        drive.Tracker("slip-blr", "husky", "line", 0.5)
    with pytest.raises(drive.DriveError, match="samples"):
        drive.Tracker(model, "husky", "line", 0.5, samples=1)
    with pytest.raises(drive.DriveError, match="history"):
        drive.Tracker(model, "husky", "line", 0.5, history=11.0)
    with pytest.raises(drive.DriveError, match="uncertainty_weight"):
        drive.Tracker(model, "husky", "line", 0.5, uncertainty_weight=-1.0)
    with pytest.raises(drive.DriveError, match="schedule_s"):
        drive.Tracker(model, "husky", "line", 0.5, schedule=-1.0)
    # On a schedule (drive track --schedule): a tick plans as usual.
    held = drive.Tracker(model, "husky", "line", 0.5, samples=64, schedule=0.5)
    assert all(math.isfinite(u) for u in held.tick(0.0, (0.0, 0.0), pose=(0.0, 0.0, 0.0))["command"])
    # The model's predicted variance weighed in its costs: a tick plans as usual.
    weighed = drive.Tracker(model, "husky", "line", 0.5, samples=64, uncertainty_weight=1.0)
    tick = weighed.tick(0.0, (0.0, 0.0), pose=(0.0, 0.0, 0.0))
    assert len(tick["command"]) == 2 and all(math.isfinite(u) for u in tick["command"])
    # No history given (None): the model's powertrain's settling time, as in drive track.
    drive.Tracker(model, "husky", "line", 0.5, history=None, samples=64)
    # The rollouts' state after the history's commands left to run free: a tick plans too.
    free = drive.Tracker(model, "husky", "line", 0.5, samples=64, observe_now=False)
    tick = free.tick(0.0, (0.0, 0.0), pose=(0.0, 0.0, 0.0), imu_yaw_rate=0.1)
    assert all(math.isfinite(u) for u in tick["command"])
    tracker = drive.Tracker(model, "husky", "line", 0.5, scale=2.0, samples=64)
    assert tracker.length == pytest.approx(12.0)
    with pytest.raises(drive.DriveError, match="no localization"):
        tracker.tick(0.0, (0.0, 0.0))
    tracker.tick(0.0, (0.0, 0.0), pose=(0.0, 0.0, 0.0))
    with pytest.raises(drive.DriveError, match="does not come after"):
        tracker.tick(0.0, (0.0, 0.0))
    with pytest.raises(drive.DriveError, match="not finite"):
        tracker.tick(0.05, (0.0, float("nan")))
    with pytest.raises(drive.DriveError, match="3 numbers"):
        tracker.tick(0.1, (0.0, 0.0), pose=(0.0, 0.0))


# The ROS 2 node ---------------------------------------------------------------------------


def odometry(x, y, yaw):
    q = NS(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    return NS(pose=NS(pose=NS(position=NS(x=x, y=y, z=0.0), orientation=q)))


def path_msg(points):
    return NS(poses=[NS(pose=NS(position=NS(x=float(x), y=float(y), z=0.0))) for x, y in points])


def joint_state(left, right):
    return NS(name=["left_wheel", "right_wheel", "caster"], velocity=[left, right, 0.0])


@pytest.fixture
def logic_module():
    load("protocol_logic")
    return load("track_logic")


def drive_node_logic(logic, robot, seconds, pressed=True, odom=True):
    outs = []
    for _ in range(int(seconds * 20)):
        now = drive_node_logic.t
        logic.on_joy(NS(buttons=[1 if pressed else 0]), now)
        logic.on_joint_state(joint_state(robot.wl, robot.wr), now)
        if odom:
            logic.on_odometry(odometry(robot.x, robot.y, robot.yaw), now)
        logic.on_imu(NS(angular_velocity=NS(x=0.0, y=0.0, z=robot.yaw_rate)))
        out = logic.on_timer(now)
        outs.append(out)
        robot.advance(*out.inputs)
        drive_node_logic.t += 0.05
    return outs


def test_the_node_logic_follows_a_path_and_stops_safely(logic_module, model_file):
    drive_node_logic.t = 0.0
    logic = logic_module.TrackLogic(model_file, "husky", 0.4, samples=256)
    robot = Wheels()
    # No path yet: zero, idle.
    (out,) = drive_node_logic(logic, robot, 0.05)
    assert (out.linear, out.angular, out.state) == (0.0, 0.0, "idle")
    logic.on_path(path_msg([(0.0, 0.0), (3.0, 0.0)]))
    outs = drive_node_logic(logic, robot, 2.0)
    assert outs[-1].state == "following" and outs[-1].linear > 0.1
    # The dead-man released: zero at once.
    out = drive_node_logic(logic, robot, 0.5, pressed=False)[-1]
    assert (out.linear, out.angular, out.state) == (0.0, 0.0, "held")
    # Stale localization: zero too.
    outs = drive_node_logic(logic, robot, 1.0, odom=False)
    assert outs[-1].state == "held" and outs[-1].linear == 0.0
    # Held again: the commands ramp up from rest (1 m/s^2 at 20 Hz: 0.05 m/s per tick).
    outs = drive_node_logic(logic, robot, 12.0)
    assert outs[0].linear <= 0.05 + 1e-9
    assert outs[-1].state == "done" and logic.done
    assert robot.x == pytest.approx(3.0, abs=0.3)
    # A path it cannot follow: an error, zero commands.
    logic.on_path(path_msg([(1.0, 1.0)]))
    out = drive_node_logic(logic, robot, 0.05)[-1]
    assert (out.linear, out.state) == (0.0, "error") and "path refused" in logic.error
    # Not-finite measurements are dropped.
    logic.on_imu(NS(angular_velocity=NS(z=float("nan"))))
    logic.on_joint_state(joint_state(float("inf"), 0.0), 0.0)
    assert logic.dropped == 2


@pytest.fixture
def fake_ros(monkeypatch, logic_module):
    from test_ros2 import FakeNode, message

    vec = lambda: NS(x=0.0, y=0.0, z=0.0)  # noqa: E731
    modules = {
        "rclpy": NS(init=lambda args=None: None, ok=lambda: True, shutdown=lambda: None),
        "rclpy.node": NS(Node=FakeNode),
        "geometry_msgs.msg": NS(Twist=message("Twist", linear=vec, angular=vec)),
        "nav_msgs.msg": NS(Odometry=message("Odometry"), Path=message("Path", poses=list)),
        "sensor_msgs.msg": NS(
            Joy=message("Joy", buttons=list, axes=list),
            Imu=message("Imu", angular_velocity=vec),
            # (Its field `name` would clash with message()'s first argument.)
            JointState=type("JointState", (), {}),
        ),
        "std_msgs.msg": NS(
            Bool=message("Bool", data=False),
            Float64=message("Float64", data=0.0),
            Int32=message("Int32", data=0),
            String=message("String", data=""),
        ),
    }
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    for name in ("geometry_msgs", "nav_msgs", "sensor_msgs", "std_msgs"):
        monkeypatch.setitem(sys.modules, name, types.ModuleType(name))
    FakeNode.clock = [0.0]
    FakeNode.overrides = {}
    FakeNode.made = []
    return load("track_node"), FakeNode


def test_the_track_node_wires_topics_and_needs_a_model(fake_ros, model_file):
    module, FakeNode = fake_ros
    with pytest.raises(ValueError, match="model_file"):
        module.DriveTrackNode()
    FakeNode.overrides = {"model_file": str(model_file), "samples": 128}
    node = module.DriveTrackNode()
    assert set(node.subscriptions) == {"path_in", "joint_states", "odometry_in", "imu_in", "joy_in"}
    assert set(node.publishers) == {"cmd_vel", "track/cross_track"}
    (timer,) = node.timers
    assert timer.period == pytest.approx(1 / 20)
    node.subscriptions["path_in"][1](path_msg([(0.0, 0.0), (2.0, 0.0)]))
    for k in range(40):
        FakeNode.clock[0] = k / 20
        node.subscriptions["joy_in"][1](NS(buttons=[1]))
        node.subscriptions["joint_states"][1](joint_state(0.0, 0.0))
        node.subscriptions["odometry_in"][1](odometry(0.0, 0.0, 0.0))
        timer.callback()
    cmds = node.publishers["cmd_vel"].sent
    assert len(cmds) == 40 and cmds[-1].linear.x > 0.0
    FakeNode.overrides = {"model_file": str(model_file), "use_joint_states": False}
    node = module.DriveTrackNode()
    assert "wheel_vel_left_measured" in node.subscriptions


def test_the_ros2_package_files_are_valid():
    for path in [*(ROS2 / "drive_ros").glob("*.py"), *(ROS2 / "launch").glob("*.py"), ROS2 / "setup.py"]:
        compile(path.read_text(), path.name, "exec")


def test_a_stamped_late_fix_is_carried_forward_from_when_it_was_measured():
    """A fix measured 0.3 s before it arrives, on a robot driving straight at 1 m/s: with its
    stamp the estimate is where the robot is, without it 0.3 m behind."""
    data = drive.load_dataset("bundled:husky_drive")
    model = drive.fit(data, "powertrain")

    def worst(stamped):
        tracker = drive.Tracker(model, "husky", "line", 0.5, scale=20.0, samples=64)
        error, fix = 0.0, None
        for k in range(60):
            t = k * 0.05
            if k % 4 == 0:
                measured = max(t - 0.3, 0.0)
                fix = (measured, (measured, 0.0, 0.0))
            tick = tracker.tick(t, (0.0, 0.0), pose=fix[1], imu_yaw_rate=0.0,
                                pose_time=fix[0] if stamped else None)
            if t >= 1.0:
                error = max(error, abs(tick["estimate"][0] - t))
        return error

    assert worst(True) < 0.02
    assert worst(False) > 0.25


def test_the_node_logic_hands_the_odometrys_stamp_to_the_tracker(logic_module, model_file):
    """The pose's header stamp (on the node's clock) reaches the tracker as when the fix was
    measured; a stamp of zero, in the future or over a second old is not used."""
    logic = logic_module.TrackLogic(model_file, "husky", 0.4, samples=64)

    def stamped(seconds):
        msg = odometry(1.0, 0.0, 0.0)
        msg.header = NS(stamp=NS(sec=int(seconds), nanosec=int(round((seconds % 1) * 1e9))))
        return msg

    logic.on_odometry(stamped(9.7), 10.0)
    assert logic._pose_stamp == pytest.approx(9.7)
    for bad in (0.0, 10.5, 8.5):
        logic.on_odometry(stamped(bad), 10.0)
        assert logic._pose_stamp is None, bad
    logic.on_odometry(odometry(1.0, 0.0, 0.0), 10.0)
    assert logic._pose_stamp is None


def test_track_and_sim_fit_return_the_command_lines_json_with_progress_and_errors(tmp_path):
    """`drive.track` and `drive.sim_fit` run the command line in this process: its --json
    document as a dict, `progress` called as each run ends, a `drive.Dataset` given as
    training data, an error as `DriveError`."""
    seen = []
    data = drive.load_dataset()  # the bundled Husky run, as training data
    result = drive.track(
        robot="husky",
        terrain="tile",
        models=["powertrain"],
        path="line",
        train_data=[data],
        progress=lambda done, total: seen.append((done, total)),
    )
    assert result["models"] == ["powertrain"]
    assert [r["model"] for r in result["runs"]] == ["powertrain"]
    assert seen and seen[-1] == (1, 1)
    with pytest.raises(drive.DriveError, match="unknown model 'gp'"):
        drive.track(robot="husky", terrain="tile", models="gp", path="line")
    with pytest.raises(drive.DriveError, match="not an option"):
        drive.track(**{"json": True})
    # A file it reads that does not exist is a FileNotFoundError; a dataset where a name
    # is taken, a negative number given as a value, named.
    with pytest.raises(FileNotFoundError, match="nope.csv: no such file"):
        drive.track(robot="husky", terrain="tile", models="powertrain", path="line", train_data=str(tmp_path / "nope.csv"))
    with pytest.raises(drive.DriveError, match="models takes no drive.Dataset"):
        drive.track(robot="husky", terrain="tile", models=data, path="line")
    with pytest.raises(drive.DriveError, match="invalid value '-1' for '--seeds"):
        drive.track(robot="husky", terrain="tile", models="powertrain", path="line", seeds=-1)
    # A twin's check: the paper's Warthog run against its twin of examples/twins.
    twin = FsPath(__file__).resolve().parents[2] / "examples" / "twins" / "warthog_drive.toml"
    with pytest.raises(drive.DriveError, match="the twin fails its check"):
        drive.sim_fit("bundled:warthog_drive", "warthog", twin=twin, check_seeds=1)
    with pytest.raises(drive.DriveError, match="data is drive.sim_fit's first argument"):
        drive.sim_fit("bundled:warthog_drive", "warthog", twin=twin, data="bundled:warthog_asphalt_a")
    with pytest.raises(drive.DriveError, match="got None"):
        drive.sim_fit(None, "warthog", twin=twin)
    checked = drive.sim_fit("bundled:warthog_drive", "warthog", twin=twin, check_seeds=1, allow_poor_twin=True)
    assert checked["poor"] and checked["check_seeds"] == [1]
