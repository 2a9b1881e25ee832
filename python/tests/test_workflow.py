"""A first week's work from Python alone: the console command, importing one's own logs,
DataFrames both ways, per-window errors, scoring on another dataset, covariances,
pickling, type hints. Each checked against the command line (the package's own `drive`
console command) to 1e-9 or exactly."""

import copy
import gzip
import json
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import drive
from test_api import BIN, ROOT, cli, close


@pytest.fixture(scope="module")
def husky():
    return drive.load_dataset()


@pytest.fixture(scope="module")
def raw_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("raw") / "husky_snow_raw.csv"
    path.write_bytes(gzip.decompress((ROOT / "tests" / "bags" / "husky_snow_raw.csv.gz").read_bytes()))
    return path


def test_the_console_command_is_the_command_line():
    # Installed with the package, next to this Python: no second build.
    assert BIN.exists()
    out = subprocess.run([str(BIN), "eval"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "DRIVE model comparison on husky-drive" in out.stdout
    assert "slip-blr   0.1357" in out.stdout
    # python -m drive runs the same; a usage error exits 2, an error 1, as the binary.
    out = subprocess.run([sys.executable, "-m", "drive", "list", "--json"], capture_output=True, text=True)
    assert out.returncode == 0 and "slip-blr+fopdt" in json.loads(out.stdout)["models"]
    assert subprocess.run([str(BIN), "no-such-command"], capture_output=True).returncode == 2
    out = subprocess.run([str(BIN), "eval", "--data", "/nonexistent.csv"], capture_output=True, text=True)
    assert out.returncode == 1 and out.stderr.startswith("error: ")


def test_import_raw_and_import_bag_equal_drive_import(raw_log, tmp_path):
    cli("import", "--raw", raw_log, "--robot", "husky", "--out", tmp_path / "cli.csv")
    data = drive.import_raw(raw_log, "husky")
    data.save(tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_text() == (tmp_path / "cli.csv").read_text()
    cli_meta = json.loads((tmp_path / "cli.meta.json").read_text())
    assert json.loads((tmp_path / "py.meta.json").read_text()) == cli_meta
    report = json.loads(cli("import", "--raw", raw_log, "--robot", "husky", "--out", tmp_path / "j.csv", "--json").stdout)
    report.pop("out")
    assert data.import_report == report
    assert drive.load_dataset(tmp_path / "cli.csv").import_report is None

    pytest.importorskip("rosbags")
    bag = tmp_path / "bag"
    subprocess.run(
        [sys.executable, ROOT / "tests" / "bags" / "make_bag.py", raw_log, bag, "--variant", "stamped-joints"],
        check=True,
        capture_output=True,
    )
    topics = {
        "cmd": "/cmd_vel",
        "meas_left_vel": "/joint_states:left_wheel_joint",
        "meas_right_vel": "/joint_states:right_wheel_joint",
    }
    cli("import", "--bag", bag, "--robot", "husky", "--out", tmp_path / "bag.csv", *(a for k, v in topics.items() for a in ("--topic", f"{k}={v}")))
    from_bag = drive.import_bag(bag, "husky", topics=topics)
    from_bag.save(tmp_path / "pybag.csv")
    assert (tmp_path / "pybag.csv").read_text() == (tmp_path / "bag.csv").read_text()
    # Without the topics it holds no command: the command line's error.
    with pytest.raises(drive.DriveError):
        drive.import_bag(bag, "husky")


def test_a_missing_file_is_a_file_not_found_error_with_the_command_lines_message(tmp_path):
    missing = tmp_path / "missing.json"
    commands = tmp_path / "c.csv"
    commands.write_text("t,cmd_left,cmd_right\n0,1,1\n")
    message = cli("predict", "--model", missing, "--commands", commands, ok=False).stderr.strip()
    for call in (
        lambda: drive.load_model(missing),
        lambda: drive.load_dataset(tmp_path / "missing.csv"),
        lambda: drive.import_raw(tmp_path / "missing.csv", "husky"),
        lambda: drive.import_bag(tmp_path / "missing_bag", "husky"),
    ):
        with pytest.raises(FileNotFoundError) as e:
            call()
        assert isinstance(e.value, drive.DriveError) and e.value.errno == 2
        assert e.value.filename is not None
    with pytest.raises(drive.DriveFileNotFoundError) as e:
        drive.load_model(missing)
    assert str(e.value) == message[len("error: "):]


def test_to_pandas_and_from_pandas_round_trip(husky, raw_log, tmp_path):
    pd = pytest.importorskip("pandas")
    df = husky.to_pandas()
    assert list(df.columns) == ["window", "phase", "k", "t", "cmd_left", "cmd_right", "enc_left", "enc_right", "x", "y", "yaw", "imu_yaw_rate"]
    assert len(df) == 603 * 40
    back = drive.Dataset.from_pandas(df, husky.meta)
    pd.testing.assert_frame_equal(back.to_pandas(), df)
    assert back.meta == {k: v for k, v in husky.meta.items()}
    # The files the command line reads, re-read by pandas: the sidecar's checksum of its
    # file is no reason to refuse data handed over in memory.
    files = pd.read_csv(ROOT / "data" / "husky_drive.csv.gz")
    meta = json.loads((ROOT / "data" / "husky_drive.meta.json").read_text())
    from_files = drive.Dataset.from_pandas(files, meta)
    close(drive.evaluate(from_files, models=["slip-blr"]), drive.evaluate(husky, models=["slip-blr"]))
    cli("import", "--raw", raw_log, "--robot", "husky", "--out", tmp_path / "run.csv")
    meta = json.loads((tmp_path / "run.meta.json").read_text())
    assert "csv" in meta  # the checksum of run.csv's bytes, which pandas does not keep
    reread = drive.Dataset.from_pandas(pd.read_csv(tmp_path / "run.csv"), meta)
    pd.testing.assert_frame_equal(reread.to_pandas(), drive.load_dataset(tmp_path / "run.csv").to_pandas())
    # An extra column is left out with a warning; the data is the same.
    with pytest.warns(UserWarning, match="left out: note"):
        extra = drive.Dataset.from_pandas(df.assign(note="x"), husky.meta)
    pd.testing.assert_frame_equal(extra.to_pandas(), df)
    # Errors name the DataFrame's column and row.
    broken = df.copy()
    broken.loc[5, "yaw"] = np.nan
    with pytest.raises(drive.DriveError, match=r"column 'yaw', row 5 \(index 5\).*not a finite number"):
        drive.Dataset.from_pandas(broken, husky.meta)
    broken = df.copy()
    broken.loc[7, "phase"] = "cruise"
    with pytest.raises(drive.DriveError, match=r"column 'phase', row 7 \(index 7\): 'cruise'"):
        drive.Dataset.from_pandas(broken, husky.meta)
    # What the parser finds (a window out of order) is reported at the DataFrame's row too.
    broken = df.copy()
    broken.loc[100, "window"] = 0
    with pytest.raises(drive.DriveError, match=r"DataFrame row 100 \(index 100\)"):
        drive.Dataset.from_pandas(broken, husky.meta)
    with pytest.raises(drive.DriveError, match="missing column 'yaw'"):
        drive.Dataset.from_pandas(df.drop(columns=["yaw"]), husky.meta)


def test_per_window_equals_drive_eval_per_window(husky, tmp_path):
    models = ["naive", "slip-blr", "slip-ipem"]
    cli("eval", "--models", ",".join(models), "--per-window", tmp_path / "w.csv")
    lines = (tmp_path / "w.csv").read_text().strip().splitlines()
    header = lines[0].split(",")
    rows = [dict(zip(header, l.split(","))) for l in lines[1:]]
    got = drive.per_window(husky, models)
    assert list(got) == header
    assert all(len(v) == len(rows) for v in got.values())
    for i, row in enumerate(rows):
        assert got["model"][i] == row["model"] and got["phase"][i] == row["phase"]
        assert got["window"][i] == int(row["window"]) and got["interval"][i] == int(row["interval"])
        for c in ("translational_m", "rotational_rad"):
            assert abs(got[c][i] - float(row[c])) <= 1e-9 * max(1.0, abs(float(row[c])))


def test_score_on_another_dataset_and_the_evaluation_half(husky, tmp_path):
    model = drive.fit(husky, "slip-blr", split=0.5)
    assert model.start == "encoders+imu"
    # On the evaluation half, the per-window errors of drive.per_window.
    errors = drive.per_window(husky, ["slip-blr"])
    score = model.score(husky)
    assert score["windows"] == 603 and score["model"] == model.name == "slip-blr+fopdt"
    by_window = {w["window"]: w["error"] for w in score["per_window"]}
    for window, t, r in zip(errors["window"], errors["translational_m"], errors["rotational_rad"]):
        assert abs(by_window[window]["translational"] - t) <= 1e-12
        assert abs(by_window[window]["rotational"] - r) <= 1e-12
    assert set(score["translational_m"]) == {"all", "transient", "steady"}
    assert score["translational_m"]["transient"]["windows"] == 201
    assert 0.0 < score["translational_m"]["all"]["median"] < 1.0
    assert set(score["uncertainty"]["coverage95"]) == {"0.5", "1.0", "2.0"}
    # Transfer: the Husky's model scored on another Husky run (imported in Python).
    raw = tmp_path / "raw.csv"
    raw.write_bytes(gzip.decompress((ROOT / "tests" / "bags" / "husky_snow_raw.csv.gz").read_bytes()))
    snow = drive.import_raw(raw, "husky")
    transfer = model.score(snow)
    assert transfer["windows"] == len(snow) and transfer["dataset"] == snow.name
    assert transfer["translational_m"]["all"]["median"] > 0.0
    # Another robot's data is refused, not scored: the Warthog is a differential drive
    # too, with other wheels.
    warthog = drive.load_dataset("bundled:warthog_grass_2024-08-08")
    assert warthog.meta["vehicle"]["type"] == husky.meta["vehicle"]["type"]
    with pytest.raises(drive.DriveError, match="fitted for the vehicle") as refused:
        model.score(warthog)
    # The refusal names what differs, as the scores across geometries do.
    ours, theirs = husky.meta["vehicle"]["baseline"], warthog.meta["vehicle"]["baseline"]
    assert f"baseline {ours} -> {theirs}" in str(refused.value), refused.value
    assert "allow_other_geometry=True" in str(refused.value)
    # Asked for (two calibrations of one robot, say), it is scored, with the difference as a
    # UserWarning and in the notes; the same geometry gives none.
    with pytest.warns(UserWarning, match="scored across geometries") as caught:
        across = model.score(warthog, allow_other_geometry=True)
    assert across["windows"] == len(warthog) and across["dataset"] == warthog.name
    assert across["translational_m"]["all"]["median"] > 0.0
    assert len(across["notes"]) == 1 and f"baseline {ours} -> {theirs}" in across["notes"][0]
    assert str(caught[0].message) == across["notes"][0]
    assert score["notes"] == [] and transfer["notes"] == []


def test_a_geometry_written_in_32_bit_floats_is_the_same_geometry(husky, tmp_path):
    # The outside sweep of 2026-12-04: a sidecar whose wheel radius and baseline were
    # written as 32-bit floats (0.16500000655651093 for 0.165) was "another geometry (+0.0%)".
    model = drive.fit(husky, "naive", split=0.5)
    csv = tmp_path / "husky.csv"
    csv.write_bytes(gzip.decompress((ROOT / "data" / "husky_drive.csv.gz").read_bytes()))
    meta = json.loads((ROOT / "data" / "husky_drive.meta.json").read_text())
    meta.pop("csv", None)
    for key in ("wheel_radius", "baseline"):
        meta[key] = float(np.float32(meta[key]))
    (tmp_path / "husky.meta.json").write_text(json.dumps(meta))
    rounded = drive.load_dataset(str(csv))
    assert rounded.meta["vehicle"]["wheel_radius"] != husky.meta["vehicle"]["wheel_radius"]
    score = model.score(rounded)
    assert score["notes"] == [] and score["windows"] == len(rounded)


def test_import_notes_and_data_check_findings_are_python_warnings(raw_log, tmp_path):
    # The IMU columns zeroed: the import keeps the log, notes that it takes the yaw rate
    # from the localization, and the imu-constant check warns; each a UserWarning, as
    # `drive import` prints them.
    lines = raw_log.read_text().splitlines()
    header = lines[0].split(",")
    imu = [i for i, name in enumerate(header) if name.startswith("imu_")]
    rows = [",".join("0.0" if i in imu else v for i, v in enumerate(line.split(","))) for line in lines[1:]]
    zeroed = tmp_path / "imu_zeroed.csv"
    zeroed.write_text("\n".join([lines[0], *rows]) + "\n")
    with pytest.warns(UserWarning) as caught:
        data = drive.import_raw(zeroed, "husky")
    texts = [str(w.message) for w in caught]
    assert any("imu-constant" in t for t in texts), texts
    assert any("yaw rate from localization" in t for t in texts), texts
    assert len(data) == 33
    # A clean log warns of nothing.
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        drive.import_raw(raw_log, "husky")


def test_predict_rows_and_covariances(husky):
    model = drive.fit(husky, "slip-blr", split=0.5)
    commands = np.tile([3.0, 4.0], (40, 1))
    poses = model.predict(commands, start=(1.0, 2.0, 0.3))
    # Row 0 is the start pose; the last command never changes the output.
    np.testing.assert_array_equal(poses[0], [1.0, 2.0, 0.3])
    changed = commands.copy()
    changed[-1] = [-5.0, 5.0]
    np.testing.assert_array_equal(model.predict(changed, start=(1.0, 2.0, 0.3)), poses)
    # Row k depends on commands 0..k-1 only: a prefix predicts the same rows.
    for k in (1, 5, 39):
        np.testing.assert_array_equal(model.predict(commands[: k + 1], start=(1.0, 2.0, 0.3)), poses[: k + 1])
    changed[0] = [-5.0, 5.0]
    assert not np.array_equal(model.predict(changed, start=(1.0, 2.0, 0.3))[-1], poses[-1])
    same, cov = model.predict(commands, start=(1.0, 2.0, 0.3), return_cov=True)
    np.testing.assert_array_equal(same, poses)
    assert cov.shape == (40, 3, 3)
    np.testing.assert_array_equal(cov[0], np.zeros((3, 3)))
    np.testing.assert_allclose(cov, np.transpose(cov, (0, 2, 1)), atol=1e-15)
    assert np.all(np.linalg.eigvalsh(cov[1:]) > -1e-12)
    assert cov[-1, 0, 0] > cov[1, 0, 0]
    with pytest.raises(drive.DriveError, match="uncertainty"):
        drive.fit(husky, "naive").predict(commands, return_cov=True)


def test_models_pickle_and_copy_with_their_start(husky):
    commands = np.random.default_rng(3).uniform(-5, 5, (40, 2))
    for name, start in (("slip-blr", None), ("slip-ipem", "encoders")):
        model = drive.fit(husky, name, split=0.5, start=start)
        expected = model.predict(commands, start_wheels=(1.0, 2.0))
        for again in (pickle.loads(pickle.dumps(model)), copy.deepcopy(model), copy.copy(model)):
            assert again.name == model.name and again.start == model.start
            np.testing.assert_array_equal(again.predict(commands, start_wheels=(1.0, 2.0)), expected)
    params = drive.fit(husky, "slip-blr", split=0.5).parameters()
    assert params["type"] == "calibrated"
    assert params["model"]["slip"]["type"] == "slip-blr"
    assert len(params["model"]["slip"]["slip_x"]["mean"]) > 0


def test_type_hints_are_installed():
    package = Path(drive.__file__).parent
    assert (package / "py.typed").exists()
    stubs = (package / "__init__.pyi").read_text()
    for name in drive.__all__:
        assert f"def {name}(" in stubs or f"class {name}" in stubs, name


def test_report_writes_the_command_lines_report(husky, tmp_path):
    small = drive.Dataset.from_pandas(husky.to_pandas().query("window < 120"), {**husky.meta, "windows": 120})
    md = drive.report(small, tmp_path / "report", models=["naive", "slip-blr"])
    assert Path(md).name == "report.md" and Path(md).exists()
    assert "slip-blr" in Path(md).read_text()
    assert any(p.suffix == ".png" for p in (tmp_path / "report").iterdir())


def test_report_reports_its_progress_and_a_stopped_report_writes_nothing(husky, tmp_path):
    small = drive.Dataset.from_pandas(husky.to_pandas().query("window < 120"), {**husky.meta, "windows": 120})
    calls = []
    drive.report(small, tmp_path / "done", models=["naive", "slip-blr"], progress=lambda d, t: calls.append((d, t)))
    # Two models' fits and scores, the convergence, the protocol regions, the figures.
    assert calls and calls[-1] == (5, 5) and all(t == 5 for _, t in calls), calls

    def stop(done, total):
        raise RuntimeError(f"stopped at {done} of {total}")

    with pytest.raises(RuntimeError, match="stopped at"):
        drive.report(small, tmp_path / "stopped", models=["naive", "slip-blr"], progress=stop)
    # The command stops at its next unit of work or before it publishes: nothing is written,
    # even after the work's thread has had time to end.
    import time

    time.sleep(3)
    assert not (tmp_path / "stopped").exists() or not any((tmp_path / "stopped").iterdir())


def test_missing_files_of_every_kind_are_file_not_found_errors(husky, raw_log, tmp_path):
    # A CSV without its sidecar, a robot file, a suite file.
    lonely = tmp_path / "lonely.csv"
    lonely.write_text(raw_log.read_text()[:100])
    missing_robot = str(tmp_path / "missing_robot.toml")
    model = drive.fit(husky, "naive")
    for call in (
        lambda: drive.load_dataset(lonely),
        lambda: drive.import_raw(raw_log, missing_robot),
        lambda: drive.bench(suite=tmp_path / "missing_suite.toml"),
        lambda: drive.ProtocolRunner(missing_robot),
        lambda: drive.Tracker(model, missing_robot, "line", 0.5),
        lambda: drive.report(husky, tmp_path / "r", robot=missing_robot),
    ):
        with pytest.raises(drive.DriveFileNotFoundError) as e:
            call()
        assert e.value.errno == 2 and e.value.filename, str(e.value)


def test_wrong_types_are_drive_errors(husky, raw_log, tmp_path):
    model = drive.fit(husky, "slip-blr", split=0.5)
    for call, words in (
        (lambda: drive.import_raw(raw_log, "husky", allow=3), "allow must be"),
        (lambda: drive.import_raw(raw_log, "husky", allow=[3]), "allow must be"),
        (lambda: drive.import_bag(raw_log, "husky", topics=3), "topics must be"),
        (lambda: model.predict(np.zeros((4, 2)), return_cov="yes"), "return_cov must be"),
        (lambda: drive.report("run.csv", tmp_path / "r"), "dataset must be"),
        (lambda: drive.report(husky, None), "out must be"),
        (lambda: drive.report(husky, tmp_path / "r", model=3), "model must be"),
    ):
        with pytest.raises(drive.DriveError, match=words):
            call()
    # numpy's booleans are booleans.
    assert len(model.predict(np.zeros((4, 2)), return_cov=np.True_)) == 2


def test_from_pandas_names_what_is_wrong_in_meta_and_columns(husky):
    pd = pytest.importorskip("pandas")
    df = husky.to_pandas()
    small = df[df["window"] < 120]
    # numpy integers in meta are numbers.
    data = drive.Dataset.from_pandas(small, {**husky.meta, "windows": small["window"].max() + 1})
    assert len(data) == 120
    with pytest.raises(drive.DriveError, match="'yaw' more than once"):
        drive.Dataset.from_pandas(pd.concat([small, small[["yaw"]]], axis=1), {**husky.meta, "windows": 120})
    with pytest.raises(drive.DriveError, match="field 'rate_hz'"):
        drive.Dataset.from_pandas(small, {**husky.meta, "windows": 120, "rate_hz": float("nan")})
    broken = small.copy()
    broken.loc[41, "phase"] = "steady,1"
    with pytest.raises(drive.DriveError, match=r"column 'phase', row 41 \(index 41\)"):
        drive.Dataset.from_pandas(broken, {**husky.meta, "windows": 120})


def test_report_errors_carry_the_command_lines_message(husky, tmp_path):
    small = drive.Dataset.from_pandas(husky.to_pandas().query("window < 120"), {**husky.meta, "windows": 120})
    with pytest.raises(drive.DriveError, match="unknown model 'nope'"):
        drive.report(small, tmp_path / "r", model="nope")
    # The dataset's name is no path: nothing is written beside the temporary directory.
    renamed = drive.Dataset.from_pandas(small.to_pandas(), {**small.meta, "name": "../escape"})
    drive.report(renamed, tmp_path / "r2", models=["naive"])
    assert (tmp_path / "r2" / "report.md").exists()


def test_the_console_command_with_closed_streams():
    out = subprocess.run(f"'{BIN}' list >&-", shell=True, capture_output=True, text=True)
    assert "Traceback" not in out.stderr
    out = subprocess.run(f"'{BIN}' no-such-command 2>&-", shell=True, capture_output=True, text=True)
    assert out.returncode == 2
