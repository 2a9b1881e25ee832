//! The paper's model comparison (Fig. 6) on one dataset: fit every named model on the
//! training intervals, score it on the evaluation intervals with eq. 8.

use crate::{
    evaluate_model, improvement_percent, split_by_interval, ModelReport, SplitError, Summary,
};
use drive_models::learners::Naive;
use drive_models::{LearnerRegistry, PowertrainChoice};
use drive_traits::{Dataset, FitError, Learner, MotionModel, Phase};
use serde::Serialize;
use std::time::Instant;
use thiserror::Error;

/// Why a comparison could not run.
#[derive(Debug, Error)]
pub enum CompareError {
    /// The split is invalid for this dataset.
    #[error(transparent)]
    Split(#[from] SplitError),
    /// A model name is not registered.
    #[error("unknown model '{name}' (the models are: {known})")]
    UnknownModel {
        /// The name asked for.
        name: String,
        /// The registered names, comma-separated.
        known: String,
    },
    /// A model could not be fitted on the training intervals.
    #[error("fitting {model}: {reason}")]
    Fit {
        /// model name
        model: String,
        /// why
        reason: FitError,
    },
}

/// Median and IQR of one error kind, with the improvement over the naive model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorSummary {
    /// Median.
    pub median: f64,
    /// First and third quartiles.
    pub iqr: [f64; 2],
    /// Improvement of the median over the naive model's, in percent.
    pub improvement_over_naive_percent: f64,
}

/// Both error kinds over a set of windows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseSummary {
    /// Windows counted.
    pub windows: usize,
    /// Translational MRMSE (m).
    pub translational_m: ErrorSummary,
    /// Rotational MRMSE (rad).
    pub rotational_rad: ErrorSummary,
}

/// One model's result.
#[derive(Debug, Serialize)]
pub struct ModelResult {
    /// Model name.
    pub name: String,
    /// The powertrain the model was fitted with (`None` for a model without one).
    pub powertrain: Option<PowertrainChoice>,
    /// Median translational MRMSE (m).
    pub translational_median_m: f64,
    /// Median rotational MRMSE (rad).
    pub rotational_median_rad: f64,
    /// Translational quartiles (m).
    pub translational_iqr_m: [f64; 2],
    /// Rotational quartiles (rad).
    pub rotational_iqr_rad: [f64; 2],
    /// All evaluation windows.
    pub all: PhaseSummary,
    /// Transient windows only.
    pub transient: Option<PhaseSummary>,
    /// Steady windows only.
    pub steady: Option<PhaseSummary>,
    /// Time to fit the model (s).
    pub fit_seconds: f64,
    /// Per-window errors (not serialized; see `--per-window`).
    #[serde(skip)]
    pub report: ModelReport,
    /// The fitted model.
    #[serde(skip)]
    pub model: Option<Box<dyn MotionModel>>,
}

/// The result of a comparison.
#[derive(Debug, Serialize)]
pub struct Comparison {
    /// Dataset name (from the sidecar).
    pub dataset: String,
    /// Robot name (from the sidecar).
    pub robot: String,
    /// Split fraction.
    pub split: f64,
    /// Training intervals.
    pub train_intervals: usize,
    /// Evaluation intervals.
    pub eval_intervals: usize,
    /// Training windows.
    pub train_windows: usize,
    /// Evaluation windows.
    pub eval_windows: usize,
    /// One result per model asked, in the order asked.
    pub models: Vec<ModelResult>,
}

fn summarize(
    report: &ModelReport,
    naive: &ModelReport,
    phase: Option<Phase>,
) -> Option<PhaseSummary> {
    let (t, r) = (report.translational(phase)?, report.rotational(phase)?);
    let (nt, nr) = (naive.translational(phase)?, naive.rotational(phase)?);
    let e = |s: Summary, base: Summary| ErrorSummary {
        median: s.median,
        iqr: [s.q1, s.q3],
        improvement_over_naive_percent: improvement_percent(s.median, base.median),
    };
    Some(PhaseSummary {
        windows: t.count,
        translational_m: e(t, nt),
        rotational_rad: e(r, nr),
    })
}

/// Fits each model of `names` (registered names, see [`drive_models::MODEL_NAMES`]) on the
/// first `floor(split x intervals)` intervals and evaluates it on the rest.
pub fn compare(data: &Dataset, split: f64, names: &[&str]) -> Result<Comparison, CompareError> {
    compare_with(&LearnerRegistry::builtin(), data, split, names, None)
}

/// Like [`compare`] with the learners taken from `registry`, each on `powertrain` (the
/// learner's default when `None`; learners without a powertrain ignore it).
///
/// ```no_run
/// # fn demo(data: &drive_traits::Dataset) -> Result<(), drive_eval::CompareError> {
/// use drive_models::{LearnerRegistry, PowertrainChoice};
/// let cmp = drive_eval::compare_with(
///     &LearnerRegistry::builtin(), data, 0.5, &["slip-blr", "acc-blr"],
///     Some(PowertrainChoice::Commanded),
/// )?;
/// assert_eq!(cmp.models[0].powertrain, Some(PowertrainChoice::Commanded));
/// # Ok(()) }
/// ```
pub fn compare_with(
    registry: &LearnerRegistry,
    data: &Dataset,
    split: f64,
    names: &[&str],
    powertrain: Option<PowertrainChoice>,
) -> Result<Comparison, CompareError> {
    let (train, eval) = split_by_interval(data, split)?;
    let unknown = |name: &str| CompareError::UnknownModel {
        name: name.to_string(),
        known: registry.names().join(", "),
    };
    let entries = names
        .iter()
        .map(|n| registry.get(n).ok_or_else(|| unknown(n)))
        .collect::<Result<Vec<_>, _>>()?;
    let fit_error = |name: &str| {
        let model = name.to_string();
        move |reason| CompareError::Fit { model, reason }
    };
    // The naive model is the reference of every improvement figure.
    let naive_model = Naive.fit(&train).map_err(fit_error("naive"))?;
    let naive = evaluate_model(&naive_model, &eval);
    let mut models = Vec::new();
    for entry in entries {
        let start = Instant::now();
        let model = entry
            .fit(&train, powertrain)
            .map_err(fit_error(entry.name()))?;
        let fit_seconds = start.elapsed().as_secs_f64();
        let used = powertrain.or(entry.default_powertrain());
        let report = evaluate_model(model.as_ref(), &eval);
        // The evaluation set is non-empty (the split guarantees it), so summaries exist.
        let all = summarize(&report, &naive, None).expect("the evaluation set is not empty");
        models.push(ModelResult {
            name: entry.name().to_string(),
            powertrain: used.filter(|_| entry.uses_powertrain()),
            translational_median_m: all.translational_m.median,
            rotational_median_rad: all.rotational_rad.median,
            translational_iqr_m: all.translational_m.iqr,
            rotational_iqr_rad: all.rotational_rad.iqr,
            all,
            transient: summarize(&report, &naive, Some(Phase::Transient)),
            steady: summarize(&report, &naive, Some(Phase::Steady)),
            fit_seconds,
            report,
            model: Some(model),
        });
    }
    let intervals = data.interval_count();
    let train_intervals = train.windows.last().map_or(0, |w| w.interval + 1);
    Ok(Comparison {
        dataset: data.robot.name.clone(),
        robot: data.robot.robot.clone(),
        split,
        train_intervals,
        eval_intervals: intervals - train_intervals,
        train_windows: train.len(),
        eval_windows: eval.len(),
        models,
    })
}
