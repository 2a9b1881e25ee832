//! Data-gathering protocols compared on the simulator (the paper's Table I) as a
//! cross-evaluation: equal driving time with each sampler, one model trained on each, every
//! model tested on held-out runs driven by each protocol (and on their union), so that no
//! protocol is judged only on its own test distribution.

use crate::{simulate_run, simulate_runs, Registries, SimRun};
use drive_eval::{
    evaluate_model_from, paired_bootstrap, BootstrapConfig, Improvement, ModelReport, PairedErrors,
    Summary,
};
use drive_samplers::{RobotSpec, SamplerError};
use drive_sim::{SimError, Simulation, Terrain};
use drive_traits::limits;
use drive_traits::limits::Short;
use drive_traits::{FitError, RegistryError};
use rayon::prelude::*;
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
    /// A terrain file is invalid, or no terrain has that name.
    #[error(transparent)]
    Terrain(#[from] drive_sim::TerrainError),
    /// A twin could not be fitted on the data.
    #[error(transparent)]
    SimFit(#[from] drive_sim::SimFitError),
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
    /// Two inputs that cannot be compared (a prior of another vehicle, rate or window
    /// length than its target, or fitted on the target's own windows).
    #[error("{0}")]
    Incompatible(String),
    /// A simulated run is no driving data (the data checks' fatal finding): a robot or
    /// terrain file whose robot cannot move, or a protocol that commands nothing.
    #[error("simulated run {run}: {finding}; check the robot's and the terrain's values")]
    Unusable {
        /// The run's label.
        run: String,
        /// The finding and its check.
        finding: String,
    },
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
/// assert_eq!(drive_studies::intervals_in(30.0).unwrap(), 5);
/// assert_eq!(drive_studies::intervals_in(35.0).unwrap(), 5);
/// assert!(drive_studies::intervals_in(5.0).is_err());
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
/// use drive_studies::{simulate_protocol, Registries};
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

/// The paper's Table I experiment as a cross-evaluation, over any robots, terrains,
/// samplers, driving times and seeds: a model trained on each training sampler's run is
/// tested on held-out runs driven by each test sampler, and on their union (`mixed`).
#[derive(Debug, Clone)]
pub struct ProtocolStudy {
    /// Robots.
    pub robots: Vec<RobotSpec>,
    /// Terrains.
    pub terrains: Vec<Terrain>,
    /// Samplers the training runs are gathered with; the first is the reference the
    /// improvements are measured for.
    pub samplers: Vec<String>,
    /// Driving time of each training run (s), characterization excluded.
    pub driving_s: Vec<f64>,
    /// Seeds: each seed is one repetition (training runs and test runs).
    pub seeds: Vec<u64>,
    /// Samplers the held-out test runs are driven by (one test run each per seed).
    pub test_samplers: Vec<String>,
    /// Also test on the union of the test runs ([`MIXED`]), when there are several.
    pub mixed_test: bool,
    /// Driving time of each held-out test run (s).
    pub test_driving_s: f64,
    /// Model trained on each run (a model name: `slip-blr`, `slip-blr+rate-limited`, ...).
    pub model: String,
}

/// The name of the test set made of every test run of a seed together.
pub const MIXED: &str = "mixed";

impl ProtocolStudy {
    /// The paper's comparison for one robot on one terrain: `uniform` (the reference),
    /// `linear` and `angular`, `driving_s` each, slip-BLR, each tested on runs driven by
    /// the three and on their union, test runs as long as the training runs, one seed.
    pub fn table_one(robot: RobotSpec, terrain: Terrain, driving_s: f64, seed: u64) -> Self {
        let three = ["uniform", "linear", "angular"].map(String::from).to_vec();
        ProtocolStudy {
            robots: vec![robot],
            terrains: vec![terrain],
            samplers: three.clone(),
            driving_s: vec![driving_s],
            seeds: vec![seed],
            test_samplers: three,
            mixed_test: true,
            test_driving_s: driving_s,
            model: "slip-blr".into(),
        }
    }

    /// The seed of the test runs of repetition `seed`: a different stream from the
    /// training runs' (different noise and inputs), the same for every test sampler.
    pub fn test_seed(seed: u64) -> u64 {
        seed ^ 0x7E57_5E7D_0000_0000
    }

    /// The test sets: the test samplers, then [`MIXED`] when asked and there are several.
    pub fn test_sets(&self) -> Vec<String> {
        let mut sets = self.test_samplers.clone();
        if self.mixed_test && self.test_samplers.len() > 1 {
            sets.push(MIXED.to_string());
        }
        sets
    }
}

/// One trained model's errors on one test set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProtocolCell {
    /// Robot name.
    pub robot: String,
    /// Terrain name.
    pub terrain: String,
    /// Training driving time (s).
    pub driving_s: f64,
    /// Sampler that gathered the training data.
    pub train_sampler: String,
    /// Sampler that drove the test run ([`MIXED`]: every test run of the seed).
    pub test_sampler: String,
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
    /// Per test window: the test run (index in the study's test samplers), the interval,
    /// the translational and the rotational error; what the paired intervals resample.
    #[serde(skip)]
    pub errors: Vec<(usize, usize, f64, f64)>,
}

/// One training sampler's result on one test set, for one robot, terrain and driving
/// time, over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProtocolRow {
    /// Robot name.
    pub robot: String,
    /// Terrain name.
    pub terrain: String,
    /// Training driving time (s).
    pub driving_s: f64,
    /// Sampler that gathered the training data.
    pub train_sampler: String,
    /// Test set: a test sampler, or [`MIXED`].
    pub test_sampler: String,
    /// Median translational error (m) over every test window of every seed.
    pub translational_median_m: f64,
    /// Median rotational error (rad) over every test window of every seed.
    pub rotational_median_rad: f64,
    /// Improvement of the reference sampler over this one in translation (%): of the
    /// medians above, with a paired bootstrap interval (the same test intervals resampled
    /// for both, every seed's test runs); 0 for the reference itself.
    pub reference_improvement_translational: Improvement,
    /// The same in rotation.
    pub reference_improvement_rotational: Improvement,
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
    /// Test sets, in order (the test samplers, then [`MIXED`]).
    pub test_sets: Vec<String>,
    /// Driving time of each test run (s).
    pub test_driving_s: f64,
    /// Per training sampler and test set, over the seeds, in study order (robot,
    /// terrain, driving time, test set, training sampler).
    pub rows: Vec<ProtocolRow>,
    /// Every trained model on every test set, per seed.
    pub cells: Vec<ProtocolCell>,
    /// The simulator each robot ran on, in the study's robot order.
    pub simulators: Vec<RobotSimulator>,
}

