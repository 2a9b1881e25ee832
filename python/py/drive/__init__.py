"""DRIVE from Python: datasets, the paper's evaluation, fitted models with numpy predictions,
and the protocol runner a ROS 2 node drives a robot with. `pip install drive-ugv` (or
`pip install ./python`) also installs the `drive` console command: the whole command line.

    >>> import drive
    >>> data = drive.load_dataset()                 # the bundled Husky data
    >>> data = drive.import_raw("raw_log.csv", "husky")  # or drive.import_bag("bag_dir", "husky")
    >>> df, meta = data.to_pandas(), data.meta      # a DataFrame of the window CSV, the sidecar
    >>> data = drive.Dataset.from_pandas(df, meta)
    >>> errors = drive.per_window(data, ["naive", "slip-blr"])  # drive eval --per-window
    >>> score = model.score(other_run)              # errors of a fitted model on any dataset
    >>> poses, cov = model.predict(commands, return_cov=True)   # (H, 3), (H, 3, 3)
    >>> result = drive.evaluate(data)               # the dict of `drive eval --json`
    >>> model = drive.fit(data, "slip-blr", split=0.5)
    >>> poses = model.predict(commands)             # (H, 2) -> (H, 3): x, y, yaw
    >>> state = model.initial_state(start=(0, 0, 0), batch=1024)  # the step API
    >>> state = model.step(state, actions)          # (1024, 2) -> state.poses (1024, 3)
    >>> dynamics = drive.MppiDynamics(model)        # pytorch_mppi's dynamics(state, action)
    >>> runner = drive.ProtocolRunner("husky", "uniform", seed=0, geofence=20.0)
    >>> command = runner.tick({"t": 0.0, "encoder": (0.0, 0.0), "pose": (0.0, 0.0, 0.0),
    ...                        "deadman": True})    # command.inputs, .linear, .angular
    >>> tracker = drive.Tracker(model, "husky", path_xy, speed=0.5)   # MPPI with the model
    >>> tick = tracker.tick(0.0, (0.0, 0.0), pose=(0.0, 0.0, 0.0), imu_yaw_rate=0.0)
    >>> tick["command"], tick["done"]               # the wheel velocities to send

Every user error raises `drive.DriveError` (a ValueError) with the command line's message;
a file that does not exist raises `drive.DriveFileNotFoundError`, both a `DriveError` and a
`FileNotFoundError`.
"""

import errno as _errno
import json as _json
import numbers as _numbers
import os as _os
import threading as _threading

import numpy as _np
from collections.abc import Mapping as _Mapping

# A researcher's own build of the bindings, holding their parts (docs/python.md, "Your own
# parts from Python"), stands in for the built-in one when DRIVE_NATIVE_MODULE names it.
if _os.environ.get("DRIVE_NATIVE_MODULE"):
    import importlib as _importlib
    import sys as _sys

    _sys.modules[__name__ + "._native"] = _importlib.import_module(
        _os.environ["DRIVE_NATIVE_MODULE"]
    )

from . import _native
from ._native import AdaptiveModel, Command, Dataset, DriveError, Model, State, Tracker, fit
from ._native import adapt_json as _adapt_json
from ._native import bench_json as _bench_json
from ._native import evaluate_json as _evaluate_json
from ._mppi import MppiDynamics


class DriveFileNotFoundError(DriveError, FileNotFoundError):
    """A file the call reads does not exist: a `FileNotFoundError` (errno ENOENT, the
    `filename`) with the command line's message, and a `DriveError`."""

    def __init__(self, message, filename=None):
        super().__init__(message)
        self.errno = _errno.ENOENT
        self.strerror = _os.strerror(_errno.ENOENT)
        self.filename = filename

    def __str__(self):
        return self.args[0]


def _missing(*paths):
    """The first of `paths` (str, os.PathLike or None) that names no file or directory."""
    for path in paths:
        if isinstance(path, _os.PathLike):
            path = _os.fspath(path)
        if isinstance(path, (str, bytes)) and not str(path).startswith("bundled:") and not _os.path.exists(path):
            return path
    return None


