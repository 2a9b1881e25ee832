"""The Python API against the command line: the same numbers (1e-9), the same messages."""

import gzip
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import drive

ROOT = Path(__file__).resolve().parents[2]
# The `drive` console command the package installed next to this Python (the command line
# run in-process by the extension module); DRIVE_BIN names another build to compare with.
BIN = Path(os.environ.get("DRIVE_BIN", Path(sys.executable).parent / "drive"))


def cli(*args, ok=True):
    if not BIN.exists():
        pytest.fail(f"no drive command at {BIN}: pip install the package, or set DRIVE_BIN")
    out = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
    if ok:
        assert out.returncode == 0, out.stderr
    return out


def close(a, b, path="", tol=1e-9):
    """Recursive equality of two JSON values, floats to `tol` (relative); the fit times
    (wall-clock measurements) are not compared."""
    if isinstance(a, dict):
        assert set(a) == set(b), f"{path}: keys {set(a) ^ set(b)}"
        for k in a:
            if k == "fit_seconds":
                continue
            close(a[k], b[k], f"{path}.{k}", tol)
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            close(x, y, f"{path}[{i}]", tol)
    elif isinstance(a, float) or isinstance(b, float):
        assert abs(a - b) <= tol * max(1.0, abs(a), abs(b)), f"{path}: {a} != {b}"
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


@pytest.fixture(scope="module")
def husky():
    return drive.load_dataset()


def test_evaluate_equals_drive_eval_json(husky):
    expected = json.loads(cli("eval", "--json").stdout)
    close(drive.evaluate(husky), expected)
    models = "slip-blr,acc-blr+fopdt"
    expected = json.loads(cli("eval", "--json", "--models", models, "--split", "0.3").stdout)
    close(drive.evaluate(husky, models=models.split(","), split=0.3), expected)


def test_bench_equals_drive_bench_json(tmp_path):
    suite = tmp_path / "suite.toml"
    suite.write_text(
        '[[dataset]]\nbundled = "warthog_grass_2024-08-08"\n'
        '[[dataset]]\npath = "bundled:warthog_asphalt_slow_2024-08-08"\nterrain = "slow asphalt"\n'
    )
    models = "naive,slip-blr,acc-blr"
    expected = json.loads(cli("bench", "--suite", suite, "--json", "--models", models).stdout)
    calls = []
    got = drive.bench(str(suite), models=models, progress=lambda done, total: calls.append((done, total)))
    close(got, expected)
    # The progress: units done counted up to the total (several units may come in one call).
    dones = [d for d, _ in calls]
    assert dones == sorted(set(dones)) and calls[-1][0] == calls[-1][1] > 2, calls
    with pytest.raises(drive.DriveError, match="progress must be a callable"):
        drive.bench(str(suite), models=models, progress="yes")
    assert [d["terrain"] for d in got["datasets"]] == ["grass", "slow asphalt"]
    assert {r["model"] for r in got["leaderboard"]} == set(models.split(","))
    assert 0.0 <= got["datasets"][0]["unpredictability"]["total"]["median"] <= 1.0
    with pytest.raises(drive.DriveError, match="robot"):
        bad = tmp_path / "bad.toml"
        bad.write_text('[[dataset]]\nraw = "log.csv"\n')
        drive.bench(bad)


def test_bench_adapt_equals_drive_bench_adapt(tmp_path):
    suite = tmp_path / "suite.toml"
    suite.write_text(
        '[[dataset]]\nbundled = "warthog_grass_2024-08-08"\n'
        '[[dataset]]\nbundled = "warthog_asphalt_slow_2024-08-08"\n'
    )
    expected = json.loads(
        cli(
            "bench", "--suite", suite, "--json", "--models", "slip-blr", "--no-transfer",
            "--adapt", "--adapt-times", "0,30",
        ).stdout
    )
    got = drive.bench(str(suite), models="slip-blr", transfer=False, adapt=[0, 30])
    close(got, expected)
    assert len(got["adaptation"]["pairs"]) == 2
    assert "adaptation" not in drive.bench(str(suite), models="slip-blr", transfer=False)
    with pytest.raises(drive.DriveError, match="adapt must be"):
        drive.bench(str(suite), models="slip-blr", adapt="yes")
    # With a third run, each pair's terrain library (drive bench --adapt-library).
    suite.write_text(suite.read_text() + '[[dataset]]\nbundled = "warthog_asphalt_a"\n')
    expected = json.loads(
        cli(
            "bench", "--suite", suite, "--json", "--models", "slip-blr", "--no-transfer",
            "--adapt", "--adapt-times", "0,30", "--adapt-library",
        ).stdout
    )
    got = drive.bench(str(suite), models="slip-blr", transfer=False, adapt=[0, 30], adapt_library=True)
    close(got, expected)
    assert all(len(p["library"]) == 2 for p in got["adaptation"]["pairs"])
    with pytest.raises(drive.DriveError, match="give adapt too"):
        drive.bench(str(suite), models="slip-blr", adapt_library=True)


