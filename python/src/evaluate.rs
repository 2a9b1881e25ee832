//! The command line's evaluations as JSON texts or columns: `drive eval`, its per-window
//! errors, `drive bench`.

use crate::args::{dataset_of, path_of, short_repr, type_name};
use crate::err;
use crate::interrupt::interruptible;
use drive::studies::compare_specs_with_progress;
use drive::traits::StartInfo;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// What the predictions start from, by its command-line name (`drive eval --start`; the
/// default when None).
pub(crate) fn start_info_of(obj: Option<&Bound<'_, PyAny>>) -> PyResult<StartInfo> {
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

/// The model names of `models` (a list of str), `None` for the default.
pub(crate) fn model_names(models: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<String>>> {
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

/// The models (default: the paper's four) fitted on the first `split` of the dataset's
/// intervals and scored on the rest, predicting from `start`: `drive eval`'s comparison.
/// Stops between models on Ctrl-C; `progress(done, total)` after each model.
fn comparison(
    py: Python<'_>,
    dataset: &Bound<'_, PyAny>,
    models: Option<&Bound<'_, PyAny>>,
    split: f64,
    start: Option<&Bound<'_, PyAny>>,
    progress: Option<&Bound<'_, PyAny>>,
    allow_useless: bool,
) -> PyResult<drive::studies::Comparison> {
    let dataset = dataset_of(dataset)?;
    crate::dataset::refuse_useless(&dataset.inner, "the dataset", allow_useless)?;
    let start = start_info_of(start)?;
    let names = model_names(models)?.unwrap_or_else(|| {
        drive::studies::PAPER_MODELS
            .split(',')
            .map(String::from)
            .collect()
    });
    if names.is_empty() {
        return Err(err("models is empty"));
    }
    // Its own copy of the data for the work's thread (a Ctrl-C returns at once, and the
    // work stops once the fits under way are done).
    let data = dataset.inner.clone();
    let progress = progress.filter(|p| !p.is_none());
    interruptible(py, progress, move |ticker| {
        let registries = crate::registries();
        let specs: Vec<_> = registries
            .models()
            .resolve_list(&names)
            .map_err(|e| e.to_string())?
            .into_iter()
            .map(|s| s.clone().with_uncertainty(s.uncertainty, start))
            .collect();
        ticker.set_total(specs.len());
        compare_specs_with_progress(&data, split, &specs, &|| ticker.tick())
            .map_err(|e| e.to_string())
    })?
    .map_err(err)
}

/// `drive eval --json` as a JSON text: the models (default: the paper's four) fitted on the
/// first `split` of the intervals and scored on the rest, their predictions starting from
/// `start` (`drive eval --start`); `progress(done, total)` after each model. Data the data
/// checks call useless is refused unless `allow_useless` (`drive eval --allow-useless`).
#[pyfunction]
#[pyo3(signature = (dataset, models=None, split=0.5, start=None, progress=None, allow_useless=false))]
pub(crate) fn evaluate_json(
    py: Python<'_>,
    dataset: &Bound<'_, PyAny>,
    models: Option<&Bound<'_, PyAny>>,
    split: f64,
    start: Option<&Bound<'_, PyAny>>,
    progress: Option<&Bound<'_, PyAny>>,
    allow_useless: bool,
) -> PyResult<String> {
    let cmp = comparison(py, dataset, models, split, start, progress, allow_useless)?;
    serde_json::to_string(&cmp).map_err(err)
}

/// Per-window errors as `drive eval --per-window` writes them: columns model, window,
/// interval, phase, translational_m, rotational_rad. Useless data refused unless
/// `allow_useless`.
#[pyfunction]
#[pyo3(signature = (dataset, models=None, split=0.5, start=None, allow_useless=false))]
pub(crate) fn per_window_columns<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, PyAny>,
    models: Option<&Bound<'py, PyAny>>,
    split: f64,
    start: Option<&Bound<'py, PyAny>>,
    allow_useless: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let cmp = comparison(py, dataset, models, split, start, None, allow_useless)?;
    let rows = cmp
        .models
        .iter()
        .flat_map(|m| m.report.windows.iter().map(move |w| (m.name.as_str(), w)));
    let (mut model, mut window, mut interval, mut phase, mut trans, mut rot) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for (name, w) in rows {
        model.push(name);
        window.push(w.window as i64);
        interval.push(w.interval as i64);
        phase.push(w.phase.as_str());
        trans.push(w.error.translational);
        rot.push(w.error.rotational);
    }
    let out = PyDict::new(py);
    out.set_item("model", model)?;
    out.set_item("window", window.into_pyarray(py))?;
    out.set_item("interval", interval.into_pyarray(py))?;
    out.set_item("phase", phase)?;
    out.set_item("translational_m", trans.into_pyarray(py))?;
    out.set_item("rotational_rad", rot.into_pyarray(py))?;
    Ok(out)
}

/// `drive bench --json` as a JSON text: the models (default: naive, powertrain, slip-blr,
/// acc-blr, slip-ipem) on every dataset of the suite file `suite` (every bundled dataset when
/// None), each split at `split`, with the transfer between runs of one robot unless
/// `transfer` is false; datasets the data checks call useless ranked when `allow_useless`.
/// Stops on Ctrl-C (`KeyboardInterrupt`); `progress(done, total)` is called as the units of
/// work complete. `adapt` (seconds of each target's training half) runs the adaptation
/// track (`--adapt --adapt-times`), with a terrain library for each pair when
/// `adapt_library` (`--adapt-library`).
#[pyfunction]
#[pyo3(signature = (suite=None, models=None, split=0.5, transfer=true, allow_useless=false, progress=None, adapt=None, adapt_library=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bench_json(
    py: Python<'_>,
    suite: Option<&Bound<'_, PyAny>>,
    models: Option<&Bound<'_, PyAny>>,
    split: f64,
    transfer: bool,
    allow_useless: bool,
    progress: Option<&Bound<'_, PyAny>>,
    adapt: Option<Vec<f64>>,
    adapt_library: bool,
) -> PyResult<String> {
    if adapt_library && adapt.is_none() {
        return Err(err(
            "adapt_library adds a terrain library to the adaptation track: give adapt too",
        ));
    }
    if let Some(times) = &adapt {
        if times.len() > 100 || times.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
            return Err(err(
                "adapt must be at most 100 seconds from 0 on (finite, not negative)",
            ));
        }
    }
    let suite = suite
        .filter(|p| !p.is_none())
        .map(|p| path_of("suite", p))
        .transpose()?;
    let names = model_names(models)?.unwrap_or_else(|| {
        drive::studies::BENCH_MODELS
            .split(',')
            .map(String::from)
            .collect()
    });
    if names.is_empty() {
        return Err(err("models is empty"));
    }
    if !(split > 0.0 && split < 1.0) {
        return Err(err(format!(
            "split {split} must lie strictly between 0 and 1"
        )));
    }
    let progress = progress.filter(|p| !p.is_none());
    let result = interruptible(py, progress, move |ticker| -> Result<String, String> {
        let registries = crate::registries();
        let specs = registries
            .models()
            .resolve_list(&names)
            .map_err(|e| e.to_string())?;
        // A dataset that cannot be read is skipped and named, as the command line does.
        let (inputs, unloaded) = match &suite {
            Some(path) => {
                let entries = drive::data::suite::read_suite(path).map_err(|e| e.to_string())?;
                drive::suite::load_skipping(registries, &entries)
            }
            None => drive::suite::bundled(registries).map(|b| (b, Vec::new())),
        }
        .map_err(|e| e.to_string())?;
        let config = drive::studies::BenchConfig {
            split,
            transfer,
            allow_useless,
            adapt: adapt.map(|times_s| drive::studies::AdaptStudy {
                split,
                times_s,
                ..Default::default()
            }),
            adapt_library,
            ..Default::default()
        };
        ticker.set_total(drive::studies::bench_units(&inputs, specs.len(), &config));
        let mut bench = drive::studies::run_bench(&inputs, &specs, &config, &|| ticker.tick())
            .map_err(|e| e.to_string())?;
        bench.skipped.extend(unloaded);
        serde_json::to_string(&bench).map_err(|e| e.to_string())
    })?;
    result.map_err(err)
}

