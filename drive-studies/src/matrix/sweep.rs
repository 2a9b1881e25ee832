//! The sweep file (TOML): what an evaluation matrix combines, checked against the
//! registries into a [`Matrix`] plan.

use super::Matrix;
use crate::{intervals_in, ExperimentError, Registries};
use drive_eval::BootstrapConfig;
use drive_models::ModelSpec;
use drive_samplers::RobotSpec;
use drive_sim::Terrain;
use drive_traits::limits;
use drive_traits::{Dataset, RegistryError, StartInfo};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use thiserror::Error;

/// Why a sweep's dataset loader ([`SweepFile::plan`]) could not give a dataset: any error (a
/// file's, a name's), said in [`MatrixError::Dataset`].
pub type DatasetLoadError = Box<dyn std::error::Error + Send + Sync>;

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
    /// A part's name is not registered.
    #[error(transparent)]
    Registry(#[from] RegistryError),
}

/// One recorded dataset of a sweep file: a window CSV (`file`, with an optional `sidecar`,
/// paths relative to the sweep file), or a bundled dataset (`bundled = "husky"`, or any name
/// of `drive list`'s datasets; `file = "bundled:NAME"` is the same).
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
    /// Positions as published or rotated into each window's first-sample frame, for a
    /// dataset whose sidecar declares the paper parser's frame (`--frame` of the command
    /// line); other datasets are already in the first sample's frame.
    #[serde(default)]
    pub frame: FrameChoice,
}

/// The positions of a dataset in the paper parser's frame (`position_frame = "paper-mean5"`):
/// as published, or rotated into each window's first-sample frame like its yaw.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrameChoice {
    /// As the dataset has them (the paper's numbers reproduce).
    #[default]
    AsPublished,
    /// Rotated into each window's first-sample frame ([`Dataset::to_first_sample_frame`]).
    Corrected,
}

impl DatasetSource {
    /// The label of this dataset in the results.
    ///
    /// An unnamed dataset in the corrected frame is labelled `<stem>, corrected frame`.
    pub fn label(&self) -> String {
        if let Some(n) = &self.name {
            return n.clone();
        }
        let stem = self.stem();
        match self.frame {
            FrameChoice::AsPublished => stem,
            FrameChoice::Corrected => format!("{stem}, corrected frame"),
        }
    }

