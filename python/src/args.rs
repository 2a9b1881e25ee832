//! Python values into the framework's: paths, numbers, numpy arrays, datasets, each with a
//! `DriveError` that names the argument.

use crate::dataset::Dataset;
use crate::err;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The Python type name of `obj`, for messages.
pub(crate) fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map_or_else(|_| "?".into(), |n| n.to_string())
}

/// A path from a `str` or an `os.PathLike`, or a `DriveError` naming `what`.
pub(crate) fn path_of(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
    obj.extract::<std::path::PathBuf>().map_err(|_| {
        err(format!(
            "{what} must be a path (str or os.PathLike), got {}",
            type_name(obj)
        ))
    })
}

/// The dataset `obj`, or a `DriveError`.
pub(crate) fn dataset_of<'a, 'py>(obj: &'a Bound<'py, PyAny>) -> PyResult<PyRef<'py, Dataset>> {
    obj.extract::<PyRef<'py, Dataset>>().map_err(|_| {
        err(format!(
            "dataset must be a drive.Dataset (drive.load_dataset or drive.Dataset.from_pandas), got {}",
            type_name(obj)
        ))
    })
}

/// `obj`'s repr for a message, cut to 40 characters (a 400-digit integer stays one line).
pub(crate) fn short_repr(obj: &Bound<'_, PyAny>) -> String {
    let r = obj
        .repr()
        .map_or_else(|_| type_name(obj), |r| r.to_string());
    match r.char_indices().nth(40) {
        Some((cut, _)) => format!("{}... ({} characters)", &r[..cut], r.chars().count()),
        None => r,
    }
}

/// A real number (not a bool), or a `DriveError` saying what `what` must be.
pub(crate) fn number_of(what: &str, expected: &str, obj: &Bound<'_, PyAny>) -> PyResult<f64> {
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
pub(crate) fn numbers_of<const N: usize>(
    what: &str,
    obj: Option<&Bound<'_, PyAny>>,
) -> PyResult<[f64; N]> {
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

/// `obj` as one number per input axis of a vehicle of `dim` axes (zero when None); a
/// `DriveError` naming `what` otherwise. Finiteness is the caller's to check.
pub(crate) fn input_of(
    what: &str,
    obj: Option<&Bound<'_, PyAny>>,
    dim: usize,
) -> PyResult<drive::traits::Input> {
    let mut u = drive::traits::Input::zeros();
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(u);
    };
    let bad = || {
        err(format!(
            "{what} must be {dim} numbers (one per input axis of the vehicle), got {}",
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
    if items.len() != dim || dim > drive::traits::MAX_INPUTS {
        return Err(bad());
    }
    for (i, item) in items.iter().enumerate() {
        if item.is_instance_of::<pyo3::types::PyBool>() {
            return Err(bad());
        }
        u[i] = item.extract::<f64>().map_err(|_| bad())?;
    }
    Ok(u)
}

/// The first `dim` axes of `u` as a Python tuple.
pub(crate) fn input_tuple<'py>(
    py: Python<'py>,
    u: &drive::traits::Input,
    dim: usize,
) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
    pyo3::types::PyTuple::new(py, u.iter().take(dim))
}

/// `obj` as a C-contiguous float64 numpy array of `ndim` dimensions (lists, integer and
/// float32 arrays converted); a `DriveError` naming `what` and `shape` otherwise.
pub(crate) fn float_array<'py>(
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

pub(crate) fn finite(what: &str, v: &[f64]) -> PyResult<()> {
    if all_finite(v) {
        return Ok(());
    }
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(err(format!(
            "{what}: entry {i} (counting from 0, row by row) is {}, not a finite number",
            v[i]
        ))),
        None => Ok(()),
    }
}

/// `Err` naming the first value of `v` beyond what the command line's readers accept
/// ([`drive::traits::limits::MAX_ABS_MEASUREMENT`], 1e9: a corrupted number, or a value in
/// other units), as `drive predict` refuses it in a command file.
pub(crate) fn within_readers(what: &str, v: &[f64]) -> PyResult<()> {
    use drive::traits::limits::{Short, MAX_ABS_MEASUREMENT};
    match v.iter().position(|x| x.abs() > MAX_ABS_MEASUREMENT) {
        Some(i) => Err(err(format!(
            "{what}: entry {i} (counting from 0, row by row) is {}, beyond {} (what the command line reads): in the robot's units?",
            Short(v[i]),
            Short(MAX_ABS_MEASUREMENT)
        ))),
        None => Ok(()),
    }
}

/// Whether every value is finite, in a loop the compiler vectorizes (`x * 0` is 0 for a
/// finite x and NaN for an infinity or a NaN; a NaN makes the sum NaN).
pub(crate) fn all_finite(v: &[f64]) -> bool {
    let mut lanes = [0.0f64; 8];
    let mut chunks = v.chunks_exact(8);
    for c in &mut chunks {
        for (l, x) in lanes.iter_mut().zip(c) {
            *l += x * 0.0;
        }
    }
    let rest: f64 = chunks.remainder().iter().map(|x| x * 0.0).sum();
    (lanes.iter().sum::<f64>() + rest) == 0.0
}

/// [`all_finite`] over chunks on every core (a batch's commands or poses, megabytes).
pub(crate) fn all_finite_parallel(v: &[f64]) -> bool {
    use rayon::prelude::*;
    v.par_chunks(1 << 15).all(all_finite)
}

/// The error of reading `path`: `drive.DriveFileNotFoundError` (a `FileNotFoundError` and a
/// `DriveError`) when `path` names a file (a `.toml` name or a path that looks like one)
/// that does not exist, a `DriveError` otherwise; the message is `e`'s either way.
pub(crate) fn read_error(py: Python<'_>, path: &str, e: impl std::fmt::Display) -> PyErr {
    let missing = path.ends_with(".toml") && !std::path::Path::new(path).exists();
    if missing {
        if let Ok(class) = py
            .import("drive")
            .and_then(|m| m.getattr("DriveFileNotFoundError"))
        {
            if let Ok(value) = class.call1((e.to_string(), path)) {
                return PyErr::from_value(value);
            }
        }
    }
    err(e)
}
