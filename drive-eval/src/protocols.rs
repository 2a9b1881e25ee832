//! Data-gathering protocols compared on the simulator (the paper's Table I): equal driving
//! time with each sampler, one model trained on each, all evaluated on one common held-out
//! test set gathered with the reference sampler (DRIVE's `uniform`).

use crate::{evaluate_model, improvement_percent, Mrmse, Summary};
use drive_models::{fit_named, DifferentialDrive};
use drive_samplers::{RobotSpec, RunnerConfig, SamplerContext, SamplerError, SamplerRegistry};
use drive_sim::{simulate, SimError, Simulation, SimulationConfig, Terrain};
use drive_traits::{CommandModel, FitError, Input, InputSampler, WindowSet};
use rayon::prelude::*;
use serde::Serialize;
use std::sync::{Arc, Mutex};
use thiserror::Error;

/// Length of one DRIVE interval (s): one transient and two steady 2 s windows.
pub const INTERVAL_S: f64 = 6.0;

/// Why an experiment could not run.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ExperimentError {
    /// A sampler could not be built.
    #[error("sampler '{name}': {reason}")]
    Sampler {
        /// sampler name
        name: String,
        /// cause
        reason: SamplerError,
    },
    /// The simulation could not run.
    #[error(transparent)]
    Simulation(#[from] SimError),
    /// A model could not be fitted.
    #[error("fitting {model} on {data}: {reason}")]
    Fit {
        /// model name
        model: String,
        /// what it was fitted on
        data: String,
        /// cause
        reason: FitError,
    },
    /// No model of that name.
    #[error("unknown model '{0}' (the models are: {models})", models = drive_models::MODEL_NAMES.join(", "))]
    UnknownModel(String),
    /// A driving time shorter than one interval, or not finite.
    #[error("driving time {0} s is shorter than one {INTERVAL_S} s DRIVE interval")]
    TooShort(f64),
    /// The study lists nothing to run.
    #[error("the study has no {0}")]
    Empty(&'static str),
    /// A data set holds too few windows for the experiment.
    #[error("{0}")]
    NotEnoughData(String),
}

/// The number of whole DRIVE intervals that fit in `driving_s` seconds of driving.
///
/// ```
/// assert_eq!(drive_eval::intervals_in(30.0).unwrap(), 5);
/// assert_eq!(drive_eval::intervals_in(35.0).unwrap(), 5);
/// assert!(drive_eval::intervals_in(5.0).is_err());
/// ```
pub fn intervals_in(driving_s: f64) -> Result<usize, ExperimentError> {
    // The tolerance keeps 0.3 x 20 from flooring to 5.
    let n = (driving_s / INTERVAL_S + 1e-9).floor();
    if !(n.is_finite() && n >= 1.0) {
        return Err(ExperimentError::TooShort(driving_s));
    }
    Ok(n as usize)
}

/// Runs the DRIVE protocol on the simulator: characterization, then `intervals` intervals
/// with the sampler registered as `sampler` ([`drive_samplers::sampler_over`]), the
/// simulator's noise and the sampler seeded with `seed`.
///
/// ```
/// use drive_eval::simulate_protocol;
/// use drive_samplers::RobotSpec;
/// use drive_sim::Terrain;
/// let husky = RobotSpec::preset("husky").unwrap();
/// let run = simulate_protocol(&husky, Terrain::preset("snow").unwrap(), "uniform", 2, 1).unwrap();
/// assert_eq!(run.dataset.windows.len(), 6);
/// ```
pub fn simulate_protocol(
    robot: &RobotSpec,
    terrain: Terrain,
    sampler: &str,
    intervals: usize,
    seed: u64,
) -> Result<Simulation, ExperimentError> {
    let runner = RunnerConfig {
        max_intervals: Some(intervals),
        ..RunnerConfig::default()
    };
    simulate_with(robot, terrain, sampler, runner, seed)
}

/// Like [`simulate_protocol`] with the runner's configuration given (for instance a
/// duration instead of a number of intervals).
pub fn simulate_with(
    robot: &RobotSpec,
    terrain: Terrain,
    sampler: &str,
    runner: RunnerConfig,
    seed: u64,
) -> Result<Simulation, ExperimentError> {
    simulate_with_samplers(
        &SamplerRegistry::builtin(),
        robot,
        terrain,
        sampler,
        runner,
        seed,
    )
}

/// Like [`simulate_with`] with the sampler taken from `samplers` (a registry holding a
/// researcher's own samplers, say).
pub fn simulate_with_samplers(
    samplers: &SamplerRegistry,
    robot: &RobotSpec,
    terrain: Terrain,
    sampler: &str,
    runner: RunnerConfig,
    seed: u64,
) -> Result<Simulation, ExperimentError> {
    let (r, b) = (robot.wheel_radius, robot.baseline);
    let vehicle = move || Box::new(DifferentialDrive::new(r, b)) as Box<dyn CommandModel>;
    let sampler_error = |reason| ExperimentError::Sampler {
        name: sampler.to_string(),
        reason,
    };
    // One way to build the sampler, over the nominal space here and the characterized one
    // inside the runner.
    let build = move |registry: &SamplerRegistry, name: &str, space, spec: &RobotSpec| {
        registry.build(
            name,
            &SamplerContext {
                space,
                robot: spec,
                vehicle: &vehicle,
                seed,
            },
        )
    };
    // Fail early on a name or limits that cannot work over the nominal input space.
    build(samplers, sampler, robot.input_space(), robot).map_err(sampler_error)?;
    // The sampler is built over the characterized space, inside the runner; an error there
    // is kept and returned after the run (the runner then holds still).
    let failure: Arc<Mutex<Option<SamplerError>>> = Arc::default();
    let (name, spec, slot, registry) = (
        sampler.to_string(),
        robot.clone(),
        failure.clone(),
        samplers.clone(),
    );
    let factory = move |space| match build(&registry, &name, space, &spec) {
        Ok(s) => s,
        Err(e) => {
            *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
            Box::new(HoldStill) as Box<dyn InputSampler>
        }
    };
    let config = SimulationConfig {
        name: format!("sim-{}-{}-{}-s{seed}", robot.name, terrain.name, sampler),
        robot: robot.clone(),
        terrain,
        seed,
        runner,
        events: Vec::new(),
    };
    let run = simulate(config, vehicle(), factory, None)?;
    let failed = failure.lock().unwrap_or_else(|p| p.into_inner()).take();
    match failed {
        Some(e) => Err(sampler_error(e)),
        None => Ok(run),
    }
}

/// Stands in for a sampler that could not be built.
struct HoldStill;

impl InputSampler for HoldStill {
    fn next_input(&mut self) -> Input {
        Input::zeros()
    }
}

/// The paper's Table I experiment, over any robots, terrains, samplers, driving times and
/// seeds.
#[derive(Debug, Clone)]
pub struct ProtocolStudy {
    /// Robots.
    pub robots: Vec<RobotSpec>,
    /// Terrains.
    pub terrains: Vec<Terrain>,
    /// Samplers compared; the first is the reference the improvements are measured for.
    pub samplers: Vec<String>,
    /// Driving time of each training run (s), characterization excluded.
    pub driving_s: Vec<f64>,
    /// Seeds: each seed is one repetition (training runs and test set).
    pub seeds: Vec<u64>,
    /// Driving time of the held-out test set (s), gathered with the reference sampler.
    pub test_driving_s: f64,
    /// Model trained on each run (a registered name, [`drive_models::MODEL_NAMES`]).
    pub model: String,
}

impl ProtocolStudy {
    /// The paper's comparison for one robot on one terrain: `uniform` (the reference),
    /// `linear` and `angular`, `driving_s` each, slip-BLR, a test set as long as the
    /// training runs, one seed.
    pub fn table_one(robot: RobotSpec, terrain: Terrain, driving_s: f64, seed: u64) -> Self {
        ProtocolStudy {
            robots: vec![robot],
            terrains: vec![terrain],
            samplers: ["uniform", "linear", "angular"].map(String::from).to_vec(),
            driving_s: vec![driving_s],
            seeds: vec![seed],
            test_driving_s: driving_s,
            model: "slip-blr".into(),
        }
    }

    /// The seed of the test set of repetition `seed`: a different stream from the training
    /// runs' (different noise and inputs), the same for every sampler.
    pub fn test_seed(seed: u64) -> u64 {
        seed ^ 0x7E57_5E7D_0000_0000
    }
}

/// One trained model's errors on the test set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProtocolCell {
    /// Robot name.
    pub robot: String,
    /// Terrain name.
    pub terrain: String,
    /// Training driving time (s).
    pub driving_s: f64,
    /// Sampler that gathered the training data.
    pub sampler: String,
    /// Repetition seed.
    pub seed: u64,
    /// Training windows.
    pub train_windows: usize,
    /// Test windows.
    pub test_windows: usize,
    /// Translational errors (m) on the test set (eq. 8).
    pub translational: Summary,
    /// Rotational errors (rad) on the test set (eq. 8).
    pub rotational: Summary,
}

