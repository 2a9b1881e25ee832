//! Python bindings of the DRIVE framework (`pip install ./python`): datasets, evaluation,
//! fitted models with numpy predictions, the protocol runner a ROS 2 node drives a robot with,
//! and the path follower that puts a fitted model inside a model-predictive controller. The Python package `drive` (py/drive) wraps this
//! module; every user error raises `drive.DriveError` with the command line's message.

use drive::eval::{compare_specs, split_by_interval};
use drive::models::batch::predict_batch_parallel;
use drive::models::model_file::{model_from_json, model_to_json};
use drive::traits::{
    Dataset as RustDataset, Input, MotionError, MotionModel, Pose, RobotDescription, StartInfo,
    StartState,
};
use drive::Registries;
use numpy::{
    IntoPyArray, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
    PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod runner;
mod tracker;

create_exception!(
    _native,
    DriveError,
    PyValueError,
    "A user error (bad data, unknown name, a fit that cannot be made): the command line's message."
);

fn err(e: impl std::fmt::Display) -> PyErr {
    DriveError::new_err(e.to_string())
}

/// A DRIVE window dataset: the window CSV with its sidecar (robot, rates, vehicle).
#[pyclass(module = "drive._native", frozen)]
struct Dataset {
    inner: RustDataset,
}

#[pymethods]
impl Dataset {
    /// A dataset from the window CSV's text and the sidecar's JSON text.
    #[staticmethod]
    fn from_text(csv: &str, sidecar: &str) -> PyResult<Self> {
        drive::data::parse_dataset("dataframe", csv, "meta", sidecar)
            .map(|inner| Dataset { inner })
            .map_err(err)
    }

    /// A dataset from a pandas DataFrame with the window CSV's columns and the sidecar as a
    /// dict.
    #[staticmethod]
    fn from_pandas(
        py: Python<'_>,
        df: &Bound<'_, PyAny>,
        meta: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        if !df.hasattr("to_csv")? || !df.hasattr("columns")? {
            return Err(err(format!(
                "df must be a pandas DataFrame with the window CSV's columns, got {}",
                type_name(df)
            )));
        }
        if !meta.is_instance_of::<PyDict>() {
            return Err(err(format!(
                "meta must be a dict (the sidecar JSON's fields), got {}",
                type_name(meta)
            )));
        }
        let kwargs = PyDict::new(py);
        kwargs.set_item("index", false)?;
        let csv: String = df
            .call_method("to_csv", (), Some(&kwargs))
            .and_then(|c| c.extract())
            .map_err(|e| err(format!("df cannot be written as CSV: {e}")))?;
        let json = py.import("json")?;
        let sidecar: String = json
            .call_method1("dumps", (meta,))
            .and_then(|j| j.extract())
            .map_err(|e| err(format!("meta cannot be written as JSON: {e}")))?;
        Self::from_text(&csv, &sidecar)
    }

    /// Number of windows.
    fn __len__(&self) -> usize {
        self.inner.windows.len()
    }

    /// Number of DRIVE intervals.
    #[getter]
    fn intervals(&self) -> usize {
        self.inner.interval_count()
    }

    /// The dataset's name (from the sidecar).
    #[getter]
    fn name(&self) -> String {
        self.inner.robot.name.clone()
    }

    /// Command rate (Hz).
    #[getter]
    fn rate_hz(&self) -> f64 {
        self.inner.robot.rate_hz
    }

    fn __repr__(&self) -> String {
        format!(
            "Dataset({:?}: {} windows, {} intervals, {} Hz)",
            self.inner.robot.name,
            self.inner.windows.len(),
            self.inner.interval_count(),
            self.inner.robot.rate_hz
        )
    }
}

/// The bundled Husky dataset (`path` None) or a window CSV with its sidecar beside it (or
/// at `sidecar`).
#[pyfunction]
#[pyo3(signature = (path=None, sidecar=None))]
fn load_dataset(
    path: Option<&Bound<'_, PyAny>>,
    sidecar: Option<&Bound<'_, PyAny>>,
) -> PyResult<Dataset> {
    let path = path
        .filter(|p| !p.is_none())
        .map(|p| path_of("path", p))
        .transpose()?;
    let sidecar = sidecar
        .filter(|p| !p.is_none())
        .map(|p| path_of("sidecar", p))
        .transpose()?;
    let inner = match path {
        None => drive::bundled::husky(),
        Some(p) => drive::data::read_dataset(&p, sidecar.as_deref()),
    }
    .map_err(err)?;
    Ok(Dataset { inner })
}

/// What the predictions start from, by its command-line name (`drive eval --start`; the
/// default when None).
fn start_info_of(obj: Option<&Bound<'_, PyAny>>) -> PyResult<StartInfo> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(StartInfo::default());
    };
    let name: String = obj.extract().map_err(|_| {
        err(format!(
            "start must be one of {}, got {}",
            StartInfo::NAMES.join(", "),
            short_repr(obj)
        ))
    })?;
    StartInfo::parse(&name).map_err(err)
}