def test_adapt_equals_drive_adapt_json(tmp_path):
    """drive.adapt with a dataset prior and with a fitted model as the prior: the dicts of
    `drive adapt --json` with the same prior (a dataset, a model file)."""
    prior = drive.load_dataset("bundled:warthog_asphalt_a")
    target = drive.load_dataset("bundled:warthog_grass_2024-08-08")
    expected = json.loads(
        cli(
            "adapt", "--prior", "bundled:warthog_asphalt_a",
            "--data", "bundled:warthog_grass_2024-08-08",
            "--models", "slip-blr", "--times", "0,30,60", "--json",
        ).stdout
    )
    calls = []
    got = drive.adapt(prior, target, models="slip-blr", times=[0, 30, 60],
                      progress=lambda done, total: calls.append((done, total)))
    close(got, expected)
    assert {p["model"] for p in got["curve"]} == {"adaptive", "frozen", "scratch", "own"}
    # Its progress: one unit per model, the last call the whole.
    assert calls and calls[-1] == (1, 1), calls
    # A fitted model as the prior: the same as its model file given to the command line.
    model = drive.fit(prior, "slip-blr")
    path = tmp_path / "prior.json"
    model.save(path)
    expected = json.loads(
        cli("adapt", "--prior", path, "--data", "bundled:warthog_grass_2024-08-08",
            "--times", "0,60", "--json").stdout
    )
    got = drive.adapt(model, target, times=[0, 60])
    close(got, expected)
    assert got["extrapolation"] is None
    with pytest.raises(drive.DriveError, match="prior must be"):
        drive.adapt("bundled:warthog_asphalt_a", target)
    with pytest.raises(drive.DriveError, match="one model"):
        drive.adapt(model, target, models="slip-blr,slip-ipem")
    # A terrain library (drive adapt --library): the same dict from Python.
    expected = json.loads(
        cli("adapt", "--prior", "bundled:warthog_asphalt_a", "--data", "bundled:warthog_grass_2024-08-08",
            "--library", "bundled:warthog_drive", "--models", "slip-blr", "--times", "0,30", "--json").stdout
    )
    got = drive.adapt(prior, target, models="slip-blr", times=[0, 30],
                      library=[drive.load_dataset("bundled:warthog_drive")])
    close(got, expected)
    assert got["library"] == ["warthog-asphalt-a", "warthog-drive"]
    with pytest.raises(drive.DriveError, match="library entries must be drive.Dataset"):
        drive.adapt(prior, target, library=["bundled:warthog_drive"])


def test_an_adaptive_model_fed_the_windows_driven_is_drive_adapts(tmp_path):
    """drive.AdaptiveModel streamed the target's first 30 and 60 s: the prior itself at 30 s,
    and at 60 s (the ground changed) the model `drive adapt` scores, to 1e-9; its adapted
    model saves and loads like any."""
    pd = pytest.importorskip("pandas")
    prior = drive.fit(drive.load_dataset("bundled:warthog_asphalt_2024-08-07"), "slip-blr")
    target = drive.load_dataset("bundled:warthog_asphalt_slow_2024-08-08")
    expected = drive.adapt(prior, target, times=[30, 60])
    point = {(p["model"], p["t_s"]): p for p in expected["curve"]}
    df, meta = target.to_pandas(), target.meta
    windows = list(dict.fromkeys(df["window"]))
    train = expected["train_windows"]

    def part(ids):
        return drive.Dataset.from_pandas(df[df["window"].isin(ids)].copy(), {**meta, "windows": len(ids)})

    evaluation = part(windows[train:])
    adaptive = drive.AdaptiveModel(prior)
    assert adaptive.windows == 0 and not adaptive.changed
    for t, first, last in [(30, 0, 15), (60, 15, 30)]:
        adaptive.add(part(windows[first:last]))
        assert adaptive.windows == last
        assert adaptive.changed == point[("adaptive", t)]["ground_changed"]
        scores = adaptive.model().score(evaluation)
        for key, axis in [("translational_median_m", "translational_m"), ("rotational_median_rad", "rotational_rad")]:
            assert scores[axis]["all"]["median"] == pytest.approx(point[("adaptive", t)][key], rel=1e-9)
    # This pair's ground changes by 60 s (a correction or a refit drives), not by 30 s.
    assert not point[("adaptive", 30)]["ground_changed"] and point[("adaptive", 60)]["ground_changed"]
    assert point[("adaptive", 60)]["translational_median_m"] != point[("frozen", 60)]["translational_median_m"]
    path = tmp_path / "adapted.json"
    adaptive.model().save(path)
    again = drive.load_model(path).score(evaluation)
    assert again["translational_m"]["all"]["median"] == pytest.approx(point[("adaptive", 60)]["translational_median_m"], rel=1e-9)
    # Saved after 30 s and read back, it adapts on as the one that went on.
    halfway = drive.AdaptiveModel(prior)
    halfway.add(part(windows[:15]))
    halfway.save(tmp_path / "state.json")
    resumed = drive.AdaptiveModel.load(tmp_path / "state.json")
    assert resumed.windows == 15 and "windows=15" in repr(resumed)
    resumed.add(part(windows[15:30]))
    assert resumed.changed and resumed.windows == 30
    assert resumed.model().score(evaluation)["translational_m"]["all"]["median"] == pytest.approx(
        point[("adaptive", 60)]["translational_median_m"], rel=1e-9)
    with pytest.raises(drive.DriveError, match="adaptive state"):
        drive.AdaptiveModel.load(path)  # a model file, not a state
    with pytest.raises(drive.DriveError, match="prior must be"):
        drive.AdaptiveModel(target)
    with pytest.raises(drive.DriveError, match="vehicle"):
        adaptive.add(drive.load_dataset("bundled:husky_drive"))


def test_from_pandas_equals_the_files(husky, tmp_path):
    pd = pytest.importorskip("pandas")
    df = pd.read_csv(ROOT / "data" / "husky_drive.csv.gz")
    meta = json.loads((ROOT / "data" / "husky_drive.meta.json").read_text())
    data = drive.Dataset.from_pandas(df, meta)
    assert len(data) == len(husky) == 603 and data.intervals == 201
    close(drive.evaluate(data, models=["slip-blr"]), drive.evaluate(husky, models=["slip-blr"]))
    with pytest.raises(drive.DriveError, match="missing column"):
        drive.Dataset.from_pandas(df.drop(columns=["yaw"]), meta)


def test_a_dataset_is_never_saved_onto_the_files_it_was_read_from(husky, tmp_path):
    # An eleventh outside sweep: save onto the CSV it was loaded from rewrote it without a
    # word, losing its calib_step column and the sidecar's source (licence) fields.
    csv = tmp_path / "run.csv"
    husky.save(csv)
    data = drive.load_dataset(csv)
    before = csv.read_bytes(), csv.with_name("run.meta.json").read_bytes()
    for target in (csv, str(csv)):
        with pytest.raises(drive.DriveError, match="the file this dataset was read from"):
            data.save(target)
    assert (csv.read_bytes(), csv.with_name("run.meta.json").read_bytes()) == before
    data.save(tmp_path / "copy.csv")
    assert len(drive.load_dataset(tmp_path / "copy.csv")) == len(husky)