/// The simulator a robot of a study ran on.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RobotSimulator {
    /// The robot.
    pub robot: String,
    /// Its simulator (the one registered for its vehicle type, or the kinematic stand-in).
    pub simulator: drive_sim::SimulatorUsed,
}

/// Which training sampler trains the best model (lowest median error) on each test set, per
/// robot, terrain and driving time of a [`ProtocolComparison`], and how often each wins:
/// Table I's win counts ([`ProtocolComparison::winners`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProtocolWinners {
    /// Per robot, terrain and driving time, in the table's order.
    pub blocks: Vec<WinnerBlock>,
    /// Per test set and training sampler, its wins over the blocks, ordered by test set
    /// then sampler name; samplers that never win are absent.
    pub wins: Vec<WinCount>,
}

/// The best training samplers of one robot, terrain and driving time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WinnerBlock {
    /// Robot.
    pub robot: String,
    /// Terrain (or twin).
    pub terrain: String,
    /// Training driving time (s).
    pub driving_s: f64,
    /// On each test set, in the table's order.
    pub best: Vec<BestOnTest>,
}

/// The training samplers with the lowest median errors on one test set (`-` when the test
/// set has no row).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BestOnTest {
    /// Test set.
    pub test_sampler: String,
    /// Lowest translational median.
    pub translational: String,
    /// Lowest rotational median.
    pub rotational: String,
}

