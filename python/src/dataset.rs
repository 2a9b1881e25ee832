//! `drive.Dataset`: windows read from files, DataFrames or an import, and written back.

use crate::args::path_of;
use crate::err;
use drive::traits::Dataset as RustDataset;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A DRIVE window dataset: the window CSV with its sidecar (robot, rates, vehicle).
#[pyclass(module = "drive._native", frozen)]
pub(crate) struct Dataset {
    pub(crate) inner: RustDataset,
    /// The keep/drop report's JSON text, for an imported dataset.
    import_report: Option<String>,
    /// The files it was read from (the window CSV and its sidecar), which `save` never
    /// rewrites.
    read_from: Vec<std::path::PathBuf>,
}

#[pymethods]
impl Dataset {
    /// A dataset from the window CSV's text and the sidecar's JSON text.
    #[staticmethod]
    fn from_text(csv: &str, sidecar: &str) -> PyResult<Self> {
        drive::data::parse_dataset("DataFrame", csv, "meta", sidecar)
            .map(|inner| Dataset {
                inner,
                import_report: None,
                read_from: Vec::new(),
            })
            .map_err(err)
    }

    /// A dataset from a pandas DataFrame with the window CSV's columns (what `to_pandas`
    /// or `pandas.read_csv` of a project CSV gives) and the sidecar as a dict (what `meta`
    /// or `json.load` of a sidecar gives). Data handed over in memory is taken as it is:
    /// the sidecar's checksum of its CSV file is not checked; extra columns are left out
    /// with a warning; an error names the DataFrame's column and row.
    #[staticmethod]
    fn from_pandas<'py>(
        py: Python<'py>,
        df: &Bound<'py, PyAny>,
        meta: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        py.import("drive._pandas")?
            .call_method1("dataset_from_pandas", (df, meta))
    }

    /// The window CSV as a pandas DataFrame (one row per sample, the command line's columns
    /// and values; needs pandas); `Dataset.from_pandas(df, dataset.meta)` gives the
    /// dataset back.
    fn to_pandas<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        slf.py()
            .import("drive._pandas")?
            .call_method1("dataset_to_pandas", (slf,))
    }

    /// The sidecar as a dict (robot, rate, vehicle, frame, terrain, window count).
    #[getter]
    fn meta<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?
            .call_method1("loads", (self.sidecar_json()?,))
    }

    /// The keep/drop report of `drive.import_raw` / `drive.import_bag` (the object of
    /// `drive import --json`), None for a dataset read from files.
    #[getter]
    fn import_report<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        match &self.import_report {
            None => Ok(None),
            Some(text) => py.import("json")?.call_method1("loads", (text,)).map(Some),
        }
    }

    /// The window CSV's columns as arrays: name -> float64 array (`phase`: a list of
    /// "transient" / "steady"; `window` and `k`: int64), in the CSV's order.
    fn _columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let data = &self.inner;
        let names = drive::data::columns(&data.robot);
        let rows: usize = data.windows.iter().map(|w| w.len()).sum();
        let mut ints = [Vec::with_capacity(rows), Vec::with_capacity(rows)];
        let mut phase = Vec::with_capacity(rows);
        let mut floats: Vec<Vec<f64>> = (0..9).map(|_| Vec::with_capacity(rows)).collect();
        let dt = data.robot.dt();
        for w in &data.windows {
            for k in 0..w.len() {
                ints[0].push(w.index as i64);
                ints[1].push(k as i64);
                phase.push(w.phase.as_str());
                let row = [
                    k as f64 * dt,
                    w.command[k][0],
                    w.command[k][1],
                    w.measured[k][0],
                    w.measured[k][1],
                    w.pose[k].x,
                    w.pose[k].y,
                    w.pose[k].z,
                    w.imu_yaw_rate[k],
                ];
                for (column, v) in floats.iter_mut().zip(row) {
                    column.push(v);
                }
            }
        }
        let out = PyDict::new(py);
        let [window, k] = ints;
        out.set_item(names[0], window.into_pyarray(py))?;
        out.set_item(names[1], phase)?;
        out.set_item(names[2], k.into_pyarray(py))?;
        for (name, column) in names[3..].iter().zip(floats) {
            out.set_item(*name, column.into_pyarray(py))?;
        }
        Ok(out)
    }

    /// The sidecar's JSON text (robot, rate, vehicle, frame, terrain, window count).
    fn sidecar_json(&self) -> PyResult<String> {
        drive::data::sidecar_json(&self.inner.robot, self.inner.windows.len(), None).map_err(err)
    }

    /// Writes the dataset as the command line's files: the window CSV at `path` and its
    /// sidecar beside it (`run.csv` -> `run.meta.json`).
    fn save(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        use drive::data::output::Outputs;
        let path = path_of("path", path)?;
        // A window CSV under its own kind of name (drive simulate --out's rule).
        drive::data::output_names::refused_name(
            &path,
            "a window CSV (uncompressed)",
            drive::data::output_names::NOT_CSV_NAMES,
            true,
        )
        .map_err(err)?;
        // Never onto the files it was read from: the CSV's columns and the sidecar's fields
        // it does not keep (calibration steps, the source and licence) would be lost.
        let read_from: Vec<(&str, &std::path::Path)> = self
            .read_from
            .iter()
            .map(|p| ("(the file this dataset was read from)", p.as_path()))
            .collect();
        let mut outputs = Outputs::new(&read_from);
        let sidecar = drive::data::sidecar_path(&path);
        outputs
            .check(&[("path", &path), ("its sidecar", &sidecar)])
            .map_err(err)?;
        drive::data::stage_dataset(&mut outputs, &self.inner, &path).map_err(err)?;
        outputs.publish().map(|_| ()).map_err(err)
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

/// The required columns of a window CSV with this sidecar (its JSON text), in order.
#[pyfunction]
pub(crate) fn columns_for_sidecar(sidecar: &str) -> PyResult<Vec<&'static str>> {
    let (robot, _) = drive::data::parse_sidecar("meta", sidecar).map_err(err)?;
    Ok(drive::data::columns(&robot).to_vec())
}

