//! The twin check: does a twin (`drive sim-fit`) drive like the real run it was fitted on?
//! The real run and runs of the twin (as long as the real one, one per seed, given the real
//! run's own commands or fresh draws of its protocol: [`CheckCommands`]) are each split in
//! halves, the same models fitted on the first and scored with eq. 8 on the second; the
//! medians of the real run against those of the twin's runs pooled, and the steady
//! windows' scatter of both.

use crate::{ExperimentError, Registries, SimRun};
use drive_eval::{median_interval, quantile, split_by_interval, BootstrapConfig};
use drive_models::{DifferentialDrive, ModelSpec};
use drive_samplers::{ReplaySampler, RobotSpec, RunnerConfig};
use drive_sim::{SimulationConfig, Terrain};
use drive_traits::UnknownName;
use drive_traits::{vehicle_as, Dataset, FitError, Input, InputSampler, WindowSet};
use rayon::prelude::*;
use serde::Serialize;

/// The models of the twin check: the manufacturer's, the powertrain's, the paper's and the
/// nonlinear slip.
pub const TWIN_CHECK_MODELS: [&str; 4] = ["naive", "powertrain", "slip-blr", "slip-ipem"];

/// How far a twin's median may be from the real one (30%).
pub const TWIN_TOLERANCE: f64 = 0.30;

/// Seeds of the twin's runs that decide whether a fitted twin keeps its variability
/// ([`choose_variability`]): apart from the check's own seeds (1, 2, ...), so that the check
/// printed after the choice does not score the very runs that chose.
pub const VARIABILITY_CHOICE_SEEDS: [u64; 2] = [1_000_001, 1_000_002];

/// How much closer (points of the mean distance, [`CheckDistance`]) a twin with another
/// contact spread must come to the real run's medians than the vehicle's own spread for
/// [`fit_twin`] to keep it, at as many medians beyond the tolerance: the mean distance
/// moves by about that between runs of other seeds (on the paper's Warthog run's twin,
/// 13.8% on the choice's two seeds, 15.5% on the check's three), so a smaller gain is
/// noise, and the vehicle's geometry stays.
pub const CONTACT_SPREAD_MARGIN: f64 = 2.0;

/// What the twin's runs of a check are commanded.
///
/// ```
/// use drive_studies::CheckCommands;
/// assert_eq!(CheckCommands::parse("draw"), Ok(CheckCommands::Draw));
/// assert_eq!(CheckCommands::default().as_str(), "replay");
/// assert!(CheckCommands::parse("fresh").unwrap_err().contains("replay"));
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CheckCommands {
    /// The real run's commands, interval by interval in their order
    /// ([`drive_samplers::ReplaySampler`]): twin and robot compared on the same inputs, so
    /// that a difference is the twin's and not that of the commands drawn (the seeds vary
    /// the twin's noise and variability only).
    #[default]
    Replay,
    /// Fresh draws of the twin's protocol, one sequence per seed (as `drive simulate` runs
    /// the twin): the comparison then also carries the real run's luck in its draws.
    Draw,
}

impl CheckCommands {
    /// From its name, `replay` or `draw`.
    pub fn parse(name: &str) -> Result<Self, UnknownName> {
        match name {
            "replay" => Ok(CheckCommands::Replay),
            "draw" => Ok(CheckCommands::Draw),
            other => Err(UnknownName::from(format!(
                "unknown check commands '{other}' (replay: the real run's commands; draw: fresh draws of the twin's protocol)"
            ))),
        }
    }

    /// Its name.
    pub fn as_str(self) -> &'static str {
        match self {
            CheckCommands::Replay => "replay",
            CheckCommands::Draw => "draw",
        }
    }
}

/// One model's medians on the real run and on the twin's runs (pooled).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TwinCheckRow {
    /// The model.
    pub model: String,
    /// Median translational error (eq. 8) over the real run's evaluation windows (m).
    pub real_translational_m: f64,
    /// The same over the twin's runs' evaluation windows, pooled (m).
    pub twin_translational_m: f64,
    /// The 95% bootstrap interval of `real_translational_m` ([`median_interval`]: the
    /// real run's evaluation intervals resampled whole, 1000 times): how precisely one run
    /// pins its median down, how far it could have fallen with other commands drawn (m).
    pub real_translational_ci_m: [f64; 2],
    /// Median rotational error over the real run's evaluation windows (rad).
    pub real_rotational_rad: f64,
    /// Median rotational error over the twin's runs' evaluation windows, pooled (rad).
    pub twin_rotational_rad: f64,
    /// The 95% bootstrap interval of `real_rotational_rad`, as `real_translational_ci_m`'s
    /// (rad).
    pub real_rotational_ci_rad: [f64; 2],
    /// `100 (twin - real) / real`, translational.
    pub translational_off_percent: f64,
    /// `100 (twin - real) / real`, rotational.
    pub rotational_off_percent: f64,
}

/// A scatter of the steady windows, forward speed (m/s) and yaw rate (rad/s), real against
/// twin: the body velocity around a smooth function of the wheel speeds
/// (`drive_sim::scatter`, [`TwinCheck::scatter`]) or the wheel speeds around a smooth
/// function of the commands (`drive_sim::command_scatter`, [`TwinCheck::command_scatter`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScatterCheck {
    /// The real run's.
    pub real: [f64; 2],
    /// The twin's runs', pooled (their mean).
    pub twin: [f64; 2],
}

