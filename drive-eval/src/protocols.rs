//! Data-gathering protocols compared on the simulator (the paper's Table I): equal driving
//! time with each sampler, one model trained on each, all evaluated on one common held-out
//! test set gathered with the reference sampler (DRIVE's `uniform`).

use crate::{
    improvement_percent, run_cells, simulate_run, simulate_runs, Registries, Setting, SimRun,
    Summary,
};
use drive_samplers::{RobotSpec, SamplerError};
use drive_sim::{SimError, Simulation, Terrain};
use drive_traits::limits;
use drive_traits::limits::Short;
use drive_traits::{FitError, RegistryError};
use serde::Serialize;
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
    /// A part's name is not registered (model, robot, terrain, ...).
    #[error(transparent)]
    Registry(#[from] RegistryError),
    /// A robot description is invalid.
    #[error("{0}")]
    Robot(String),
    /// A driving time shorter than one interval, or not finite.
    #[error("{}", too_short(*.0))]
    TooShort(f64),
    /// A size beyond its documented limit (see `drive_traits::limits`).
    #[error(transparent)]
    TooLarge(#[from] drive_traits::limits::TooLarge),
    /// The study lists nothing to run.
    #[error("the study has no {0}")]
    Empty(&'static str),
    /// A data set holds too few windows for the experiment.
    #[error("{0}")]
    NotEnoughData(String),
}

fn too_short(driving_s: f64) -> String {
    if driving_s.is_finite() {
        format!(
            "driving time {} s is shorter than one {INTERVAL_S} s DRIVE interval",
            Short(driving_s)
        )
    } else {
        format!("driving time {driving_s} s is not a finite number of seconds")
    }
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
/// with the registered sampler `sampler`; robot and terrain are registered names (or a robot
/// TOML file); the simulator's noise and the sampler are seeded with `seed`.
///
/// ```
/// use drive_eval::{simulate_protocol, Registries};
/// let run = simulate_protocol(&Registries::builtin(), "husky", "snow", "uniform", 2, 1).unwrap();
/// assert_eq!(run.dataset.windows.len(), 6);
/// ```
pub fn simulate_protocol(
    registries: &Registries,
    robot: &str,
    terrain: &str,
    sampler: &str,
    intervals: usize,
    seed: u64,
) -> Result<Simulation, ExperimentError> {
    let robot = registries
        .robot(robot)
        .map_err(|e| ExperimentError::Robot(e.to_string()))?;
    let terrain = registries.terrain(terrain)?;
    simulate_run(
        registries,
        &SimRun::intervals(&robot, &terrain, sampler, intervals, seed),
    )
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
    /// Model trained on each run (a model name: `slip-blr`, `slip-blr+rate-limited`, ...).
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

/// Runs a [`ProtocolStudy`] with the registered samplers and model: every simulation in
/// parallel, then every fit (the experiment engine).
///
/// ```no_run
/// use drive_eval::{compare_protocols, ProtocolStudy, Registries};
/// let r = Registries::builtin();
/// let study = ProtocolStudy::table_one(r.robot("husky").unwrap(), r.terrain("snow").unwrap(), 300.0, 1);
/// let table = compare_protocols(&r, &study).unwrap();
/// for row in &table.rows {
///     println!("{}: {:.3} m", row.sampler, row.translational_median_m);
/// }
/// ```
pub fn compare_protocols(
    registries: &Registries,
    study: &ProtocolStudy,
) -> Result<ProtocolComparison, ExperimentError> {
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
    limits::at_most(
        "seeds",
        study.seeds.len() as f64,
        limits::MAX_SEEDS as f64,
        "",
    )?;
    let runs = [
        study.robots.len(),
        study.terrains.len(),
        study.samplers.len(),
        study.driving_s.len(),
        study.seeds.len(),
    ]
    .iter()
    .map(|n| *n as f64)
    .product::<f64>();
    limits::at_most(
        "the study's runs (robots x terrains x samplers x durations x seeds)",
        runs,
        limits::MAX_COMBINATIONS as f64,
        "",
    )?;
    let model = registries.model(&study.model)?;
    for s in &study.samplers {
        registries.samplers.get(s)?;
    }
    let test_intervals = intervals_in(study.test_driving_s)?;
    for d in &study.driving_s {
        intervals_in(*d)?;
    }
    let reference = &study.samplers[0];
    // Per robot, terrain and seed: the test run, then every driving time and sampler.
    let mut runs = Vec::new();
    let mut tests = Vec::new();
    let mut trains = Vec::new();
    for robot in &study.robots {
        for terrain in &study.terrains {
            for &seed in &study.seeds {
                let test = runs.len();
                tests.push(test);
                runs.push(SimRun::intervals(
                    robot,
                    terrain,
                    reference,
                    test_intervals,
                    ProtocolStudy::test_seed(seed),
                ));
                for &driving_s in &study.driving_s {
                    for sampler in &study.samplers {
                        trains.push((runs.len(), test, robot, terrain, seed, driving_s, sampler));
                        runs.push(SimRun::intervals(
                            robot,
                            terrain,
                            sampler,
                            intervals_in(driving_s)?,
                            seed,
                        ));
                    }
                }
            }
        }
    }
    let sims = simulate_runs(registries, &runs, &|| {})?;
    let settings: Vec<Setting<'_>> = trains
        .iter()
        .map(|&(train, test, ..)| Setting {
            train: sims[train].dataset.all(),
            eval: sims[test].dataset.all(),
        })
        .collect();
    let scored = run_cells(&settings, std::slice::from_ref(&model), false, &|| {});
    let mut cells = Vec::new();
    for (cell, &(train, test, robot, terrain, seed, driving_s, sampler)) in
        scored.into_iter().zip(&trains)
    {
        let data = &sims[train].dataset;
        let report = cell.outcome.map_err(|reason| ExperimentError::Fit {
            model: model.name.clone(),
            data: data.robot.name.clone(),
            reason,
        })?;
        let empty =
            || ExperimentError::NotEnoughData(format!("no test window for {}", data.robot.name));
        cells.push(ProtocolCell {
            robot: robot.name.clone(),
            terrain: terrain.name.clone(),
            driving_s,
            sampler: sampler.clone(),
            seed,
            train_windows: data.windows.len(),
            test_windows: sims[test].dataset.windows.len(),
            translational: report.report.translational(None).ok_or_else(empty)?,
            rotational: report.report.rotational(None).ok_or_else(empty)?,
        });
    }
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
        model: model.name.clone(),
        reference: reference.clone(),
        test_driving_s: study.test_driving_s,
        rows,
        cells,
    })
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
        terrain: terrain.name.clone(),
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