/// Imports a raw DRIVE log (`bag` false) or a rosbag2 bag for `robot` as `drive import`:
/// the dataset (with its keep/drop report, `drive import --json`'s object) and why it must
/// not be used (None when it may).
#[pyfunction]
#[pyo3(signature = (path, robot, bag, topics, max_gap, localization_timeout, terrain, allow))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn import_recording(
    py: Python<'_>,
    path: &Bound<'_, PyAny>,
    robot: &str,
    bag: bool,
    topics: Vec<String>,
    max_gap: f64,
    localization_timeout: f64,
    terrain: String,
    allow: Vec<String>,
) -> PyResult<(Dataset, Option<String>)> {
    use drive::import::{import_recording, ImportOptions, Recording};
    let path = path_of("path", path)?;
    let checks: Vec<&str> = drive::data::quality::CHECKS
        .iter()
        .map(|(k, _)| *k)
        .collect();
    if let Some(a) = allow.iter().find(|a| !checks.contains(&a.as_str())) {
        return Err(err(format!(
            "allow: no check {a:?} (the checks are: {})",
            checks.join(", ")
        )));
    }
    let imported = py.detach(|| {
        let recording = if bag {
            Recording::Bag {
                path: &path,
                topics: &topics,
            }
        } else {
            Recording::Raw(&path)
        };
        let options = ImportOptions {
            max_gap_s: max_gap,
            localization_timeout_s: localization_timeout,
            terrain,
            name: None,
        };
        import_recording(crate::registries(), &recording, robot, &options)
            .map_err(|e| e.to_string())
    });
    let imported = imported.map_err(err)?;
    let failure = imported.failure(&allow);
    // What `drive import` prints as notes, and the data checks' findings that do not stop
    // the import, each a UserWarning (a fatal finding not allowed is the failure instead).
    if failure.is_none() {
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        let name = &imported.dataset.robot.name;
        let texts = imported
            .report
            .notes
            .iter()
            .map(|n| format!("{name}: {n}"))
            .chain(imported.report.checks.iter().map(|f| {
                let allowed = if f.severity == drive::data::quality::Severity::Fatal {
                    ", which drive check calls fatal: imported because allow names it"
                } else {
                    ""
                };
                format!("{name}: {} ({}{allowed})", f.message, f.check)
            }));
        for text in texts {
            // The notes and findings hold no NUL (this project writes them).
            let message = std::ffi::CString::new(text).unwrap_or_default();
            PyErr::warn(py, &category, &message, 1)?;
        }
    }
    let report = imported.report.to_json().to_string();
    Ok((
        Dataset {
            inner: imported.dataset,
            import_report: Some(report),
            read_from: vec![path.clone()],
        },
        failure,
    ))
}

