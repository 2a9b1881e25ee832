"""The ROS 2 package drive_ros (examples/ros2) without ROS: the prediction display's logic
against the model it loads, its node's wiring, the protocol node's JointState input, and
every entry point of setup.py importable and callable, all with fake messages and a fake
rclpy (the package's files are checked by .ci/check-ros2)."""

import ast
import math
import subprocess
import sys
import types
from types import SimpleNamespace as NS

import numpy as np
import pytest

import drive
from test_ros2 import ROS2, FakeNode, load, odometry


def msgtype(name, **defaults):
    """A fake message class: attributes with defaults (a callable default is called)."""

    def init(self, **kw):
        for k, v in defaults.items():
            setattr(self, k, v() if callable(v) else v)
        for k, v in kw.items():
            setattr(self, k, v)

    return type(name, (), {"__init__": init})


def vec():
    return NS(x=0.0, y=0.0, z=0.0)


def header():
    return NS(frame_id="", stamp=None)


FAKE_MESSAGES = {
    "geometry_msgs.msg": NS(
        Twist=msgtype("Twist", linear=vec, angular=vec),
        Point=msgtype("Point", x=0.0, y=0.0, z=0.0),
        PoseStamped=msgtype(
            "PoseStamped", header=header, pose=lambda: NS(position=vec(), orientation=NS(x=0.0, y=0.0, z=0.0, w=1.0))
        ),
    ),
    "nav_msgs.msg": NS(Odometry=msgtype("Odometry"), Path=msgtype("Path", header=header, poses=list)),
    "sensor_msgs.msg": NS(
        Joy=msgtype("Joy", buttons=list, axes=list),
        Imu=msgtype("Imu", angular_velocity=vec),
        JointState=type("JointState", (), {}),
    ),
    "std_msgs.msg": NS(
        Bool=msgtype("Bool", data=False),
        Float64=msgtype("Float64", data=0.0),
        Int32=msgtype("Int32", data=0),
        String=msgtype("String", data=""),
    ),
    "visualization_msgs.msg": NS(
        Marker=type(
            "Marker",
            (msgtype(
                "MarkerFields",
                header=header,
                ns="",
                id=0,
                type=0,
                action=0,
                pose=lambda: NS(position=vec(), orientation=NS(x=0.0, y=0.0, z=0.0, w=0.0)),
                scale=vec,
                color=lambda: NS(r=0.0, g=0.0, b=0.0, a=0.0),
                points=list,
            ),),
            {"ADD": 0, "LINE_STRIP": 4, "DELETEALL": 3},
        ),
        MarkerArray=msgtype("MarkerArray", markers=list),
    ),
}


@pytest.fixture
def fake_ros(monkeypatch):
    modules = {
        "rclpy": NS(init=lambda args=None: None, ok=lambda: True, shutdown=lambda: None, spin=lambda node: None),
        "rclpy.node": NS(Node=FakeNode),
        **FAKE_MESSAGES,
    }
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    for name in ("geometry_msgs", "nav_msgs", "sensor_msgs", "std_msgs", "visualization_msgs"):
        monkeypatch.setitem(sys.modules, name, types.ModuleType(name))
    FakeNode.clock = [0.0]
    FakeNode.overrides = {}
    FakeNode.made = []
    return modules


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    husky = drive.load_dataset()
    out = {}
    for name in ("slip-blr", "naive"):
        model = drive.fit(husky, name, split=0.5)
        path = tmp_path_factory.mktemp(name) / "model.json"
        model.save(path)
        out[name] = (model, path)
    return out


def joint_state(left, right):
    return NS(name=["left_wheel", "right_wheel"], velocity=[left, right])


def twist(linear, angular):
    return NS(linear=NS(x=linear, y=0.0, z=0.0), angular=NS(x=0.0, y=0.0, z=angular))