/// One sampler's result for one robot, terrain and driving time, over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProtocolRow {
    /// Robot name.
    pub robot: String,
    /// Terrain name.
    pub terrain: String,
    /// Training driving time (s).
    pub driving_s: f64,
    /// Sampler.
    pub sampler: String,
    /// Median over the seeds of the median translational error (m).
    pub translational_median_m: f64,
    /// Median over the seeds of the median rotational error (rad).
    pub rotational_median_rad: f64,
    /// Improvement of the reference sampler over this one in translation (%), from the
    /// medians above; 0 for the reference itself.
    pub reference_improvement_translational_percent: f64,
    /// Improvement of the reference sampler over this one in rotation (%).
    pub reference_improvement_rotational_percent: f64,
    /// Seeds in which the reference had the lower median translational error.
    pub reference_wins_translational: usize,
    /// Seeds in which the reference had the lower median rotational error.
    pub reference_wins_rotational: usize,
    /// Seeds.
    pub seeds: usize,
}

/// What a [`ProtocolStudy`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProtocolComparison {
    /// Model trained.
    pub model: String,
    /// Reference sampler.
    pub reference: String,
    /// Test set driving time (s).
    pub test_driving_s: f64,
    /// Per sampler, over the seeds, in study order (robot, terrain, driving time, sampler).
    pub rows: Vec<ProtocolRow>,
    /// Every trained model, per seed.
    pub cells: Vec<ProtocolCell>,
}