def test_saves_are_named_for_what_they_are_and_never_replace_a_dataset(husky, tmp_path):
    # Issue 63, a third sweep: Model.save wrote over a dataset's sidecar (run.meta.json, or
    # run.json beside run.csv: the dataset no longer loaded) and under .npy or .csv names;
    # Dataset.save wrote a CSV under .json or .npy. The command line's rules apply.
    husky.save(tmp_path / "run.csv")
    (tmp_path / "old.csv").write_bytes((tmp_path / "run.csv").read_bytes())
    (tmp_path / "old.json").write_bytes((tmp_path / "run.meta.json").read_bytes())
    model = drive.fit(husky, model="naive")
    for name, says in [
        ("run.meta.json", "the name says .meta.json"),
        ("old.json", "the sidecar of the dataset"),
        ("model.npy", "the name says .npy"),
        ("model.csv", "the name says .csv"),
    ]:
        with pytest.raises(drive.DriveError, match=says):
            model.save(tmp_path / name)
    for name in ["copy.json", "copy.npy"]:
        with pytest.raises(drive.DriveError, match="the name says"):
            husky.save(tmp_path / name)
    assert len(drive.load_dataset(tmp_path / "run.csv")) == len(husky)
    assert len(drive.load_dataset(tmp_path / "old.csv")) == len(husky)
    model.save(tmp_path / "model.json")


def test_a_number_that_is_not_finite_is_named_by_its_place(husky):
    # An eleventh outside sweep: "value 3 is not a finite number" read as the value itself.
    model = drive.fit(husky, model="naive")
    with pytest.raises(drive.DriveError, match=r"entry 3 \(counting from 0, row by row\) is inf"):
        model.predict(np.array([[1.0, 2.0], [3.0, np.inf]]))


def commands_csv(path, commands, dt):
    rows = ["t,cmd_left,cmd_right"] + [f"{k * dt!r},{float(l)!r},{float(r)!r}" for k, (l, r) in enumerate(commands)]
    path.write_text("\n".join(rows) + "\n")


def cli_poses(model, commands, tmp_path, *flags):
    """The x, y, yaw columns `drive predict` prints for `model` (saved to a file) on
    `commands`, with the start `flags`."""
    saved = tmp_path / "model.json"
    model.save(saved)
    cmds = tmp_path / "cmds.csv"
    commands_csv(cmds, commands, model.dt)
    lines = cli("predict", "--model", saved, "--commands", cmds, *flags).stdout.strip().splitlines()
    header = lines[0].split(",")
    table = np.array([[float(v) for v in l.split(",")] for l in lines[1:]])
    return table[:, [header.index(c) for c in ("x", "y", "yaw")]]


def test_predict_equals_drive_train_and_predict(husky, tmp_path):
    rng = np.random.default_rng(7)
    commands = rng.uniform(-5, 5, size=(40, 2))
    for name in ["slip-blr", "acc-blr", "powertrain"]:
        model = drive.fit(husky, name, split=0.5)
        saved = tmp_path / f"{name}.json"
        model.save(saved)
        # The command line's own fit, saved, loads in Python and predicts the same.
        cli_model = tmp_path / f"{name}-cli.json"
        cli("train", "--model", name, "--split", "0.5", "--out", cli_model)
        loaded = drive.load_model(cli_model)
        cmds = tmp_path / "cmds.csv"
        commands_csv(cmds, commands, model.dt)
        out = cli("predict", "--model", saved, "--commands", cmds, "--start", "1,2,0.3", "--start-wheels", "2,3").stdout
        lines = out.strip().splitlines()
        header = lines[0].split(",")
        table = np.array([[float(v) for v in l.split(",")] for l in lines[1:]])
        expected = table[:, [header.index(c) for c in ("x", "y", "yaw")]]
        for m in (model, loaded):
            got = m.predict(commands, start=(1.0, 2.0, 0.3), start_wheels=(2.0, 3.0))
            assert got.shape == (40, 3)
            np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)


def test_predict_warns_where_the_command_line_notes(husky):
    """Commands or a start beyond what the model was trained on are warned about, as
    drive predict notes them; a value beyond what its readers take (1e9) is refused."""
    model = drive.fit(husky, "slip-blr", split=0.5)
    far = np.full((40, 2), 100.0)
    with pytest.warns(UserWarning, match=r"command 0 holds 100 rad/s on axis 'cmd_left', beyond the commands it was trained on"):
        model.predict(far)
    with pytest.warns(UserWarning, match=r"beyond the commands it was trained on"):
        model.predict_batch(np.stack([np.zeros((40, 2)), far]))
    with pytest.warns(UserWarning, match=r"start_wheels holds 100 rad/s"):
        model.predict(np.zeros((40, 2)), start_wheels=(100.0, 100.0))
    with pytest.warns(UserWarning, match=r"start_wheels\[1\] holds 100 rad/s"):
        model.predict_batch(np.zeros((2, 40, 2)), start_wheels=np.array([[0.0, 0.0], [100.0, 100.0]]))
    for huge in (1e12, 1e300):
        with pytest.raises(drive.DriveError, match=r"beyond 1e\+?0?9"):
            model.predict(np.full((40, 2), huge))
        with pytest.raises(drive.DriveError, match=r"beyond 1e\+?0?9"):
            model.predict_batch(np.full((1, 40, 2), huge))
    # Within what it knows: no warning.
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(np.full((40, 2), 1.0))


def test_bench_skips_a_dataset_it_cannot_read_as_the_command_line_does(tmp_path):
    """A suite entry whose file is missing is skipped and named (the command line's
    behaviour); the rest is benchmarked."""
    suite = tmp_path / "suite.toml"
    suite.write_text('[[dataset]]\npath = "missing.csv"\n[[dataset]]\npath = "bundled:husky_drive"\n')
    result = drive.bench(suite=suite, models="naive", transfer=False)
    assert [d["name"] for d in result["datasets"]] == ["husky_drive"]
    assert [s["dataset"] for s in result["skipped"]] == ["missing"]
    assert "No such file" in result["skipped"][0]["reason"] or "cannot read" in result["skipped"][0]["reason"]


