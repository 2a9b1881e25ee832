//! The evaluation matrix: every combination of datasets (recorded, or simulated robot x
//! terrain x sampler x driving time x seed), learners, powertrains and splits scored with
//! eq. 8 in one run, summarized per scenario with the improvement over a baseline model and
//! its bootstrap confidence interval.

use crate::{evaluate_model, improvement_percent, intervals_in, quantile, simulate_with_samplers};
use crate::{split_by_interval, ExperimentError, Mrmse, Summary};
use drive_models::{LearnerEntry, LearnerRegistry, PowertrainChoice};
use drive_samplers::{RobotSpec, RunnerConfig, SamplerRegistry};
use drive_sim::Terrain;
use drive_traits::{Dataset, WindowSet};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;
use thiserror::Error;

/// Why a sweep cannot run.
#[derive(Debug, Error)]
pub enum MatrixError {
    /// The sweep file is not valid TOML or has unknown or mistyped keys.
    #[error("{file}: {reason}")]
    Parse {
        /// The sweep file.
        file: String,
        /// What the TOML reader said.
        reason: String,
    },
    /// The sweep asks for something that does not exist or cannot work.
    #[error("{0}")]
    Invalid(String),
    /// A dataset could not be loaded.
    #[error("dataset {name}: {reason}")]
    Dataset {
        /// The dataset as named in the sweep.
        name: String,
        /// Why.
        reason: String,
    },
    /// A simulated run failed.
    #[error("simulating {what}: {reason}")]
    Simulation {
        /// Robot, terrain, sampler, seed.
        what: String,
        /// Why.
        reason: Box<ExperimentError>,
    },
}

/// One recorded dataset of a sweep file: a window CSV (`file`, with an optional `sidecar`,
/// paths relative to the sweep file), or a bundled dataset (`bundled = "husky"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetSource {
    /// Window CSV (`.csv` or `.csv.gz`).
    #[serde(default)]
    pub file: Option<PathBuf>,
    /// Its sidecar JSON (default: the CSV's path with `.json`).
    #[serde(default)]
    pub sidecar: Option<PathBuf>,
    /// A bundled dataset's name.
    #[serde(default)]
    pub bundled: Option<String>,
    /// Label in the results (default: the file's stem or the bundled name).
    #[serde(default)]
    pub name: Option<String>,
}

impl DatasetSource {
    /// The label of this dataset in the results.
    pub fn label(&self) -> String {
        if let Some(n) = &self.name {
            return n.clone();
        }
        if let Some(b) = &self.bundled {
            return b.clone();
        }
        self.file
            .as_ref()
            .and_then(|f| f.file_name())
            .map(|f| {
                let f = f.to_string_lossy();
                f.trim_end_matches(".gz")
                    .trim_end_matches(".csv")
                    .to_string()
            })
            .unwrap_or_default()
    }
}

/// The simulated part of a sweep: every robot x terrain x sampler x driving time x seed is
/// one training run; each robot x terrain x seed has one held-out test run (driven with
/// `test_sampler`, seeded apart from the training runs) that all its models are scored on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulatedSweep {
    /// Robot presets (husky, hd2, warthog) or robot TOML files.
    pub robots: Vec<String>,
    /// Terrains (tile, gravel, snow, ice).
    pub terrains: Vec<String>,
    /// Samplers (registered names).
    pub samplers: Vec<String>,
    /// Driving time of each training run (s), characterization excluded.
    pub durations: Vec<f64>,
    /// Seeds (one repetition each).
    pub seeds: Vec<u64>,
    /// Driving time of the test runs (s); default: the longest duration, at least 300 s.
    #[serde(default)]
    pub test_duration: Option<f64>,
    /// Sampler of the test runs.
    #[serde(default = "uniform")]
    pub test_sampler: String,
}

fn uniform() -> String {
    "uniform".into()
}

/// The bootstrap of the improvement confidence intervals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BootstrapConfig {
    /// Resamples of the evaluation windows.
    pub resamples: usize,
    /// Confidence level of the interval.
    pub level: f64,
    /// Seed of the resampling.
    pub seed: u64,
}

impl Default for BootstrapConfig {
    fn default() -> Self {
        BootstrapConfig {
            resamples: 1000,
            level: 0.95,
            seed: 0,
        }
    }
}