/// `drive eval --json` as a JSON text: the models (default: the paper's four) fitted on the
/// first `split` of the intervals and scored on the rest, their predictions starting from
/// `start` (`drive eval --start`).
#[pyfunction]
#[pyo3(signature = (dataset, models=None, split=0.5, start=None))]
fn evaluate_json(
    py: Python<'_>,
    dataset: &Bound<'_, PyAny>,
    models: Option<&Bound<'_, PyAny>>,
    split: f64,
    start: Option<&Bound<'_, PyAny>>,
) -> PyResult<String> {
    let dataset = dataset_of(dataset)?;
    let start = start_info_of(start)?;
    let names = model_names(models)?.unwrap_or_else(|| {
        ["naive", "powertrain", "slip-blr", "acc-blr"]
            .map(String::from)
            .to_vec()
    });
    if names.is_empty() {
        return Err(err("models is empty"));
    }
    let data = &dataset.inner;
    let result = py.detach(|| {
        let registries = Registries::builtin();
        let specs: Vec<_> = registries
            .models()
            .resolve_list(&names)
            .map_err(|e| e.to_string())?
            .into_iter()
            .map(|s| s.clone().with_uncertainty(s.uncertainty, start))
            .collect();
        compare_specs(data, split, &specs).map_err(|e| e.to_string())
    });
    let cmp = result.map_err(err)?;
    serde_json::to_string(&cmp).map_err(err)
}

/// The model names of `models` (a list of str), `None` for the default.
fn model_names(models: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<String>>> {
    models
        .filter(|m| !m.is_none())
        .map(|m| {
            m.extract().map_err(|_| {
                err(format!(
                    "models must be model names (a list of str, or one str with commas), got {}",
                    type_name(m)
                ))
            })
        })
        .transpose()
}

/// `drive bench --json` as a JSON text: the models (default: naive, powertrain, slip-blr,
/// acc-blr, slip-ipem) on every dataset of the suite file `suite` (every bundled dataset when
/// None), each split at `split`, with the transfer between runs of one robot unless
/// `transfer` is false.
#[pyfunction]
#[pyo3(signature = (suite=None, models=None, split=0.5, transfer=true))]
fn bench_json(
    py: Python<'_>,
    suite: Option<&Bound<'_, PyAny>>,
    models: Option<&Bound<'_, PyAny>>,
    split: f64,
    transfer: bool,
) -> PyResult<String> {
    let suite = suite
        .filter(|p| !p.is_none())
        .map(|p| path_of("suite", p))
        .transpose()?;
    let names = model_names(models)?.unwrap_or_else(|| {
        ["naive", "powertrain", "slip-blr", "acc-blr", "slip-ipem"]
            .map(String::from)
            .to_vec()
    });
    if names.is_empty() {
        return Err(err("models is empty"));
    }
    if !(split > 0.0 && split < 1.0) {
        return Err(err(format!(
            "split {split} must lie strictly between 0 and 1"
        )));
    }
    let result = py.detach(|| -> Result<String, String> {
        let registries = Registries::builtin();
        let specs = registries
            .models()
            .resolve_list(&names)
            .map_err(|e| e.to_string())?;
        let inputs = match &suite {
            Some(path) => {
                let entries = drive::data::suite::read_suite(path).map_err(|e| e.to_string())?;
                drive::suite::load(&registries, &entries)
            }
            None => drive::suite::bundled(&registries),
        }
        .map_err(|e| e.to_string())?;
        let config = drive::eval::BenchConfig {
            split,
            transfer,
            ..Default::default()
        };
        let bench =
            drive::eval::run_bench(&inputs, &specs, &config, &|| {}).map_err(|e| e.to_string())?;
        serde_json::to_string(&bench).map_err(|e| e.to_string())
    });
    result.map_err(err)
}

/// A fitted motion model: predictions from commands, saved as the command line's model file.
#[pyclass(module = "drive._native", frozen)]
struct Model {
    model: std::sync::Arc<dyn MotionModel>,
    robot: RobotDescription,
}

impl Model {
    fn start(
        &self,
        pose: [f64; 3],
        wheels: [f64; 2],
        yaw_rate: Option<f64>,
        velocity: Option<[f64; 2]>,
    ) -> StartState {
        let start = StartState::measured(
            Pose::new(pose[0], pose[1], pose[2]),
            Input::new(wheels[0], wheels[1]),
            self.robot.vehicle.as_ref(),
        );
        let start = yaw_rate.map_or(start, |w| start.with_yaw_rate(w));
        velocity.map_or(start, |v| start.with_velocity(v))
    }
}

/// The Python type name of `obj`, for messages.
fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map_or_else(|_| "?".into(), |n| n.to_string())
}

