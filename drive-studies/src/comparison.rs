//! The paper's model comparison (Fig. 6) on one dataset: fit every named model on the
//! training intervals, score it on the evaluation intervals with eq. 8.

use crate::{run_cells, Registries, Setting};
use drive_eval::{
    evaluate_model, improvement_percent, paired_bootstrap, split_by_interval, BootstrapConfig,
    Improvement, ModelReport, PairedErrors, SplitError, Summary,
};
use drive_models::calibration::Uncertainty;
use drive_models::powertrain::{Commanded, Fopdt};
use drive_models::slip::{NoSlip, SlipBlr};
use drive_models::{Composed, ModelSpec};
use drive_traits::{Dataset, FitError, Learner, MotionModel, Phase, RegistryError, StartInfo};
use serde::Serialize;
use std::collections::BTreeMap;
use thiserror::Error;

/// Why a comparison could not run.
#[derive(Debug, Error)]
pub enum CompareError {
    /// The split is invalid for this dataset.
    #[error(transparent)]
    Split(#[from] SplitError),
    /// A model name does not resolve.
    #[error(transparent)]
    Model(#[from] RegistryError),
    /// A model could not be fitted on the training intervals.
    #[error("fitting {model}: {reason}")]
    Fit {
        /// model name
        model: String,
        /// why
        reason: FitError,
    },
    /// Two models share a name: they would be two rows of one name ([`check_names`]).
    #[error("the model '{0}' is named twice")]
    DuplicateModel(String),
}

/// `Err` naming the first model of `specs` whose name an earlier one has: a comparison
/// would give two rows of one name. [`compare_specs`] refuses such a list; a caller can
/// check it before loading any data (`drive eval` and `drive report` do). Names are what
/// is checked: the same model under two names (`powertrain` and its spelled-out
/// `no-slip+fopdt`) gives two rows that say which is which (`drive bench`, whose
/// leaderboard ranks models, refuses that too).
///
/// ```
/// use drive_studies::{check_names, CompareError, Registries};
/// let r = Registries::builtin();
/// let specs = r.models().resolve_list(&["naive", "slip-blr", "naive"]).unwrap();
/// assert!(matches!(check_names(&specs), Err(CompareError::DuplicateModel(n)) if n == "naive"));
/// let specs = r.models().resolve_list(&["powertrain", "no-slip+fopdt"]).unwrap();
/// assert!(check_names(&specs).is_ok());
/// ```
pub fn check_names(specs: &[ModelSpec]) -> Result<(), CompareError> {
    match specs
        .iter()
        .enumerate()
        .find(|(i, m)| specs[..*i].iter().any(|o| o.name == m.name))
    {
        Some((_, twice)) => Err(CompareError::DuplicateModel(twice.name.clone())),
        None => Ok(()),
    }
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

/// A model's improvement over a reference model, translational and rotational, each with
/// its paired bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PairedImprovement {
    /// Of the median translational MRMSE (percent).
    pub translational: Improvement,
    /// Of the median rotational MRMSE (percent).
    pub rotational: Improvement,
}

impl PairedImprovement {
    /// The improvement of `model` over `reference` (errors on the same evaluation windows),
    /// with whole DRIVE intervals resampled (the windows of one command together).
    pub fn of(model: &ModelReport, reference: &ModelReport, config: &BootstrapConfig) -> Self {
        let blocks: Vec<usize> = model.windows.iter().map(|w| w.interval).collect();
        let one = |pick: fn(&drive_eval::Mrmse) -> f64, salt: u64| {
            let m: Vec<f64> = model.windows.iter().map(|w| pick(&w.error)).collect();
            let r: Vec<f64> = reference.windows.iter().map(|w| pick(&w.error)).collect();
            let run = PairedErrors {
                model: &m,
                reference: &r,
                blocks: Some(&blocks),
            };
            paired_bootstrap(&[run], config, config.seed ^ salt)
        };
        PairedImprovement {
            translational: one(|e| e.translational, 0),
            rotational: one(|e| e.rotational, 1 << 63),
        }
    }
}

/// One model's result.
#[derive(Debug, Serialize)]
pub struct ModelResult {
    /// Model name, as asked (`slip-blr`).
    pub name: String,
    /// The model's full name (`slip-blr+fopdt`).
    pub model: String,
    /// Its learner (a slip learner or a baseline).
    pub learner: String,
    /// The powertrain the model was fitted with (`None` for a baseline without one).
    pub powertrain: Option<String>,
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
    /// What the predictions started from (`encoders` or `encoders+imu`).
    pub start: StartInfo,
    /// How a pose covariance was made (`calibrated` or `paper`), for a model with one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<Uncertainty>,
    /// Fraction of the measured positions inside the predicted 95% ellipse at 0.5, 1 and
    /// 2 s, for a model with a pose covariance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage95: Option<BTreeMap<String, f64>>,
    /// The same for the yaw's 95% interval.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw_coverage95: Option<BTreeMap<String, f64>>,
    /// Mean negative log-likelihood of the measured positions per step (nats).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nll: Option<f64>,
    /// `coverage95` of the transient and of the steady windows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage95_by_phase: Option<drive_eval::GroupCoverage>,
    /// `yaw_coverage95` of the transient and of the steady windows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw_coverage95_by_phase: Option<drive_eval::GroupCoverage>,
    /// `coverage95` in the thirds of the windows by commanded speed (`low`, `mid`, `high`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage95_by_speed: Option<drive_eval::GroupCoverage>,
    /// `yaw_coverage95` in the same thirds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw_coverage95_by_speed: Option<drive_eval::GroupCoverage>,
    /// Mean 95% ellipse area at 2 s over the smallest constant circle of the same coverage.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub area_ratio_to_constant: Option<f64>,
    /// Mean 95% yaw interval width at 2 s over the smallest constant width of the same
    /// coverage.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw_width_ratio_to_constant: Option<f64>,
    /// Spearman's correlation at 2 s of the predicted spread with the actual error
    /// (`position`, `yaw`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_rank_correlation: Option<BTreeMap<String, f64>>,
    /// The reliability diagram (nominal against observed coverage, every step) of the
    /// transient and of the steady windows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reliability_by_phase: Option<BTreeMap<String, Vec<drive_eval::ReliabilityPoint>>>,
    /// Improvement of the medians over the naive model, with 95% paired bootstrap intervals.
    pub improvement_over_naive: PairedImprovement,
    /// Improvement of the medians over slip-BLR (the paper's model, `slip-blr+fopdt`, fitted
    /// on the same training intervals as the reference), with 95% paired bootstrap
    /// intervals; absent when slip-BLR cannot be fitted on the data.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub improvement_over_slip_blr: Option<PairedImprovement>,
    /// Per-window errors (not serialized; see `--per-window`).
    #[serde(skip)]
    pub report: ModelReport,
    /// The fitted model.
    #[serde(skip)]
    pub fitted: Option<Box<dyn MotionModel>>,
}

/// The result of a comparison.
#[derive(Debug, Serialize)]
pub struct Comparison {
    /// Dataset name (from the sidecar).
    pub dataset: String,
    /// Robot name (from the sidecar).
    pub robot: String,
    /// The vehicle type (from the sidecar).
    pub vehicle: String,
    /// The ground the data was recorded on (the sidecar's free-text `terrain`; empty when
    /// not recorded).
    pub terrain: String,
    /// The frame of the positions scored: `paper-mean5` (the paper parser's, as published)
    /// or `first-sample` (the frame of yaw; imported, simulated or corrected data).
    pub position_frame: &'static str,
    /// Split fraction.
    pub split: f64,
    /// The windows' length (s): samples over the command rate (2 s in the paper), what
    /// eq. 8 is taken over.
    pub window_s: f64,
    /// Training intervals.
    pub train_intervals: usize,
    /// Evaluation intervals.
    pub eval_intervals: usize,
    /// Training windows.
    pub train_windows: usize,
    /// Evaluation windows.
    pub eval_windows: usize,
    /// The bootstrap behind every improvement interval: resamples of the evaluation
    /// intervals, confidence level, seed.
    pub bootstrap: BootstrapConfig,
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

/// The vehicle type of a dataset (its sidecar's `vehicle.type`).
pub fn vehicle_type(data: &Dataset) -> String {
    drive_traits::vehicle_tag(data.robot.vehicle.as_ref()).unwrap_or_default()
}

/// Fits each model of `names` (model names resolved by `registries`; `all` for every
/// registered combination) on the first `floor(split x intervals)` intervals and evaluates
/// it on the rest; the improvements are over the naive model (eq. 4 on the commands).
///
/// ```no_run
/// # fn demo(data: &drive_traits::Dataset) -> Result<(), drive_studies::CompareError> {
/// use drive_studies::{compare, Registries};
/// let cmp = compare(&Registries::builtin(), data, 0.5, &["slip-blr", "slip-blr+commanded"])?;
/// assert_eq!(cmp.models[1].powertrain.as_deref(), Some("commanded"));
/// # Ok(()) }
/// ```
pub fn compare<S: AsRef<str>>(
    registries: &Registries,
    data: &Dataset,
    split: f64,
    names: &[S],
) -> Result<Comparison, CompareError> {
    let specs = registries.models().resolve_list(names)?;
    compare_specs(data, split, &specs)
}

/// Like [`compare`] with the models resolved.
pub fn compare_specs(
    data: &Dataset,
    split: f64,
    specs: &[ModelSpec],
) -> Result<Comparison, CompareError> {
    compare_specs_with_progress(data, split, specs, &|| {})
}

/// [`compare_specs`], calling `progress` after each model of `specs` is fitted and scored
/// (for a progress bar, or to stop the work between models).
///
/// ```no_run
/// # fn demo(data: &drive_traits::Dataset) -> Result<(), drive_studies::CompareError> {
/// use drive_studies::{compare_specs_with_progress, Registries};
/// let specs = Registries::builtin().models().resolve_list(&["naive", "slip-blr"]).unwrap();
/// let done = std::sync::atomic::AtomicUsize::new(0);
/// let tick = || {
///     done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
/// };
/// compare_specs_with_progress(data, 0.5, &specs, &tick)?;
/// assert_eq!(done.into_inner(), 2);
/// # Ok(()) }
/// ```
pub fn compare_specs_with_progress(
    data: &Dataset,
    split: f64,
    specs: &[ModelSpec],
    progress: &(dyn Fn() + Sync),
) -> Result<Comparison, CompareError> {
    check_names(specs)?;
    let (train, eval) = split_by_interval(data, split)?;
    // The naive model is the reference of every improvement figure.
    let naive_model =
        Learner::fit(&Composed::new(Commanded, NoSlip), &train).map_err(|reason| {
            CompareError::Fit {
                model: "naive".into(),
                reason,
            }
        })?;
    let naive = evaluate_model(&naive_model, &eval);
    // slip-BLR, the paper's model, is the second reference (its point predictions do not
    // depend on the start information or on the uncertainty method).
    let slip_blr = Learner::fit(&Composed::new(Fopdt::default(), SlipBlr::default()), &train)
        .ok()
        .map(|m| evaluate_model(&m, &eval));
    let bootstrap = BootstrapConfig::default();
    let setting = [Setting {
        train: train.clone(),
        eval: eval.clone(),
    }];
    let cells = run_cells(&setting, specs, true, progress);
    let mut models = Vec::new();
    for (spec, cell) in specs.iter().zip(cells) {
        let scored = cell.outcome.map_err(|reason| CompareError::Fit {
            model: spec.name.clone(),
            reason,
        })?;
        // The uncertainty the fitted model has: a calibration asked for but not made (fewer
        // training intervals than its folds, or a fold's refit failed) leaves the model's
        // own covariance, which is what `paper` names.
        let uncertainty = match &scored.model {
            Some(m)
                if spec.uncertainty != Uncertainty::Paper && m.typetag_name() != "calibrated" =>
            {
                Uncertainty::Paper
            }
            _ => spec.uncertainty,
        };
        let report = scored.report;
        let u = report.uncertainty.as_ref();
        // The evaluation set is non-empty (the split guarantees it), so summaries exist.
        let all = summarize(&report, &naive, None).expect("the evaluation set is not empty");
        models.push(ModelResult {
            name: spec.name.clone(),
            model: spec.canonical(),
            learner: spec.learner.clone(),
            powertrain: spec.powertrain.clone(),
            translational_median_m: all.translational_m.median,
            rotational_median_rad: all.rotational_rad.median,
            translational_iqr_m: all.translational_m.iqr,
            rotational_iqr_rad: all.rotational_rad.iqr,
            all,
            transient: summarize(&report, &naive, Some(Phase::Transient)),
            steady: summarize(&report, &naive, Some(Phase::Steady)),
            fit_seconds: cell.fit_seconds,
            start: spec.start,
            uncertainty: u.map(|_| uncertainty),
            coverage95: u.map(|u| u.coverage95.clone()),
            yaw_coverage95: u.map(|u| u.yaw_coverage95.clone()),
            nll: u.map(|u| u.nll),
            coverage95_by_phase: u.map(|u| u.coverage95_by_phase.clone()),
            yaw_coverage95_by_phase: u.map(|u| u.yaw_coverage95_by_phase.clone()),
            coverage95_by_speed: u.map(|u| u.coverage95_by_speed.clone()),
            yaw_coverage95_by_speed: u.map(|u| u.yaw_coverage95_by_speed.clone()),
            area_ratio_to_constant: u.map(|u| u.area_ratio_to_constant),
            yaw_width_ratio_to_constant: u.map(|u| u.yaw_width_ratio_to_constant),
            error_rank_correlation: u.map(|u| u.error_rank_correlation.clone()),
            reliability_by_phase: u.map(|u| u.reliability_by_phase.clone()),
            improvement_over_naive: PairedImprovement::of(&report, &naive, &bootstrap),
            improvement_over_slip_blr: slip_blr
                .as_ref()
                .map(|r| PairedImprovement::of(&report, r, &bootstrap)),
            report,
            fitted: scored.model,
        });
    }
    let intervals = data.interval_count();
    let train_intervals = train.windows.last().map_or(0, |w| w.interval + 1);
    Ok(Comparison {
        dataset: data.robot.name.clone(),
        robot: data.robot.robot.clone(),
        vehicle: vehicle_type(data),
        terrain: data.robot.terrain.clone(),
        position_frame: data.robot.position_frame.as_str(),
        split,
        window_s: data.robot.window_len as f64 / data.robot.rate_hz,
        train_intervals,
        eval_intervals: intervals - train_intervals,
        train_windows: train.len(),
        eval_windows: eval.len(),
        bootstrap,
        models,
    })
}