def test_predict_batch_matches_predict_row_by_row(husky):
    model = drive.fit(husky, "slip-blr", split=0.5)
    rng = np.random.default_rng(3)
    commands = rng.uniform(-6, 6, size=(257, 40, 2))
    starts = rng.uniform(-1, 1, size=(257, 3))
    wheels = rng.uniform(-2, 2, size=(257, 2))
    batch = model.predict_batch(commands, starts=starts, start_wheels=wheels)
    assert batch.shape == (257, 40, 3)
    for b in range(257):
        one = model.predict(commands[b], start=starts[b], start_wheels=wheels[b])
        assert np.array_equal(batch[b], one), b
    # Default starts: the origin at rest.
    np.testing.assert_array_equal(model.predict_batch(commands[:2])[1], model.predict(commands[1]))


def test_the_start_yaw_rate_reaches_slip_ipem_as_on_the_command_line(husky, tmp_path):
    """slip-ipem reads the IMU's yaw rate at the start (its yaw disturbance): predict's
    start_yaw_rate is drive predict's --start-yaw-rate, and predict_batch's start_yaw_rates
    its rows."""
    model = drive.fit(husky, "slip-ipem", split=0.5)
    rng = np.random.default_rng(11)
    commands = rng.uniform(-5, 5, size=(40, 2))
    expected = cli_poses(model, commands, tmp_path, "--start-wheels", "2,3", "--start-yaw-rate", "0.6")
    got = model.predict(commands, start_wheels=(2.0, 3.0), start_yaw_rate=0.6)
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)
    # The measured yaw rate changes the prediction; None is no measurement.
    assert not np.allclose(got, model.predict(commands, start_wheels=(2.0, 3.0)))
    np.testing.assert_array_equal(
        model.predict(commands, start_yaw_rate=None), model.predict(commands)
    )
    batch_commands = rng.uniform(-5, 5, size=(9, 40, 2))
    rates = rng.uniform(-1, 1, size=9)
    batch = model.predict_batch(batch_commands, start_yaw_rates=rates)
    for b in range(9):
        assert np.array_equal(batch[b], model.predict(batch_commands[b], start_yaw_rate=rates[b])), b
    with pytest.raises(drive.DriveError, match="start_yaw_rates must be a \\(9,\\) array"):
        model.predict_batch(batch_commands, start_yaw_rates=rates[:3])
    with pytest.raises(drive.DriveError, match="start_yaw_rate must be a number"):
        model.predict(commands, start_yaw_rate="fast")
    # Each start argument is named in its own error.
    for kwargs, says in [
        ({"start_yaw_rate": float("nan")}, "start_yaw_rate: entry 0 .counting from 0, row by row. is NaN, not a finite number"),
        ({"start_wheels": (0.0, float("inf"))}, "start_wheels: entry 1 .counting from 0, row by row. is inf, not a finite number"),
        ({"start": (0.0, 0.0, float("nan"))}, "start: entry 2 .counting from 0, row by row. is NaN, not a finite number"),
        ({"start_yaw_rate": 10**400}, r"got 1000000000.*\(401 characters\)$"),
    ]:
        with pytest.raises(drive.DriveError, match=says):
            model.predict(commands, **kwargs)
    with pytest.raises(drive.DriveError, match="got booleans"):
        model.predict_batch(batch_commands, start_yaw_rates=np.ones(9, dtype=bool))
    with pytest.raises(drive.DriveError, match=r"must be a \(B,\) array, got shape \[\]"):
        model.predict_batch(batch_commands, start_yaw_rates=0.5)


def test_the_start_velocity_reaches_slip_ipem_as_on_the_command_line(husky, tmp_path):
    """fit(start="encoders+imu+localization") is drive train --start, predict's
    start_velocity drive predict's --start-velocity, predict_batch's start_velocities its
    rows, and evaluate(start=...) drive eval --start."""
    start = "encoders+imu+localization"
    model = drive.fit(husky, "slip-ipem", split=0.5, start=start)
    rng = np.random.default_rng(12)
    commands = rng.uniform(-5, 5, size=(40, 2))
    expected = cli_poses(model, commands, tmp_path, "--start-wheels", "2,3", "--start-velocity", "0.4,-0.1")
    got = model.predict(commands, start_wheels=(2.0, 3.0), start_velocity=(0.4, -0.1))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)
    assert not np.allclose(got, model.predict(commands, start_wheels=(2.0, 3.0)))
    batch_commands = rng.uniform(-5, 5, size=(5, 40, 2))
    velocities = rng.uniform(-1, 1, size=(5, 2))
    batch = model.predict_batch(batch_commands, start_velocities=velocities)
    for b in range(5):
        one = model.predict(batch_commands[b], start_velocity=velocities[b])
        assert np.array_equal(batch[b], one), b
    with pytest.raises(drive.DriveError, match=r"start_velocities must be a \(5, 2\) array"):
        model.predict_batch(batch_commands, start_velocities=velocities[:2])
    with pytest.raises(drive.DriveError, match="start_velocity: entry 1 .counting from 0, row by row. is .*, not a finite number"):
        model.predict(commands, start_velocity=(0.0, float("nan")))
    expected = json.loads(cli("eval", "--json", "--models", "slip-ipem", "--start", start).stdout)
    close(drive.evaluate(husky, models=["slip-ipem"], start=start), expected)
    with pytest.raises(drive.DriveError, match="unknown start information"):
        drive.evaluate(husky, models=["slip-blr"], start="gps")
    # A model named twice: refused as by the command line (two rows of one name before).
    with pytest.raises(drive.DriveError, match="the model 'naive' is named twice"):
        drive.evaluate(husky, models=["naive", "slip-blr", "naive"])


