//! What a benchmark reports: per dataset, per model, the transfer between runs, the
//! terrain's unpredictability and the leaderboard (the JSON of `drive bench --json`).

use crate::{Comparison, PairedImprovement};
use drive_eval::{BootstrapConfig, UnpredictabilitySummary, WindowUnpredictability};
use drive_samplers::BodySize;
use serde::Serialize;
use std::collections::BTreeMap;

/// A model's median ratio to slip-BLR's (below 1: better than slip-BLR).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ratio {
    /// Of the translational medians.
    pub translational: f64,
    /// Of the rotational medians.
    pub rotational: f64,
}

/// The errors in one third of a dataset's evaluation windows sorted by their
/// unpredictability.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UnpredictabilityBin {
    /// The range of the windows' unpredictability.
    pub unpredictability: [f64; 2],
    /// Windows in the bin.
    pub windows: usize,
    /// Median translational MRMSE (m).
    pub translational_median_m: f64,
    /// Median rotational MRMSE (rad).
    pub rotational_median_rad: f64,
}

/// How a model's error grows with the windows' unpredictability on one dataset.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ErrorGrowth {
    /// Spearman's correlation of the translational MRMSE with the translational
    /// unpredictability over the evaluation windows.
    pub spearman_translational: Option<f64>,
    /// The same, rotational.
    pub spearman_rotational: Option<f64>,
    /// Which unpredictability sorts the windows into thirds (`total`, or `translational`
    /// without the body's size).
    pub binned_by: &'static str,
    /// The evaluation windows in thirds of that unpredictability, lowest first.
    pub thirds: Vec<UnpredictabilityBin>,
}

/// One model on one dataset.
#[derive(Debug, Clone, Serialize)]
pub struct BenchModel {
    /// The name asked (`slip-blr`).
    pub name: String,
    /// The full name (`slip-blr+fopdt`).
    pub model: String,
    /// Median translational MRMSE on the evaluation windows (m).
    pub translational_median_m: f64,
    /// Median rotational MRMSE (rad).
    pub rotational_median_rad: f64,
    /// Translational quartiles (m).
    pub translational_iqr_m: [f64; 2],
    /// Rotational quartiles (rad).
    pub rotational_iqr_rad: [f64; 2],
    /// Rank among the benchmark's models on this dataset by translational median (1 best,
    /// ties share their mean rank).
    pub rank_translational: f64,
    /// The same, rotational.
    pub rank_rotational: f64,
    /// Improvement over naive with 95% paired bootstrap intervals.
    pub improvement_over_naive: PairedImprovement,
    /// Improvement over slip-BLR (fitted on the same training intervals) with 95% paired
    /// bootstrap intervals; absent when slip-BLR cannot be fitted on the data.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub improvement_over_slip_blr: Option<PairedImprovement>,
    /// The median's ratio to slip-BLR's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ratio_to_slip_blr: Option<Ratio>,
    /// Share of the measured positions inside the predicted 95% region at 2 s, for a model
    /// with a pose covariance and windows that reach 2 s (absent for shorter ones).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_coverage95_2s: Option<f64>,
    /// The same for the yaw's interval.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw_coverage95_2s: Option<f64>,
    /// Position coverage of the 95% regions per phase (`transient`, `steady`) at 0.5, 1 and
    /// 2 s, as `drive eval --json` gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage95_by_phase: Option<drive_eval::GroupCoverage>,
    /// Mean 95% ellipse area at 2 s over the constant circle of the same coverage.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub area_ratio_to_constant: Option<f64>,
    /// Spearman's correlation at 2 s of the predicted spread with the error (`position`,
    /// `yaw`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_rank_correlation: Option<BTreeMap<String, f64>>,
    /// Time to fit (s).
    pub fit_seconds: f64,
    /// How the error grows with the windows' unpredictability.
    pub error_growth: ErrorGrowth,
}

/// A dataset's unpredictability as the benchmark reports it: the summaries, the body used.
#[derive(Debug, Clone, Serialize)]
pub struct BenchUnpredictability {
    /// Translational.
    pub translational: Option<UnpredictabilitySummary>,
    /// Rotational.
    pub rotational: Option<UnpredictabilitySummary>,
    /// Total; `None` without the body's size.
    pub total: Option<UnpredictabilitySummary>,
    /// The windows pooled (`steady` or `all`).
    pub pooled: &'static str,
    /// The body's footprint used by the total.
    pub body: Option<BodySize>,
    /// Where it comes from.
    pub body_source: String,
}