def _robot_file(robot):
    """`robot` when it names a robot file (a `.toml` name), else None: a registered name
    such as "husky" is no file."""
    if isinstance(robot, _os.PathLike):
        robot = _os.fspath(robot)
    return robot if isinstance(robot, str) and robot.endswith(".toml") else None


def _sidecars(path, sidecar):
    """The sidecar files a window CSV at `path` may be read with: `sidecar`, or beside it
    (`run.csv` -> `run.meta.json`, the older `run.json`) when the CSV exists."""
    if sidecar is not None or path is None:
        return [sidecar]
    if isinstance(path, _os.PathLike):
        path = _os.fspath(path)
    if not isinstance(path, str) or path.startswith("bundled:") or not _os.path.exists(path):
        return []
    stem = _os.path.splitext(path)[0]
    meta, legacy = stem + ".meta.json", stem + ".json"
    return [] if _os.path.exists(meta) or _os.path.exists(legacy) else [meta]


def _reading(call, *paths):
    """`call()`, its error a `DriveFileNotFoundError` when one of `paths` does not exist."""
    try:
        return call()
    except DriveError as e:
        missing = _missing(*paths)
        if missing is not None:
            raise DriveFileNotFoundError(str(e), missing) from None
        raise


def load_dataset(path=None, sidecar=None):
    """The bundled Husky dataset (`path` None), a bundled dataset by name
    ("bundled:warthog_grass_2024-08-08", see `drive list`), or a window CSV with its sidecar
    beside it (`run.csv` -> `run.meta.json`) or at `sidecar`."""
    return _reading(lambda: _native.load_dataset(path, sidecar), path, *_sidecars(path, sidecar))


def load_model(path):
    """A model file written by `drive train` or `Model.save`."""
    return _reading(lambda: _native.load_model(path), path)


def _import(path, robot, bag, topics, max_gap, localization_timeout, terrain, allow):
    if isinstance(robot, _os.PathLike):
        robot = _os.fspath(robot)
    if not isinstance(robot, str):
        raise DriveError(f"robot must be a registered robot name or a robot TOML file, got {robot!r}")
    for name, value in (("max_gap", max_gap), ("localization_timeout", localization_timeout)):
        if not _is_number(value):
            raise DriveError(f"{name} must be a number of seconds, got {value!r}")
    if not isinstance(terrain, str):
        raise DriveError(f"terrain must be a str, got {terrain!r}")
    if isinstance(allow, str):
        allow = [a.strip() for a in allow.split(",") if a.strip()]
    if allow is None:
        allow = []
    if not isinstance(allow, (list, tuple)) or not all(isinstance(a, str) for a in allow):
        raise DriveError(f"allow must be check names (a list of str, or one str with commas), got {allow!r}")
    allow = list(allow)
    dataset, failure = _reading(
        lambda: _native.import_recording(
            path, robot, bag, list(topics), float(max_gap), float(localization_timeout), terrain, allow
        ),
        path,
        _robot_file(robot),
    )
    if failure is not None:
        raise DriveError(f"{failure}; nothing imported")
    return dataset


def import_raw(path, robot, *, max_gap=0.25, localization_timeout=0.5, terrain="", allow=()):
    """A raw DRIVE logger CSV imported for `robot` (a registered robot such as "husky", or
    a robot TOML file), as `drive import --raw PATH --robot ROBOT`: the same windows and
    sidecar. The keep/drop report (`drive import --json`) is `dataset.import_report`; a
    log with no usable window, or with a fatal data check not named in `allow`
    ("not-moving", "encoders-zero", ...), raises `DriveError`. `dataset.save("run.csv")`
    writes the command line's files."""
    return _import(path, robot, False, [], max_gap, localization_timeout, terrain, allow)