/// A path from a `str` or an `os.PathLike`, or a `DriveError` naming `what`.
fn path_of(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
    obj.extract::<std::path::PathBuf>().map_err(|_| {
        err(format!(
            "{what} must be a path (str or os.PathLike), got {}",
            type_name(obj)
        ))
    })
}

/// The dataset `obj`, or a `DriveError`.
fn dataset_of<'a, 'py>(obj: &'a Bound<'py, PyAny>) -> PyResult<PyRef<'py, Dataset>> {
    obj.extract::<PyRef<'py, Dataset>>().map_err(|_| {
        err(format!(
            "dataset must be a drive.Dataset (drive.load_dataset or drive.Dataset.from_pandas), got {}",
            type_name(obj)
        ))
    })
}

/// `obj`'s repr for a message, cut to 40 characters (a 400-digit integer stays one line).
fn short_repr(obj: &Bound<'_, PyAny>) -> String {
    let r = obj
        .repr()
        .map_or_else(|_| type_name(obj), |r| r.to_string());
    match r.char_indices().nth(40) {
        Some((cut, _)) => format!("{}... ({} characters)", &r[..cut], r.chars().count()),
        None => r,
    }
}

/// A real number (not a bool), or a `DriveError` saying what `what` must be.
fn number_of(what: &str, expected: &str, obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    let bad = || {
        err(format!(
            "{what} must be {expected}, got {}",
            short_repr(obj)
        ))
    };
    if obj.is_instance_of::<pyo3::types::PyBool>() {
        return Err(bad());
    }
    obj.extract::<f64>().map_err(|_| bad())
}

/// `N` real numbers (a start pose, start wheels; zeros when None), or a `DriveError`.
fn numbers_of<const N: usize>(what: &str, obj: Option<&Bound<'_, PyAny>>) -> PyResult<[f64; N]> {
    let Some(obj) = obj else {
        return Ok([0.0; N]);
    };
    let bad = || {
        err(format!(
            "{what} must be {N} numbers, got {}",
            short_repr(obj)
        ))
    };
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(bad());
    }
    let items: Vec<Bound<'_, PyAny>> = obj
        .try_iter()
        .map_err(|_| bad())?
        .collect::<PyResult<_>>()
        .map_err(|_| bad())?;
    if items.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, item) in out.iter_mut().zip(&items) {
        if item.is_instance_of::<pyo3::types::PyBool>() {
            return Err(bad());
        }
        *o = item.extract::<f64>().map_err(|_| bad())?;
    }
    Ok(out)
}