/// `drive adapt --json` as a JSON text: `prior` (a fitted `drive.Model`, adapted as it is, or
/// a `drive.Dataset` each model of `models` is fitted on) adapting to `data`'s training half
/// (its first `split` of the intervals), scored on the rest after each of `times` seconds
/// (default 0, 15, 30, 60, 120, 240) beside the prior alone, a fit from scratch and the own
/// fit. Stops on Ctrl-C (`KeyboardInterrupt`) between models; `progress(done, total)` after
/// each model. `library`: datasets of the robot on other grounds, blended with the prior by
/// their likelihood (`drive adapt --library`).
#[pyfunction]
#[pyo3(signature = (prior, data, models=None, split=0.5, times=None, progress=None, allow_useless=false, library=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn adapt_json(
    py: Python<'_>,
    prior: &Bound<'_, PyAny>,
    data: &Bound<'_, PyAny>,
    models: Option<&Bound<'_, PyAny>>,
    split: f64,
    times: Option<Vec<f64>>,
    progress: Option<&Bound<'_, PyAny>>,
    allow_useless: bool,
    library: Option<Vec<Bound<'_, PyAny>>>,
) -> PyResult<String> {
    let target = dataset_of(data)?;
    crate::dataset::refuse_useless(&target.inner, "the target", allow_useless)?;
    if library.as_ref().is_some_and(|l| l.len() > 50) {
        return Err(err("library holds at most 50 datasets"));
    }
    let mut library_data = Vec::new();
    for entry in library.iter().flatten() {
        let d = dataset_of(entry).map_err(|_| {
            err(format!(
                "library entries must be drive.Dataset objects, got {}",
                type_name(entry)
            ))
        })?;
        crate::dataset::refuse_useless(&d.inner, "a library dataset", allow_useless)?;
        library_data.push(std::sync::Arc::new(d.inner.clone()));
    }
    if !(split > 0.0 && split < 1.0) {
        return Err(err(format!(
            "split {split} must lie strictly between 0 and 1"
        )));
    }
    let times = times.unwrap_or_else(|| drive::studies::ADAPT_TIMES_S.to_vec());
    if times.len() > 100 || times.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
        return Err(err(
            "times must be at most 100 seconds from 0 on (finite, not negative)",
        ));
    }
    let names = model_names(models)?;
    let prior_model = prior.extract::<PyRef<'_, crate::model::Model>>().ok();
    let prior_data = if prior_model.is_some() {
        None
    } else {
        Some(dataset_of(prior).map_err(|_| {
            err(format!(
                "prior must be a drive.Model (fitted or loaded) or a drive.Dataset, got {}",
                type_name(prior)
            ))
        })?)
    };
    if let Some(d) = &prior_data {
        crate::dataset::refuse_useless(&d.inner, "the prior", allow_useless)?;
    }
    let model_name = prior_model.as_ref().map(|m| m.model.name());
    let names = match (names, &model_name) {
        (Some(n), Some(_)) if n.len() != 1 => {
            return Err(err(
                "a model prior is one model: models names the one fitted from scratch and on the target beside it",
            ))
        }
        (Some(n), _) => n,
        (None, Some(name)) => vec![name.clone()],
        (None, None) => drive::studies::ADAPT_MODELS
            .split(',')
            .map(String::from)
            .collect(),
    };
    if names.is_empty() {
        return Err(err("models is empty"));
    }
    let model = prior_model
        .as_ref()
        .map(|m| std::sync::Arc::clone(&m.model));
    // The work's thread has its own copies of the data (a Ctrl-C returns at once, while the
    // fits under way finish there).
    let prior_inner = prior_data.as_ref().map(|d| d.inner.clone());
    let target = target.inner.clone();
    let progress = progress.filter(|p| !p.is_none());
    interruptible(py, progress, move |ticker| -> Result<String, String> {
        let registries = crate::registries();
        let specs = registries
            .models()
            .resolve_list(&names)
            .map_err(|e| e.to_string())?;
        ticker.set_total(specs.len());
        let prior = match (&model, prior_inner.as_ref()) {
            (Some(m), _) => drive::studies::AdaptPrior::Model(m.as_ref()),
            (None, Some(d)) => drive::studies::AdaptPrior::Data(d),
            (None, None) => return Err("no prior".to_string()),
        };
        let study = drive::studies::AdaptStudy {
            split,
            times_s: times,
            library: library_data,
            ..Default::default()
        };
        let result = drive::studies::adapt_with_progress(
            registries,
            &prior,
            &target,
            &specs,
            &study,
            &|| ticker.tick(),
        )
        .map_err(|e| e.to_string())?;
        serde_json::to_string(&result).map_err(|e| e.to_string())
    })?
    .map_err(err)
}