def import_bag(path, robot, topics=None, *, max_gap=0.25, localization_timeout=0.5, terrain="", allow=()):
    """A rosbag2 recording in MCAP storage (its directory or a .mcap file) imported for
    `robot`, as `drive import --bag PATH --robot ROBOT`. `topics` maps the logger's keys to
    the bag's topics where they differ, e.g. {"odometry": "/odom", "meas_left_vel":
    "/joint_states:left_wheel_joint"} (a dict, or a list of "KEY=/topic"; see
    `drive import --help`). Otherwise as `import_raw`."""
    if topics is None:
        topics = []
    elif isinstance(topics, _Mapping):
        topics = [f"{k}={v}" for k, v in topics.items()]
    elif isinstance(topics, str):
        topics = [topics]
    elif not isinstance(topics, (list, tuple)):
        raise DriveError(f"topics must be a dict of key -> topic, or a list of 'KEY=/topic', got {topics!r}")
    topics = list(topics)
    if not all(isinstance(t, str) for t in topics):
        raise DriveError(f"topics must be a dict of key -> topic, or a list of 'KEY=/topic', got {topics!r}")
    return _import(path, robot, True, topics, max_gap, localization_timeout, terrain, allow)


def per_window(dataset, models=None, split=0.5, start=None, allow_useless=False):
    """The errors of each evaluation window, as `drive eval --per-window` writes them: a
    dict of equal-length columns model, window, interval, phase, translational_m,
    rotational_rad (`pandas.DataFrame(drive.per_window(...))`). The models (default:
    naive, powertrain, slip-blr, acc-blr) are fitted on the first `split` of the intervals
    and scored on the rest, predicting from `start`, as `drive.evaluate`."""
    models = _model_names(models, split)
    return dict(_native.per_window_columns(dataset, models, float(split), start, _flag("allow_useless", allow_useless)))


def report(dataset, out, models=None, split=0.5, model="slip-blr", robot=None, progress=None, allow_useless=False):
    """`drive report` on `dataset`: report.md and the paper's figures (PNG) in the directory
    `out`, for the models (default: every model of `drive report`) with `model`'s
    uncertainty figures; `robot` (a registered robot or TOML file) for the naive input
    space's figure. Returns the path of report.md; a `DriveError` carries the command
    line's message.

    Ctrl-C raises KeyboardInterrupt within a fraction of a second, and nothing is written to
    `out` (the report stops at its next unit of work: a model's fit and score, the
    convergence, the protocol regions, the figures). `progress` is a callable given
    `(done, total)` as those units complete, or True for a tqdm bar (when tqdm is
    installed; nothing otherwise). A dataset the data checks call useless raises
    `DriveError` naming the finding unless `allow_useless` (`drive report --allow-useless`)."""
    import tempfile

    if not isinstance(dataset, Dataset):
        raise DriveError(f"dataset must be a drive.Dataset, got {type(dataset).__name__}")
    if not isinstance(out, (str, _os.PathLike)):
        raise DriveError(f"out must be a directory path (str or os.PathLike), got {out!r}")
    if not isinstance(model, str):
        raise DriveError(f"model must be a model name such as 'slip-blr', got {model!r}")
    if robot is not None and not isinstance(robot, (str, _os.PathLike)):
        raise DriveError(f"robot must be a robot name or a robot TOML file, got {robot!r}")
    models = _model_names(models, split)
    out = _os.fspath(out)
    missing = _missing(_robot_file(robot))
    if missing is not None:
        raise DriveFileNotFoundError(f"{missing}: no such robot file", missing)
    # Refused here, naming the dataset (the command line would name its temporary copy).
    allow_useless = _flag("allow_useless", allow_useless)
    _native._refuse_useless(dataset, allow_useless)
    with tempfile.TemporaryDirectory() as tmp:
        csv = _os.path.join(tmp, "data.csv")
        dataset.save(csv)
        args = ["drive", "report", "--data", csv, "--out", out, "--split", repr(float(split)), "--model", model]
        if models is not None:
            args += ["--models", ",".join(models)]
        if robot is not None:
            args += ["--robot", _os.fspath(robot)]
        if allow_useless:
            args.append("--allow-useless")
        with _progress(progress, "report") as reporting:
            status, said = _run_capturing_stderr(args, tmp, reporting)
    if status != 0:
        errors = [line[len("error: "):] for line in said.splitlines() if line.startswith("error: ")]
        raise DriveError(errors[-1] if errors else f"drive report failed: {said.strip()}")
    return _os.path.join(out, "report.md")