/// How often a training sampler is the best on a test set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WinCount {
    /// Test set.
    pub test_sampler: String,
    /// Training sampler.
    pub train_sampler: String,
    /// Blocks where its translational median is the lowest.
    pub translational: usize,
    /// Blocks where its rotational median is the lowest.
    pub rotational: usize,
}

impl ProtocolComparison {
    /// The best training sampler on each test set per robot, terrain and driving time (the
    /// first in row order on a tie), and the wins of each.
    ///
    /// ```
    /// use drive_studies::ProtocolComparison;
    /// let t = ProtocolComparison { model: "slip-blr".into(), reference: "uniform".into(), test_sets: vec![], test_driving_s: 60.0, rows: vec![], cells: vec![], simulators: vec![] };
    /// assert!(t.winners().blocks.is_empty() && t.winners().wins.is_empty());
    /// ```
    pub fn winners(&self) -> ProtocolWinners {
        let mut keys: Vec<(&str, &str, f64)> = Vec::new();
        for r in &self.rows {
            let key = (r.robot.as_str(), r.terrain.as_str(), r.driving_s);
            if !keys.contains(&key) {
                keys.push(key);
            }
        }
        let mut wins: std::collections::BTreeMap<(String, String), [usize; 2]> = Default::default();
        let mut blocks = Vec::new();
        for &(robot, terrain, d) in &keys {
            let mut best = Vec::new();
            for test in &self.test_sets {
                let rows: Vec<&ProtocolRow> = self
                    .rows
                    .iter()
                    .filter(|r| {
                        (r.robot.as_str(), r.terrain.as_str(), r.driving_s) == (robot, terrain, d)
                            && &r.test_sampler == test
                    })
                    .collect();
                let lowest = |f: fn(&ProtocolRow) -> f64| {
                    rows.iter()
                        .min_by(|a, b| f(a).total_cmp(&f(b)))
                        .map_or("-", |r| r.train_sampler.as_str())
                        .to_string()
                };
                let (t, r) = (
                    lowest(|r| r.translational_median_m),
                    lowest(|r| r.rotational_median_rad),
                );
                wins.entry((test.clone(), t.clone())).or_default()[0] += 1;
                wins.entry((test.clone(), r.clone())).or_default()[1] += 1;
                best.push(BestOnTest {
                    test_sampler: test.clone(),
                    translational: t,
                    rotational: r,
                });
            }
            blocks.push(WinnerBlock {
                robot: robot.to_string(),
                terrain: terrain.to_string(),
                driving_s: d,
                best,
            });
        }
        ProtocolWinners {
            blocks,
            wins: wins
                .into_iter()
                .map(|((test_sampler, train_sampler), [t, r])| WinCount {
                    test_sampler,
                    train_sampler,
                    translational: t,
                    rotational: r,
                })
                .collect(),
        }
    }
}