/// `obj` as a C-contiguous float64 numpy array of `ndim` dimensions (lists, integer and
/// float32 arrays converted); a `DriveError` naming `what` and `shape` otherwise.
fn float_array<'py>(
    py: Python<'py>,
    what: &str,
    shape: &str,
    obj: &Bound<'py, PyAny>,
    ndim: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let numpy = py.import("numpy")?;
    if numpy
        .call_method1("iscomplexobj", (obj,))
        .and_then(|c| c.extract::<bool>())
        .unwrap_or(false)
    {
        return Err(err(format!(
            "{what} must be a {shape} array of real numbers, got complex numbers"
        )));
    }
    // Booleans are not numbers here (True would silently be 1).
    let kind: Option<String> = numpy
        .call_method1("asarray", (obj,))
        .and_then(|a| a.getattr("dtype")?.getattr("kind")?.extract())
        .ok();
    if kind.as_deref() == Some("b") {
        return Err(err(format!(
            "{what} must be a {shape} array of numbers, got booleans"
        )));
    }
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    // asarray keeps a 0-d input 0-d (ascontiguousarray would make it 1-d), so that its
    // shape is reported as it is.
    let a = numpy
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| err(format!("{what} must be a {shape} array of numbers: {e}")))?;
    let dims: Vec<usize> = a.getattr("shape")?.extract()?;
    let a = numpy.call_method1("ascontiguousarray", (a,))?;
    if dims.len() != ndim {
        return Err(err(format!(
            "{what} must be a {shape} array, got shape {dims:?}"
        )));
    }
    Ok(a)
}

fn finite(what: &str, v: &[f64]) -> PyResult<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(err(format!("{what}: value {i} is not a finite number"))),
        None => Ok(()),
    }
}

#[pymethods]
impl Model {
    /// The model's name.
    #[getter]
    fn name(&self) -> String {
        self.model.name()
    }