def _captured(fd, path, run):
    """`run()` with the file descriptor `fd` (1 or 2) written into the file `path` instead;
    its result."""
    import sys

    stream = sys.stdout if fd == 1 else sys.stderr
    if stream is not None:
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    saved = _os.dup(fd)
    try:
        with open(path, "wb") as captured:
            _os.dup2(captured.fileno(), fd)
            try:
                return run()
            finally:
                _os.dup2(saved, fd)
    finally:
        _os.close(saved)


def _run_capturing_stderr(args, tmp, progress=None):
    """The command line run in-process with its standard error (file descriptor 2) read
    back: (exit status, what it said). What it said is passed on to `sys.stderr` on
    success (its notes). `progress(done, total)` as its units of work end."""
    import sys

    path = _os.path.join(tmp, "stderr.txt")
    status = _captured(2, path, lambda: _native.run_cli(args, progress))
    with open(path, encoding="utf-8", errors="replace") as f:
        said = f.read()
    if status == 0 and said and sys.stderr is not None:
        sys.stderr.write(said)
    return status, said


__all__ = [
    "AdaptiveModel",
    "Command",
    "Dataset",
    "DriveError",
    "DriveFileNotFoundError",
    "Measurements",
    "Model",
    "MppiDynamics",
    "ProtocolRunner",
    "State",
    "Tracker",
    "adapt",
    "bench",
    "evaluate",
    "fit",
    "import_bag",
    "import_raw",
    "load_dataset",
    "load_model",
    "per_window",
    "report",
    "sim_fit",
    "track",
]


def _flag(name, value):
    """`value` when it is True or False; a `DriveError` naming `name` otherwise."""
    if not isinstance(value, bool):
        raise DriveError(f"{name} must be True or False, got {value!r}")
    return value


def _model_names(models, split):
    """`models` (None, a list of names, or one str with commas) as a list of names (None for
    the default), after checking `split` is a number."""
    if isinstance(models, str):
        models = [m.strip() for m in models.split(",") if m.strip()]
    if not _is_number(split):
        raise DriveError(f"split must be a number between 0 and 1, got {split!r}")
    if models is not None and not isinstance(models, (list, tuple)):
        raise DriveError(
            f"models must be model names (a list of str, or one str with commas), got {models!r}"
        )
    return None if models is None else list(models)


def evaluate(dataset, models=None, split=0.5, start=None, progress=None, allow_useless=False):
    """The models (default: naive, powertrain, slip-blr, acc-blr) fitted on the first
    `split` of the dataset's intervals and scored on the rest, their predictions starting
    from `start` ("encoders", "encoders+imu" (the default) or "encoders+imu+localization",
    as `drive eval --start`): the same dict as `drive eval --json`. Ctrl-C raises
    KeyboardInterrupt at once (the work stops after the models under way); `progress` is a
    callable given `(done, total)` as models complete, or True for a tqdm bar. A dataset
    the data checks call useless (`drive check`'s fatal findings) raises `DriveError`
    naming the finding unless `allow_useless` (`drive eval --allow-useless`)."""
    models = _model_names(models, split)
    allow_useless = _flag("allow_useless", allow_useless)
    with _progress(progress, "evaluate") as report:
        return _json.loads(_evaluate_json(dataset, models, float(split), start, report, allow_useless))