def test_user_errors_raise_with_the_command_lines_message(husky, tmp_path):
    missing = tmp_path / "missing.csv"
    cli_err = cli("eval", "--data", missing, ok=False).stderr.strip()
    assert cli_err.startswith("error: ")
    with pytest.raises(drive.DriveError) as e:
        drive.load_dataset(missing)
    assert str(e.value) == cli_err[len("error: "):]
    with pytest.raises(drive.DriveError, match="unknown model 'gp'"):
        drive.fit(husky, "gp")
    with pytest.raises(drive.DriveError, match="unknown model 'gp'"):
        drive.evaluate(husky, models=["gp"])
    with pytest.raises(drive.DriveError, match="split"):
        drive.evaluate(husky, split=1.5)
    model = drive.fit(husky, "naive")
    with pytest.raises(drive.DriveError, match=r"\(H, 2\)"):
        model.predict(np.zeros((5, 3)))
    with pytest.raises(drive.DriveError, match="not a finite number"):
        model.predict(np.array([[np.nan, 1.0]]))
    with pytest.raises(drive.DriveError, match="starts must be"):
        model.predict_batch(np.zeros((2, 4, 2)), starts=np.zeros((3, 3)))
    with pytest.raises(drive.DriveError, match="start must be 3 numbers"):
        model.predict(np.zeros((5, 2)), start=(0, 0))
    with pytest.raises(drive.DriveError, match="array of numbers"):
        model.predict([["a", "b"]])
    with pytest.raises(drive.DriveError, match="split must be a number"):
        drive.evaluate(husky, split="a")
    # Integer arrays, float32 arrays and lists are numbers too: the same poses.
    slip = drive.fit(husky, "slip-blr", split=0.5)
    ints = np.tile([3, 4], (40, 1))
    expected = slip.predict(ints.astype(float))
    for same in (ints, ints.astype(np.float32), ints.tolist()):
        assert np.array_equal(slip.predict(same), expected)
    assert np.array_equal(slip.predict_batch(ints[None]), expected[None])
    # The command line's message for a missing model file.
    none = tmp_path / "none.json"
    commands = tmp_path / "c.csv"
    commands.write_text("t,cmd_left,cmd_right\n0,1,1\n")
    cli_err = cli("predict", "--model", none, "--commands", commands, ok=False).stderr.strip()
    with pytest.raises(drive.DriveError) as e:
        drive.load_model(none)
    assert str(e.value) == cli_err[len("error: "):]
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(drive.DriveError):
        drive.load_model(bad)
    # DriveError is a ValueError: code catching ValueError keeps working.
    assert issubclass(drive.DriveError, ValueError)


def test_a_bag_with_stamped_commands_and_joint_states_gives_the_csvs_windows(tmp_path):
    pytest.importorskip("rosbags")
    raw = tmp_path / "raw.csv"
    raw.write_bytes(gzip.decompress((ROOT / "tests" / "bags" / "husky_snow_raw.csv.gz").read_bytes()))
    bag = tmp_path / "bag"
    subprocess.run(
        [sys.executable, ROOT / "tests" / "bags" / "make_bag.py", raw, bag, "--variant", "stamped-joints"],
        check=True,
        capture_output=True,
    )
    cli("import", "--raw", raw, "--robot", "husky", "--out", tmp_path / "a.csv")
    cli(
        "import", "--bag", bag, "--robot", "husky", "--out", tmp_path / "b.csv",
        "--topic", "cmd=/cmd_vel",
        "--topic", "meas_left_vel=/joint_states:left_wheel_joint",
        "--topic", "meas_right_vel=/joint_states:right_wheel_joint",
    )
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def runner_commands(runner, seconds):
    rate = runner.rate_hz
    return [
        runner.tick(t=k / rate, encoder=(0.0, 0.0), pose=(0.0, 0.0, 0.0), deadman=True)
        for k in range(int(round(seconds * rate)))
    ]


@pytest.mark.parametrize("robot,sampler,seed", [("husky", "uniform", 4), ("warthog", "grid", 1)])
def test_protocol_runner_over_the_nominal_space_equals_drive_protocol(tmp_path, robot, sampler, seed):
    out = tmp_path / "schedule.csv"
    cli("protocol", "--robot", robot, "--sampler", sampler, "--seed", seed, "--intervals", 3, "--out", out)
    rows = [line.split(",") for line in out.read_text().splitlines()[1:]]
    runner = drive.ProtocolRunner(robot, sampler, seed, characterize=False, max_intervals=3)
    cmds = runner_commands(runner, 18.0 + 1.0)
    driving = [c for c in cmds if c.recording]
    assert len(driving) == len(rows) == 360
    for c, row in zip(driving, rows):
        assert c.interval == int(row[1]) and c.phase == row[2]
        assert c.inputs == pytest.approx((float(row[3]), float(row[4])), rel=1e-9, abs=1e-12)
        assert tuple(c) == c.inputs and len(c) == 2
    assert runner.done and runner.stop_reason == "intervals" and runner.completed_intervals == 3
    assert all(tuple(c) == (0.0, 0.0) for c in cmds[360:])


def test_protocol_runner_takes_measurements_as_a_dict_an_object_or_keywords():
    def run(make):
        runner = drive.ProtocolRunner("husky", "uniform", 2)
        return [
            tuple(runner.tick(make(k / 20, (0.1 * k, 0.1 * k), (0.0, 0.0, 0.0) if k % 2 else None)))
            for k in range(100)
        ]

    as_dict = run(lambda t, e, p: {"t": t, "encoder": e, "pose": p, "deadman": True})
    as_object = run(lambda t, e, p: drive.Measurements(t, e, p, deadman=True))
    assert as_dict == as_object
    runner = drive.ProtocolRunner("husky", "uniform", 2)
    as_keywords = [
        tuple(runner.tick(t=k / 20, encoder=(0.1 * k, 0.1 * k), pose=(0.0, 0.0, 0.0) if k % 2 else None, deadman=True))
        for k in range(100)
    ]
    assert as_dict == as_keywords
    # No localization yet at the first tick: held still; then the first characterization
    # probe drives straight ahead.
    assert as_dict[0] == (0.0, 0.0)
    assert as_dict[1][0] == as_dict[1][1] > 0