/// The bundled Husky dataset (`path` None) or a window CSV with its sidecar beside it (or
/// at `sidecar`). What the data checks (`drive check`) find in it is raised as a
/// `UserWarning` each, naming the check (`not-moving`, `encoder-units`, ...) and whether it
/// calls the data useless: `warnings.simplefilter("error")` turns them into errors.
#[pyfunction]
#[pyo3(signature = (path=None, sidecar=None))]
pub(crate) fn load_dataset(
    py: Python<'_>,
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
    let read_from = path
        .iter()
        .flat_map(|p| {
            [
                p.clone(),
                sidecar
                    .clone()
                    .unwrap_or_else(|| drive::data::sidecar_to_read(p)),
            ]
        })
        .collect();
    let inner = match path {
        None => drive::bundled::husky(),
        Some(p) => drive::data::read_dataset(&p, sidecar.as_deref()),
    }
    .map_err(err)?;
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for f in drive::data::quality::check(&inner, None) {
        let fatal = if f.severity == drive::data::quality::Severity::Fatal {
            ", which drive check calls fatal: the command line refuses such data without --allow-useless"
        } else {
            ""
        };
        let message = std::ffi::CString::new(format!(
            "{}: {} ({}{fatal})",
            inner.robot.name, f.message, f.check
        ))
        // A finding's text holds no NUL (the checks write it).
        .unwrap_or_default();
        PyErr::warn(py, &category, &message, 1)?;
    }
    Ok(Dataset {
        inner,
        import_report: None,
        read_from,
    })
}

/// `Err` naming the first fatal finding of the data checks (`drive check`) of `data`, as
/// the command line refuses useless data in every command that fits or scores on it;
/// `Ok` when `allow` (the command line's `--allow-useless`) or when nothing is fatal.
pub(crate) fn refuse_useless(data: &RustDataset, what: &str, allow: bool) -> PyResult<()> {
    if allow {
        return Ok(());
    }
    let fatal = drive::data::quality::check(data, None)
        .into_iter()
        .find(|f| f.severity == drive::data::quality::Severity::Fatal);
    match fatal {
        Some(f) => Err(err(format!(
            "{what} '{}': the data checks call it useless: {} ({}; drive check says more; allow_useless=True fits and scores on it anyway)",
            data.robot.name, f.message, f.check
        ))),
        None => Ok(()),
    }
}

/// Raises `DriveError` naming the first fatal finding of the data checks of `dataset`
/// unless `allow_useless`: what a call that runs the command line on a temporary copy of
/// the dataset (`drive.report`) asks first, so that the error names the dataset.
#[pyfunction]
pub(crate) fn _refuse_useless(dataset: &Bound<'_, PyAny>, allow_useless: bool) -> PyResult<()> {
    let dataset = crate::args::dataset_of(dataset)?;
    refuse_useless(&dataset.inner, "the dataset", allow_useless)
}