def feed(logic, now, pose=(1.0, 2.0, 0.5), wheels=(3.0, 4.0), yaw_rate=0.1, command=(0.5, 0.2)):
    msg = odometry(*pose)
    msg.header = NS(frame_id="odom")
    logic.on_odometry(msg, now)
    logic.on_joint_state(joint_state(*wheels), now)
    logic.on_imu(NS(angular_velocity=NS(x=0.0, y=0.0, z=yaw_rate)), now)
    if command is not None:
        logic.on_cmd_vel(twist(*command), now)


def test_the_prediction_is_the_models_for_the_held_command(models):
    model, path = models["slip-blr"]
    logic = load("predict_logic").PredictLogic(str(path), horizon=2.0, ellipse_every=5)
    assert logic.has_covariance and logic.uses_imu and logic.steps == 40
    assert logic.on_timer(0.0) is None  # nothing measured yet
    feed(logic, 0.0)
    out = logic.on_timer(0.01)
    assert out.frame_id == "odom" and len(out.poses) == 41
    inputs = model.input_for(0.5, 0.2)
    assert out.command == pytest.approx(inputs)
    # A differential drive: the wheels of (v, w) are ((v - w b/2) / r, (v + w b/2) / r).
    radius, baseline = 0.165, 0.55
    assert inputs == pytest.approx(((0.5 - 0.2 * baseline / 2) / radius, (0.5 + 0.2 * baseline / 2) / radius))
    expected, cov = model.predict(
        np.tile(inputs, (41, 1)), start=(1.0, 2.0, 0.5), start_wheels=(3.0, 4.0), start_yaw_rate=0.1, return_cov=True
    )
    np.testing.assert_allclose(np.array(out.poses), expected, rtol=0, atol=1e-12)
    assert out.poses[0] == pytest.approx((1.0, 2.0, 0.5))
    # 95% regions at 0.25, 0.5, ... 2 s: the outline is the chi-square(2) level set.
    assert [e.t for e in out.ellipses] == pytest.approx([0.25 * k for k in range(1, 9)])
    for e in out.ellipses:
        k = int(round(e.t / out.dt))
        inverse = np.linalg.inv(cov[k, :2, :2])
        assert e.major >= e.minor > 0.0 and (e.x, e.y) == pytest.approx(tuple(expected[k, :2]))
        outline = e.outline()
        assert outline[0] == pytest.approx(outline[-1])
        for px, py in outline:
            d = np.array([px - e.x, py - e.y])
            assert d @ inverse @ d == pytest.approx(5.991464547107979, rel=1e-9)
    assert out.ellipses[-1].major > out.ellipses[0].major


def test_stale_measurements_and_a_silent_command(models):
    _, path = models["slip-blr"]
    logic = load("predict_logic").PredictLogic(str(path), stale_timeout=0.5, command_timeout=0.5)
    feed(logic, 0.0)
    assert logic.on_timer(0.6) is None  # the pose and wheels are stale
    feed(logic, 1.0, command=None)  # the last command is 1 s old: the robot's driver stops
    out = logic.on_timer(1.0)
    assert out.command == (0.0, 0.0)
    logic.on_odometry(odometry(float("nan"), 0.0, 0.0), 1.0)
    assert logic.dropped == 1
    with pytest.raises(ValueError, match="horizon"):
        load("predict_logic").PredictLogic(str(path), horizon=0.0)


def test_a_model_without_uncertainty_draws_the_path_only(models):
    _, path = models["naive"]
    logic = load("predict_logic").PredictLogic(str(path))
    assert not logic.has_covariance
    feed(logic, 0.0)
    out = logic.on_timer(0.0)
    assert len(out.poses) == 41 and out.ellipses == []