/// A sweep description, as read from TOML.
///
/// ```
/// let sweep = drive_eval::SweepFile::parse("sweep.toml", r#"
///     learners = ["slip-blr", "acc-blr"]
///     powertrains = ["commanded", "fopdt"]
///     baseline = "acc-blr/commanded"
///     [[datasets]]
///     bundled = "husky"
///     [simulated]
///     robots = ["husky"]
///     terrains = ["tile", "ice"]
///     samplers = ["uniform", "linear"]
///     durations = [60]
///     seeds = [1, 2]
/// "#).unwrap();
/// assert_eq!(sweep.splits, [0.5]); // the default
/// assert_eq!(sweep.simulated.unwrap().test_sampler, "uniform");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepFile {
    /// Recorded datasets, each scored with every split.
    #[serde(default)]
    pub datasets: Vec<DatasetSource>,
    /// Simulated datasets.
    #[serde(default)]
    pub simulated: Option<SimulatedSweep>,
    /// Learners (registered names); default: every registered learner.
    #[serde(default)]
    pub learners: Option<Vec<String>>,
    /// Powertrains of the learners built on one.
    #[serde(default = "both_powertrains")]
    pub powertrains: Vec<PowertrainChoice>,
    /// Training fractions of the recorded datasets (first intervals train, the rest evaluate).
    #[serde(default = "half")]
    pub splits: Vec<f64>,
    /// The model improvements are measured against: `learner` or `learner/powertrain`.
    #[serde(default = "naive")]
    pub baseline: String,
    /// Bootstrap of the improvement confidence intervals.
    #[serde(default)]
    pub bootstrap: BootstrapConfig,
}

fn both_powertrains() -> Vec<PowertrainChoice> {
    PowertrainChoice::ALL.to_vec()
}
fn half() -> Vec<f64> {
    vec![0.5]
}
fn naive() -> String {
    "naive".into()
}

impl SweepFile {
    /// Parses a sweep file's text; `file` names it in errors.
    pub fn parse(file: &str, text: &str) -> Result<SweepFile, MatrixError> {
        toml::from_str(text).map_err(|e| MatrixError::Parse {
            file: file.to_string(),
            reason: e.message().to_string()
                + &e.span()
                    .map(|s| {
                        let line = text[..s.start.min(text.len())].lines().count().max(1);
                        format!(" (line {line})")
                    })
                    .unwrap_or_default(),
        })
    }