/// What the twin check found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TwinCheck {
    /// Seeds of the twin's runs.
    pub seeds: Vec<u64>,
    /// What the twin's runs were commanded.
    pub commands: CheckCommands,
    /// Evaluation windows of the real run and of the twin's runs together.
    pub windows: [usize; 2],
    /// Per model.
    pub check: Vec<TwinCheckRow>,
    /// The steady scatter, when both have at least 30 steady windows.
    pub scatter: Option<ScatterCheck>,
    /// How consistently the wheels follow the commands (`drive_sim::command_scatter`: the
    /// steady windows' wheel speeds around a smooth function of their commands), when both
    /// have at least 30 steady windows. Reported: a real powertrain that stalls under load
    /// on some commands and not on others like them, which a twin's does not, shows here.
    pub command_scatter: Option<ScatterCheck>,
    /// How much of the commanded forward speed (driving nearly straight) and yaw rate
    /// (turning) the body keeps on held commands (`drive_sim::speeds_kept`: medians over
    /// the steady windows, body over commanded), when both have enough such windows.
    /// Reported: a twin can hold the models' median errors while keeping half the real
    /// run's speed.
    pub speed_kept: Option<ScatterCheck>,
    /// The tolerance of `poor` (a fraction: 0.3 is 30%).
    pub tolerance: f64,
    /// Every median further than the tolerance from the real one, in words: what makes a
    /// poor twin.
    pub poor: Vec<String>,
    /// The steady scatter where it is further than the tolerance from the real one, in
    /// words (reported; it does not make a poor twin alone).
    pub scatter_off: Vec<String>,
    /// The same of `command_scatter` (reported; it does not make a poor twin alone).
    pub command_scatter_off: Vec<String>,
    /// The same of `speed_kept` (reported; it does not make a poor twin alone).
    pub speed_kept_off: Vec<String>,
}

/// Runs the twin check of `twin`, fitted on `data` for `robot`, with `seeds` twin runs
/// commanded as `commands` says and the models `models` (each fitted with its own
/// uncertainty: medians do not depend on the calibration).
///
/// ```no_run
/// use drive_studies::{twin_check, CheckCommands, Registries, TWIN_CHECK_MODELS};
/// let r = Registries::builtin();
/// let data = drive_data::read_dataset("run.csv".as_ref(), None).unwrap();
/// let robot = r.robot("husky").unwrap();
/// let twin = r.terrain("twin.toml").unwrap();
/// let models = r.models().resolve_list(&TWIN_CHECK_MODELS).unwrap();
/// let check = twin_check(&r, &data, &robot, &twin, &[1, 2, 3], &models, CheckCommands::Replay)
///     .unwrap();
/// for p in &check.poor { println!("{p}"); }
/// ```
pub fn twin_check(
    registries: &Registries,
    data: &Dataset,
    robot: &RobotSpec,
    twin: &Terrain,
    seeds: &[u64],
    models: &[ModelSpec],
    commands: CheckCommands,
) -> Result<TwinCheck, ExperimentError> {
    if seeds.is_empty() {
        return Err(ExperimentError::Empty("seeds"));
    }
    if models.is_empty() {
        return Err(ExperimentError::Empty("models"));
    }
    let intervals = data.interval_count();
    let runs: Vec<SimRun> = seeds
        .iter()
        .map(|&seed| SimRun {
            robot: robot.clone(),
            terrain: twin.clone(),
            // The twin draws what its real run drew (its protocol wraps the sampler).
            sampler: "uniform".into(),
            runner: RunnerConfig {
                max_intervals: Some(intervals.max(2)),
                ..RunnerConfig::default()
            },
            seed,
        })
        .collect();
    let recorded = ReplaySampler::interval_commands(&data.windows);
    let simulated: Vec<Dataset> = runs
        .par_iter()
        .map(|run| match commands {
            CheckCommands::Draw => crate::simulate_run(registries, run).map(|s| s.dataset),
            CheckCommands::Replay => replay_run(registries, run, &recorded),
        })
        .collect::<Result<_, _>>()?;
    // Every (dataset, model) cell: the real run first.
    let sets: Vec<&Dataset> = std::iter::once(data).chain(simulated.iter()).collect();
    let cells: Vec<(usize, usize)> = (0..sets.len())
        .flat_map(|d| (0..models.len()).map(move |m| (d, m)))
        .collect();
    let errors: Vec<Vec<WindowError>> = cells
        .par_iter()
        .map(|&(d, m)| window_errors(sets[d], &models[m]))
        .collect::<Result<_, _>>()?;
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        quantile(v, 0.5).unwrap_or(f64::NAN)
    };
    let mut check = Vec::new();
    let mut windows = [0, 0];
    for (m, spec) in models.iter().enumerate() {
        let of = |d: usize| &errors[d * models.len() + m];
        let (mut rt, mut rr): (Vec<f64>, Vec<f64>) =
            of(0).iter().map(|e| (e.error[0], e.error[1])).unzip();
        let blocks: Vec<usize> = of(0).iter().map(|e| e.interval).collect();
        // Seed 0, as `drive eval`'s intervals; one draw for both errors.
        let interval_of =
            |errors: &[f64]| median_interval(errors, Some(&blocks), &BootstrapConfig::default(), 0);
        let (real_t_ci, real_r_ci) = (interval_of(&rt), interval_of(&rr));
        let (mut tt, mut tr): (Vec<f64>, Vec<f64>) = (1..sets.len())
            .flat_map(|d| of(d).iter().map(|e| (e.error[0], e.error[1])))
            .unzip();
        windows = [rt.len(), tt.len()];
        let (real_t, real_r, twin_t, twin_r) = (
            median(&mut rt),
            median(&mut rr),
            median(&mut tt),
            median(&mut tr),
        );
        let off = |twin: f64, real: f64| 100.0 * (twin - real) / real;
        check.push(TwinCheckRow {
            model: spec.name.clone(),
            real_translational_m: real_t,
            real_translational_ci_m: real_t_ci,
            twin_translational_m: twin_t,
            real_rotational_rad: real_r,
            real_rotational_ci_rad: real_r_ci,
            twin_rotational_rad: twin_r,
            translational_off_percent: off(twin_t, real_t),
            rotational_off_percent: off(twin_r, real_r),
        });
    }
    let geometry = vehicle_as::<DifferentialDrive>(data.robot.vehicle.as_ref());
    let scatter = geometry.as_ref().and_then(|g| {
        pooled_check(data, &simulated, |d| {
            drive_sim::scatter(d, g).map(|s| s.rms)
        })
    });
    let command_scatter = geometry
        .as_ref()
        .and_then(|g| pooled_check(data, &simulated, |d| drive_sim::command_scatter(d, g)));
    let speed_kept = geometry
        .as_ref()
        .and_then(|g| pooled_check(data, &simulated, |d| drive_sim::speeds_kept(d, g)));
    let poor = poor_twin(&check, TWIN_TOLERANCE);
    let scatter_off = scatter.map_or_else(Vec::new, |s| {
        let what = ["steady forward-speed scatter", "steady yaw-rate scatter"];
        scatters_off(&s, what, TWIN_TOLERANCE)
    });
    let command_scatter_off = command_scatter.map_or_else(Vec::new, |s| {
        let what = [
            "wheels' forward-speed scatter around the commands",
            "wheels' yaw-rate scatter around the commands",
        ];
        scatters_off(&s, what, TWIN_TOLERANCE)
    });
    let speed_kept_off = speed_kept.map_or_else(Vec::new, |s| {
        let mut out = Vec::new();
        for (axis, what) in [
            "forward speed kept driving nearly straight (body over commanded)",
            "yaw rate kept turning (body over commanded)",
        ]
        .iter()
        .enumerate()
        {
            off_by(
                &mut out,
                what.to_string(),
                s.twin[axis],
                (s.real[axis], None),
                "of the commanded",
                TWIN_TOLERANCE,
            );
        }
        out
    });
    Ok(TwinCheck {
        seeds: seeds.to_vec(),
        commands,
        windows,
        check,
        scatter,
        command_scatter,
        tolerance: TWIN_TOLERANCE,
        poor,
        scatter_off,
        command_scatter_off,
        speed_kept,
        speed_kept_off,
    })
}