/// Runs a [`ProtocolStudy`], in parallel over robots, terrains and seeds (rayon).
///
/// ```no_run
/// use drive_eval::{compare_protocols, ProtocolStudy};
/// use drive_samplers::RobotSpec;
/// use drive_sim::Terrain;
/// let study = ProtocolStudy::table_one(
///     RobotSpec::preset("husky").unwrap(), Terrain::preset("snow").unwrap(), 300.0, 1);
/// let table = compare_protocols(&study).unwrap();
/// for row in &table.rows {
///     println!("{}: {:.3} m", row.sampler, row.translational_median_m);
/// }
/// ```
pub fn compare_protocols(study: &ProtocolStudy) -> Result<ProtocolComparison, ExperimentError> {
    for (what, empty) in [
        ("robots", study.robots.is_empty()),
        ("terrains", study.terrains.is_empty()),
        ("samplers", study.samplers.is_empty()),
        ("driving times", study.driving_s.is_empty()),
        ("seeds", study.seeds.is_empty()),
    ] {
        if empty {
            return Err(ExperimentError::Empty(what));
        }
    }
    if !drive_models::MODEL_NAMES.contains(&study.model.as_str()) {
        return Err(ExperimentError::UnknownModel(study.model.clone()));
    }
    let test_intervals = intervals_in(study.test_driving_s)?;
    for d in &study.driving_s {
        intervals_in(*d)?;
    }
    let mut tasks = Vec::new();
    for robot in &study.robots {
        for terrain in &study.terrains {
            for seed in &study.seeds {
                tasks.push((robot, *terrain, *seed));
            }
        }
    }
    let per_task: Vec<Vec<ProtocolCell>> = tasks
        .par_iter()
        .map(|(robot, terrain, seed)| run_task(study, robot, *terrain, *seed, test_intervals))
        .collect::<Result<_, _>>()?;
    let cells: Vec<ProtocolCell> = per_task.into_iter().flatten().collect();
    let reference = &study.samplers[0];
    let mut rows = Vec::new();
    for robot in &study.robots {
        for terrain in &study.terrains {
            for &driving_s in &study.driving_s {
                let of = |sampler: &str| -> Vec<&ProtocolCell> {
                    cells
                        .iter()
                        .filter(|c| {
                            c.robot == robot.name
                                && c.terrain == terrain.name
                                && c.driving_s == driving_s
                                && c.sampler == sampler
                        })
                        .collect()
                };
                let base = of(reference);
                for sampler in &study.samplers {
                    let these = of(sampler);
                    rows.push(row(&base, &these, robot, terrain, driving_s, sampler));
                }
            }
        }
    }
    Ok(ProtocolComparison {
        model: study.model.clone(),
        reference: reference.clone(),
        test_driving_s: study.test_driving_s,
        rows,
        cells,
    })
}