    /// Checks the sweep against the registries and loads what it names: recorded datasets
    /// through `load` (which resolves files and bundled names), robots and terrains by name.
    pub fn plan(
        &self,
        learners: &LearnerRegistry,
        samplers: &SamplerRegistry,
        load: &dyn Fn(&DatasetSource) -> Result<Dataset, String>,
    ) -> Result<Matrix, MatrixError> {
        let invalid = |s: String| MatrixError::Invalid(s);
        let names: Vec<String> = match &self.learners {
            Some(l) => l.clone(),
            None => learners.names().iter().map(|s| s.to_string()).collect(),
        };
        if names.is_empty() {
            return Err(invalid("the sweep lists no learner".into()));
        }
        if self.powertrains.is_empty() {
            return Err(invalid("the sweep lists no powertrain".into()));
        }
        let mut models = Vec::new();
        for name in &names {
            let entry = learners.get(name).ok_or_else(|| {
                invalid(format!(
                    "unknown learner '{name}' (the learners are: {})",
                    learners.names().join(", ")
                ))
            })?;
            if entry.uses_powertrain() {
                for p in &self.powertrains {
                    models.push(ModelKey::new(name, Some(*p)));
                }
            } else {
                models.push(ModelKey::new(name, None));
            }
        }
        models.dedup();
        let baseline = ModelKey::parse(&self.baseline, learners)?;
        if !models.contains(&baseline) {
            return Err(invalid(format!(
                "the baseline '{}' is not one of the sweep's models ({})",
                self.baseline,
                models
                    .iter()
                    .map(ModelKey::label)
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        if let Some(bad) = self
            .splits
            .iter()
            .find(|f| !(f.is_finite() && **f > 0.0 && **f < 1.0))
        {
            return Err(invalid(format!(
                "split {bad} is not between 0 and 1 (exclusive)"
            )));
        }
        let b = self.bootstrap;
        if !(b.level > 0.0 && b.level < 1.0) || b.resamples < 10 {
            return Err(invalid(format!(
                "bootstrap needs a level in (0, 1) and at least 10 resamples, got level {} and {} resamples",
                b.level, b.resamples
            )));
        }
        let mut datasets = Vec::new();
        for source in &self.datasets {
            let label = source.label();
            let one_of = [source.file.is_some(), source.bundled.is_some()];
            if one_of.iter().filter(|b| **b).count() != 1 {
                return Err(invalid(format!(
                    "dataset '{label}': give exactly one of file = \"...\" and bundled = \"...\""
                )));
            }
            if self.splits.is_empty() {
                return Err(invalid(
                    "the sweep has recorded datasets but no split".into(),
                ));
            }
            let data = load(source).map_err(|reason| MatrixError::Dataset {
                name: label.clone(),
                reason,
            })?;
            datasets.push((label, data));
        }
        let simulated = match &self.simulated {
            None => None,
            Some(s) => Some(SimulatedPlan::new(s, samplers)?),
        };
        if datasets.is_empty() && simulated.is_none() {
            return Err(invalid(
                "the sweep has no dataset: add [[datasets]] or [simulated]".into(),
            ));
        }
        Ok(Matrix {
            datasets,
            simulated,
            models,
            splits: self.splits.clone(),
            baseline,
            bootstrap: self.bootstrap,
        })
    }
}

/// The simulated part of a plan, with robots and terrains resolved.
#[derive(Debug, Clone)]
pub struct SimulatedPlan {
    /// Robots.
    pub robots: Vec<RobotSpec>,
    /// Terrains.
    pub terrains: Vec<Terrain>,
    /// Samplers of the training runs.
    pub samplers: Vec<String>,
    /// Driving times of the training runs (s).
    pub durations: Vec<f64>,
    /// Seeds.
    pub seeds: Vec<u64>,
    /// Driving time of the test runs (s).
    pub test_duration: f64,
    /// Sampler of the test runs.
    pub test_sampler: String,
}

impl SimulatedPlan {
    fn new(s: &SimulatedSweep, samplers: &SamplerRegistry) -> Result<Self, MatrixError> {
        let invalid = |s: String| MatrixError::Invalid(s);
        for (what, empty) in [
            ("robots", s.robots.is_empty()),
            ("terrains", s.terrains.is_empty()),
            ("samplers", s.samplers.is_empty()),
            ("durations", s.durations.is_empty()),
            ("seeds", s.seeds.is_empty()),
        ] {
            if empty {
                return Err(invalid(format!("[simulated] lists no {what}")));
            }
        }
        let robots = s
            .robots
            .iter()
            .map(|r| RobotSpec::load(r).map_err(|e| invalid(format!("[simulated] robot: {e}"))))
            .collect::<Result<Vec<_>, _>>()?;
        let terrains = s
            .terrains
            .iter()
            .map(|t| {
                Terrain::preset(t).ok_or_else(|| {
                    invalid(format!(
                        "[simulated] unknown terrain '{t}' (the terrains are: {})",
                        Terrain::NAMES.join(", ")
                    ))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        for name in s.samplers.iter().chain([&s.test_sampler]) {
            if !samplers.contains(name) {
                return Err(invalid(format!(
                    "[simulated] unknown sampler '{name}' (the samplers are: {})",
                    samplers.names().join(", ")
                )));
            }
        }
        let test_duration = s
            .test_duration
            .unwrap_or_else(|| s.durations.iter().copied().fold(300.0, f64::max));
        for d in s.durations.iter().chain([&test_duration]) {
            intervals_in(*d).map_err(|e| invalid(format!("[simulated] {e}")))?;
        }
        Ok(SimulatedPlan {
            robots,
            terrains,
            samplers: s.samplers.clone(),
            durations: s.durations.clone(),
            seeds: s.seeds.clone(),
            test_duration,
            test_sampler: s.test_sampler.clone(),
        })
    }
}

/// A model of the matrix: a learner and, for a learner built on one, its powertrain.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize)]
pub struct ModelKey {
    /// Registered learner name.
    pub learner: String,
    /// Powertrain (`None` for a learner without one).
    pub powertrain: Option<PowertrainChoice>,
}

impl ModelKey {
    fn new(learner: &str, powertrain: Option<PowertrainChoice>) -> Self {
        ModelKey {
            learner: learner.to_string(),
            powertrain,
        }
    }

    /// `learner/powertrain`, or the learner alone when it has no powertrain.
    pub fn label(&self) -> String {
        match self.powertrain {
            Some(p) => format!("{}/{}", self.learner, p.name()),
            None => self.learner.clone(),
        }
    }

    /// Reads `learner` or `learner/powertrain` (a learner built on a powertrain and named
    /// alone means its default powertrain).
    pub fn parse(text: &str, learners: &LearnerRegistry) -> Result<ModelKey, MatrixError> {
        let (name, pt) = match text.split_once('/') {
            Some((n, p)) => (n, Some(p)),
            None => (text, None),
        };
        let entry = learners.get(name).ok_or_else(|| {
            MatrixError::Invalid(format!(
                "unknown learner '{name}' in '{text}' (the learners are: {})",
                learners.names().join(", ")
            ))
        })?;
        let powertrain = match pt {
            None => entry.default_powertrain(),
            Some(p) => {
                let choice = PowertrainChoice::parse(p).ok_or_else(|| {
                    MatrixError::Invalid(format!(
                        "unknown powertrain '{p}' in '{text}' (the powertrains are: commanded, fopdt)"
                    ))
                })?;
                if !entry.uses_powertrain() {
                    return Err(MatrixError::Invalid(format!(
                        "'{name}' has no powertrain option; write '{name}' alone"
                    )));
                }
                Some(choice)
            }
        };
        Ok(ModelKey::new(name, powertrain))
    }
}

/// A checked sweep, ready to run (see [`SweepFile::plan`]).
#[derive(Debug, Clone)]
pub struct Matrix {
    /// Recorded datasets with their labels.
    pub datasets: Vec<(String, Dataset)>,
    /// Simulated datasets.
    pub simulated: Option<SimulatedPlan>,
    /// Every model (learner x powertrain).
    pub models: Vec<ModelKey>,
    /// Training fractions of the recorded datasets.
    pub splits: Vec<f64>,
    /// The reference of the improvement figures.
    pub baseline: ModelKey,
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
    pub model: ModelKey,
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
}

/// An improvement over the baseline with its bootstrap confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Improvement {
    /// `100 (baseline median - median) / baseline median`.
    pub percent: f64,
    /// Bootstrap percentile interval of the same figure.
    pub ci: [f64; 2],
}

/// One model in one scenario, every seed pooled.
#[derive(Debug, Clone, Serialize)]
pub struct SummaryRow {
    /// The scenario.
    pub scenario: Scenario,
    /// The model.
    pub model: ModelKey,
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
    pub baseline: ModelKey,
    /// Bootstrap settings.
    pub bootstrap: BootstrapConfig,
    /// Every combination, in plan order.
    pub cells: Vec<MatrixCell>,
    /// Per scenario and model, seeds pooled.
    pub summary: Vec<SummaryRow>,
}

/// One evaluation setting: a training set and the evaluation set it is scored on.
struct Setting<'a> {
    scenario: Scenario,
    seed: Option<u64>,
    train: WindowSet<'a>,
    eval: WindowSet<'a>,
}

/// Runs every combination of `matrix` in parallel (rayon), calling `progress(done, total)`
/// after each simulated run and each fitted model.
pub fn run_matrix(
    matrix: &Matrix,
    learners: &LearnerRegistry,
    samplers: &SamplerRegistry,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<MatrixResult, MatrixError> {
    // Every model's learner, resolved before anything runs (a plan made with another
    // registry fails here, not after the simulations).
    let entries = matrix
        .models
        .iter()
        .map(|m| {
            learners.get(&m.learner).ok_or_else(|| {
                MatrixError::Invalid(format!(
                    "learner '{}' is not in the registry the matrix runs with (it has: {})",
                    m.learner,
                    learners.names().join(", ")
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let done = AtomicUsize::new(0);
    // Simulated runs first: (robot, terrain, seed, Some(sampler, duration)) trains,
    // (robot, terrain, seed, None) is the test run.
    type Run<'p> = (&'p RobotSpec, Terrain, u64, Option<(&'p str, f64)>);
    let mut runs: Vec<Run<'_>> = Vec::new();
    if let Some(sim) = &matrix.simulated {
        for robot in &sim.robots {
            for terrain in &sim.terrains {
                for &seed in &sim.seeds {
                    runs.push((robot, *terrain, seed, None));
                    for sampler in &sim.samplers {
                        for &d in &sim.durations {
                            runs.push((robot, *terrain, seed, Some((sampler.as_str(), d))));
                        }
                    }
                }
            }
        }
    }
    let settings_per_data: usize = matrix.datasets.len() * matrix.splits.len();
    let sim_settings = runs.iter().filter(|r| r.3.is_some()).count();
    let sim_scenarios = matrix
        .simulated
        .as_ref()
        .map_or(0, |s| sim_settings / s.seeds.len().max(1));
    // Simulated runs, fits, then one summary row per scenario and model.
    let total = runs.len()
        + (settings_per_data + sim_settings) * matrix.models.len()
        + (settings_per_data + sim_scenarios) * matrix.models.len();
    let tick = || progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
    let simulated: Vec<Dataset> = runs
        .par_iter()
        .map(|&(robot, terrain, seed, train)| {
            let (sampler, driving, seed) = match (train, &matrix.simulated) {
                (Some((s, d)), _) => (s, d, seed),
                // Test runs exist only when the plan has a simulated part.
                (None, Some(sim)) => (
                    sim.test_sampler.as_str(),
                    sim.test_duration,
                    crate::ProtocolStudy::test_seed(seed),
                ),
                (None, None) => unreachable!("runs are only made from the simulated plan"),
            };
            let what = format!(
                "{} on {} with {sampler}, seed {seed}",
                robot.name, terrain.name
            );
            let fail = |reason| MatrixError::Simulation {
                what: what.clone(),
                reason: Box::new(reason),
            };
            let runner = RunnerConfig {
                max_intervals: Some(intervals_in(driving).map_err(fail)?),
                ..RunnerConfig::default()
            };
            let run = simulate_with_samplers(samplers, robot, terrain, sampler, runner, seed)
                .map_err(fail)?;
            tick();
            Ok(run.dataset)
        })
        .collect::<Result<_, MatrixError>>()?;

    let mut settings = Vec::new();
    for (label, data) in &matrix.datasets {
        for &split in &matrix.splits {
            let (train, eval) =
                split_by_interval(data, split).map_err(|e| MatrixError::Dataset {
                    name: label.clone(),
                    reason: e.to_string(),
                })?;
            settings.push(Setting {
                scenario: Scenario {
                    dataset: label.clone(),
                    robot: data.robot.robot.clone(),
                    terrain: None,
                    sampler: None,
                    duration_s: None,
                    split: Some(split),
                },
                seed: None,
                train,
                eval,
            });
        }
    }
    let mut test = None;
    for (run, data) in runs.iter().zip(&simulated) {
        let (robot, terrain, seed, train) = *run;
        let Some((sampler, duration)) = train else {
            test = Some(data);
            continue;
        };
        // Each robot, terrain and seed's test run precedes its training runs.
        let test = test.expect("the test run is pushed before its training runs");
        if data.windows.is_empty() || test.windows.is_empty() {
            return Err(MatrixError::Simulation {
                what: format!(
                    "{} on {} with {sampler}, seed {seed}",
                    robot.name, terrain.name
                ),
                reason: Box::new(ExperimentError::NotEnoughData(
                    "the run recorded no interval".into(),
                )),
            });
        }
        settings.push(Setting {
            scenario: Scenario {
                dataset: "sim".into(),
                robot: robot.name.clone(),
                terrain: Some(terrain.name.to_string()),
                sampler: Some(sampler.to_string()),
                duration_s: Some(duration),
                split: None,
            },
            seed: Some(seed),
            train: data.all(),
            eval: test.all(),
        });
    }

    let tasks: Vec<(&Setting<'_>, &ModelKey, &LearnerEntry)> = settings
        .iter()
        .flat_map(|s| {
            matrix
                .models
                .iter()
                .zip(&entries)
                .map(move |(m, e)| (s, m, *e))
        })
        .collect();
    let cells: Vec<MatrixCell> = tasks
        .par_iter()
        .map(|(setting, model, entry)| {
            let cell = score(setting, model, entry);
            tick();
            cell
        })
        .collect();
    let summary = summarize(matrix, &cells, &tick);
    Ok(MatrixResult {
        baseline: matrix.baseline.clone(),
        bootstrap: matrix.bootstrap,
        cells,
        summary,
    })
}

/// Fits one model on a setting's training set and scores it on its evaluation set.
fn score(setting: &Setting<'_>, model: &ModelKey, learner: &LearnerEntry) -> MatrixCell {
    let start = Instant::now();
    let fitted = learner.fit(&setting.train, model.powertrain);
    let fit_seconds = start.elapsed().as_secs_f64();
    let mut cell = MatrixCell {
        scenario: setting.scenario.clone(),
        seed: setting.seed,
        model: model.clone(),
        train_windows: setting.train.len(),
        eval_windows: setting.eval.len(),
        fit_seconds,
        translational: None,
        rotational: None,
        failure: None,
        errors: Vec::new(),
    };
    match fitted {
        Ok(m) => {
            let report = evaluate_model(m.as_ref(), &setting.eval);
            cell.translational = report.translational(None);
            cell.rotational = report.rotational(None);
            cell.errors = report.windows.iter().map(|w| w.error).collect();
        }
        Err(e) => cell.failure = Some(e.to_string()),
    }
    cell
}

/// The median of `values` (reordered in place; NaN-free), as [`quantile`] at 0.5 gives it;
/// NaN when empty. Linear time (selection, no sort): the bootstrap calls it for every draw.
fn median_of(values: &mut [f64]) -> f64 {
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    let (left, mid, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
    let upper = *mid;
    if n % 2 == 1 {
        return upper;
    }
    // The lower middle value is the largest of the left part.
    let lower = left.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    lower + (upper - lower) * 0.5
}

/// Pooled summaries per scenario and model, with improvements over the baseline.
fn summarize(matrix: &Matrix, cells: &[MatrixCell], tick: &(dyn Fn() + Sync)) -> Vec<SummaryRow> {
    let mut scenarios: Vec<&Scenario> = Vec::new();
    for c in cells {
        if !scenarios.contains(&&c.scenario) {
            scenarios.push(&c.scenario);
        }
    }
    let jobs: Vec<(&Scenario, &ModelKey)> = scenarios
        .iter()
        .flat_map(|s| matrix.models.iter().map(move |m| (*s, m)))
        .collect();
    jobs.par_iter()
        .map(|&(scenario, model)| {
            // Each row's resampling stream depends on what it compares only, so a row's
            // interval is the same in any sweep that holds it.
            let index = fnv1a(&format!(
                "{}|{:?}|{}",
                scenario.label(),
                scenario.split,
                model.label()
            ));
            let of = |m: &ModelKey| -> Vec<&MatrixCell> {
                cells
                    .iter()
                    .filter(|c| &c.scenario == scenario && &c.model == m)
                    .collect()
            };
            let mine = of(model);
            let base = of(&matrix.baseline);
            let ok: Vec<&MatrixCell> = mine
                .iter()
                .copied()
                .filter(|c| c.failure.is_none())
                .collect();
            let pooled = |pick: fn(&Mrmse) -> f64| {
                Summary::of(ok.iter().flat_map(|c| c.errors.iter().map(pick)))
            };
            // Pairs of (model, baseline) runs scored on the same evaluation windows.
            let pairs: Vec<(&MatrixCell, &MatrixCell)> = ok
                .iter()
                .filter_map(|c| {
                    base.iter()
                        .find(|b| b.seed == c.seed && b.failure.is_none())
                        .map(|b| (*c, *b))
                })
                .collect();
            let complete = !pairs.is_empty() && pairs.len() == mine.len();
            let improvement = |pick: fn(&Mrmse) -> f64, salt: u64| {
                complete
                    .then(|| bootstrap_improvement(&pairs, pick, &matrix.bootstrap, index, salt))
            };
            let row = SummaryRow {
                scenario: scenario.clone(),
                model: model.clone(),
                runs: mine.len(),
                windows: ok.iter().map(|c| c.errors.len()).sum(),
                translational: pooled(|e| e.translational),
                rotational: pooled(|e| e.rotational),
                translational_improvement: improvement(|e| e.translational, 0),
                rotational_improvement: improvement(|e| e.rotational, 1),
                failed: mine.len() - ok.len(),
            };
            tick();
            row
        })
        .collect()
}

/// FNV-1a of a text: a fixed, platform-independent hash.
fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The improvement of the pooled median over the baseline's, and its bootstrap percentile
/// interval: each run's evaluation windows resampled with replacement, the same draw for the
/// model and the baseline (a paired bootstrap).
fn bootstrap_improvement(
    pairs: &[(&MatrixCell, &MatrixCell)],
    pick: fn(&Mrmse) -> f64,
    config: &BootstrapConfig,
    index: u64,
    salt: u64,
) -> Improvement {
    let mut mine: Vec<f64> = Vec::new();
    let mut base: Vec<f64> = Vec::new();
    for (m, b) in pairs {
        mine.extend(m.errors.iter().map(pick));
        base.extend(b.errors.iter().map(pick));
    }
    let percent = improvement_percent(median_of(&mut mine), median_of(&mut base));
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(
        config.seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (salt << 63),
    );
    let mut draws = Vec::with_capacity(config.resamples);
    for _ in 0..config.resamples {
        mine.clear();
        base.clear();
        for (m, b) in pairs {
            let n = m.errors.len().min(b.errors.len());
            for _ in 0..n {
                let i = rng.random_range(0..n);
                mine.push(pick(&m.errors[i]));
                base.push(pick(&b.errors[i]));
            }
        }
        let p = improvement_percent(median_of(&mut mine), median_of(&mut base));
        if p.is_finite() {
            draws.push(p);
        }
    }
    draws.sort_unstable_by(f64::total_cmp);
    let tail = (1.0 - config.level) / 2.0;
    Improvement {
        percent,
        ci: [
            quantile(&draws, tail).unwrap_or(f64::NAN),
            quantile(&draws, 1.0 - tail).unwrap_or(f64::NAN),
        ],
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

impl MatrixResult {
    /// The tidy CSV: one row per combination and metric (`translational_mrmse` in m,
    /// `rotational_mrmse` in rad), empty numbers and the reason in `failure` for a failed fit.
    pub fn to_csv(&self) -> String {
        let mut out = String::from(
            "dataset,robot,terrain,sampler,duration_s,split,seed,learner,powertrain,metric,unit,windows,median,q1,q3,train_windows,fit_s,failure\n",
        );
        for c in &self.cells {
            let s = &c.scenario;
            for (metric, unit, summary) in [
                ("translational_mrmse", "m", c.translational),
                ("rotational_mrmse", "rad", c.rotational),
            ] {
                let _ = writeln!(
                    out,
                    "{},{},{},{},{},{},{},{},{},{metric},{unit},{},{},{},{},{},{:.6},{}",
                    csv_field(&s.dataset),
                    csv_field(&s.robot),
                    opt(s.terrain.as_deref()),
                    opt(s.sampler.as_deref()),
                    opt(s.duration_s),
                    opt(s.split),
                    opt(c.seed),
                    csv_field(&c.model.learner),
                    opt(c.model.powertrain.map(PowertrainChoice::name)),
                    summary.map_or(0, |s| s.count),
                    opt(summary.map(|s| s.median)),
                    opt(summary.map(|s| s.q1)),
                    opt(summary.map(|s| s.q3)),
                    c.train_windows,
                    c.fit_seconds,
                    csv_field(c.failure.as_deref().unwrap_or("")),
                );
            }
        }
        out
    }

    /// The Markdown summary: per scenario and model, the median and IQR of both errors (every
    /// run's evaluation windows pooled) and the improvement over the baseline with its
    /// bootstrap confidence interval.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let level = 100.0 * self.bootstrap.level;
        let _ = writeln!(s, "# DRIVE evaluation matrix\n");
        let _ = writeln!(
            s,
            "{} combinations. MRMSE over 2 s windows (paper eq. 8), median [IQR] of every evaluation window of the scenario's runs pooled. \
             Improvement: `100 (baseline - model) / baseline` of the medians, baseline **{}**, with a {level:.0}% paired bootstrap interval ({} resamples of the evaluation windows).\n",
            self.cells.len(),
            self.baseline.label(),
            self.bootstrap.resamples,
        );
        let _ = writeln!(
            s,
            "| scenario | model | runs | windows | transl. MRMSE [m] | vs baseline | rot. MRMSE [rad] | vs baseline |"
        );
        let _ = writeln!(s, "|---|---|---:|---:|---|---|---|---|");
        let cell = |x: Option<Summary>, digits: usize| {
            x.map_or("failed".into(), |x| {
                format!("{:.d$} [{:.d$}, {:.d$}]", x.median, x.q1, x.q3, d = digits)
            })
        };
        let imp = |i: Option<Improvement>, is_baseline: bool| match i {
            _ if is_baseline => "baseline".to_string(),
            Some(i) => format!("{:+.1}% [{:+.1}, {:+.1}]", i.percent, i.ci[0], i.ci[1]),
            None => "-".to_string(),
        };
        for r in &self.summary {
            let is_base = r.model == self.baseline;
            let _ = writeln!(
                s,
                "| {} | {} | {}{} | {} | {} | {} | {} | {} |",
                r.scenario.label(),
                r.model.label(),
                r.runs,
                if r.failed > 0 {
                    format!(" ({} failed)", r.failed)
                } else {
                    String::new()
                },
                r.windows,
                cell(r.translational, 4),
                imp(r.translational_improvement, is_base),
                cell(r.rotational, 4),
                imp(r.rotational_improvement, is_base),
            );
        }
        let failures: Vec<&MatrixCell> =
            self.cells.iter().filter(|c| c.failure.is_some()).collect();
        if !failures.is_empty() {
            let _ = writeln!(s, "\n## Failed fits\n");
            for c in failures {
                let _ = writeln!(
                    s,
                    "- {} {}{}: {}",
                    c.scenario.label(),
                    c.model.label(),
                    c.seed.map_or(String::new(), |k| format!(" seed {k}")),
                    c.failure.as_deref().unwrap_or("")
                );
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(seed: u64, errors: &[f64]) -> MatrixCell {
        MatrixCell {
            scenario: Scenario {
                dataset: "d".into(),
                robot: "r".into(),
                terrain: None,
                sampler: None,
                duration_s: None,
                split: Some(0.5),
            },
            seed: Some(seed),
            model: ModelKey::new("m", None),
            train_windows: 1,
            eval_windows: errors.len(),
            fit_seconds: 0.0,
            translational: Summary::of(errors.iter().copied()),
            rotational: Summary::of(errors.iter().copied()),
            failure: None,
            errors: errors
                .iter()
                .map(|&e| Mrmse {
                    translational: e,
                    rotational: 2.0 * e,
                })
                .collect(),
        }
    }

    #[test]
    fn median_by_selection_equals_the_interpolated_quantile() {
        for n in 1..12 {
            let mut v: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 * 0.5).collect();
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            assert_eq!(
                median_of(&mut v),
                quantile(&sorted, 0.5).unwrap(),
                "n = {n}"
            );
        }
        assert!(median_of(&mut []).is_nan());
    }

    #[test]
    fn a_model_with_half_the_baseline_errors_improves_by_exactly_fifty_percent() {
        let base = cell(1, &[0.2, 0.4, 0.6, 0.8, 1.0]);
        let half = cell(1, &[0.1, 0.2, 0.3, 0.4, 0.5]);
        let config = BootstrapConfig::default();
        let i = bootstrap_improvement(&[(&half, &base)], |e| e.translational, &config, 0, 0);
        // Paired resampling keeps the ratio of every draw at 1/2, so the interval is a point.
        assert!((i.percent - 50.0).abs() < 1e-9);
        assert!((i.ci[0] - 50.0).abs() < 1e-9 && (i.ci[1] - 50.0).abs() < 1e-9);
        let same = bootstrap_improvement(&[(&base, &base)], |e| e.rotational, &config, 0, 1);
        assert_eq!((same.percent, same.ci), (0.0, [0.0, 0.0]));
    }

    #[test]
    fn the_interval_widens_with_noisy_pairs_and_brackets_the_estimate() {
        let base = cell(1, &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        let model = cell(1, &[0.2, 0.9, 0.4, 1.2, 0.6, 0.3, 1.1, 0.5]);
        let config = BootstrapConfig::default();
        let i = bootstrap_improvement(&[(&model, &base)], |e| e.translational, &config, 3, 0);
        // Median of the model: (0.5 + 0.6) / 2 = 0.55, so 45% better than 1.0.
        assert!((i.percent - 45.0).abs() < 1e-9);
        assert!(i.ci[0] < 45.0 && i.ci[1] > 45.0, "{:?}", i.ci);
        // Same seed, same interval.
        let again = bootstrap_improvement(&[(&model, &base)], |e| e.translational, &config, 3, 0);
        assert_eq!(i, again);
    }

    #[test]
    fn model_keys_read_learner_and_powertrain() {
        let r = LearnerRegistry::builtin();
        assert_eq!(
            ModelKey::parse("slip-blr", &r).unwrap().label(),
            "slip-blr/fopdt"
        );
        assert_eq!(
            ModelKey::parse("acc-blr", &r).unwrap().label(),
            "acc-blr/commanded"
        );
        assert_eq!(ModelKey::parse("naive", &r).unwrap().label(), "naive");
        assert!(ModelKey::parse("naive/fopdt", &r).is_err());
        assert!(ModelKey::parse("slip-blr/turbo", &r).is_err());
        assert!(ModelKey::parse("gp", &r).is_err());
    }

    #[test]
    fn a_sweep_expands_learners_over_powertrains_only_where_they_have_one() {
        let sweep = SweepFile::parse(
            "t",
            "learners = [\"naive\", \"slip-blr\"]\n[simulated]\nrobots = [\"husky\"]\nterrains = [\"ice\"]\nsamplers = [\"uniform\"]\ndurations = [12]\nseeds = [1]\n",
        )
        .unwrap();
        let plan = sweep
            .plan(
                &LearnerRegistry::builtin(),
                &SamplerRegistry::builtin(),
                &|_| Err("no files here".into()),
            )
            .unwrap();
        let labels: Vec<String> = plan.models.iter().map(ModelKey::label).collect();
        assert_eq!(labels, ["naive", "slip-blr/commanded", "slip-blr/fopdt"]);
        // The test run defaults to the longest duration, at least 300 s.
        assert_eq!(plan.simulated.unwrap().test_duration, 300.0);
    }
}