def test_protocol_runner_errors_are_the_command_lines():
    for args, flag in [(("husk",), ["--robot", "husk"]), (("husky", "unif"), ["--robot", "husky", "--sampler", "unif"])]:
        message = cli("protocol", *flag, "--intervals", 1, "--out", "/nonexistent/x.csv", ok=False).stderr
        with pytest.raises(drive.DriveError) as e:
            drive.ProtocolRunner(*args)
        assert message.strip() == f"error: {e.value}"
    runner = drive.ProtocolRunner("husky")
    for bad, match in [
        ({"t": 0.0, "encoder": (0, 0)}, "need 'deadman'"),
        ({"encoder": (0, 0), "deadman": True}, "need 't'"),
        ({"t": 0.0, "deadman": True, "wheels": (0, 0)}, "unknown measurement 'wheels'"),
        ({"t": 0.0, "deadman": "yes"}, "deadman must be True or False"),
        ({"t": 0.0, "deadman": 1}, "deadman must be True or False"),
        ({"t": "5", "deadman": True}, "t must be a time"),
        ({"t": 0.0, "deadman": True, "encoder": "12"}, "encoder must be 2 numbers"),
        ({"t": 0.0, "deadman": True, "pose": "345"}, "pose must be 3 numbers"),
        ({"t": 0.0, "deadman": True, "encoder": (0, 0, 0)}, "encoder must be 2 numbers"),
        ({"t": 0.0, "deadman": True, "pose": (0, float("nan"), 0)}, "pose: entry 1 .counting from 0, row by row. is NaN, not a finite"),
        ({"t": float("inf"), "deadman": True}, "t must be a finite time"),
    ]:
        with pytest.raises(drive.DriveError, match=match):
            runner.tick(bad)
    runner.tick(t=5.0, deadman=True)
    with pytest.raises(drive.DriveError, match="time went backwards"):
        runner.tick(t=4.0, deadman=True)
    for kwargs, match in [
        ({"geofence": 0.0}, "geofence must be a positive"),
        ({"max_intervals": 0}, "max_intervals must be a whole number of intervals, at least 1"),
        ({"geofence": 5.0, "localization": False}, "geofence needs localization"),
        ({"max_duration": float("nan")}, "max_duration must be a positive"),
        ({"seed": -1}, "seed must be an integer"),
        ({"max_intervals": -1}, "max_intervals must be a whole number"),
        ({"geofence": "20"}, "geofence must be a number"),
        ({"wheels": 2}, "unknown option 'wheels'"),
    ]:
        with pytest.raises(drive.DriveError, match=match):
            drive.ProtocolRunner("husky", **kwargs)


def test_protocol_runner_stops_the_robot_without_the_deadman_or_sensors():
    runner = drive.ProtocolRunner("husky", "uniform", 0, characterize=False)
    moving = runner.tick(t=0.0, encoder=(0, 0), pose=(0, 0, 0), deadman=True)
    assert runner.state == "driving" and tuple(moving) != (0.0, 0.0)
    released = runner.tick(t=0.05, encoder=(0, 0), pose=(0, 0, 0), deadman=False)
    assert tuple(released) == (0.0, 0.0) and runner.pause_reason == "deadman released"
    runner.tick(t=0.1, encoder=(0, 0), pose=(0, 0, 0), deadman=True)
    stale = runner.tick(t=1.0, deadman=True)  # nothing measured for 0.9 s
    assert tuple(stale) == (0.0, 0.0) and runner.pause_reason in ("encoders stale", "localization stale")
    fenced = drive.ProtocolRunner("husky", "uniform", 0, characterize=False, geofence=1.0)
    fenced.tick(t=0.0, encoder=(0, 0), pose=(0, 0, 0), deadman=True)
    out = fenced.tick(t=0.05, encoder=(0, 0), pose=(1.5, 0, 0), deadman=True)
    assert tuple(out) == (0.0, 0.0) and fenced.done and fenced.stop_reason.startswith("geofence: 1.50 m")