/// One dataset's results.
#[derive(Debug, Serialize)]
pub struct BenchDataset {
    /// Its name in the benchmark.
    pub name: String,
    /// Where it was read from.
    pub source: String,
    /// The robot's identity (see [`BenchInput::robot`](super::BenchInput::robot)).
    pub robot: String,
    /// The sidecar's robot text.
    pub robot_description: String,
    /// The ground.
    pub terrain: String,
    /// The vehicle type.
    pub vehicle: String,
    /// Windows in the dataset.
    pub windows: usize,
    /// The windows' length (s; 2 in the paper): what eq. 8 is taken over.
    pub window_s: f64,
    /// DRIVE intervals in the dataset.
    pub intervals: usize,
    /// Training windows (the first `split` of the intervals).
    pub train_windows: usize,
    /// Evaluation windows.
    pub eval_windows: usize,
    /// Evaluation intervals (the blocks the bootstrap resamples).
    pub eval_intervals: usize,
    /// Whether the dataset has enough evaluation intervals for its bootstrap intervals to
    /// count as evidence in the leaderboard ([`BenchConfig::min_evidence_intervals`](super::BenchConfig::min_evidence_intervals)).
    pub evidence: bool,
    /// The frame of the positions scored.
    pub position_frame: &'static str,
    /// One entry per model, in the order asked.
    pub models: Vec<BenchModel>,
    /// The terrain's unpredictability.
    pub unpredictability: BenchUnpredictability,
    /// The full comparison (per-window errors, fitted models).
    #[serde(skip)]
    pub comparison: Comparison,
    /// Every window's unpredictability.
    #[serde(skip)]
    pub window_unpredictability: Vec<WindowUnpredictability>,
    /// What loading it noted (a data check's warning): one line each.
    pub notes: Vec<String>,
}

/// One model fitted on all of one dataset and scored on another's evaluation windows.
#[derive(Debug, Clone, Serialize)]
pub struct TransferCell {
    /// Model name as asked.
    pub model: String,
    /// The dataset it was fitted on (all of it).
    pub train: String,
    /// The dataset it was scored on (its evaluation windows).
    pub test: String,
    /// The robot both datasets are of.
    pub robot: String,
    /// Whether the two runs' vehicle geometries are the same (the transferred model keeps
    /// the geometry of the run it was fitted on: with another one, even the naive model's
    /// errors differ).
    pub same_geometry: bool,
    /// Whether the two terrains are the same; `None` when one is not known.
    pub same_terrain: Option<bool>,
    /// Median translational MRMSE on the test dataset's evaluation windows (m).
    pub translational_median_m: f64,
    /// Median rotational MRMSE (rad).
    pub rotational_median_rad: f64,
    /// The same model fitted on the test dataset's own training half (m).
    pub own_translational_median_m: f64,
    /// The same, rotational (rad).
    pub own_rotational_median_rad: f64,
    /// `100 (transfer - own) / own`, translational: what is lost by fitting elsewhere.
    pub loss_translational_percent: f64,
    /// The same, rotational.
    pub loss_rotational_percent: f64,
}

/// The transfer of one model over a group of pairs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TransferGroup {
    /// Ordered pairs of datasets in the group.
    pub pairs: usize,
    /// Median over the pairs of the translational loss (percent).
    pub median_loss_translational_percent: Option<f64>,
    /// Median over the pairs of the rotational loss (percent).
    pub median_loss_rotational_percent: Option<f64>,
}

/// One model's transfer: on the same terrain, on another one.
#[derive(Debug, Clone, Serialize)]
pub struct TransferSummary {
    /// Model name as asked.
    pub model: String,
    /// Pairs of the same robot on the same terrain.
    pub same_terrain: TransferGroup,
    /// Pairs of the same robot on two terrains.
    pub other_terrain: TransferGroup,
    /// Pairs where a terrain is not known (not in either group).
    pub unknown_terrain_pairs: usize,
    /// Pairs (in any group) between runs of two vehicle geometries.
    pub other_geometry_pairs: usize,
}