/// Runs a [`ProtocolStudy`] with the registered samplers and model: every simulation in
/// parallel, then every fit, then every test.
///
/// ```no_run
/// use drive_studies::{compare_protocols, ProtocolStudy, Registries};
/// let r = Registries::builtin();
/// let study = ProtocolStudy::table_one(r.robot("husky").unwrap(), r.terrain("snow").unwrap(), 300.0, 1);
/// let table = compare_protocols(&r, &study).unwrap();
/// for row in &table.rows {
///     println!("{} on {}: {:.3} m", row.train_sampler, row.test_sampler, row.translational_median_m);
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
        ("test samplers", study.test_samplers.is_empty()),
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
    let n = |v: usize| v as f64;
    let runs = n(study.robots.len())
        * n(study.terrains.len())
        * n(study.seeds.len())
        * (n(study.samplers.len()) * n(study.driving_s.len()) + n(study.test_samplers.len()));
    limits::at_most(
        "the study's runs (robots x terrains x seeds x (samplers x durations + test samplers))",
        runs,
        limits::MAX_COMBINATIONS as f64,
        "",
    )?;
    let spec = registries.model(&study.model)?;
    for s in study.samplers.iter().chain(&study.test_samplers) {
        registries.samplers.get(s)?;
    }
    let test_intervals = intervals_in(study.test_driving_s)?;
    for d in &study.driving_s {
        intervals_in(*d)?;
    }
    let reference = &study.samplers[0];
    // Per robot, terrain and seed: the test runs, then every driving time and sampler.
    let mut runs = Vec::new();
    let mut trains = Vec::new();
    for robot in &study.robots {
        for terrain in &study.terrains {
            for &seed in &study.seeds {
                let tests = runs.len();
                for sampler in &study.test_samplers {
                    runs.push(SimRun::intervals(
                        robot,
                        terrain,
                        sampler,
                        test_intervals,
                        ProtocolStudy::test_seed(seed),
                    ));
                }
                for &driving_s in &study.driving_s {
                    for sampler in &study.samplers {
                        trains.push((runs.len(), tests, robot, terrain, seed, driving_s, sampler));
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
    let fitted: Vec<_> = trains
        .par_iter()
        .map(|&(train, ..)| spec.fit(&sims[train].dataset.all()))
        .collect();
    let n_tests = study.test_samplers.len();
    // Every fitted model on every test run.
    let plan: Vec<(usize, usize)> = (0..trains.len())
        .flat_map(|t| (0..n_tests).map(move |k| (t, k)))
        .collect();
    let tested: Vec<Option<ModelReport>> = plan
        .par_iter()
        .map(|&(t, k)| {
            let model = fitted[t].as_ref().ok()?;
            let test = &sims[trains[t].1 + k].dataset;
            Some(evaluate_model_from(model.as_ref(), &test.all(), spec.start))
        })
        .collect();
    let mut cells = Vec::new();
    for (t, &(train, tests, robot, terrain, seed, driving_s, sampler)) in trains.iter().enumerate()
    {
        let data = &sims[train].dataset;
        if let Err(reason) = &fitted[t] {
            return Err(ExperimentError::Fit {
                model: spec.name.clone(),
                data: data.robot.name.clone(),
                reason: reason.clone(),
            });
        }
        let reports = &tested[t * n_tests..(t + 1) * n_tests];
        let mut sets: Vec<(String, Vec<usize>)> = study
            .test_samplers
            .iter()
            .enumerate()
            .map(|(k, s)| (s.clone(), vec![k]))
            .collect();
        if study.mixed_test && n_tests > 1 {
            sets.push((MIXED.to_string(), (0..n_tests).collect()));
        }
        for (name, members) in sets {
            let errors: Vec<(usize, usize, f64, f64)> = members
                .iter()
                .flat_map(|&k| {
                    reports[k].iter().flat_map(move |r| {
                        r.windows.iter().map(move |w| {
                            (k, w.interval, w.error.translational, w.error.rotational)
                        })
                    })
                })
                .collect();
            let empty = || {
                ExperimentError::NotEnoughData(format!(
                    "no test window in the {name} test run of {}",
                    data.robot.name
                ))
            };
            let translational = Summary::of(errors.iter().map(|e| e.2)).ok_or_else(empty)?;
            let rotational = Summary::of(errors.iter().map(|e| e.3)).ok_or_else(empty)?;
            cells.push(ProtocolCell {
                robot: robot.name.clone(),
                terrain: terrain.name.clone(),
                driving_s,
                train_sampler: sampler.clone(),
                test_sampler: name,
                seed,
                train_windows: data.windows.len(),
                test_windows: members
                    .iter()
                    .map(|&k| sims[tests + k].dataset.windows.len())
                    .sum(),
                translational,
                rotational,
                errors,
            });
        }
    }
    let test_sets = study.test_sets();
    let mut groups = Vec::new();
    for robot in &study.robots {
        for terrain in &study.terrains {
            for &driving_s in &study.driving_s {
                for test in &test_sets {
                    for sampler in &study.samplers {
                        groups.push((robot, terrain, driving_s, test, sampler));
                    }
                }
            }
        }
    }
    let rows: Vec<ProtocolRow> = groups
        .par_iter()
        .map(|&(robot, terrain, driving_s, test, sampler)| {
            let of = |train: &str| -> Vec<&ProtocolCell> {
                cells
                    .iter()
                    .filter(|c| {
                        c.robot == robot.name
                            && c.terrain == terrain.name
                            && c.driving_s == driving_s
                            && c.test_sampler == *test
                            && c.train_sampler == train
                    })
                    .collect()
            };
            row(
                &of(reference),
                &of(sampler),
                (robot, terrain, driving_s, test, sampler),
            )
        })
        .collect();
    Ok(ProtocolComparison {
        model: spec.name.clone(),
        reference: reference.clone(),
        test_sets,
        test_driving_s: study.test_driving_s,
        rows,
        cells,
        simulators: study
            .robots
            .iter()
            .map(|r| RobotSimulator {
                robot: r.name.clone(),
                simulator: drive_sim::simulator_used(&registries.simulators, r),
            })
            .collect(),
    })
}

/// The median of `values` ([`drive_traits::median`]'s, through the summary), NaN when there
/// are none.
pub(crate) fn median_or_nan(values: impl IntoIterator<Item = f64>) -> f64 {
    Summary::of(values).map_or(f64::NAN, |s| s.median)
}

fn row(
    base: &[&ProtocolCell],
    these: &[&ProtocolCell],
    (robot, terrain, driving_s, test, sampler): (&RobotSpec, &Terrain, f64, &String, &String),
) -> ProtocolRow {
    let pooled = |cells: &[&ProtocolCell], pick: fn(&(usize, usize, f64, f64)) -> f64| {
        median_or_nan(cells.iter().flat_map(|c| c.errors.iter().map(pick)))
    };
    // Paired by seed and test run: the reference and this sampler's models on the same
    // test windows, whole intervals resampled.
    let improvement = |pick: fn(&(usize, usize, f64, f64)) -> f64, salt: u64| {
        let mut series: Vec<(Vec<f64>, Vec<f64>, Vec<usize>)> = Vec::new();
        for c in these {
            let Some(b) = base.iter().find(|b| b.seed == c.seed) else {
                continue;
            };
            let runs: std::collections::BTreeSet<usize> = c.errors.iter().map(|e| e.0).collect();
            for k in runs {
                let mine: Vec<&(usize, usize, f64, f64)> =
                    c.errors.iter().filter(|e| e.0 == k).collect();
                let theirs: Vec<&(usize, usize, f64, f64)> =
                    b.errors.iter().filter(|e| e.0 == k).collect();
                series.push((
                    theirs.iter().map(|e| pick(e)).collect(),
                    mine.iter().map(|e| pick(e)).collect(),
                    mine.iter().map(|e| e.1).collect(),
                ));
            }
        }
        let paired: Vec<PairedErrors<'_>> = series
            .iter()
            .map(|(model, reference, blocks)| PairedErrors {
                model,
                reference,
                blocks: Some(blocks),
            })
            .collect();
        let config = BootstrapConfig::default();
        paired_bootstrap(&paired, &config, config.seed ^ salt)
    };
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
        train_sampler: sampler.clone(),
        test_sampler: test.clone(),
        translational_median_m: pooled(these, |e| e.2),
        rotational_median_rad: pooled(these, |e| e.3),
        reference_improvement_translational: improvement(|e| e.2, 0),
        reference_improvement_rotational: improvement(|e| e.3, 1 << 63),
        reference_wins_translational: wins(|c| c.translational.median),
        reference_wins_rotational: wins(|c| c.rotational.median),
        seeds: these.len(),
    }
}