def test_wrong_types_and_unintegrable_inputs_raise_drive_errors(husky, tmp_path):
    """Every user error is a DriveError, the wrong Python type of an argument too; a
    prediction is never a non-finite number (the command line's refusal)."""
    model = drive.fit(husky, "slip-blr", split=0.5)
    commands = np.zeros((40, 2))
    for call, says in [
        (lambda: model.predict(commands, start="abc"), "start must be 3 numbers"),
        (lambda: model.predict(commands, start=5), "start must be 3 numbers"),
        (lambda: model.predict(commands, start=[0, "x", 0]), "start must be 3 numbers"),
        (lambda: model.predict(commands, start_wheels=(True, 1.0)), "start_wheels must be 2"),
        (lambda: model.predict(np.zeros((40, 2)) + 1j), "real numbers"),
        (lambda: drive.fit(husky, "slip-blr", split="a"), "split must be a number"),
        (lambda: drive.fit(husky, 123), "model must be a model name"),
        (lambda: drive.fit(None, "slip-blr"), "dataset must be a drive.Dataset"),
        (lambda: drive.evaluate("x"), "dataset must be a drive.Dataset"),
        (lambda: drive.evaluate(husky, models=5), "models must be model names"),
        (lambda: drive.load_dataset(5), "path must be a path"),
        (lambda: drive.load_model(None), "path must be a path"),
        (lambda: model.save(3.5), "path must be a path"),
        (lambda: drive.Dataset.from_pandas({"a": [1]}, {}), "df must be a pandas DataFrame"),
        (lambda: drive.ProtocolRunner(None), "robot must be"),
        (lambda: drive.ProtocolRunner("husky", None), "sampler must be"),
    ]:
        with pytest.raises(drive.DriveError, match=says):
            call()
    # Beyond what the model can integrate: refused as the command line refuses it.
    huge = np.full((40, 2), 1e300)
    model_file = tmp_path / "m.json"
    model.save(model_file)
    cmds = tmp_path / "huge.csv"
    cmds.write_text("t,cmd_left,cmd_right\n" + "".join(f"{k * 0.05},1,1\n" for k in range(40)))
    cli_err = cli(
        "predict", "--model", model_file, "--commands", cmds, "--start-wheels", "1e300,1e300",
        ok=False,
    ).stderr.strip()
    # The command line refuses a start beyond 1e9 before predicting, as it refuses commands.
    assert "--start-wheels = 1e300 is more than the limit of 1e9" in cli_err
    # Commands of 1e300 in a file are refused as corrupted numbers before any prediction.
    cmds.write_text("t,cmd_left,cmd_right\n" + "".join(f"{k * 0.05},1e300,1e300\n" for k in range(40)))
    cli_err = cli("predict", "--model", model_file, "--commands", cmds, ok=False).stderr.strip()
    assert "is more than the limit of 1e9" in cli_err
    # And so does Python, the commands and the start alike (the readers' 1e9).
    with pytest.raises(drive.DriveError, match=r"commands: entry 0 .* is 1e300, beyond 1e9"):
        model.predict(huge, start_wheels=(1e300, 1e300))
    with pytest.raises(drive.DriveError, match=r"start_wheels: entry 0 .* is 1e300, beyond 1e9"):
        model.predict(commands, start_wheels=(1e300, 1e300))
    with pytest.raises(drive.DriveError, match=r"commands: entry .* is 1e300, beyond 1e9"):
        model.predict_batch(np.stack([commands, huge]), start_wheels=[[0, 0], [1e300, 1e300]])
    with pytest.raises(drive.DriveError, match=r"start_wheels: entry 2 .* is 1e300, beyond 1e9"):
        model.predict_batch(np.stack([commands, commands]), start_wheels=[[0, 0], [1e300, 1e300]])


def test_a_protocol_runner_used_from_another_thread_raises_a_drive_error():
    import threading

    runner = drive.ProtocolRunner("husky", "uniform", seed=0, characterize=False)
    runner.tick(t=0.0, encoder=(0.0, 0.0), pose=(0.0, 0.0, 0.0), deadman=True)
    caught = []

    def other():
        try:
            runner.tick(t=0.05, encoder=(0.0, 0.0), pose=(0.0, 0.0, 0.0), deadman=True)
        except Exception as e:  # what a node's handler catches
            caught.append(e)

    t = threading.Thread(target=other)
    t.start()
    t.join()
    assert len(caught) == 1 and isinstance(caught[0], drive.DriveError), caught
    assert "thread" in str(caught[0])
    # Still usable from its own thread.
    runner.tick(t=0.05, encoder=(0.0, 0.0), pose=(0.0, 0.0, 0.0), deadman=True)


def test_a_three_input_base_predicts_as_the_command_line_in_single_and_batch(tmp_path):
    """The omnidirectional base (v_x, v_y, w): a model fitted on its simulated run takes
    (H, 3) commands and three start inputs, as `drive predict` does; a batch equals its rows;
    two columns are refused with the vehicle's count."""
    data = tmp_path / "omni.csv"
    cli("simulate", "--robot", "ridgeback", "--terrain", "gravel", "--duration", "240", "--seed", "5", "--out", data)
    omni = drive.load_dataset(data)
    model = drive.fit(omni, "slip-blr", split=0.5)
    saved = tmp_path / "omni.json"
    model.save(saved)
    rng = np.random.default_rng(11)
    commands = rng.uniform(-1, 1, size=(40, 3))
    cmds = tmp_path / "cmds.csv"
    with open(cmds, "w") as f:
        f.write("t,cmd_vx,cmd_vy,cmd_w\n")
        for k, (a, b, c) in enumerate(commands):
            f.write(f"{k * model.dt!r},{float(a)!r},{float(b)!r},{float(c)!r}\n")
    out = cli("predict", "--model", saved, "--commands", cmds, "--start-wheels", "0.2,-0.1,0.3").stdout
    lines = out.strip().splitlines()
    header = lines[0].split(",")
    table = np.array([[float(v) for v in l.split(",")] for l in lines[1:]])
    expected = table[:, [header.index(c) for c in ("x", "y", "yaw")]]
    got = model.predict(commands, start_wheels=(0.2, -0.1, 0.3))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)
    # It drives sideways: the lateral commands move it.
    assert np.abs(got[:, 1]).max() > 0.05
    batch = model.predict_batch(np.stack([commands, commands[::-1]]), start_wheels=np.array([[0.2, -0.1, 0.3], [0.0, 0.0, 0.0]]))
    np.testing.assert_array_equal(batch[0], got)
    np.testing.assert_array_equal(batch[1], model.predict(commands[::-1]))
    assert model.input_for(0.5, 0.2) == (0.5, 0.0, 0.2)
    with pytest.raises(drive.DriveError, match=r"\(H, 3\)"):
        model.predict(commands[:, :2])
    with pytest.raises(drive.DriveError, match="3 numbers"):
        model.predict(commands, start_wheels=(0.2, 0.1))
    runner = drive.ProtocolRunner("ridgeback", "uniform", 1, characterize=False, max_intervals=1)
    assert runner.inputs == ("v_x", "v_y", "w")
    command = runner.tick(t=0.0, encoder=(0.0, 0.0, 0.0), pose=(0.0, 0.0, 0.0), deadman=True)
    assert tuple(command) == command.inputs
    with pytest.raises(drive.DriveError, match="3 numbers"):
        runner.tick(t=0.05, encoder=(0.0, 0.0), pose=None, deadman=True)
    assert len(command) == 3 and len(command.inputs) == 3