def bench(suite=None, models=None, split=0.5, transfer=True, allow_useless=False, progress=None, adapt=False, adapt_library=False):
    """The benchmark of `drive bench --json`, as a dict: the models (default: naive,
    powertrain, slip-blr, acc-blr, slip-ipem) on every dataset of the suite file `suite` (a
    path to a TOML file; every bundled dataset when None), each dataset's first `split` of
    the intervals training; the transfer between runs of the same robot unless `transfer` is
    False; the terrain's unpredictability; the leaderboard. A dataset the data checks call
    useless, or one no model can be fitted on, is skipped (`skipped`, with why) unless
    `allow_useless` (`--allow-useless`) ranks the useless ones.

    Ctrl-C raises KeyboardInterrupt within a fraction of a second (the work stops at its next
    unit: a dataset's comparison or a transfer fit). `progress` is a callable given
    `(done, total)` as units of work complete, or True for a tqdm bar (when tqdm is
    installed; nothing otherwise).

    `adapt` runs the adaptation track (`drive bench --adapt`, the dict's `adaptation`):
    True for the times 0, 15, 30, 60, 120 and 240 s, or a sequence of seconds of each
    target's training half. `adapt_library` adds a terrain library to each pair (the prior
    and the model fitted on each of the robot's other runs, blended by their likelihood;
    `drive bench --adapt-library`)."""
    models = _model_names(models, split)
    for name, flag in (("transfer", transfer), ("allow_useless", allow_useless), ("adapt_library", adapt_library)):
        if not isinstance(flag, bool):
            raise DriveError(f"{name} must be True or False, got {flag!r}")
    if adapt is True:
        adapt = [0.0, 15.0, 30.0, 60.0, 120.0, 240.0]
    elif adapt is False or adapt is None:
        adapt = None
    elif isinstance(adapt, (str, bytes)) or not hasattr(adapt, "__iter__"):
        raise DriveError(f"adapt must be True, False or a sequence of seconds, got {adapt!r}")
    else:
        try:
            adapt = [float(t) for t in adapt]
        except (TypeError, ValueError):
            raise DriveError(f"adapt must be True, False or a sequence of seconds, got {adapt!r}") from None
    with _progress(progress, "bench") as report:
        return _json.loads(
            _reading(
                lambda: _bench_json(suite, models, float(split), transfer, allow_useless, report, adapt, adapt_library),
                suite,
            )
        )


class _progress:
    """`progress` as a call's progress argument: a callable as it is, True as a tqdm bar
    (closed on exit; None when tqdm is not installed), None or False as None."""

    def __init__(self, progress, what):
        self.bar = None
        if progress is None or progress is False:
            self.report = None
        elif progress is True:
            try:
                from tqdm.auto import tqdm
            except ImportError:
                self.report = None
            else:
                self.bar = tqdm(desc=what, unit="unit")
                self.report = self._tqdm
        elif callable(progress):
            self.report = progress
        else:
            raise DriveError(f"progress must be a callable, True or None, got {progress!r}")

    def _tqdm(self, done, total):
        if total and self.bar.total != total:
            self.bar.total = total
        self.bar.update(done - self.bar.n)

    def __enter__(self):
        return self.report

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.close()
        return False


def adapt(prior, data, models=None, split=0.5, times=None, progress=None, allow_useless=False, library=None):
    """`drive adapt --json` as a dict: `prior` (a fitted or loaded `drive.Model`, adapted as
    it is, or a `drive.Dataset` on which each model of `models`, default slip-blr and
    slip-ipem, is fitted) adapting to the dataset `data`: its first `split` of the intervals
    streamed in time order into the adaptive model, scored on the rest after each of `times`
    seconds (default 0, 15, 30, 60, 120, 240) beside the prior alone (`frozen`), a fit from
    scratch on the same seconds (`scratch`) and the fit on the whole half (`own`); `curve`
    holds one entry per learner, model and time (docs/adaptation.md). `library`, a list of
    `drive.Dataset` of the same robot on other grounds: each model fitted on each, blended
    with the prior by their likelihood of the windows driven (`library` in the curve, with
    its `weights`; `drive adapt --library`).

    Ctrl-C raises KeyboardInterrupt within a fraction of a second (the work stops after the
    model under way). `progress` is a callable given `(done, total)` as each model's curve
    is done, or True for a tqdm bar (when tqdm is installed; nothing otherwise). A prior or
    target dataset the data checks call useless raises `DriveError` naming the finding
    unless `allow_useless`."""
    models = _model_names(models, split)
    if times is not None:
        times = [float(t) for t in times]
    with _progress(progress, "adapt") as report:
        return _json.loads(
            _adapt_json(prior, data, models, float(split), times, report, _flag("allow_useless", allow_useless),
                        None if library is None else list(library))
        )