/// A statistic of the real run against its mean over the twin's runs; `None` where the real
/// run or every twin run has none.
fn pooled_check(
    data: &Dataset,
    simulated: &[Dataset],
    statistic: impl Fn(&Dataset) -> Option<[f64; 2]>,
) -> Option<ScatterCheck> {
    let real = statistic(data)?;
    let twins: Vec<[f64; 2]> = simulated.iter().filter_map(&statistic).collect();
    if twins.is_empty() {
        return None;
    }
    let n = twins.len() as f64;
    Some(ScatterCheck {
        real,
        twin: [
            twins.iter().map(|t| t[0]).sum::<f64>() / n,
            twins.iter().map(|t| t[1]).sum::<f64>() / n,
        ],
    })
}

/// `run` with the recorded commands `recorded` held in their order instead of its sampler's
/// draws, one interval each. A twin's protocol maps what a sampler draws in the protocol's
/// geometry to the recorded commands ([`drive_sim::ProtocolSampler`]): the commands are
/// given to it mapped back, and its rectangle of body velocities (which redraws inputs
/// outside it) is not applied, so that every interval holds the command the real one held.
/// Without a protocol the commands are held as recorded (every input axis).
fn replay_run(
    registries: &Registries,
    run: &SimRun,
    recorded: &[Input],
) -> Result<Dataset, ExperimentError> {
    let mut terrain = run.terrain.clone();
    let commands = drive_sim::replay_commands(&mut terrain, &run.robot, recorded);
    let sampler = ReplaySampler::new(commands).ok_or_else(|| {
        ExperimentError::NotEnoughData("the twin check: the real run has no command".into())
    })?;
    let config = SimulationConfig {
        name: SimRun {
            sampler: "replay".into(),
            ..run.clone()
        }
        .label(),
        robot: run.robot.clone(),
        terrain,
        seed: run.seed,
        // As many intervals as commands: the two runs' evaluation halves hold the same ones.
        runner: RunnerConfig {
            max_intervals: Some(recorded.len().max(2)),
            ..run.runner.clone()
        },
        events: Vec::new(),
    };
    let label = config.name.clone();
    let factory = move |_| Box::new(sampler.clone()) as Box<dyn InputSampler>;
    let dataset = drive_sim::simulate(config, &registries.simulators, factory, None)?.dataset;
    crate::experiment::usable(&label, &dataset)?;
    Ok(dataset)
}

