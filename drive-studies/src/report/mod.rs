//! The report's analyses (`drive report`): the model comparison, the convergence of the
//! analysed model, the protocol regions and what each figure shows, computed from a dataset
//! and its fitted models ([`ReportAnalysis`]); `drive-report` draws and writes them.

pub mod analysis;

use crate::{
    compare_regions, compare_specs_with_progress, convergence, Comparison, Convergence,
    ExperimentError, RegionComparison, RegionStudy, Registries,
};
use analysis::{Calibration, InputSpaceFigure, PowertrainTrace, Trajectory};
use drive_eval::split_by_interval;
use drive_models::powertrain::CommandedPowertrain;
use drive_traits::{CommandModel, Dataset, InputSpace, MotionModel, Powertrain};
use std::sync::Arc;
use thiserror::Error;

/// Why a report's analyses could not be made.
#[derive(Debug, Error)]
pub enum ReportStudyError {
    /// The model comparison failed (split, fit).
    #[error(transparent)]
    Compare(#[from] crate::CompareError),
    /// The split is not valid for this dataset.
    #[error(transparent)]
    Split(#[from] drive_eval::SplitError),
    /// A model or part name does not resolve.
    #[error(transparent)]
    Registry(#[from] drive_traits::RegistryError),
    /// A model needed by the figures could not be fitted.
    #[error("fitting {model}: {reason}")]
    Fit {
        /// Model.
        model: String,
        /// Why.
        reason: drive_traits::FitError,
    },
    /// The dataset has no command or encoder sample.
    #[error("the dataset has no samples to draw")]
    Empty,
}

/// What the report is made with.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// Training fraction of the intervals (the rest evaluates).
    pub split: f64,
    /// The models compared (model names); the paper's four by default.
    pub models: Vec<String>,
    /// The model whose convergence is analysed (Fig. 7) and trained on the protocol
    /// regions (Fig. 5).
    pub model: String,
    /// The manufacturer's input space and where it comes from (for Fig. 1); `None` when
    /// unknown.
    pub naive_input_space: Option<(String, InputSpace)>,
    /// Intervals shown in the powertrain figure.
    pub powertrain_intervals: usize,
    /// Evaluation windows shown in the trajectory figure.
    pub trajectories: usize,
    /// Convergence gradient thresholds (m/s, rad/s).
    pub thresholds: [f64; 2],
    /// Uniform draws of the protocol comparison.
    pub draws: usize,
    /// Figure size in pixels (PNG) and points (SVG).
    pub size: (u32, u32),
    /// What every model's predictions start from.
    pub start: drive_traits::StartInfo,
    /// How the models' pose covariances are made.
    pub uncertainty: drive_models::calibration::Uncertainty,
    /// The robot's body footprint for the terrain's total unpredictability, and where it
    /// comes from; without it the report gives the translational and rotational ones.
    pub body: Option<(String, drive_samplers::BodySize)>,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions {
            split: 0.5,
            models: crate::PAPER_MODELS.split(',').map(String::from).collect(),
            model: "slip-blr".into(),
            naive_input_space: None,
            powertrain_intervals: 3,
            trajectories: 4,
            thresholds: [0.01, 0.01],
            draws: 25,
            size: (1200, 800),
            start: drive_traits::StartInfo::default(),
            uncertainty: drive_models::calibration::Uncertainty::default(),
            body: None,
        }
    }
}

/// One compared model's fitted parameters, as its parts give them
/// ([`MotionModel::parameters`]: a plug-in part reports its own).
#[derive(Debug, Clone, PartialEq)]
pub struct FittedParameters {
    /// The model's name in the comparison.
    pub model: String,
    /// Its parameters by name, in the order the model lists them.
    pub parameters: Vec<(String, f64)>,
}

/// Everything a report shows, computed once ([`ReportAnalysis::build`]); `drive-report`
/// draws and writes it.
pub struct ReportAnalysis {
    /// Dataset and robot names.
    pub dataset: String,
    /// The options used.
    pub options: ReportOptions,
    /// The models compared (eq. 8).
    pub comparison: Comparison,
    /// The convergence of the analysed model (Fig. 7).
    pub convergence: Convergence,
    /// The protocol comparison on the recorded data, or why it could not run.
    pub protocols: Result<RegionComparison, ExperimentError>,
    /// Each compared model's fitted parameters, in the comparison's order.
    pub fitted: Vec<FittedParameters>,
    /// Fig. 1 data.
    pub input_space: InputSpaceFigure,
    /// Fig. 3 data.
    pub powertrain: PowertrainTrace,
    /// Trajectory figure data.
    pub trajectories: Vec<Trajectory>,
    /// Calibration of the BLR models.
    pub calibration: Vec<Calibration>,
    /// The terrain's unpredictability (energy-based, T-FR 2025).
    pub unpredictability: drive_eval::Unpredictability,
    /// The dataset's vehicle (its geometry and input axes, in the report's tables).
    pub vehicle: Arc<dyn CommandModel>,
    /// The dataset's sample period (s).
    pub dt: f64,
    /// What the data checks found (`check NAME (severity): message`; a fatal one means the
    /// report was asked for anyway, `--allow-useless`): the report says it beside its numbers.
    pub data_checks: Vec<String>,
}

impl ReportAnalysis {
    /// Fits and evaluates everything the report shows, with the models of `registries`.
    ///
    /// ```no_run
    /// use drive_studies::report::{ReportAnalysis, ReportOptions};
    /// let registries = drive_studies::Registries::builtin();
    /// let data = drive_data::read_dataset("run.csv".as_ref(), None).unwrap();
    /// let analysis = ReportAnalysis::build(&registries, &data, &ReportOptions::default()).unwrap();
    /// println!("{} models compared", analysis.comparison.models.len());
    /// ```
    pub fn build(
        registries: &Registries,
        data: &Dataset,
        options: &ReportOptions,
    ) -> Result<ReportAnalysis, ReportStudyError> {
        Self::build_with_progress(registries, data, options, &|_| {})
    }

