//! The evaluation matrix: every combination of datasets (recorded, or simulated robot x
//! terrain x sampler x driving time x seed), models and splits scored with eq. 8 in one run,
//! summarized per scenario with the improvement over a baseline model and its bootstrap
//! confidence interval.
//!
//! | file | job |
//! |---|---|
//! | `sweep.rs` | the sweep file (TOML) and its check into a plan |
//! | `run.rs` | the plan run: simulations, then every cell (the experiment engine) |
//! | `stats.rs` | pooled summaries and the paired bootstrap of the improvements |
//! | `output.rs` | the tidy CSV and the Markdown summary |

mod output;
mod run;
mod stats;
mod sweep;

pub use drive_eval::BootstrapConfig;
pub use run::run_matrix;
pub use sweep::{
    DatasetLoadError, DatasetSource, FrameChoice, MatrixError, SimulatedPlan, SimulatedSweep,
    SweepFile,
};

use drive_eval::{Mrmse, Summary};
use drive_models::ModelSpec;
use drive_traits::Dataset;
use serde::Serialize;

/// A checked sweep, ready to run (see [`SweepFile::plan`]).
#[derive(Debug, Clone)]
pub struct Matrix {
    /// Recorded datasets with their labels.
    pub datasets: Vec<(String, Dataset)>,
    /// Simulated datasets.
    pub simulated: Option<SimulatedPlan>,
    /// Every model (learner x powertrain).
    pub models: Vec<ModelSpec>,
    /// Training fractions of the recorded datasets.
    pub splits: Vec<f64>,
    /// The reference of the improvement figures.
    pub baseline: ModelSpec,
    /// Bootstrap settings.
    pub bootstrap: BootstrapConfig,
}

/// Where an evaluation set comes from: the combination minus the model (and minus the seed
/// for the summary).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scenario {
    /// Dataset label (`sim` for simulated runs).
    pub dataset: String,
    /// Robot name.
    pub robot: String,
    /// Terrain (simulated runs).
    pub terrain: Option<String>,
    /// Sampler of the training run (simulated runs).
    pub sampler: Option<String>,
    /// Driving time of the training run (s, simulated runs).
    pub duration_s: Option<f64>,
    /// Training fraction (recorded datasets).
    pub split: Option<f64>,
}

impl Scenario {
    /// A short label, e.g. `sim husky/ice uniform 120 s` or `husky_drive split 0.5`.
    pub fn label(&self) -> String {
        match (&self.terrain, &self.sampler, self.duration_s, self.split) {
            (Some(t), Some(s), Some(d), _) => format!("{}/{t} {s} {d} s", self.robot),
            (_, _, _, Some(f)) => format!("{} split {f}", self.dataset),
            _ => self.dataset.clone(),
        }
    }
}

/// One combination's result: a model fitted on one training set and scored on its
/// evaluation set.
#[derive(Debug, Clone, Serialize)]
pub struct MatrixCell {
    /// Where the data comes from.
    pub scenario: Scenario,
    /// Seed of the simulated runs (`None` for recorded data).
    pub seed: Option<u64>,
    /// The model.
    pub model: ModelSpec,
    /// Training windows.
    pub train_windows: usize,
    /// Evaluation windows.
    pub eval_windows: usize,
    /// Time to fit (s).
    pub fit_seconds: f64,
    /// Translational MRMSE (m) over the evaluation windows; `None` when the fit failed.
    pub translational: Option<Summary>,
    /// Rotational MRMSE (rad) over the evaluation windows.
    pub rotational: Option<Summary>,
    /// Why the fit failed, if it did.
    pub failure: Option<String>,
    /// Per-window errors, in evaluation order (the bootstrap's material).
    #[serde(skip)]
    pub errors: Vec<Mrmse>,
    /// The DRIVE interval of each of `errors`' windows: the bootstrap resamples whole
    /// intervals, as `drive eval` does.
    #[serde(skip)]
    pub intervals: Vec<usize>,
}

pub use drive_eval::Improvement;

/// One model in one scenario, every seed pooled.
#[derive(Debug, Clone, Serialize)]
pub struct SummaryRow {
    /// The scenario.
    pub scenario: Scenario,
    /// The model.
    pub model: ModelSpec,
    /// Seeds (runs) pooled.
    pub runs: usize,
    /// Evaluation windows pooled.
    pub windows: usize,
    /// Translational MRMSE (m).
    pub translational: Option<Summary>,
    /// Rotational MRMSE (rad).
    pub rotational: Option<Summary>,
    /// Improvement of the translational median over the baseline's.
    pub translational_improvement: Option<Improvement>,
    /// Improvement of the rotational median over the baseline's.
    pub rotational_improvement: Option<Improvement>,
    /// Runs whose fit failed.
    pub failed: usize,
}

/// What a sweep produced.
#[derive(Debug, Clone, Serialize)]
pub struct MatrixResult {
    /// The baseline model.
    pub baseline: ModelSpec,
    /// Bootstrap settings.
    pub bootstrap: BootstrapConfig,
    /// Every combination, in plan order.
    pub cells: Vec<MatrixCell>,
    /// Per scenario and model, seeds pooled.
    pub summary: Vec<SummaryRow>,
    /// The simulator each simulated robot ran on (empty without simulated runs).
    pub simulators: Vec<crate::RobotSimulator>,
    /// What a reader must know of these figures (a dataset the data checks call useless,
    /// scored because it was allowed); absent from the JSON when there is none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}
