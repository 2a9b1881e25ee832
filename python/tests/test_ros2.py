"""The ROS 2 node example (examples/ros2) without ROS: its logic driven by fake messages and
a fake clock against a small simulated robot, and the node's wiring against a fake rclpy."""

import importlib
import math
import sys
import types
from pathlib import Path
from types import SimpleNamespace as NS

import pytest

import drive

ROS2 = Path(__file__).resolve().parents[2] / "examples" / "ros2"


sys.path.insert(0, str(ROS2))


def load(name):
    """The module drive_ros.NAME of the ROS 2 package, executed afresh (with the fake ROS
    modules of the test that asks, if any)."""
    for module in [m for m in sys.modules if m.startswith("drive_ros.")]:
        del sys.modules[module]
    return importlib.import_module(f"drive_ros.{name}")


logic_module = load("protocol_logic")
ProtocolLogic = logic_module.ProtocolLogic


def joy(pressed):
    return NS(buttons=[1 if pressed else 0, 0], axes=[0.0, 0.0])


def odometry(x, y, yaw):
    q = NS(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    return NS(pose=NS(pose=NS(position=NS(x=x, y=y, z=0.0), orientation=q)))


class Robot:
    """A Husky-like skid-steer: wheels follow the commanded body velocity with a first-order
    lag; the pose integrates the ideal differential drive. Encoders at 20 Hz, odometry at
    10 Hz, a joystick at 10 Hz, all from one fake clock."""

    def __init__(self, logic, radius=0.165, baseline=0.555):
        self.logic, self.r, self.b = logic, radius, baseline
        self.wl = self.wr = 0.0
        self.x = self.y = self.yaw = 0.0
        self.v = self.w = 0.0
        self.t = 0.0
        self.k = 0
        self.outputs = []

    def step(self, pressed=True, joystick=True, encoders=True, odom=True):
        dt = 1.0 / 20.0
        if joystick and self.k % 2 == 0:
            self.logic.on_joy(joy(pressed), self.t)
        if encoders:
            self.logic.on_left_wheel(NS(data=self.wl))
            self.logic.on_right_wheel(NS(data=self.wr))
        if odom and self.k % 2 == 0:
            self.logic.on_odometry(odometry(self.x, self.y, self.yaw))
        out = self.logic.on_timer(self.t)
        self.outputs.append(out)
        # The robot's controller: body command -> wheel targets, then a lag.
        tl = (out.linear - out.angular * self.b / 2) / self.r
        tr = (out.linear + out.angular * self.b / 2) / self.r
        self.wl += 0.3 * (tl - self.wl)
        self.wr += 0.3 * (tr - self.wr)
        v = self.r * (self.wl + self.wr) / 2
        w = self.r * (self.wr - self.wl) / self.b
        self.x += v * math.cos(self.yaw) * dt
        self.y += v * math.sin(self.yaw) * dt
        self.yaw += w * dt
        self.t += dt
        self.k += 1
        return out

    def run(self, seconds, **kw):
        return [self.step(**kw) for _ in range(int(round(seconds * 20)))]


def test_a_full_run_characterizes_then_drives_intervals_and_stops():
    logic = ProtocolLogic("husky", "uniform", 3, max_intervals=3)
    robot = Robot(logic)
    outs = robot.run(120)
    assert logic.finished and logic.runner.stop_reason == "intervals"
    assert logic.runner.completed_intervals == 3
    # Characterization first (idle, no interval), then the three intervals of 6 s.
    states = [o.state for o in outs]
    assert states[0] == "characterizing"
    calib = [o for o in outs if o.calib_state == "calib"]
    assert len(calib) == 3 * 120
    assert [o.calib_step for o in calib] == [k for k in range(3) for _ in range(120)]
    # The identified geometry is the simulated robot's.
    g = logic.runner.geometry
    assert g["wheel_radius"] == pytest.approx(0.165, rel=0.02)
    assert g["baseline"] == pytest.approx(0.555, rel=0.02)
    # Every command stays within the characterized input space (body speeds of J).
    (lo_l, hi_l), (lo_r, hi_r) = logic.runner.input_space
    for o in calib:
        wl = (o.linear - o.angular * 0.555 / 2) / 0.165
        wr = (o.linear + o.angular * 0.555 / 2) / 0.165
        assert lo_l - 1e-6 <= wl <= hi_l + 1e-6 and lo_r - 1e-6 <= wr <= hi_r + 1e-6
    # Once done: zero commands, idle.
    last = outs[-1]
    assert (last.linear, last.angular, last.calib_state) == (0.0, 0.0, "idle")
    assert not any(o.joy_switch for o in outs)


def test_the_same_seed_gives_the_same_commands():
    def commands(seed):
        logic = ProtocolLogic("husky", "uniform", seed, max_intervals=2)
        return [(o.linear, o.angular) for o in Robot(logic).run(60)]

    assert commands(5) == commands(5)
    assert commands(5) != commands(6)


def test_releasing_the_deadman_stops_the_robot_and_restarts_the_interval():
    logic = ProtocolLogic("husky", "uniform", 1, characterize=False)
    robot = Robot(logic)
    robot.run(3.0)  # 2 s transient window and 1 s of the first steady one
    assert robot.outputs[-1].calib_step == 0 and robot.outputs[-1].calib_state == "calib"
    released = robot.run(1.0, pressed=False)
    # Zero from the first tick after the release, the operator's switch published.
    assert all((o.linear, o.angular) == (0.0, 0.0) for o in released[1:])
    assert all(o.joy_switch and o.state == "paused" for o in released[1:])
    assert logic.runner.pause_reason == "deadman released"
    # The suspended interval is still the logger's calib step.
    assert all(o.calib_state == "calib" and o.calib_step == 0 for o in released[1:])
    resumed = robot.run(6.0)
    # It restarts interval 0 from its transient window: 6 s of interval 0 again.
    assert [o.calib_step for o in resumed] == [0] * 120
    assert logic.runner.completed_intervals == 1


def test_a_silent_joystick_counts_as_released():
    logic = ProtocolLogic("husky", "uniform", 1, characterize=False, joy_timeout=0.5)
    robot = Robot(logic)
    robot.run(1.0)
    assert robot.outputs[-1].linear != 0.0 or robot.outputs[-1].angular != 0.0
    silent = robot.run(1.5, joystick=False)
    # Moving until the last message is 0.5 s old, stopped after.
    assert all((o.linear, o.angular) == (0.0, 0.0) for o in silent[11:])
    assert silent[-1].state == "paused"


def test_the_geofence_ends_the_protocol():
    logic = ProtocolLogic("husky", "linear", 2, characterize=False, geofence=3.0)
    robot = Robot(logic)
    outs = robot.run(120)
    assert logic.finished
    assert logic.runner.stop_reason.startswith("geofence")
    assert math.hypot(robot.x, robot.y) < 3.0 + 0.5  # stopped soon after crossing
    done = [o for o in outs if o.state == "done"]
    assert done and all((o.linear, o.angular) == (0.0, 0.0) for o in done)


def test_stale_encoders_pause_and_bad_messages_are_dropped():
    logic = ProtocolLogic("husky", "uniform", 1, characterize=False)
    robot = Robot(logic)
    robot.run(1.0)
    stale = robot.run(1.0, encoders=False)
    assert stale[-1].state == "paused" and logic.runner.pause_reason == "encoders stale"
    assert (stale[-1].linear, stale[-1].angular) == (0.0, 0.0)
    # Non-finite wheel and odometry messages are dropped, not passed on.
    logic.on_left_wheel(NS(data=float("nan")))
    logic.on_odometry(odometry(float("inf"), 0.0, 0.0))
    assert logic.dropped == 2
    robot.run(1.0)
    assert logic.error is None and robot.outputs[-1].state == "driving"


def test_a_runner_error_ends_with_a_zero_command():
    logic = ProtocolLogic("husky", "uniform", 1, characterize=False)
    robot = Robot(logic)
    robot.run(1.0)
    robot.t -= 10.0  # the clock jumps back (a bag replayed, sim time reset)
    out = robot.step()
    assert logic.finished and "time went backwards" in logic.error
    assert (out.linear, out.angular, out.state) == (0.0, 0.0, "error")
    assert robot.step().state == "error"


def test_bad_configuration_is_refused():
    with pytest.raises(drive.DriveError, match="unknown robot|no registered robot|husk"):
        ProtocolLogic("husk")
    with pytest.raises(drive.DriveError, match="geofence"):
        ProtocolLogic("husky", geofence=-1.0)
    with pytest.raises(ValueError, match="joy_timeout"):
        ProtocolLogic("husky", joy_timeout=0.0)


# The node's wiring, against a fake rclpy -------------------------------------------------


class FakeNode:
    clock = [0.0]
    overrides = {}
    made = []

    def __init__(self, name):
        FakeNode.made.append(self)
        self.name = name
        self.subscriptions = {}
        self.publishers = {}
        self.timers = []
        self.logged = []

    def declare_parameter(self, name, default):
        return NS(value=self.overrides.get(name, default))

    def create_subscription(self, kind, topic, callback, qos):
        self.subscriptions[topic] = (kind, callback)

    def create_publisher(self, kind, topic, qos):
        pub = NS(kind=kind, sent=[])
        pub.publish = pub.sent.append
        self.publishers[topic] = pub
        return pub

    def create_timer(self, period, callback):
        timer = NS(period=period, callback=callback, cancelled=False)
        timer.cancel = lambda: setattr(timer, "cancelled", True)
        self.timers.append(timer)
        return timer

    def get_clock(self):
        def now():
            nanoseconds = int(round(FakeNode.clock[0] * 1e9))
            return NS(nanoseconds=nanoseconds, to_msg=lambda: NS(sec=nanoseconds // 10**9, nanosec=nanoseconds % 10**9))

        return NS(now=now)

    def get_logger(self):
        return NS(info=self.logged.append, warn=self.logged.append, error=self.logged.append)

    def destroy_node(self):
        pass


def message(name, **defaults):
    def init(self, **kw):
        for k, v in defaults.items():
            setattr(self, k, v() if callable(v) else v)
        for k, v in kw.items():
            setattr(self, k, v)

    return type(name, (), {"__init__": init})


@pytest.fixture
def fake_ros(monkeypatch):
    vec = lambda: NS(x=0.0, y=0.0, z=0.0)  # noqa: E731
    modules = {
        "rclpy": NS(init=lambda args=None: None, ok=lambda: True, shutdown=lambda: None),
        "rclpy.node": NS(Node=FakeNode),
        "geometry_msgs.msg": NS(Twist=message("Twist", linear=vec, angular=vec)),
        "nav_msgs.msg": NS(Odometry=message("Odometry")),
        "sensor_msgs.msg": NS(
            Joy=message("Joy", buttons=list, axes=list),
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
    return load("protocol_node")


def test_the_node_subscribes_publishes_and_ticks_at_the_robot_rate(fake_ros):
    FakeNode.overrides = {"robot": "husky", "max_intervals": 1, "characterize": False}
    node = fake_ros.DriveProtocolNode()
    assert set(node.subscriptions) == {
        "joy_in", "wheel_vel_left_measured", "wheel_vel_right_measured", "odometry_in"
    }
    assert set(node.publishers) == {"doughnut_cmd_vel", "calib_step", "calib_state", "drive/joy_switch"}
    (timer,) = node.timers
    assert timer.period == pytest.approx(1 / 20)
    Joy = sys.modules["sensor_msgs.msg"].Joy
    Float64 = sys.modules["std_msgs.msg"].Float64
    for k in range(200):
        FakeNode.clock[0] = k / 20
        node.subscriptions["joy_in"][1](Joy(buttons=[1]))
        node.subscriptions["wheel_vel_left_measured"][1](Float64(data=0.0))
        node.subscriptions["wheel_vel_right_measured"][1](Float64(data=0.0))
        node.subscriptions["odometry_in"][1](odometry(0.0, 0.0, 0.0))
        if not timer.cancelled:
            timer.callback()
    cmds = node.publishers["doughnut_cmd_vel"].sent
    states = [m.data for m in node.publishers["calib_state"].sent]
    # One interval (120 ticks) recorded, then a zero command and the timer cancelled.
    assert states.count("calib") == 120
    assert timer.cancelled and len(cmds) == 121
    assert any(abs(c.linear.x) + abs(c.angular.z) > 0 for c in cmds[:120])
    assert (cmds[-1].linear.x, cmds[-1].angular.z) == (0.0, 0.0)
    assert {m.data for m in node.publishers["drive/joy_switch"].sent} == {False}


def test_ctrl_c_stops_the_node_with_a_zero_command(fake_ros, monkeypatch):
    FakeNode.overrides = {"robot": "husky", "characterize": False}
    ticks = [0]

    def spin_once(node, timeout_sec=None):
        # Two timer ticks with the dead-man held, then the operator's Ctrl-C.
        if ticks[0] == 2:
            raise KeyboardInterrupt
        FakeNode.clock[0] = ticks[0] / 20
        node.on_joy(sys.modules["sensor_msgs.msg"].Joy(buttons=[1]))
        Float64 = sys.modules["std_msgs.msg"].Float64
        node.logic.on_left_wheel(Float64(data=0.0))
        node.logic.on_right_wheel(Float64(data=0.0))
        node.logic.on_odometry(odometry(0.0, 0.0, 0.0))
        node.on_timer()
        ticks[0] += 1

    monkeypatch.setattr(sys.modules["rclpy"], "spin_once", spin_once, raising=False)
    fake_ros.main()
    (node,) = FakeNode.made
    cmds = node.publishers["doughnut_cmd_vel"].sent
    assert len(cmds) == 3
    assert abs(cmds[1].linear.x) + abs(cmds[1].angular.z) > 0
    assert (cmds[-1].linear.x, cmds[-1].angular.z) == (0.0, 0.0)


def test_a_negative_limit_is_refused(fake_ros):
    FakeNode.overrides = {"geofence": -5.0}
    with pytest.raises(ValueError, match="geofence must be 0"):
        fake_ros.DriveProtocolNode()


def test_the_launch_files_are_valid_python():
    for path in (ROS2 / "launch").glob("*.launch.py"):
        compile(path.read_text(), path.name, "exec")