    /// The prediction step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// Poses (H, 3): x, y, yaw after each of the (H, 2) commands (the vehicle's inputs), from
    /// `start` (x, y, yaw; the origin by default) with the measured inputs `start_wheels`
    /// (zero by default), the yaw rate the IMU measured, `start_yaw_rate` (none by
    /// default), and the body velocity (x, y; m/s) the localization measured just before,
    /// `start_velocity` (none by default), as `drive predict`.
    #[pyo3(signature = (commands, start=None, start_wheels=None, start_yaw_rate=None, start_velocity=None))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        commands: &Bound<'py, PyAny>,
        start: Option<&Bound<'py, PyAny>>,
        start_wheels: Option<&Bound<'py, PyAny>>,
        start_yaw_rate: Option<&Bound<'py, PyAny>>,
        start_velocity: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let velocity: Option<[f64; 2]> = start_velocity
            .filter(|v| !v.is_none())
            .map(|v| numbers_of("start_velocity", Some(v)))
            .transpose()?;
        if let Some(v) = velocity {
            finite("start_velocity", &v)?;
        }
        let start: [f64; 3] = numbers_of("start", start)?;
        let start_wheels: [f64; 2] = numbers_of("start_wheels", start_wheels)?;
        let yaw_rate = start_yaw_rate
            .filter(|w| !w.is_none())
            .map(|w| number_of("start_yaw_rate", "a number (rad/s)", w))
            .transpose()?;
        let commands = float_array(py, "commands", "(H, 2)", commands, 2)?;
        let commands: PyReadonlyArray2<'py, f64> = commands.extract()?;
        let shape = commands.shape();
        if shape.len() != 2 || shape[1] != 2 {
            return Err(err(format!(
                "commands must be an (H, 2) array, got shape {shape:?}"
            )));
        }
        let flat: Vec<f64> = commands.as_array().iter().copied().collect();
        finite("commands", &flat)?;
        finite("start", &start)?;
        finite("start_wheels", &start_wheels)?;
        if let Some(w) = yaw_rate {
            finite("start_yaw_rate", &[w])?;
        }
        let start = self.start(start, start_wheels, yaw_rate, velocity);
        let cmds: Vec<Input> = flat
            .chunks_exact(2)
            .map(|c| Input::new(c[0], c[1]))
            .collect();
        let poses = self.model.predict(&start, &cmds);
        // Never a non-finite pose: the command line's refusal.
        if let Some(e) = MotionError::not_finite(&self.model.name(), self.model.dt(), &poses, &[]) {
            return Err(err(e));
        }
        let out: Vec<f64> = poses.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        numpy::ndarray::Array2::from_shape_vec((poses.len(), 3), out)
            .map(|a| a.into_pyarray(py))
            .map_err(err)
    }

    /// Poses (B, H, 3) of B command sequences (B, H, 2), each from its row of `starts`
    /// (B, 3; the origin by default), `start_wheels` (B, 2; zero by default) and
    /// `start_yaw_rates` (B,; none by default) and `start_velocities` (B, 2; none by
    /// default); computed in parallel without the GIL. Row b equals
    /// `predict(commands[b], starts[b], ...)`.
    #[pyo3(signature = (commands, starts=None, start_wheels=None, start_yaw_rates=None, start_velocities=None))]
    fn predict_batch<'py>(
        &self,
        py: Python<'py>,
        commands: &Bound<'py, PyAny>,
        starts: Option<&Bound<'py, PyAny>>,
        start_wheels: Option<&Bound<'py, PyAny>>,
        start_yaw_rates: Option<&Bound<'py, PyAny>>,
        start_velocities: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let commands = float_array(py, "commands", "(B, H, 2)", commands, 3)?;
        let commands: PyReadonlyArray3<'py, f64> = commands.extract()?;
        let starts = match starts {
            Some(a) => Some(float_array(py, "starts", "(B, 3)", a, 2)?.extract()?),
            None => None,
        };
        let start_wheels = match start_wheels {
            Some(a) => Some(float_array(py, "start_wheels", "(B, 2)", a, 2)?.extract()?),
            None => None,
        };
        let start_velocities = match start_velocities.filter(|a| !a.is_none()) {
            Some(a) => Some(float_array(py, "start_velocities", "(B, 2)", a, 2)?.extract()?),
            None => None,
        };
        let shape = commands.shape().to_vec();
        if shape[2] != 2 {
            return Err(err(format!(
                "commands must be a (B, H, 2) array, got shape {shape:?}"
            )));
        }
        let (b, h) = (shape[0], shape[1]);
        let flat: Vec<f64> = commands.as_array().iter().copied().collect();
        finite("commands", &flat)?;
        let rows = |a: Option<PyReadonlyArray2<'py, f64>>,
                    width: usize,
                    what: &str|
         -> PyResult<Vec<f64>> {
            match a {
                None => Ok(vec![0.0; b * width]),
                Some(a) => {
                    if a.shape() != [b, width] {
                        return Err(err(format!(
                            "{what} must be a ({b}, {width}) array, got shape {:?}",
                            a.shape()
                        )));
                    }
                    let v: Vec<f64> = a.as_array().iter().copied().collect();
                    finite(what, &v)?;
                    Ok(v)
                }
            }
        };
        let poses0 = rows(starts, 3, "starts")?;
        let wheels = rows(start_wheels, 2, "start_wheels")?;
        let velocities = start_velocities
            .is_some()
            .then(|| rows(start_velocities, 2, "start_velocities"))
            .transpose()?;
        let yaw_rates: Option<Vec<f64>> = match start_yaw_rates.filter(|w| !w.is_none()) {
            None => None,
            Some(a) => {
                let a: PyReadonlyArray1<'py, f64> =
                    float_array(py, "start_yaw_rates", "(B,)", a, 1)?.extract()?;
                if a.shape() != [b] {
                    return Err(err(format!(
                        "start_yaw_rates must be a ({b},) array, got shape {:?}",
                        a.shape()
                    )));
                }
                let v: Vec<f64> = a.as_array().iter().copied().collect();
                finite("start_yaw_rates", &v)?;
                Some(v)
            }
        };
        let starts: Vec<StartState> = (0..b)
            .map(|i| {
                self.start(
                    [poses0[3 * i], poses0[3 * i + 1], poses0[3 * i + 2]],
                    [wheels[2 * i], wheels[2 * i + 1]],
                    yaw_rates.as_ref().map(|w| w[i]),
                    velocities.as_ref().map(|v| [v[2 * i], v[2 * i + 1]]),
                )
            })
            .collect();
        let cmds: Vec<Input> = flat
            .chunks_exact(2)
            .map(|c| Input::new(c[0], c[1]))
            .collect();
        let mut poses = vec![Pose::zeros(); b * h];
        let model = self.model.as_ref();
        py.detach(|| predict_batch_parallel(model, &starts, &cmds, h, &mut poses, 64))
            .map_err(err)?;
        // Never a non-finite pose: the command line's refusal, naming the sequence.
        if h > 0 {
            for (i, row) in poses.chunks(h).enumerate() {
                if let Some(e) = MotionError::not_finite(&model.name(), model.dt(), row, &[]) {
                    return Err(err(format!("sequence {i}: {e}")));
                }
            }
        }
        let out: Vec<f64> = poses.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        numpy::ndarray::Array3::from_shape_vec((b, h, 3), out)
            .map(|a| a.into_pyarray(py))
            .map_err(err)
    }

    /// Saves the model as the command line's model file (`drive predict --model`).
    fn save(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = path_of("path", path)?;
        let text = model_to_json(self.model.as_ref(), &self.robot).map_err(err)?;
        std::fs::write(&path, text)
            .map_err(|e| err(format!("{}: cannot write: {e}", path.display())))
    }

    fn __repr__(&self) -> String {
        format!("Model({:?}, dt={} s)", self.model.name(), self.model.dt())
    }
}