def test_the_data_checks_findings_are_python_warnings(tmp_path):
    """What `drive check` finds in a window CSV is a UserWarning on load, naming the check;
    the bundled Husky run passes every check (no warning)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        husky = drive.load_dataset()
    frozen = tmp_path / "frozen.csv"
    df = husky.to_pandas()
    for column in ("x", "y", "yaw"):
        df[column] = 0.0
    drive.Dataset.from_pandas(df, husky.meta).save(frozen)
    with pytest.warns(UserWarning, match=r"\(not-moving, which drive check calls fatal"):
        drive.load_dataset(frozen)


def test_bench_skips_a_useless_dataset_as_the_command_line_does(tmp_path):
    """A frozen localization in a suite: skipped with why (as `drive bench`), the other run
    ranked; `allow_useless=True` ranks both. (The frozen run is another run than the one
    beside it: a copy of that one with its localization alone altered is the same run, and
    no transfer would be planned between them.)"""
    pd = pytest.importorskip("pandas")  # noqa: F841
    other = drive.load_dataset("bundled:warthog_asphalt_slow_2024-08-08")
    df = other.to_pandas()
    for column in ("x", "y", "yaw"):
        df[column] = 0.0
    drive.Dataset.from_pandas(df, other.meta).save(tmp_path / "frozen.csv")
    suite = tmp_path / "suite.toml"
    suite.write_text('[[dataset]]\nbundled = "warthog_grass_2024-08-08"\n[[dataset]]\npath = "frozen.csv"\n')
    got = drive.bench(suite, models="naive", transfer=False)
    expected = json.loads(cli("bench", "--suite", suite, "--json", "--models", "naive", "--no-transfer").stdout)
    assert [d["name"] for d in got["datasets"]] == [d["name"] for d in expected["datasets"]]
    assert [s["dataset"] for s in got["skipped"]] == ["frozen"] == [s["dataset"] for s in expected["skipped"]]
    assert "not-moving" in got["skipped"][0]["reason"]
    allowed = drive.bench(suite, models="naive", transfer=False, allow_useless=True)
    assert len(allowed["datasets"]) == 2 and "skipped" not in allowed
    with pytest.raises(drive.DriveError, match="allow_useless"):
        drive.bench(suite, models="naive", allow_useless="yes")
    # With transfer, the skipped run's planned transfer units count as done: a progress bar
    # ends at its total.
    calls = []
    drive.bench(suite, models="naive", progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1][0] == calls[-1][1] > 2, calls


def test_every_call_that_fits_or_scores_refuses_useless_data_as_the_command_line_does(tmp_path):
    """A frozen localization: drive.evaluate, per_window, fit, adapt and Model.score raise
    DriveError naming the finding (`drive eval`, `train`, `adapt` refuse it), each with
    `allow_useless=True` to look anyway; a model the loader would refuse is not saved."""
    import warnings

    grass = drive.load_dataset("bundled:warthog_grass_2024-08-08")
    df = grass.to_pandas()
    for column in ("x", "y", "yaw"):
        df[column] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        frozen = drive.Dataset.from_pandas(df, grass.meta)
    model = drive.fit(grass, "naive")
    for call in (
        lambda **k: drive.evaluate(frozen, ["naive"], **k),
        lambda **k: drive.per_window(frozen, ["naive"], **k),
        lambda **k: drive.fit(frozen, "slip-blr", **k),
        lambda **k: drive.adapt(grass, frozen, models="slip-blr", times=[0], **k),
        lambda **k: drive.adapt(frozen, grass, models="slip-blr", times=[0], **k),
        lambda **k: model.score(frozen, **k),
        lambda **k: drive.report(frozen, tmp_path / "report", models=["naive"], **k),
    ):
        with pytest.raises(drive.DriveError, match=r"^(the dataset|the prior|the target) '") as refused:
            call()
        assert re.search(r"useless: .*\(not-moving; .*allow_useless=True", str(refused.value)), refused.value
    assert drive.evaluate(frozen, ["naive"], allow_useless=True)["models"][0]["name"] == "naive"
    assert model.score(frozen, allow_useless=True)["translational_m"]["all"]["windows"] > 0
    with pytest.raises(drive.DriveError, match="allow_useless must be True or False"):
        drive.evaluate(frozen, ["naive"], allow_useless="yes")
    # slip-BLR on a localization that never moves: a noise of zero, which the loader
    # refuses, so save refuses to write it (as drive train does).
    useless = drive.fit(frozen, "slip-blr", allow_useless=True)
    with pytest.raises(drive.DriveError, match="not one the loader accepts, so it is not written"):
        useless.save(tmp_path / "useless.json")
    assert not (tmp_path / "useless.json").exists()


def test_a_long_call_stops_on_ctrl_c_between_units_of_work():
    """Ctrl-C (SIGINT) during `drive.bench` raises KeyboardInterrupt before the benchmark is
    done: its work checks the signals between units; an exception from the progress
    callback stops it likewise."""
    import signal
    import threading

    calls = []

    def interrupt_once(done, total):
        # Ctrl-C as the first unit of work is done.
        calls.append((done, total))
        if len(calls) == 1:
            threading.Thread(target=os.kill, args=(os.getpid(), signal.SIGINT)).start()

    # Python's own Ctrl-C handler, whatever this process inherited: a process started in
    # the background by a shell without job control ignores SIGINT, and Python then
    # installs no handler (a CI script run with `&` saw no KeyboardInterrupt).
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            drive.bench(progress=interrupt_once)
    finally:
        signal.signal(signal.SIGINT, inherited)
    assert calls and calls[-1][0] < calls[-1][1], calls

    def stop(done, total):
        raise RuntimeError(f"stopped at {done} of {total}")

    with pytest.raises(RuntimeError, match="stopped at"):
        drive.bench(models="naive", transfer=False, progress=stop)


def test_evaluate_reports_its_progress_model_by_model(husky):
    calls = []
    got = drive.evaluate(husky, ["naive", "slip-blr"], progress=lambda d, t: calls.append((d, t)))
    assert [m["name"] for m in got["models"]] == ["naive", "slip-blr"]
    assert calls and calls[-1] == (2, 2) and all(t == 2 for _, t in calls), calls
