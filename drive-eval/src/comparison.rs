//! The paper's model comparison (Fig. 6) on one dataset: fit every named model on the
//! training intervals, score it on the evaluation intervals with eq. 8.

use crate::{
    evaluate_model, improvement_percent, split_by_interval, ModelReport, SplitError, Summary,
};
use drive_traits::{Dataset, FitError, MotionModel, Phase};
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
    #[error("unknown model '{0}' (the models are: {names})", names = drive_models::MODEL_NAMES.join(", "))]
    UnknownModel(String),
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
    let (train, eval) = split_by_interval(data, split)?;
    if let Some(bad) = names
        .iter()
        .find(|n| !drive_models::MODEL_NAMES.contains(n))
    {
        return Err(CompareError::UnknownModel(bad.to_string()));
    }
    let fit = |name: &str| -> Result<(Box<dyn MotionModel>, f64), CompareError> {
        let start = Instant::now();
        // Names were checked against the registry above.
        let model = drive_models::fit_named(name, &train)
            .ok_or_else(|| CompareError::UnknownModel(name.to_string()))?
            .map_err(|reason| CompareError::Fit {
                model: name.to_string(),
                reason,
            })?;
        Ok((model, start.elapsed().as_secs_f64()))
    };
    // The naive model is the reference of every improvement figure.
    let (naive_model, _) = fit("naive")?;
    let naive = evaluate_model(naive_model.as_ref(), &eval);
    let mut models = Vec::new();
    for name in names {
        let (model, fit_seconds) = fit(name)?;
        let report = evaluate_model(model.as_ref(), &eval);
        // The evaluation set is non-empty (the split guarantees it), so summaries exist.
        let all = summarize(&report, &naive, None).expect("the evaluation set is not empty");
        models.push(ModelResult {
            name: name.to_string(),
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