/// One evaluation window's translational and rotational errors (eq. 8) and its interval.
struct WindowError {
    error: [f64; 2],
    interval: usize,
}

/// The translational and rotational errors (eq. 8) of `spec`, fitted on the first half of
/// `data`'s intervals, over the windows of the second half.
fn window_errors(data: &Dataset, spec: &ModelSpec) -> Result<Vec<WindowError>, ExperimentError> {
    let (train, eval) = split_by_interval(data, 0.5).map_err(|e| {
        ExperimentError::NotEnoughData(format!("the twin check on {}: {e}", data.robot.name))
    })?;
    let fit = |train: &WindowSet<'_>| -> Result<_, FitError> { spec.fit_uncalibrated(train) };
    let model = fit(&train).map_err(|reason| ExperimentError::Fit {
        model: spec.name.clone(),
        data: data.robot.name.clone(),
        reason,
    })?;
    let report = drive_eval::evaluate_errors(model.as_ref(), &eval, spec.start);
    Ok(report
        .windows
        .iter()
        .map(|w| WindowError {
            error: [w.error.translational, w.error.rotational],
            interval: w.interval,
        })
        .collect())
}

/// The medians further than `tolerance` (a fraction) from the real ones, in words, each with
/// the real median's bootstrap interval (how precisely the real run pins it down; with the
/// real commands replayed the twin shares them, so a twin median inside it is a weak sign,
/// not a proof, that the miss is the run's sampling).
///
/// ```
/// use drive_studies::{poor_twin, TwinCheckRow};
/// let row = TwinCheckRow { model: "slip-blr".into(), real_translational_m: 0.10,
///     real_translational_ci_m: [0.09, 0.11], twin_translational_m: 0.12,
///     real_rotational_rad: 0.10, real_rotational_ci_rad: [0.08, 0.13],
///     twin_rotational_rad: 0.21, translational_off_percent: 20.0,
///     rotational_off_percent: 110.0 };
/// let poor = poor_twin(&[row], 0.3);
/// assert_eq!(poor, ["slip-blr rotational median +110% (twin 0.2100 rad against the real run's \
///     0.1000, whose 95% interval is [0.0800, 0.1300])"]);
/// ```
pub fn poor_twin(check: &[TwinCheckRow], tolerance: f64) -> Vec<String> {
    let mut out = Vec::new();
    for r in check {
        off_by(
            &mut out,
            format!("{} translational median", r.model),
            r.twin_translational_m,
            (r.real_translational_m, Some(r.real_translational_ci_m)),
            "m",
            tolerance,
        );
        off_by(
            &mut out,
            format!("{} rotational median", r.model),
            r.twin_rotational_rad,
            (r.real_rotational_rad, Some(r.real_rotational_ci_rad)),
            "rad",
            tolerance,
        );
    }
    out
}

/// The scatters (forward speed, yaw rate: `what`) further than `tolerance` from the real
/// ones, in words.
fn scatters_off(s: &ScatterCheck, what: [&str; 2], tolerance: f64) -> Vec<String> {
    let mut out = Vec::new();
    for (axis, unit) in [(0, "m/s"), (1, "rad/s")] {
        off_by(
            &mut out,
            what[axis].into(),
            s.twin[axis],
            (s.real[axis], None),
            unit,
            tolerance,
        );
    }
    out
}

/// Adds `what` to `out` when `twin` is further than `tolerance` (a fraction) from `real`
/// (or not a number); `real` comes with its interval where it has one.
fn off_by(
    out: &mut Vec<String>,
    what: String,
    twin: f64,
    (real, interval): (f64, Option<[f64; 2]>),
    unit: &str,
    tolerance: f64,
) {
    let off = (twin - real) / real;
    if off.is_nan() || off.abs() > tolerance {
        let interval = interval.map_or_else(String::new, |[lo, hi]| {
            format!(", whose 95% interval is [{lo:.4}, {hi:.4}]")
        });
        out.push(format!(
            "{what} {:+.0}% (twin {twin:.4} {unit} against the real run's {real:.4}{interval})",
            100.0 * off
        ));
    }
}

/// How far one twin's medians are from the real run's in a check.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CheckDistance {
    /// The mean distance of the medians (translational and rotational, every model), in
    /// percent of the real ones.
    pub mean_off_percent: f64,
    /// How many of them are further than [`TWIN_TOLERANCE`].
    pub beyond_tolerance: usize,
}