/// Fits `model` (a model name, as `drive train --model`) on the dataset's first `split` of
/// the intervals (all of them when None), for predictions that start from `start`
/// (`drive train --start`).
#[pyfunction]
#[pyo3(signature = (dataset, model, split=None, start=None))]
fn fit(
    py: Python<'_>,
    dataset: &Bound<'_, PyAny>,
    model: &Bound<'_, PyAny>,
    split: Option<&Bound<'_, PyAny>>,
    start: Option<&Bound<'_, PyAny>>,
) -> PyResult<Model> {
    let dataset = dataset_of(dataset)?;
    let start = start_info_of(start)?;
    let model: String = model.extract().map_err(|_| {
        err(format!(
            "model must be a model name such as 'slip-blr' (see drive list), got {}",
            type_name(model)
        ))
    })?;
    let model = model.as_str();
    let split = split
        .filter(|s| !s.is_none())
        .map(|s| number_of("split", "a number between 0 and 1", s))
        .transpose()?;
    let registries = Registries::builtin();
    let spec = registries.model(model).map_err(err)?.clone();
    let spec = spec.clone().with_uncertainty(spec.uncertainty, start);
    let data = &dataset.inner;
    let fitted = py.detach(|| -> Result<Box<dyn MotionModel>, String> {
        let train = match split {
            Some(f) => split_by_interval(data, f).map_err(|e| e.to_string())?.0,
            None => data.all(),
        };
        spec.fit(&train)
            .map_err(|e| format!("fitting {model}: {e}"))
    });
    Ok(Model {
        model: fitted.map_err(err)?.into(),
        robot: data.robot.clone(),
    })
}

/// Loads a model file written by `drive train` or `Model.save`.
#[pyfunction]
fn load_model(path: &Bound<'_, PyAny>) -> PyResult<Model> {
    let path = path_of("path", path)?;
    let name = path.display().to_string();
    // The command line's words (drive predict --model).
    let text =
        drive::traits::files::read_text(&path, drive::models::model_file::MAX_MODEL_FILE_BYTES)
            .map_err(|e| err(format!("reading {name}: {e}")))?;
    let (model, robot) = model_from_json(&name, &text).map_err(err)?;
    Ok(Model {
        model: model.into(),
        robot,
    })
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("DriveError", m.py().get_type::<DriveError>())?;
    m.add_class::<Dataset>()?;
    m.add_class::<Model>()?;
    m.add_function(wrap_pyfunction!(load_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_json, m)?)?;
    m.add_function(wrap_pyfunction!(bench_json, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(load_model, m)?)?;
    runner::register(m)?;
    tracker::register(m)?;
    Ok(())
}