/// One model's standing over the datasets.
#[derive(Debug, Clone, Serialize)]
pub struct LeaderboardRow {
    /// Model name as asked.
    pub model: String,
    /// Datasets it was scored on.
    pub datasets: usize,
    /// Mean over the datasets of the mean of its translational and rotational ranks.
    pub mean_rank: f64,
    /// Mean translational rank.
    pub mean_rank_translational: f64,
    /// Mean rotational rank.
    pub mean_rank_rotational: f64,
    /// Datasets where it beats slip-BLR in both translation and rotation, each with its 95%
    /// interval above 0 (datasets with enough evaluation intervals only:
    /// [`BenchDataset::evidence`]).
    pub wins_over_slip_blr: usize,
    /// Datasets where it beats slip-BLR in translation with the interval above 0.
    pub wins_translational: usize,
    /// Datasets where it beats slip-BLR in rotation with the interval above 0.
    pub wins_rotational: usize,
    /// Datasets where slip-BLR beats it in translation or rotation with the interval below 0.
    pub losses_to_slip_blr: usize,
    /// Geometric mean over the datasets of its median's ratio to slip-BLR's.
    pub ratio_to_slip_blr: Ratio,
    /// Mean over the datasets of the Spearman correlation of its window errors with the
    /// windows' unpredictability (translational, rotational).
    pub error_growth_spearman: [Option<f64>; 2],
    /// With the adaptation track (`drive bench --adapt`): the median over the pairs of its
    /// adapted model's error over the model fitted on the target run itself, after 60 s
    /// of the target's driving; absent without the track or where no pair reaches 60 s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive_over_own_60s: Option<Ratio>,
}

/// A benchmark's results.
#[derive(Debug, Serialize)]
pub struct Bench {
    /// The training fraction of each dataset.
    pub split: f64,
    /// The models, as asked.
    pub model_names: Vec<String>,
    /// The bootstrap behind the intervals.
    pub bootstrap: BootstrapConfig,
    /// The evaluation intervals a dataset needs for its intervals to count as evidence.
    pub min_evidence_intervals: usize,
    /// One entry per dataset, in the suite's order.
    pub datasets: Vec<BenchDataset>,
    /// Every model on every ordered pair of datasets of the same robot.
    pub transfer: Vec<TransferCell>,
    /// The transfer per model: same terrain against another terrain.
    pub transfer_summary: Vec<TransferSummary>,
    /// Models by mean rank, best first.
    pub leaderboard: Vec<LeaderboardRow>,
    /// Ordered pairs of the same robot skipped (another rate or vehicle), with why.
    pub transfer_skipped: Vec<String>,
    /// Robots left without any transfer pair (one dataset, or every pair skipped), with
    /// why; empty without transfer (`--no-transfer`).
    pub transfer_unpaired: Vec<UnpairedRobot>,
    /// Datasets skipped (the data checks call them useless, or the models cannot be
    /// compared on them), with why; absent from the JSON when none was.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub skipped: Vec<SkippedDataset>,
    /// The adaptation track (`drive bench --adapt`); absent from the JSON without it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptation: Option<super::BenchAdaptation>,
}

/// A dataset a benchmark skipped, and why.
#[derive(Debug, Clone, Serialize)]
pub struct SkippedDataset {
    /// The dataset's name.
    pub dataset: String,
    /// Why it was skipped.
    pub reason: String,
}

impl SkippedDataset {
    /// Datasets skipped, in one line: `'name': reason; ...`.
    ///
    /// ```
    /// use drive_studies::SkippedDataset;
    /// let s = |d: &str, r: &str| SkippedDataset { dataset: d.into(), reason: r.into() };
    /// assert_eq!(SkippedDataset::listed(&[s("a", "no file"), s("b", "useless")]), "'a': no file; 'b': useless");
    /// ```
    pub fn listed(skipped: &[SkippedDataset]) -> String {
        skipped
            .iter()
            .map(|s| format!("'{}': {}", s.dataset, s.reason))
            .collect::<Vec<_>>()
            .join("; ")
    }
}

/// A robot of a benchmark left without a transfer pair.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnpairedRobot {
    /// The robot (a registered robot's name, or the sidecar's robot text).
    pub robot: String,
    /// Its datasets.
    pub datasets: Vec<String>,
    /// Why it has no pair.
    pub reason: String,
}