impl CheckDistance {
    /// The distance of a check's medians.
    ///
    /// ```
    /// use drive_studies::{CheckDistance, TwinCheckRow};
    /// let row = |t: f64, r: f64| TwinCheckRow { model: "m".into(), real_translational_m: 1.0,
    ///     real_translational_ci_m: [0.9, 1.1], twin_translational_m: 1.0 + t / 100.0,
    ///     real_rotational_rad: 1.0, real_rotational_ci_rad: [0.9, 1.1],
    ///     twin_rotational_rad: 1.0 + r / 100.0, translational_off_percent: t,
    ///     rotational_off_percent: r };
    /// let d = CheckDistance::of(&[row(10.0, -40.0), row(0.0, 26.0)]);
    /// assert_eq!(d.mean_off_percent, 19.0);
    /// assert_eq!(d.beyond_tolerance, 1); // as the check counts them (`poor_twin`)
    /// ```
    pub fn of(check: &[TwinCheckRow]) -> Self {
        let offs: Vec<f64> = check
            .iter()
            .flat_map(|r| [r.translational_off_percent, r.rotational_off_percent])
            .map(f64::abs)
            .collect();
        CheckDistance {
            mean_off_percent: offs.iter().sum::<f64>() / offs.len().max(1) as f64,
            // The check's own count (NaN, a median that could not be computed, is beyond).
            beyond_tolerance: poor_twin(check, TWIN_TOLERANCE).len(),
        }
    }

    /// The mean distance, an undefined one (NaN) the farthest.
    fn mean_or_farthest(&self) -> f64 {
        if self.mean_off_percent.is_nan() {
            f64::INFINITY
        } else {
            self.mean_off_percent
        }
    }

    /// True when `self` is closer than `other` by more than the runs' seeds move it: fewer
    /// medians beyond the tolerance, or as many and a mean distance smaller by more than
    /// [`CONTACT_SPREAD_MARGIN`] points.
    fn clearly_closer_than(&self, other: &CheckDistance) -> bool {
        self.beyond_tolerance < other.beyond_tolerance
            || (self.beyond_tolerance == other.beyond_tolerance
                && self.mean_or_farthest() < other.mean_or_farthest() - CONTACT_SPREAD_MARGIN)
    }

    /// True when `self` is closer than `other`: fewer medians beyond the tolerance, then a
    /// smaller mean distance (an undefined one, NaN, is the farthest).
    fn closer_than(&self, other: &CheckDistance) -> bool {
        (self.beyond_tolerance, self.mean_or_farthest())
            < (other.beyond_tolerance, other.mean_or_farthest())
    }
}

/// Whether a fitted twin keeps its ground's variability ([`choose_variability`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VariabilityChoice {
    /// True when the twin keeps the fitted variability.
    pub kept: bool,
    /// The fitted variability, kept or not.
    pub fitted: drive_sim::Variability,
    /// The twin with its fitted variability against the real run.
    pub with: CheckDistance,
    /// The same twin without variability.
    pub without: CheckDistance,
    /// Seeds of the twins' runs ([`VARIABILITY_CHOICE_SEEDS`]).
    pub seeds: Vec<u64>,
}

/// Whether the fitted `twin` keeps its variability: the twin with and without it, each
/// checked against `data` as [`twin_check`] does (its runs given the real run's commands,
/// [`VARIABILITY_CHOICE_SEEDS`]), and the one whose medians come closer
/// ([`CheckDistance`]: fewer beyond the tolerance, then the smaller mean distance) is kept;
/// on a tie the variability stays. `None` when the twin has no variability.
///
/// The variability's fit matches the steady windows' scatter, a proxy: on the released
/// Warthog runs the real excess scatter is uncorrelated between an interval's two steady
/// windows, so the fit adds a ground that changes within a fifth of a second, which can take
/// the twin's model errors further from the real run's than no variability does (2024-09-20a:
/// slip-BLR's rotational median +51% with it, -9% without). What the twin is for, the
/// models' errors, decides.
///
/// ```no_run
/// use drive_studies::{choose_variability, Registries, TWIN_CHECK_MODELS};
/// let r = Registries::builtin();
/// let data = drive_data::read_dataset("run.csv".as_ref(), None).unwrap();
/// let robot = r.robot("husky").unwrap();
/// let twin = r.terrain("twin.toml").unwrap();
/// let models = r.models().resolve_list(&TWIN_CHECK_MODELS).unwrap();
/// if let Some(choice) = choose_variability(&r, &data, &robot, &twin, &models).unwrap() {
///     println!("kept: {} ({:?} against {:?})", choice.kept, choice.with, choice.without);
/// }
/// ```
pub fn choose_variability(
    registries: &Registries,
    data: &Dataset,
    robot: &RobotSpec,
    twin: &Terrain,
    models: &[ModelSpec],
) -> Result<Option<VariabilityChoice>, ExperimentError> {
    let Some(fitted) = twin.variability else {
        return Ok(None);
    };
    let without_variability = Terrain {
        variability: None,
        ..twin.clone()
    };
    let seeds = VARIABILITY_CHOICE_SEEDS.to_vec();
    let distance = |t: &Terrain| -> Result<CheckDistance, ExperimentError> {
        let check = twin_check(
            registries,
            data,
            robot,
            t,
            &seeds,
            models,
            CheckCommands::Replay,
        )?;
        Ok(CheckDistance::of(&check.check))
    };
    let (with, without) = (distance(twin)?, distance(&without_variability)?);
    Ok(Some(VariabilityChoice {
        kept: !without.closer_than(&with),
        fitted,
        with,
        without,
        seeds,
    }))
}