    fn stem(&self) -> String {
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
    /// Robot presets (husky, hd2, warthog) or robot TOML files (`drive matrix` reads a
    /// relative path relative to the sweep file). Each at most once, as every list here.
    pub robots: Vec<String>,
    /// Terrains (tile, gravel, snow, ice) or terrain TOML files.
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

/// A sweep description, as read from TOML.
///
/// ```
/// let sweep = drive_studies::SweepFile::parse("sweep.toml", r#"
///     learners = ["slip-blr", "acc-blr"]
///     powertrains = ["commanded", "fopdt"]
///     baseline = "acc-blr+commanded"
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
/// assert_eq!(sweep.start, drive_traits::StartInfo::EncodersImu); // the default
/// assert_eq!(sweep.datasets[0].frame, drive_studies::FrameChoice::AsPublished);
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
    /// Learners: slip learners and baselines (each run on every powertrain it takes), the
    /// paper's model names, or whole models (`slip-blr+fopdt`); default: every registered
    /// slip learner and baseline.
    #[serde(default)]
    pub learners: Option<Vec<String>>,
    /// Powertrains of the learners built on one (registered names); default: every
    /// registered powertrain.
    #[serde(default)]
    pub powertrains: Option<Vec<String>>,
    /// Training fractions of the recorded datasets (first intervals train, the rest evaluate).
    #[serde(default = "half")]
    pub splits: Vec<f64>,
    /// The model improvements are measured against: a model name (`naive`,
    /// `acc-blr+commanded`; `learner/powertrain` is read as `learner+powertrain`).
    #[serde(default = "naive")]
    pub baseline: String,
    /// Bootstrap of the improvement confidence intervals.
    #[serde(default)]
    pub bootstrap: BootstrapConfig,
    /// What every model's predictions start from, in its calibration and its scoring
    /// (`"encoders+imu"` by default, as `--start` of the command line).
    #[serde(default)]
    pub start: StartInfo,
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
            reason: drive_traits::exact::parse_message(
                text,
                e.message(),
                e.span().map(|s| s.start),
            ),
        })
    }

    /// Checks the sweep against the registries and loads what it names: recorded datasets
    /// through `load` (which resolves files and bundled names), robots and terrains by name.
    pub fn plan(
        &self,
        registries: &Registries,
        load: &dyn Fn(&DatasetSource) -> Result<Dataset, DatasetLoadError>,
    ) -> Result<Matrix, MatrixError> {
        let invalid = |s: String| MatrixError::Invalid(s);
        let models = registries.models();
        let learners: Vec<String> = match &self.learners {
            Some(l) => l.clone(),
            None => registries
                .slip_learners
                .names()
                .into_iter()
                .chain(registries.baselines.names())
                .map(String::from)
                .collect(),
        };
        if learners.is_empty() {
            return Err(invalid("the sweep lists no learner".into()));
        }
        let powertrains: Vec<String> = match &self.powertrains {
            Some(p) => p.clone(),
            None => registries
                .powertrains
                .names()
                .into_iter()
                .map(String::from)
                .collect(),
        };
        if powertrains.is_empty() {
            return Err(invalid("the sweep lists no powertrain".into()));
        }
        for p in &powertrains {
            registries.powertrains.get(p)?;
        }
        let mut specs: Vec<ModelSpec> = Vec::new();
        for name in &learners {
            let on_powertrains = !name.contains(['+', '/'])
                && (registries.slip_learners.contains(name)
                    || registries
                        .baselines
                        .find(name)
                        .is_some_and(|b| b.part().default_powertrain().is_some()));
            let found = if on_powertrains {
                powertrains
                    .iter()
                    .map(|p| models.resolve(&format!("{name}+{p}")))
                    .collect::<Result<Vec<_>, _>>()?
            } else {
                vec![models.resolve(name)?]
            };
            for spec in found {
                let spec = spec.clone().with_uncertainty(spec.uncertainty, self.start);
                if !specs.contains(&spec) {
                    specs.push(spec);
                }
            }
        }
        let baseline = models.resolve(&self.baseline)?;
        let baseline = baseline
            .clone()
            .with_uncertainty(baseline.uncertainty, self.start);
        if !specs.contains(&baseline) {
            return Err(invalid(format!(
                "the baseline '{}' ({}) is not one of the sweep's models ({})",
                self.baseline,
                baseline.canonical(),
                specs
                    .iter()
                    .map(ModelSpec::canonical)
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
                "split {} is not between 0 and 1 (exclusive)",
                limits::Short(*bad)
            )));
        }
        // A value listed twice would pool the same cells twice, as if they were
        // independent runs (narrower bootstrap intervals from duplicated rows).
        if let Some(f) = first_repeat(&self.splits) {
            return Err(invalid(format!(
                "split {} is listed twice: each would be scored as another run",
                limits::Short(*f)
            )));
        }
        let b = self.bootstrap;
        if !(b.level > 0.0 && b.level < 1.0) || b.resamples < 10 {
            return Err(invalid(format!(
                "bootstrap needs a level in (0, 1) and at least 10 resamples, got level {} and {} resamples",
                limits::Short(b.level), b.resamples
            )));
        }
        limits::at_most(
            "bootstrap.resamples",
            b.resamples as f64,
            limits::MAX_RESAMPLES as f64,
            "",
        )
        .map_err(|e| invalid(e.to_string()))?;
        // Counted before anything is loaded or simulated, in floating point (a product of
        // list lengths can overflow an integer).
        let runs = self.simulated.as_ref().map_or(0.0, |s| {
            [
                s.robots.len(),
                s.terrains.len(),
                s.samplers.len(),
                s.durations.len(),
                s.seeds.len(),
            ]
            .iter()
            .map(|n| *n as f64)
            .product::<f64>()
        });
        let combinations =
            (self.datasets.len() as f64 * self.splits.len() as f64 + runs) * specs.len() as f64;
        limits::at_most(
            "the sweep's combinations",
            combinations,
            limits::MAX_COMBINATIONS as f64,
            "split it into several sweeps",
        )
        .map_err(|e| invalid(e.to_string()))?;
        let mut datasets: Vec<(String, Dataset)> = Vec::new();
        for source in &self.datasets {
            let label = source.label();
            // A label is one line of a table: no control character or line separator.
            if limits::breaks_text(&label) {
                return Err(invalid(format!(
                    "dataset {}: its name holds a control character or a line separator (it labels a line of the tables)",
                    label.escape_debug()
                )));
            }
            // Cells are grouped by label: two datasets under one label would be pooled.
            if datasets.iter().any(|(l, _)| *l == label)
                || (label == "sim" && self.simulated.is_some())
            {
                return Err(invalid(format!(
                    "two datasets are labelled '{label}': give each its own name = \"...\""
                )));
            }
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
            let mut data = load(source).map_err(|reason| MatrixError::Dataset {
                name: label.clone(),
                reason: reason.to_string(),
            })?;
            if source.frame == FrameChoice::Corrected {
                data.to_first_sample_frame();
            }
            datasets.push((label, data));
        }
        let simulated = match &self.simulated {
            None => None,
            Some(s) => Some(SimulatedPlan::new(s, registries)?),
        };
        if datasets.is_empty() && simulated.is_none() {
            return Err(invalid(
                "the sweep has no dataset: add [[datasets]] or [simulated]".into(),
            ));
        }
        Ok(Matrix {
            datasets,
            simulated,
            models: specs,
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

/// The first value of `values` that an earlier one equals.
fn first_repeat<T: PartialEq>(values: &[T]) -> Option<&T> {
    values
        .iter()
        .enumerate()
        .find(|(i, v)| values[..*i].contains(v))
        .map(|(_, v)| v)
}

impl SimulatedPlan {
    fn new(s: &SimulatedSweep, registries: &Registries) -> Result<Self, MatrixError> {
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
        // Listed twice, a value would pool its runs twice (the same seed simulates the same
        // run): refused, as two datasets under one label are.
        let repeated = [
            ("robot", first_repeat(&s.robots).map(|r| format!("'{r}'"))),
            (
                "terrain",
                first_repeat(&s.terrains).map(|t| format!("'{t}'")),
            ),
            (
                "sampler",
                first_repeat(&s.samplers).map(|t| format!("'{t}'")),
            ),
            (
                "duration",
                first_repeat(&s.durations).map(|d| format!("{} s", limits::Short(*d))),
            ),
            ("seed", first_repeat(&s.seeds).map(|d| d.to_string())),
        ];
        if let Some((what, Some(value))) = repeated.into_iter().find(|(_, v)| v.is_some()) {
            return Err(invalid(format!(
                "[simulated] lists {what} {value} twice: its runs would be pooled as if they were others"
            )));
        }
        let robots = s
            .robots
            .iter()
            .map(|r| {
                registries
                    .robot(r)
                    .map_err(|e| invalid(format!("[simulated] robot: {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let terrains = s
            .terrains
            .iter()
            .map(|t| {
                registries
                    .terrain(t)
                    .map_err(|e| invalid(format!("[simulated] {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        for name in s.samplers.iter().chain([&s.test_sampler]) {
            registries
                .samplers
                .get(name)
                .map_err(|e| invalid(format!("[simulated] {e}")))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_names_of_the_sweep_resolve_like_the_command_line() {
        let r = Registries::builtin();
        let m = r.models();
        assert_eq!(m.resolve("slip-blr").unwrap().canonical(), "slip-blr+fopdt");
        assert_eq!(
            m.resolve("acc-blr/commanded").unwrap().canonical(),
            "acc-blr+commanded"
        );
        assert!(m.resolve("naive/fopdt").is_err());
        assert!(m.resolve("slip-blr/turbo").is_err());
    }

    #[test]
    fn a_sweep_expands_learners_over_powertrains_only_where_they_have_one() {
        let sweep = SweepFile::parse(
            "t",
            "learners = [\"naive\", \"slip-blr\"]\npowertrains = [\"commanded\", \"fopdt\"]\n[simulated]\nrobots = [\"husky\"]\nterrains = [\"ice\"]\nsamplers = [\"uniform\"]\ndurations = [12]\nseeds = [1]\n",
        )
        .unwrap();
        let plan = sweep
            .plan(&Registries::builtin(), &|_| Err("no files here".into()))
            .unwrap();
        let labels: Vec<String> = plan.models.iter().map(ModelSpec::canonical).collect();
        assert_eq!(
            labels,
            ["no-slip+commanded", "slip-blr+commanded", "slip-blr+fopdt"]
        );
        // The test run defaults to the longest duration, at least 300 s.
        assert_eq!(plan.simulated.unwrap().test_duration, 300.0);
    }

    #[test]
    fn a_value_listed_twice_is_refused_not_pooled_twice() {
        let plan = |text: &str| {
            SweepFile::parse("t", text)
                .unwrap()
                .plan(&Registries::builtin(), &|_| Err("no files here".into()))
                .map(|_| ())
                .unwrap_err()
                .to_string()
        };
        let sim = |line: &str| {
            let base = "robots = [\"husky\"]\nterrains = [\"ice\"]\nsamplers = [\"uniform\"]\ndurations = [12]\nseeds = [1]\n";
            let key = line.split(' ').next().unwrap();
            let kept: String = base
                .lines()
                .filter(|l| !l.starts_with(key))
                .map(|l| format!("{l}\n"))
                .collect();
            format!("learners = [\"naive\", \"slip-blr\"]\npowertrains = [\"commanded\", \"fopdt\"]\n[simulated]\n{kept}{line}\n")
        };
        let e = plan(&sim("seeds = [1, 2, 1]"));
        assert!(e.contains("lists seed 1 twice"), "{e}");
        assert!(plan(&sim("durations = [12, 12.0]")).contains("lists duration 12 s twice"));
        assert!(plan(&sim("robots = [\"husky\", \"husky\"]")).contains("lists robot 'husky' twice"));
        let splits = format!("splits = [0.5, 0.3, 0.5]\n{}", sim("seeds = [1]"));
        assert!(plan(&splits).contains("split 0.5 is listed twice"));
    }
}