def track(progress=None, **options):
    """`drive track --json` as a dict: each model inside the MPPI controller following paths
    on the simulator (docs/closed-loop.md). `options` are the command line's flags, a
    keyword each with underscores for hyphens: `robot="warthog"`, `terrain="gravel"` (or a
    twin's TOML file), `models=["powertrain", "slip-blr"]`, `path="figure8"`,
    `speed=[0.5, 0.8]`, `seeds=3`, `train_data=[dataset, ...]` (a `drive.Dataset`, a path or
    `"bundled:NAME"`), `out=DIR`; a list is joined with commas, `True` gives a flag without
    a value (`adapt=True`), `None` and `False` leave it out.

    Ctrl-C raises KeyboardInterrupt within a fraction of a second (the work stops after the
    run under way, and nothing is written to `out`). `progress` is a callable given
    `(done, total)` as each model's run ends, or True for a tqdm bar (when tqdm is
    installed; nothing otherwise). An error raises `DriveError` with the command line's
    message."""
    return _run_json("track", options, progress)


def sim_fit(dataset, robot, progress=None, **options):
    """`drive sim-fit --json` as a dict: a twin of the robot `robot` (a registered robot or
    a robot TOML file) fitted on `dataset` (a `drive.Dataset`, a path or `"bundled:NAME"`)
    and checked against it (docs/twins.md); `out=PATH` writes the twin's terrain TOML file
    (a fit needs it), `twin=PATH` checks a twin instead of fitting one. Other `options` are
    the command line's flags, as `drive.track` takes them (`check_seeds=3`,
    `allow_poor_twin=True`, ...).

    Ctrl-C raises KeyboardInterrupt within a fraction of a second, and nothing is written.
    `progress` as in `drive.track`. A dataset the data checks call useless, or a twin that
    fails its check, raises `DriveError` with the command line's message."""
    for key in ("data", "robot"):
        if key in options:
            raise DriveError(f"{key} is drive.sim_fit's {'first' if key == 'data' else 'second'} argument, not an option")
    if dataset is None:
        raise DriveError("dataset must be a drive.Dataset, a path or 'bundled:NAME', got None")
    return _run_json("sim-fit", dict(options, data=dataset, robot=robot), progress)


# The options whose values are datasets (a `drive.Dataset` is saved for them), and those
# that name files the command writes (not checked for existence).
_DATASET_OPTIONS = {"data", "train_data", "library", "prior"}
_OUTPUT_OPTIONS = {"out", "raw_out", "per_window"}
_FILE_SUFFIXES = (".csv", ".toml", ".json", ".yaml", ".yml", ".mcap", ".db3")


def _run_json(command, options, progress):
    """`drive COMMAND --json` run in this process with `options` as its flags: its JSON
    document as a dict, its notes passed on to `sys.stderr`, its error a `DriveError` (a
    file it reads that does not exist a `DriveFileNotFoundError`)."""
    import re
    import tempfile

    if "json" in options:
        raise DriveError(f"json is not an option of drive.{command.replace('-', '_')}: it returns the --json document")
    with tempfile.TemporaryDirectory() as tmp:
        args = ["drive", command, "--json"]
        for i, (key, value) in enumerate(options.items()):
            if not isinstance(key, str) or not key.replace("_", "").isalnum():
                raise DriveError(f"{key!r} is not an option of drive {command}")
            flag = "--" + key.replace("_", "-")
            if value is None or value is False:
                continue
            if value is True:
                args.append(flag)
                continue
            values = value if isinstance(value, (list, tuple)) else [value]
            texts = []
            for j, v in enumerate(values):
                if isinstance(v, Dataset):
                    if key not in _DATASET_OPTIONS:
                        raise DriveError(f"{key} takes no drive.Dataset (the options that do: {', '.join(sorted(_DATASET_OPTIONS))})")
                    # Named after the dataset: the results name their training data by it.
                    folder = _os.path.join(tmp, f"{i}_{j}")
                    _os.mkdir(folder)
                    path = _os.path.join(folder, (re.sub(r"[^A-Za-z0-9_.-]", "_", v.name) or "data") + ".csv")
                    v.save(path)
                    texts.append(path)
                elif isinstance(v, bool) or not isinstance(v, (str, _os.PathLike, _numbers.Real)):
                    raise DriveError(f"{key} must be a string, a path, a number, a drive.Dataset or a list of them, got {v!r}")
                elif isinstance(v, _numbers.Real) and not isinstance(v, str):
                    texts.append(repr(v) if isinstance(v, float) else str(v))
                else:
                    text = _os.fspath(v)
                    if (
                        key not in _OUTPUT_OPTIONS
                        and isinstance(text, str)
                        and text.lower().endswith(_FILE_SUFFIXES)
                        and _missing(text) is not None
                    ):
                        raise DriveFileNotFoundError(f"{text}: no such file ({key})", text)
                    texts.append(text)
            # `--flag=value`: a value that starts with '-' (a negative number) is a value.
            args.append(f"{flag}={','.join(texts)}")
        out_path = _os.path.join(tmp, "stdout.json")
        with _progress(progress, command) as reporting:
            status, said = _captured(1, out_path, lambda: _run_capturing_stderr(args, tmp, reporting))
        with open(out_path, encoding="utf-8", errors="replace") as f:
            printed = f.read()
    if status != 0:
        errors = [line[len("error: "):] for line in said.splitlines() if line.startswith("error: ")]
        raise DriveError(errors[-1] if errors else f"drive {command} failed: {(said or printed).strip()}")
    return _json.loads(printed)