/// One contact spread a twin's fit tried ([`fit_twin`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpreadTried {
    /// The contacts' spread along each side, as a share of the baseline.
    pub contact_spread: f64,
    /// True for the vehicle's own spread (0.9 of the baseline for wheels, 1.1 for tracks).
    pub vehicle_own: bool,
    /// The twin fitted with it against the real run (its variability kept or not, as
    /// [`choose_variability`] decided); `None` when no twin could be fitted with it.
    pub distance: Option<CheckDistance>,
    /// Why no twin could be fitted with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// Which contact spread a fitted twin keeps ([`fit_twin`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactSpreadChoice {
    /// The spread kept, a share of the baseline.
    pub kept: f64,
    /// True when it is the vehicle's own (the twin file then has none).
    pub vehicle_own: bool,
    /// True when the spread was chosen among the vehicle's own and
    /// [`drive_sim::CONTACT_SPREAD_CHOICES`] ([`ContactSpreads::Choose`]); false when only one
    /// was fitted, as asked ([`ContactSpreads::Own`] or [`ContactSpreads::Given`]).
    pub chosen: bool,
    /// The spreads tried, the vehicle's own first (when it was tried).
    pub tried: Vec<SpreadTried>,
    /// Seeds of the twins' runs that chose ([`VARIABILITY_CHOICE_SEEDS`]).
    pub seeds: Vec<u64>,
}

/// A twin fitted by [`fit_twin`], with the choices its fit made.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedTwin {
    /// The twin and its fit's report.
    pub fit: drive_sim::SimFit,
    /// Whether it keeps its ground's variability ([`choose_variability`]).
    pub variability: Option<VariabilityChoice>,
    /// Which contact spread it keeps.
    pub contact_spread: ContactSpreadChoice,
}

/// Which contact spreads a twin's fit tries ([`fit_twin_with`]; `drive sim-fit
/// --contact-spread`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactSpreads {
    /// The vehicle's own and each of [`drive_sim::CONTACT_SPREAD_CHOICES`], the one kept as
    /// [`fit_twin`] says: four fits.
    Choose,
    /// The vehicle's own only: one fit, a quarter of the time.
    Own,
    /// This share of the baseline only (within the simulator's range, else refused): one
    /// fit, kept in the twin file.
    Given(f64),
}

impl ContactSpreads {
    /// Parses `choose`, `own` or a share of the baseline (`drive sim-fit --contact-spread`).
    ///
    /// ```
    /// use drive_studies::ContactSpreads;
    /// assert_eq!(ContactSpreads::parse("own").unwrap(), ContactSpreads::Own);
    /// assert_eq!(ContactSpreads::parse("0.75").unwrap(), ContactSpreads::Given(0.75));
    /// assert!(ContactSpreads::parse("wide").is_err());
    /// assert!(ContactSpreads::parse("nan").is_err());
    /// ```
    pub fn parse(text: &str) -> Result<Self, UnknownName> {
        match text {
            "choose" => Ok(Self::Choose),
            "own" => Ok(Self::Own),
            _ => match text.parse::<f64>() {
                Ok(share) if share.is_finite() && share > 0.0 => Ok(Self::Given(share)),
                _ => Err(UnknownName::from(format!(
                    "a contact spread is choose, own or a positive share of the baseline, not '{text}'"
                ))),
            },
        }
    }
}

/// Fits a twin of `robot` on `data` as `drive sim-fit` does: [`drive_sim::sim_fit`], its
/// variability kept or dropped by [`choose_variability`], its models' errors measured
/// against the real run's (on
/// [`VARIABILITY_CHOICE_SEEDS`], not the check's own seeds), the ground refitted with its
/// contacts spread over each of [`drive_sim::CONTACT_SPREAD_CHOICES`] of the baseline
/// ([`drive_sim::sim_fit_with_contact_spread`]). The vehicle's own spread is kept unless
/// another twin is clearly closer to the real run's medians ([`CheckDistance`]: fewer
/// medians beyond the tolerance, or as many and a mean distance smaller by more than
/// [`CONTACT_SPREAD_MARGIN`] points); among those, the closest. Four fits: this takes four
/// times [`drive_sim::sim_fit`]'s time.
///
/// Why the spread: a skid-steer turns by scrubbing its wheels sideways, and how far apart
/// along each side the ground resists that (the lever arm of the turning resistance) sets
/// how much forward speed a turn costs for the yaw rate it keeps. The axles' distance is a
/// first guess; tyres that deform, a load shared unevenly between the axles and a
/// suspension that lets them ride (the Warthog's) make the effective lever differ by ground
/// (the expansion factors of skid-steer kinematics, Mandow et al. 2007, vary with the
/// ground the same way). The ground's per-window fit does not identify it (on the paper's
/// Warthog run it prefers a longer lever, whose twin is further from the real models'
/// errors); the models' errors, what the twin is for, do. The choice is made on the fitted
/// run itself (an indirect inference of one parameter, on seeds apart from the check's).
///
/// ```no_run
/// use drive_studies::{fit_twin, Registries, TWIN_CHECK_MODELS};
/// let r = Registries::builtin();
/// let data = drive_data::read_dataset("run.csv".as_ref(), None).unwrap();
/// let robot = r.robot("husky").unwrap();
/// let models = r.models().resolve_list(&TWIN_CHECK_MODELS).unwrap();
/// let twin = fit_twin(&r, &data, &robot, "my twin", &models).unwrap();
/// println!("contact spread {} of the baseline", twin.contact_spread.kept);
/// ```
pub fn fit_twin(
    registries: &Registries,
    data: &Dataset,
    robot: &RobotSpec,
    name: &str,
    models: &[ModelSpec],
) -> Result<FittedTwin, ExperimentError> {
    fit_twin_with(
        registries,
        data,
        robot,
        name,
        models,
        ContactSpreads::Choose,
    )
}