/// One robot, terrain and seed: the test set, then every sampler and driving time.
fn run_task(
    study: &ProtocolStudy,
    robot: &RobotSpec,
    terrain: Terrain,
    seed: u64,
    test_intervals: usize,
) -> Result<Vec<ProtocolCell>, ExperimentError> {
    let reference = &study.samplers[0];
    let test = simulate_protocol(
        robot,
        terrain,
        reference,
        test_intervals,
        ProtocolStudy::test_seed(seed),
    )?
    .dataset;
    let mut cells = Vec::new();
    for &driving_s in &study.driving_s {
        let intervals = intervals_in(driving_s)?;
        for sampler in &study.samplers {
            let train = simulate_protocol(robot, terrain, sampler, intervals, seed)?.dataset;
            let (translational, rotational, _) =
                train_and_test(&study.model, &train.all(), &train.robot.name, &test.all())?;
            cells.push(ProtocolCell {
                robot: robot.name.clone(),
                terrain: terrain.name.to_string(),
                driving_s,
                sampler: sampler.clone(),
                seed,
                train_windows: train.windows.len(),
                test_windows: test.windows.len(),
                translational,
                rotational,
            });
        }
    }
    Ok(cells)
}

/// Fits `model` on `train` (`what` names it in errors) and scores it on every window of
/// `test`: the summaries of the translational and rotational errors (eq. 8) and every
/// window's errors.
pub(crate) fn train_and_test(
    model: &str,
    train: &WindowSet<'_>,
    what: &str,
    test: &WindowSet<'_>,
) -> Result<(Summary, Summary, Vec<Mrmse>), ExperimentError> {
    let fitted = fit_named(model, train)
        .ok_or_else(|| ExperimentError::UnknownModel(model.to_string()))?
        .map_err(|reason| ExperimentError::Fit {
            model: model.to_string(),
            data: what.to_string(),
            reason,
        })?;
    let report = evaluate_model(fitted.as_ref(), test);
    let empty = || ExperimentError::NotEnoughData(format!("no test window for {what}"));
    Ok((
        report.translational(None).ok_or_else(empty)?,
        report.rotational(None).ok_or_else(empty)?,
        report.windows.iter().map(|w| w.error).collect(),
    ))
}

/// The median of `values` (NaN when there are none).
pub(crate) fn median(values: impl IntoIterator<Item = f64>) -> f64 {
    Summary::of(values).map_or(f64::NAN, |s| s.median)
}

fn row(
    base: &[&ProtocolCell],
    these: &[&ProtocolCell],
    robot: &RobotSpec,
    terrain: &Terrain,
    driving_s: f64,
    sampler: &str,
) -> ProtocolRow {
    let t = median(these.iter().map(|c| c.translational.median));
    let r = median(these.iter().map(|c| c.rotational.median));
    let t_ref = median(base.iter().map(|c| c.translational.median));
    let r_ref = median(base.iter().map(|c| c.rotational.median));
    // Seeds pair the reference and this sampler (same test set).
    let wins = |metric: fn(&ProtocolCell) -> f64| {
        these
            .iter()
            .filter(|c| {
                base.iter()
                    .find(|b| b.seed == c.seed)
                    .is_some_and(|b| metric(b) < metric(c))
            })
            .count()
    };
    ProtocolRow {
        robot: robot.name.clone(),
        terrain: terrain.name.to_string(),
        driving_s,
        sampler: sampler.to_string(),
        translational_median_m: t,
        rotational_median_rad: r,
        reference_improvement_translational_percent: improvement_percent(t_ref, t),
        reference_improvement_rotational_percent: improvement_percent(r_ref, r),
        reference_wins_translational: wins(|c| c.translational.median),
        reference_wins_rotational: wins(|c| c.rotational.median),
        seeds: these.len(),
    }
}