class Measurements:
    """What the robot measured since the last tick.

    `t` the time (s); `encoder` the vehicle's measured inputs, one per input axis (the
    (left, right) wheel velocities in rad/s of a differential drive; (v_x, v_y, w) of an
    omnidirectional base) when new ones arrived, else None; `pose` the localization
    (x, y, yaw) when a new one arrived, else None; `deadman` True while the operator holds
    the dead-man switch (required: the robot never moves without it).
    """

    __slots__ = ("t", "encoder", "pose", "deadman")

    def __init__(self, t, encoder=None, pose=None, *, deadman):
        self.t = t
        self.encoder = encoder
        self.pose = pose
        self.deadman = deadman

    def __repr__(self):
        return (
            f"Measurements(t={self.t!r}, encoder={self.encoder!r}, pose={self.pose!r}, "
            f"deadman={self.deadman!r})"
        )


_KEYS = ("t", "encoder", "pose", "deadman")


def _is_number(v):
    return isinstance(v, _numbers.Real) and not isinstance(v, (bool, _np.bool_))


def _values(name, value, n):
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise DriveError(f"{name} must be {n} numbers or None, got {value!r}")
    values = list(value)
    if len(values) != n or not all(_is_number(v) for v in values):
        raise DriveError(f"{name} must be {n} numbers or None, got {value!r}")
    return [float(v) for v in values]


_OPTIONS = {
    "characterize": "bool",
    "localization": "bool",
    "geofence": "number",
    "max_duration": "number",
    "stale_timeout": "number",
    "characterization_time": "number",
    "max_intervals": "count",
}


def _check_options(options):
    for key, value in options.items():
        kind = _OPTIONS.get(key)
        if kind is None:
            raise DriveError(
                f"unknown option {key!r}: expected one of {', '.join(sorted(_OPTIONS))}"
            )
        if value is None and key in ("geofence", "max_duration", "max_intervals"):
            continue  # no such limit
        if kind == "bool" and not isinstance(value, (bool, _np.bool_)):
            raise DriveError(f"{key} must be True or False, got {value!r}")
        if kind == "number" and not _is_number(value):
            raise DriveError(f"{key} must be a number, got {value!r}")
        if kind == "count" and not (
            isinstance(value, _numbers.Integral) and not isinstance(value, (bool, _np.bool_)) and value >= 1
        ):
            raise DriveError(f"{key} must be a whole number of intervals, at least 1, got {value!r}")
    return {k: (bool(v) if _OPTIONS[k] == "bool" else v) for k, v in options.items()}