/// [`fit_twin`] with the contact spreads to try: [`ContactSpreads::Choose`] is
/// [`fit_twin`]; [`ContactSpreads::Own`] and [`ContactSpreads::Given`] fit one twin, with
/// that spread, its variability still chosen and its distance from the real run still
/// measured (`tried` holds it alone).
///
/// ```no_run
/// use drive_studies::{fit_twin_with, ContactSpreads, Registries, TWIN_CHECK_MODELS};
/// let r = Registries::builtin();
/// let data = drive_data::read_dataset("run.csv".as_ref(), None).unwrap();
/// let robot = r.robot("husky").unwrap();
/// let models = r.models().resolve_list(&TWIN_CHECK_MODELS).unwrap();
/// let twin = fit_twin_with(&r, &data, &robot, "my twin", &models, ContactSpreads::Own).unwrap();
/// assert!(twin.contact_spread.vehicle_own && !twin.contact_spread.chosen);
/// ```
pub fn fit_twin_with(
    registries: &Registries,
    data: &Dataset,
    robot: &RobotSpec,
    name: &str,
    models: &[ModelSpec],
    spreads: ContactSpreads,
) -> Result<FittedTwin, ExperimentError> {
    let seeds = VARIABILITY_CHOICE_SEEDS.to_vec();
    // A twin fitted with the spread (the vehicle's own when `None`), its variability chosen,
    // and its distance from the real run on the choice's seeds.
    type Attempt = (drive_sim::SimFit, Option<VariabilityChoice>, CheckDistance);
    let attempt = |spread: Option<f64>| -> Result<Attempt, ExperimentError> {
        let mut fit = drive_sim::sim_fit_with_contact_spread(data, robot, name, spread)?;
        let variability = choose_variability(registries, data, robot, &fit.terrain, models)?;
        let distance = match &variability {
            Some(c) if c.kept => c.with,
            Some(c) => {
                fit = fit.without_variability();
                c.without
            }
            None => {
                let check = twin_check(
                    registries,
                    data,
                    robot,
                    &fit.terrain,
                    &seeds,
                    models,
                    CheckCommands::Replay,
                )?;
                CheckDistance::of(&check.check)
            }
        };
        Ok((fit, variability, distance))
    };
    let own = drive_sim::VehicleParams::nominal_contact_spread(robot.tracked);
    if let ContactSpreads::Given(share) = spreads {
        // One fit with the spread asked for: its refusals stand.
        let (fit, variability, distance) = attempt(Some(share))?;
        return Ok(FittedTwin {
            fit,
            variability,
            contact_spread: ContactSpreadChoice {
                kept: share,
                vehicle_own: false,
                chosen: false,
                tried: vec![SpreadTried {
                    contact_spread: share,
                    vehicle_own: false,
                    distance: Some(distance),
                    error: None,
                }],
                seeds,
            },
        });
    }
    let others: &[f64] = match spreads {
        ContactSpreads::Choose => &drive_sim::CONTACT_SPREAD_CHOICES,
        ContactSpreads::Own | ContactSpreads::Given(_) => &[],
    };
    // The spreads' fits are independent: on rayon's threads, each alone (a fit is the same
    // on any number of threads) and taken below in their order, so the twin is too.
    let spreads_tried: Vec<Option<f64>> = std::iter::once(None)
        .chain(others.iter().map(|&s| Some(s)))
        .collect();
    let mut attempts = spreads_tried
        .par_iter()
        .map(|&s| attempt(s))
        .collect::<Vec<_>>()
        .into_iter();
    // The vehicle's own spread: its fit's refusals are the data's, and stand.
    let (fit, variability, own_distance) = attempts
        .next()
        .expect("spreads_tried starts with the vehicle's own")?;
    let mut best = (None, fit, variability, own_distance);
    let mut tried = vec![SpreadTried {
        contact_spread: own,
        vehicle_own: true,
        distance: Some(own_distance),
        error: None,
    }];
    for (&spread, result) in others.iter().zip(attempts) {
        match result {
            Ok((fit, variability, distance)) => {
                tried.push(SpreadTried {
                    contact_spread: spread,
                    vehicle_own: false,
                    distance: Some(distance),
                    error: None,
                });
                if distance.clearly_closer_than(&own_distance) && distance.closer_than(&best.3) {
                    best = (Some(spread), fit, variability, distance);
                }
            }
            // A spread with which the ground cannot be fitted is not kept; the others are
            // still tried.
            Err(e) => tried.push(SpreadTried {
                contact_spread: spread,
                vehicle_own: false,
                distance: None,
                error: Some(e.to_string()),
            }),
        }
    }
    let (spread, fit, variability, _) = best;
    Ok(FittedTwin {
        fit,
        variability,
        contact_spread: ContactSpreadChoice {
            kept: spread.unwrap_or(own),
            vehicle_own: spread.is_none(),
            chosen: spreads == ContactSpreads::Choose,
            tried,
            seeds,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn another_contact_spread_must_come_clearly_closer() {
        let d = |mean_off_percent, beyond_tolerance| CheckDistance {
            mean_off_percent,
            beyond_tolerance,
        };
        let own = d(15.5, 2);
        // Fewer medians beyond the tolerance, however the means compare.
        assert!(d(16.0, 1).clearly_closer_than(&own));
        // As many: the mean must be more than CONTACT_SPREAD_MARGIN points smaller.
        assert!(d(13.4, 2).clearly_closer_than(&own));
        assert!(!d(13.6, 2).clearly_closer_than(&own));
        assert!(!d(9.0, 3).clearly_closer_than(&own));
        // An undefined distance is the farthest.
        assert!(!d(f64::NAN, 2).clearly_closer_than(&own));
        assert!(d(30.0, 2).clearly_closer_than(&d(f64::NAN, 2)));
    }

    #[test]
    fn a_replayed_run_holds_the_recorded_commands_through_the_twins_protocol() {
        // The shipped Husky twin draws in a 0.222 m baseline and records in the robot's
        // 0.55 m: the replayed commands go through that mapping and come out as recorded.
        let r = Registries::builtin();
        let robot = r.robot("husky").unwrap();
        let twin = r
            .terrain(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../examples/husky_twin.toml"
            ))
            .unwrap();
        assert!(twin.protocol.is_some());
        let drawn = crate::simulate_run(&r, &SimRun::intervals(&robot, &twin, "uniform", 12, 5))
            .unwrap()
            .dataset;
        let mut recorded = ReplaySampler::interval_commands(&drawn.windows);
        assert_eq!(recorded.len(), 12);
        // Straight ahead at the top wheel speeds: 0.99 m/s, outside the protocol's rectangle
        // of body velocities (up to 0.96 m/s), which would redraw it.
        recorded.insert(3, Input::new(6.0, 6.0, 0.0));
        let run = SimRun::intervals(&robot, &twin, "uniform", 12, 6);
        let replayed = replay_run(&r, &run, &recorded).unwrap();
        let held = ReplaySampler::interval_commands(&replayed.windows);
        assert_eq!(held.len(), recorded.len());
        for (a, b) in held.iter().zip(&recorded) {
            assert!((a - b).norm() < 1e-9, "{a} against {b}");
        }
        // Its own draws (seed 6) are other commands.
        let other = crate::simulate_run(&r, &run).unwrap().dataset;
        assert_ne!(ReplaySampler::interval_commands(&other.windows), recorded);
    }

    #[test]
    fn a_variability_that_takes_the_models_away_from_the_run_is_dropped_and_one_that_brings_them_closer_kept(
    ) {
        let r = Registries::builtin();
        let robot = r.robot("husky").unwrap();
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/husky_twin.toml");
        let twin = r.terrain(path).unwrap();
        let models = r.models().resolve_list(&TWIN_CHECK_MODELS).unwrap();
        let run_of = |terrain: &Terrain| {
            crate::simulate_run(&r, &SimRun::intervals(&robot, terrain, "uniform", 60, 21))
                .unwrap()
                .dataset
        };
        let wild = Terrain {
            variability: Some(drive_sim::Variability {
                traction: 0.5,
                lateral: 3.0,
                rolling: 3.0,
                correlation_time: 0.2,
            }),
            ..twin.clone()
        };
        // A run of a steady ground, and a twin whose ground varies wildly: dropped. A run
        // of that varying ground, and the same twin: kept. No variability, nothing to
        // choose. The three cases are independent: run side by side.
        let steady = Terrain {
            variability: None,
            ..twin.clone()
        };
        let choose = |run: &Terrain, twin: &Terrain| {
            choose_variability(&r, &run_of(run), &robot, twin, &models).unwrap()
        };
        let (dropped, (kept, none)) = rayon::join(
            || choose(&steady, &wild),
            || rayon::join(|| choose(&wild, &wild), || choose(&steady, &steady)),
        );
        let choice = dropped.unwrap();
        assert!(!choice.kept, "{choice:?}");
        assert!(choice.without.mean_off_percent < choice.with.mean_off_percent);
        assert_eq!(choice.seeds, VARIABILITY_CHOICE_SEEDS);
        let choice = kept.unwrap();
        assert!(choice.kept, "{choice:?}");
        assert!(none.is_none());
    }

    #[test]
    fn a_replayed_run_without_a_protocol_holds_every_input_axis() {
        // An omnidirectional base (v_x, v_y, w) on a preset ground: the yaw-rate command
        // is held too.
        let r = Registries::builtin();
        let robot = r.robot("ridgeback").unwrap();
        let ground = r.terrain("tile").unwrap();
        let run = SimRun::intervals(&robot, &ground, "uniform", 8, 3);
        let drawn = crate::simulate_run(&r, &run).unwrap().dataset;
        let recorded = ReplaySampler::interval_commands(&drawn.windows);
        assert!(recorded.iter().any(|u| u.z.abs() > 0.1));
        let replayed = replay_run(&r, &SimRun { seed: 4, ..run }, &recorded).unwrap();
        assert_eq!(
            ReplaySampler::interval_commands(&replayed.windows),
            recorded
        );
        assert!(
            replayed.robot.name.contains("replay"),
            "{}",
            replayed.robot.name
        );
    }
}
