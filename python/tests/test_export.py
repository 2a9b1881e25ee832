"""`drive export --format norlab`: the files load as norlab_controllers loads them
(norlabcontrollib/models/blr_slip.py, load_params and predict_slip, re-implemented here with
numpy) and give the fitted model's slip and its eq. 7 variance."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import drive

BIN = Path(os.environ.get("DRIVE_BIN", Path(sys.executable).parent / "drive"))


def cli(*args):
    out = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out


def test_norlab_export_gives_the_models_slip_and_variance(tmp_path):
    model_file = tmp_path / "m.json"
    cli("train", "--model", "slip-blr", "--uncertainty", "paper", "--split", "0.5", "--out", model_file)
    out = tmp_path / "norlab"
    cli("export", "--model", model_file, "--format", "norlab", "--out", out)
    p = out / "slip_blr"
    # load_params: the twelve arrays, in the shapes train_params/save_params write.
    weights = {d: np.load(p / f"weights_{d}.npy") for d in ("x", "y", "yaw")}
    cov = {d: np.load(p / f"covariance_{d}.npy") for d in ("x", "y", "yaw")}
    a = {d: np.load(p / f"a_param_n_{d}.npy") for d in ("x", "y", "yaw")}
    b = {d: np.load(p / f"b_param_n_{d}.npy") for d in ("x", "y", "yaw")}
    assert [weights[d].shape for d in ("x", "y", "yaw")] == [(1, 1), (1, 1), (3, 1)]
    assert cov["yaw"].shape == (3, 3) and a["x"].shape == () and b["x"].shape == (1, 1)
    for side in ("left", "right"):
        tau, delay = np.load(out / "powertrain" / f"powertrain_training_{side}.npy")
        assert 0.0 < tau < 20.0 and 0.0 <= delay < 1.0
    yaml = (out / "norlab_controller.yaml").read_text()
    assert "controller_name: 'SlipBLRPwrtrnDiffDriveMPC'" in yaml and "wheel_radius: 0.165" in yaml

    # norlab's slip at a commanded body velocity (predict_slip_from_body_vels): x @ w.
    model = drive.load_model(model_file)
    r, base, dt = 0.165, 0.55, model.dt
    for u in [(3.0, 5.0), (-2.0, 4.0), (6.0, 6.0)]:
        fx, fw = r * (u[0] + u[1]) / 2, r * (u[1] - u[0]) / base
        inputs = {"x": np.array([[fx]]), "y": np.array([[fx * fw]]), "yaw": np.array([[fx * fw, fx, fw]])}
        slip = {d: (inputs[d] @ weights[d]).item() for d in inputs}
        # The model at steady state (wheels at the command): one step of eq. 1 from yaw 0.
        poses, c = model.predict(np.array([u, u]), start_wheels=u, return_cov=True)
        v = (poses[1] - poses[0]) / dt
        np.testing.assert_allclose(v, [fx - slip["x"], -slip["y"], fw - slip["yaw"]], rtol=0, atol=1e-9)
        # predict_slip's variance (eq. 7's Student-t): the one-step covariance over dt^2.
        for i, d in enumerate(("x", "y", "yaw")):
            x = inputs[d]
            scale = 2 * a[d]
            variance = (b[d] / a[d] * (1 + x @ cov[d] @ x.T)).item() * scale / (scale - 2)
            assert abs(c[1][i, i] / dt**2 - variance) <= 1e-9 * variance


def test_a_model_the_layout_cannot_hold_is_refused(tmp_path):
    model_file = tmp_path / "m.json"
    cli("train", "--model", "acc-blr", "--split", "0.5", "--out", model_file)
    out = subprocess.run([str(BIN), "export", "--model", model_file, "--format", "norlab", "--out", tmp_path / "x"],
                         capture_output=True, text=True)
    assert out.returncode == 1
    assert "cannot be exported as --format norlab" in out.stderr and "baseline" in out.stderr
    assert not (tmp_path / "x").exists()