class ProtocolRunner:
    """The DRIVE protocol as a state machine a robot driver ticks at the command rate.

    Built from a robot (a registered name such as "husky", "warthog", or a robot TOML
    file), a sampler name ("uniform", the paper's; "grid", "linear", "angular",
    "targeted", "targeted-coverage"; see `drive list`) and a seed. It characterizes the
    input space first (step 1: the vehicle's probes, about 24 s for a differential drive;
    `characterize=False` samples the robot's nominal input space instead, as
    `drive protocol` does), then drives intervals of 6 s (one transient and two steady
    2 s windows) with inputs drawn by the sampler, through the robot's acceleration
    limits.

    Each `tick(measurements)` returns the `Command` to send now; it is zero while the
    dead-man switch is released, while encoders or localization are older than
    `stale_timeout` (s), and once done: after `max_intervals`, `max_duration` (s), or
    beyond `geofence` (m from the start). A paused interval restarts from its transient
    window. Same robot, sampler, seed and measurements: the same commands.
    """

    def __init__(self, robot, sampler="uniform", seed=0, **options):
        if isinstance(robot, _os.PathLike):
            robot = _os.fspath(robot)
        if not isinstance(robot, str):
            raise DriveError(
                f"robot must be a registered robot name or a robot TOML file, got {robot!r}"
            )
        if not isinstance(sampler, str):
            raise DriveError(f"sampler must be a sampler name (see drive list), got {sampler!r}")
        if isinstance(seed, bool) or not isinstance(seed, _numbers.Integral) or not 0 <= seed < 2**64:
            raise DriveError(f"seed must be an integer from 0 to 2^64 - 1, got {seed!r}")
        options = _check_options(options)
        self._native = _reading(
            lambda: _native.ProtocolRunner(robot, sampler, int(seed), **options), _robot_file(robot)
        )
        self._thread = _threading.get_ident()

    def _own_thread(self):
        # The native runner belongs to the thread that made it.
        if _threading.get_ident() != self._thread:
            raise DriveError(
                "a ProtocolRunner is used from the thread that created it (a ROS 2 node: its "
                "single-threaded executor); this is another thread"
            )

    def tick(self, measurements=None, **fields):
        """The command for this tick, from `measurements`: a `Measurements`, a dict with
        the keys t, encoder, pose, deadman, or the same as keywords."""
        self._own_thread()
        if measurements is None:
            measurements = fields
        elif fields:
            raise DriveError("tick takes measurements or keywords, not both")
        if isinstance(measurements, _Mapping):
            unknown = [k for k in measurements if k not in _KEYS]
            if unknown:
                raise DriveError(
                    f"unknown measurement {unknown[0]!r}: expected t, encoder, pose, deadman"
                )
            has, get = measurements.__contains__, measurements.get
        else:
            has = lambda k: hasattr(measurements, k)  # noqa: E731
            get = lambda k: getattr(measurements, k, None)  # noqa: E731
        if not has("t"):
            raise DriveError("measurements need 't': the time in seconds")
        if not has("deadman"):
            raise DriveError(
                "measurements need 'deadman': True while the operator holds the dead-man "
                "switch (the robot never moves without it)"
            )
        deadman = get("deadman")
        if not isinstance(deadman, (bool, _np.bool_)):
            raise DriveError(f"deadman must be True or False, got {deadman!r}")
        t = get("t")
        if not _is_number(t):
            raise DriveError(f"t must be a time in seconds, got {t!r}")
        return self._native.tick(
            float(t),
            _values("encoder", get("encoder"), len(self._native.inputs)),
            _values("pose", get("pose"), 3),
            bool(deadman),
        )

    def observe(self, interval):
        """Hands the windows of the interval that just ended (a `Dataset`) to the sampler:
        what "targeted" (largest slip-BLR uncertainty) learns from; other samplers ignore
        them."""
        self._own_thread()
        self._native.observe(interval)

    def __getattr__(self, name):
        # state, done, pause_reason, stop_reason, completed_intervals, input_space,
        # geometry, robot, rate_hz, inputs
        if name in ("_native", "_thread"):
            raise AttributeError(name)
        self._own_thread()
        return getattr(self._native, name)

    def __repr__(self):
        self._own_thread()
        return repr(self._native)