    /// [`ReportAnalysis::build`], calling `progress(total)` as each of its `total` units of
    /// work ends: each compared model's fit and score, the convergence, the protocol
    /// regions, the figures' analyses (the number of models plus 3). What a host shows a
    /// long report's progress by, and where it may stop it (a progress call that unwinds
    /// stops the report there).
    ///
    /// ```no_run
    /// use drive_studies::report::{ReportAnalysis, ReportOptions};
    /// let registries = drive_studies::Registries::builtin();
    /// let data = drive_data::read_dataset("run.csv".as_ref(), None).unwrap();
    /// let options = ReportOptions::default();
    /// let progress = |total: usize| eprintln!("one more of {total} units done");
    /// ReportAnalysis::build_with_progress(&registries, &data, &options, &progress).unwrap();
    /// ```
    pub fn build_with_progress(
        registries: &Registries,
        data: &Dataset,
        options: &ReportOptions,
        progress: &(dyn Fn(usize) + Sync),
    ) -> Result<ReportAnalysis, ReportStudyError> {
        let specs: Vec<_> = registries
            .models()
            .resolve_list(&options.models)?
            .into_iter()
            .map(|s| s.with_uncertainty(options.uncertainty, options.start))
            .collect();
        // The models' fits and scores, the convergence, the regions, the figures.
        let total = specs.len() + 3;
        let unit_done = || progress(total);
        let comparison = compare_specs_with_progress(data, options.split, &specs, &unit_done)?;
        let (train, eval) = split_by_interval(data, options.split)?;
        let model = registries
            .model(&options.model)?
            .with_uncertainty(options.uncertainty, options.start);
        let convergence = convergence(data, options.split, options.thresholds, &model)?;
        unit_done();
        let protocols = compare_regions(
            registries,
            data,
            &RegionStudy {
                split: options.split,
                draws: options.draws,
                model: options.model.clone(),
                ..RegionStudy::default()
            },
        );
        unit_done();
        let fitted = comparison
            .models
            .iter()
            .filter_map(|m| {
                m.fitted.as_deref().map(|f| FittedParameters {
                    model: m.name.clone(),
                    parameters: f.parameters(),
                })
            })
            .collect();
        let input_space = analysis::input_space(&data.all(), options.naive_input_space.clone())
            .ok_or(ReportStudyError::Empty)?;
        // The powertrain figure draws the analysed model's own powertrain (a plug-in's
        // included), from the comparison's fit when the model is compared.
        let compared = comparison
            .models
            .iter()
            .find(|m| m.name == options.model)
            .and_then(|m| m.fitted.as_deref());
        let own;
        let analysed: &dyn MotionModel = match compared {
            Some(m) => m,
            None => {
                own = model.fit(&train).map_err(|reason| ReportStudyError::Fit {
                    model: options.model.clone(),
                    reason,
                })?;
                own.as_ref()
            }
        };
        let (label, modeled): (String, &dyn Powertrain) = match analysed.powertrain() {
            Some(p) => (
                format!(
                    "{} ({})",
                    model.powertrain.as_deref().unwrap_or("its powertrain"),
                    options.model
                ),
                p,
            ),
            None => (
                format!("commanded ({} has no powertrain)", options.model),
                &CommandedPowertrain,
            ),
        };
        let powertrain =
            analysis::powertrain_trace(&eval, &label, modeled, options.powertrain_intervals);
        let models: Vec<(&str, &dyn MotionModel)> = comparison
            .models
            .iter()
            .filter_map(|m| m.fitted.as_deref().map(|f| (m.name.as_str(), f)))
            .collect();
        let trajectories = analysis::trajectories(&eval, &models, options.trajectories);
        let calibration = models
            .iter()
            .filter_map(|(name, m)| analysis::calibration(name, *m, &eval, options.start))
            .collect();
        let unpredictability = drive_eval::unpredictability(
            data,
            options.body.as_ref().map(|b| b.1),
            &drive_eval::UnpredictabilityConfig::default(),
        );
        unit_done();
        Ok(ReportAnalysis {
            dataset: format!("{} ({})", data.robot.name, data.robot.robot),
            unpredictability,
            options: options.clone(),
            comparison,
            convergence,
            protocols,
            fitted,
            input_space,
            powertrain,
            trajectories,
            calibration,
            vehicle: Arc::clone(&data.robot.vehicle),
            dt: data.robot.dt(),
            data_checks: drive_data::quality::check(data, None)
                .into_iter()
                .map(|f| {
                    let severity = match f.severity {
                        drive_data::quality::Severity::Fatal => "fatal: the data is useless",
                        drive_data::quality::Severity::Warning => "warning",
                    };
                    format!("check {} ({severity}): {}", f.check, f.message)
                })
                .collect(),
        })
    }
}