def test_the_predict_node_publishes_a_path_and_ellipses(fake_ros, models):
    _, path = models["slip-blr"]
    module = load("predict_node")
    with pytest.raises(ValueError, match="model_file"):
        module.DrivePredictNode()
    FakeNode.overrides = {"model_file": str(path)}
    node = module.DrivePredictNode()
    assert set(node.subscriptions) == {"odometry_in", "joint_states", "imu_in", "cmd_vel_in"}
    assert set(node.publishers) == {"predicted_path", "predicted_ellipses"}
    (timer,) = node.timers
    assert timer.period == pytest.approx(0.1)
    timer.callback()
    assert node.publishers["predicted_path"].sent == []  # nothing measured yet
    msg = odometry(1.0, 2.0, 0.5)
    msg.header = NS(frame_id="map")
    node.subscriptions["odometry_in"][1](msg)
    node.subscriptions["joint_states"][1](joint_state(3.0, 4.0))
    node.subscriptions["imu_in"][1](NS(angular_velocity=NS(x=0.0, y=0.0, z=0.1)))
    node.subscriptions["cmd_vel_in"][1](twist(0.5, 0.2))
    timer.callback()
    (sent,) = node.publishers["predicted_path"].sent
    assert sent.header.frame_id == "map" and len(sent.poses) == 41
    first = sent.poses[0].pose
    assert (first.position.x, first.position.y) == (1.0, 2.0)
    assert 2 * math.atan2(first.orientation.z, first.orientation.w) == pytest.approx(0.5)
    (markers,) = node.publishers["predicted_ellipses"].sent
    kinds = [m.action for m in markers.markers]
    assert kinds[0] == 3 and kinds[1:] == [0] * 8  # clear the last ones, then 8 ellipses
    assert all(m.type == 4 and len(m.points) == 25 and m.header.frame_id == "map" for m in markers.markers[1:])
    FakeNode.overrides = {"model_file": str(path), "use_joint_states": False, "frame_id": "odom"}
    node = module.DrivePredictNode()
    assert {"wheel_vel_left_measured", "wheel_vel_right_measured"} <= set(node.subscriptions)


def test_the_protocol_node_reads_wheels_from_joint_states(fake_ros):
    module = load("protocol_node")
    FakeNode.overrides = {"robot": "husky", "characterize": False, "max_intervals": 1, "use_joint_states": True}
    node = module.DriveProtocolNode()
    assert "joint_states" in node.subscriptions and "wheel_vel_left_measured" not in node.subscriptions
    (timer,) = node.timers
    for k in range(40):
        FakeNode.clock[0] = k / 20
        node.subscriptions["joy_in"][1](NS(buttons=[1], axes=[]))
        node.subscriptions["joint_states"][1](joint_state(0.0, 0.0))
        node.subscriptions["odometry_in"][1](odometry(0.0, 0.0, 0.0))
        timer.callback()
    states = [m.data for m in node.publishers["calib_state"].sent]
    assert states.count("calib") > 0  # the wheels are heard: the interval runs
    # A JointState without the configured joints is ignored, like a silent encoder.
    logic = load("protocol_logic").ProtocolLogic("husky", characterize=False, left_joint="l", right_joint="r")
    logic.on_joint_state(joint_state(1.0, 2.0))
    assert logic._left is None
    logic.on_joint_state(NS(name=["r", "l"], velocity=[2.0, 1.0]))
    assert (logic._left, logic._right) == (1.0, 2.0)


def test_every_entry_point_imports_and_is_callable(fake_ros):
    tree = ast.parse((ROS2 / "setup.py").read_text())
    call = next(n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", "") == "setup")
    entry_points = ast.literal_eval(next(k.value for k in call.keywords if k.arg == "entry_points"))
    scripts = entry_points["console_scripts"]
    assert {s.split("=")[0].strip() for s in scripts} == {"protocol", "track", "predict"}
    for spec in scripts:
        module, function = spec.split("=")[1].strip().split(":")
        assert callable(getattr(load(module.split(".", 1)[1]), function))


def test_the_package_check_passes():
    root = ROS2.parents[1]
    out = subprocess.run([sys.executable, root / ".ci" / "check-ros2", ROS2], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
