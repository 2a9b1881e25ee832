//! The closed-loop experiment (`drive track`): a controller with a fitted model drives the
//! simulated robot (a preset terrain or a twin of a real run) along reference paths, for
//! each model, training source, path, speed and seed; scored by how closely the robot
//! followed the path.
//!
//! One run: the plant at rest; the path placed where the robot's localization frame starts,
//! leaving along its heading; a [`Tracker`] ticked at the robot's command rate with what
//! the plant's sensors report, its commands sent to the plant; the run ends when the
//! tracker reaches the end of the path, or at the time limit (then not completed). The
//! scores use the plant's true pose of the localization frame ([`drive_sim::Plant::true_pose`]), not
//! the noisy localization the controller sees.
//!
//! The speeds are fractions of the robot's top speed **on this terrain**, measured on the
//! plant as DRIVE's characterization does (Sec. III-A, step 1): the straightest fastest
//! input of the input space held for 6 s, the speed over its last 2 s. The preset paths are
//! scaled to it: `max(2 m, 4 s x top speed)`.

use crate::{simulate_run, ExperimentError, Registries, SimRun};
use drive_control::{
    ControlError, ControlSetup, InputMap, MakeController, Observation, PathError, PathShape,
    ReferencePath, Tracker, TrackerConfig,
};
use drive_models::{DifferentialDrive, ModelSpec};
use drive_samplers::{next_command, RobotSpec, RunnerConfig, SentCommand};
use drive_sim::{plant_for, scale_difference, Terrain};
use drive_traits::limits::{Exact, Short};
use drive_traits::{
    vehicle_as, vehicle_tag, wrap_angle, Dataset, FitError, Input, MotionModel, Phase, Pose,
    Window, WindowSet,
};
use rayon::prelude::*;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;
use thiserror::Error;

mod adaptive;
mod feasibility;
mod plant;
mod results;
#[cfg(test)]
mod tests;

use feasibility::*;
pub use feasibility::{yaw_rate_needed, Feasibility, TURN_SPAN_S};
use plant::*;
use results::*;

/// Why a closed-loop study could not run.
#[derive(Debug, Error)]
pub enum TrackError {
    /// A simulated training run or a part's name failed.
    #[error(transparent)]
    Experiment(#[from] ExperimentError),
    /// The controller could not be built or gave no command.
    #[error("{model} on {path}: {reason}")]
    Control {
        /// The model.
        model: String,
        /// The path.
        path: String,
        /// Why.
        reason: ControlError,
    },
    /// A path is refused.
    #[error(transparent)]
    Path(#[from] PathError),
    /// A model could not be fitted on its training data.
    #[error("fitting {model} on {data}: {reason}")]
    Fit {
        /// The model.
        model: String,
        /// Its training data.
        data: String,
        /// Why.
        reason: FitError,
    },
    /// A setting of the study is out of range, or its parts do not fit together.
    #[error("{0}")]
    Invalid(String),
}

/// What a model is fitted on.
#[derive(Debug, Clone)]
pub enum Training {
    /// A recorded (or simulated) dataset: every one of its windows.
    Data {
        /// Its label in the results (the file's name).
        name: String,
        /// The windows.
        dataset: Arc<Dataset>,
    },
    /// A DRIVE run on the plant itself, simulated for each seed.
    Protocol {
        /// The registered sampler it is driven by (`uniform`, `linear`, `angular`).
        sampler: String,
        /// Driving time (s), characterization excluded.
        driving_s: f64,
    },
}

impl Training {
    /// The label in the results: the dataset's name, or the sampler's.
    pub fn label(&self) -> String {
        match self {
            Training::Data { name, .. } => name.clone(),
            Training::Protocol { sampler, .. } => sampler.clone(),
        }
    }
}

/// A path of the study: a preset shape (scaled to the robot's top speed) or a given one.
#[derive(Debug, Clone)]
pub enum PathChoice {
    /// A preset shape.
    Preset(PathShape),
    /// A path as given (a CSV file), placed at the robot's start.
    Given(ReferencePath),
}

impl PathChoice {
    /// The path's name.
    pub fn name(&self) -> String {
        match self {
            PathChoice::Preset(s) => s.as_str().to_string(),
            PathChoice::Given(p) => p.name().to_string(),
        }
    }
}

/// A closed-loop study.
#[derive(Clone)]
pub struct TrackStudy {
    /// The robot.
    pub robot: RobotSpec,
    /// The ground: a preset terrain, or a twin (`drive sim-fit`).
    pub terrain: Terrain,
    /// What the models are fitted on; each is a column of the results.
    pub training: Vec<Training>,
    /// The models.
    pub models: Vec<ModelSpec>,
    /// Models already fitted (model files), by their place in `models`: each is driven as
    /// it is on every training source, never fitted again (its spec names it and gives its
    /// start). Its period must be the robot's.
    pub given: Vec<(usize, Arc<dyn MotionModel>)>,
    /// The paths.
    pub paths: Vec<PathChoice>,
    /// Speeds along the path, as fractions of the robot's top speed, in (0, 1].
    pub speeds: Vec<f64>,
    /// Seeds: the plant's noise, the controller's sampling ([`ControlSetup::seed`]) and the
    /// simulated training runs.
    pub seeds: Vec<u64>,
    /// The controller's name, for the results.
    pub controller_name: String,
    /// The controller.
    pub controller: Arc<dyn MakeController>,
    /// Time limit of a run (s), at most [`MAX_RUN_S`]; default: twice the path's length at
    /// its speed, plus 20 s (which must be within [`MAX_RUN_S`]).
    pub time_limit_s: Option<f64>,
    /// How far back the controller's predictions start (s, in [0, 10]): from the state this
    /// long ago through the commands sent since ([`TrackerConfig::history_s`]); default:
    /// each model's powertrain's settling time ([`drive_control::settling_history_s`]).
    pub history_s: Option<f64>,
    /// Whether each localization fix reaches the controller with the time it was measured
    /// ([`drive_control::Observation::pose_time`]: a ROS pose message's header stamp), so
    /// that the tracker carries it forward from then; `false` (`drive track
    /// --no-pose-stamps`): each fix taken as measured when it arrives, its latency unseen.
    pub pose_stamps: bool,
    /// The reference's timing ([`TrackerConfig::schedule_s`]): `Some(lead_s)` holds the
    /// robot to a schedule at the asked speed, within `lead_s` seconds of travel; `None`
    /// (`drive track --schedule 0`) starts the reference where the robot is.
    pub schedule_s: Option<f64>,
    /// Where the ground changes along the path (`drive track --terrains`), in order: the
    /// robot drives onto each change's ground once it has covered that share of the path
    /// ([`drive_sim::Plant::change_ground`]). Empty: `terrain` all along. The top speed and
    /// the feasibility are measured on `terrain`, the first stretch's.
    pub ground_changes: Vec<GroundChange>,
    /// The models (by place in `models`) that adapt to the ground inside the loop (`drive
    /// track --adapt`): each window the run drives is fed, as it completes, to an
    /// [`crate::AdaptiveFit`] of the fitted model (`drive adapt`'s adaptive model), whose
    /// model the controller predicts with from the next tick on. Each must be composed of a
    /// powertrain and a slip model.
    pub adaptive: Vec<usize>,
}

/// What a model adapting in the loop did in one run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LoopAdaptation {
    /// When (s into the run) the adaptive model first departed from the prior (a slip
    /// correction or the refit taken); `None` when it never did.
    pub changed_from_s: Option<f64>,
    /// When the refit (the model fitted from scratch on the windows driven) first took over.
    pub refit_from_s: Option<f64>,
    /// Whether the model at the end of the run is not the prior.
    pub changed_at_end: bool,
}

/// A change of ground along a path.
#[derive(Debug, Clone)]
pub struct GroundChange {
    /// The share of the path's length covered where the ground changes, in (0, 1).
    pub at: f64,
    /// The ground from there on (a preset or a twin's ground; the robot stays the first
    /// terrain's).
    pub terrain: Terrain,
}

/// Where a run's ground changed, in the results.
#[derive(Debug, Clone, Serialize)]
pub struct GroundChangeAt {
    /// The share of the path's length covered where it changes.
    pub at: f64,
    /// The ground's name from there on.
    pub terrain: String,
}

impl std::fmt::Debug for TrackStudy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TrackStudy")
            .field("robot", &self.robot.name)
            .field("terrain", &self.terrain.name)
            .field("controller", &self.controller_name)
            .finish_non_exhaustive()
    }
}

/// One closed-loop run.
#[derive(Debug, Clone, Serialize)]
pub struct TrackRun {
    /// The model.
    pub model: String,
    /// What it was fitted on ([`Training::label`]).
    pub train: String,
    /// The path.
    pub path: String,
    /// Speed as a fraction of the top speed.
    pub speed_fraction: f64,
    /// Speed (m/s).
    pub speed_m_s: f64,
    /// Seed.
    pub seed: u64,
    /// RMS distance of the robot from the path (m), over the run.
    pub cross_track_rms_m: f64,
    /// Largest distance from the path (m).
    pub cross_track_max_m: f64,
    /// RMS heading error against the path's direction (rad).
    pub heading_rms_rad: f64,
    /// RMS of the angle between the direction the robot moves in (tick to tick) and the
    /// path's (rad): with [`Self::heading_rms_rad`], tells weaving (both large) from a
    /// sideslip (the heading off the path, the course on it).
    pub course_rms_rad: f64,
    /// The end of the path was reached within the time limit.
    pub completed: bool,
    /// Time driven (s): to the end of the path, or to the time limit.
    pub duration_s: f64,
    /// The share of the asked speed the robot kept along the path: the path covered over
    /// the time driven, over [`Self::speed_m_s`] (1: on time; a robot that crawls keeps
    /// closer to the path with less to show for it).
    pub speed_kept: f64,
    /// RMS of the commands, normalised by the input space's half-range (0: at its centre,
    /// 1: at its corners).
    pub effort: f64,
    /// RMS of the change of the normalised command from one tick to the next (the
    /// smoothness of the control: 0 for a constant command).
    pub command_change_rms: f64,
    /// Sign changes of the commanded yaw rate over the run (values within a tenth of its
    /// RMS of zero not counted): how much the controller weaves.
    pub yaw_rate_sign_changes: usize,
    /// [`Self::yaw_rate_sign_changes`] per metre of path covered.
    pub yaw_rate_sign_changes_per_m: f64,
    /// With a ground that changes along the path: the RMS cross-track error (m) from the
    /// first change on (absent without a change, or when the run never reached it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cross_track_rms_after_change_m: Option<f64>,
    /// For a model adapting in the loop (`--adapt`): when (s into the run) its adaptive
    /// model first departed from the prior, and when the refit first took over (absent
    /// when it never did).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adapted: Option<LoopAdaptation>,
    /// Median time the controller took per tick (ms).
    pub tick_ms_median: f64,
    /// How far back the controller's predictions started (s): the study's history, or
    /// the model's settling time ([`drive_control::settling_history_s`]).
    pub history_s: f64,
    /// The path's length (m).
    pub length_m: f64,
    /// The robot's positions, one per tick (for figures; not in the JSON).
    #[serde(skip)]
    pub trajectory: Vec<[f64; 2]>,
    /// What the run drove cut into windows of the training data's length (the vehicle's
    /// commands, the measured inputs, the true poses; not in the JSON): what the models'
    /// open-loop scores on the controllers' commands are measured on.
    #[serde(skip)]
    pub recorded: Vec<Window>,
}

/// Runs of one model, training, path and speed over the seeds.
#[derive(Debug, Clone, Serialize)]
pub struct TrackSummary {
    /// The model.
    pub model: String,
    /// What it was fitted on.
    pub train: String,
    /// The path.
    pub path: String,
    /// Speed as a fraction of the top speed.
    pub speed_fraction: f64,
    /// Runs (seeds).
    pub runs: usize,
    /// Mean over the runs of their RMS cross-track error (m).
    pub cross_track_rms_m: f64,
    /// Largest cross-track error of any run (m).
    pub cross_track_max_m: f64,
    /// Mean of the runs' RMS heading error (rad).
    pub heading_rms_rad: f64,
    /// Mean of the runs' RMS course error (rad, [`TrackRun::course_rms_rad`]).
    pub course_rms_rad: f64,
    /// Share of the runs that reached the end.
    pub completed_share: f64,
    /// Mean time of the completed runs (s); absent when none completed.
    pub duration_s: Option<f64>,
    /// Mean of the runs' [`TrackRun::speed_kept`].
    pub speed_kept: f64,
    /// Mean effort.
    pub effort: f64,
    /// Mean of the runs' [`TrackRun::command_change_rms`].
    pub command_change_rms: f64,
    /// Mean of the runs' [`TrackRun::yaw_rate_sign_changes_per_m`].
    pub yaw_rate_sign_changes_per_m: f64,
    /// Mean over the runs of how far back the controller's predictions started (s).
    pub history_s: f64,
    /// With a ground that changes along the path: the mean over the runs of
    /// [`TrackRun::cross_track_rms_after_change_m`] (absent unless every run reached the
    /// change).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cross_track_rms_after_change_m: Option<f64>,
    /// Whether the robot can drive this path at this speed on this ground
    /// ([`Feasibility`]); `None` where the vehicle has no input for the turns it needs.
    pub feasible: Option<bool>,
    /// How much lower the RMS cross-track error is than the first model's with the same
    /// training, path and speed (%; positive is better), when this is not the first model
    /// and both reached the end in every run (absent otherwise: a run that stops short is
    /// scored on the part of the path it covered).
    pub improvement_over_first_percent: Option<f64>,
    /// How much lower the RMS cross-track error is than the powertrain model's (FOPDT, no
    /// slip: `powertrain`) with the same training, path and speed (%; positive is better),
    /// when the powertrain model is among the models, this is not it and both reached the
    /// end in every run (see [`Self::feasible`] before reading it as the model's merit).
    pub improvement_over_powertrain_percent: Option<f64>,
    /// The mean RMS heading error over the powertrain model's (weaving shows as a ratio
    /// well above 1), under the same conditions.
    pub heading_rms_ratio_to_powertrain: Option<f64>,
    /// The mean share of the asked speed kept over the powertrain model's, under the same
    /// conditions: far from 1, the two cross-track errors are of different speeds (a note
    /// says so below a ratio of 0.8 or above 1.25).
    pub speed_kept_ratio_to_powertrain: Option<f64>,
    /// This model's open-loop error on what the controllers drove here: the median
    /// translational MRMSE (eq. 8, m) of its predictions of the windows cut from every run
    /// of this training, path and speed (every model's, every seed), from their recorded
    /// commands. How well it predicts the commands a controller sends, which are not
    /// DRIVE's held steps. `None` without a whole window.
    pub open_loop_translational_median_m: Option<f64>,
    /// The same, rotational (rad).
    pub open_loop_rotational_median_rad: Option<f64>,
}

/// A placed reference path, for figures.
#[derive(Debug, Clone, Serialize)]
pub struct PlacedPath {
    /// The path's name.
    pub path: String,
    /// Its points.
    pub points: Vec<[f64; 2]>,
}

/// What a closed-loop study found.
#[derive(Debug, Clone, Serialize)]
pub struct TrackResult {
    /// The robot.
    pub robot: String,
    /// The terrain (or twin).
    pub terrain: String,
    /// The controller.
    pub controller: String,
    /// The simulator the robot ran on (the one registered for its vehicle type, or the
    /// kinematic stand-in).
    pub simulator: drive_sim::SimulatorUsed,
    /// The robot's top speed on this terrain, as measured (m/s).
    pub top_speed_m_s: f64,
    /// The preset paths' scale (m).
    pub path_scale_m: f64,
    /// The reference's timing ([`TrackStudy::schedule_s`]): the schedule's lead (s), or
    /// `None` where the reference starts where the robot is.
    pub schedule_s: Option<f64>,
    /// The models, in order (the first is the one improvements are measured against).
    pub models: Vec<String>,
    /// The training sources, in order.
    pub training: Vec<String>,
    /// Every run.
    pub runs: Vec<TrackRun>,
    /// Per model, training, path and speed.
    pub summary: Vec<TrackSummary>,
    /// The paths as placed.
    pub paths: Vec<PlacedPath>,
    /// Whether each path can be driven at each speed on this ground.
    pub feasibility: Vec<Feasibility>,
    /// What the reader should know (a run that ended at its time limit, ...).
    pub notes: Vec<String>,
    /// Where the ground changes along the path (`--terrains`); absent when it does not.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub ground_changes: Vec<GroundChangeAt>,
}

/// A model fitted on one training set (of a seed, for a simulated one).
struct Fitted {
    training: usize,
    seed: Option<u64>,
    model: usize,
    fitted: Arc<dyn MotionModel>,
}

/// Most runs of one study (models x trainings x paths x speeds x seeds).
pub const MAX_TRACK_RUNS: usize = 10_000;
/// Longest run (s of simulated time): an hour, 72,000 ticks at 20 Hz (a few minutes of
/// computing).
pub const MAX_RUN_S: f64 = 3600.0;
/// Longest simulated training run (s of driving): two hours (a DRIVE run is 5 to 20
/// minutes).
pub const MAX_TRAINING_S: f64 = 7200.0;
/// Most simulated training driving of one study, over its samplers and seeds (s): ten
/// hours.
pub const MAX_TRAINING_TOTAL_S: f64 = 36_000.0;

/// Runs the closed-loop study: the top speed, the training data and the fits, then every
/// run, in parallel (rayon); `progress` is called after each run.
///
/// ```no_run
/// use drive_control::PathShape;
/// use drive_studies::{run_track, PathChoice, Registries, Training, TrackStudy};
/// use std::sync::Arc;
/// let r = Registries::builtin();
/// let study = TrackStudy {
///     robot: r.robot("husky").unwrap(),
///     terrain: r.terrain("gravel").unwrap(),
///     training: vec![Training::Protocol { sampler: "uniform".into(), driving_s: 300.0 }],
///     models: r.models().resolve_list(&["naive", "slip-blr"]).unwrap(),
///     given: vec![],
///     paths: vec![PathChoice::Preset(PathShape::FigureEight)],
///     speeds: vec![0.5],
///     seeds: vec![1],
///     controller_name: "mppi".into(),
///     controller: Arc::clone(r.controllers.get("mppi").unwrap().part()),
///     time_limit_s: None,
///     history_s: None,
///     pose_stamps: true,
///     schedule_s: None,
///     ground_changes: vec![],
///     adaptive: vec![],
/// };
/// let result = run_track(&r, &study, &|| {}).unwrap();
/// assert_eq!(result.runs.len(), 2);
/// ```
pub fn run_track(
    registries: &Registries,
    study: &TrackStudy,
    progress: &(dyn Fn() + Sync),
) -> Result<TrackResult, TrackError> {
    for (what, empty) in [
        ("models", study.models.is_empty()),
        ("training data", study.training.is_empty()),
        ("paths", study.paths.is_empty()),
        ("speeds", study.speeds.is_empty()),
        ("seeds", study.seeds.is_empty()),
    ] {
        if empty {
            return Err(TrackError::Invalid(format!("the study has no {what}")));
        }
    }
    for (k, (m, model)) in study.given.iter().enumerate() {
        let Some(spec) = study.models.get(*m) else {
            return Err(TrackError::Invalid(format!(
                "a given model is model {m} of {}",
                study.models.len()
            )));
        };
        if study.given[..k].iter().any(|(other, _)| other == m) {
            return Err(TrackError::Invalid(format!(
                "model '{}' is given twice",
                spec.name
            )));
        }
        let period = 1.0 / study.robot.rate_hz;
        if (model.dt() - period).abs() > 1e-9 * period {
            return Err(TrackError::Invalid(format!(
                "model '{}' steps every {} s, the robot '{}' commands every {} s: fit it on data of the robot's rate",
                spec.name,
                Exact(model.dt()),
                study.robot.name,
                Exact(period)
            )));
        }
    }
    for &f in &study.speeds {
        if !(f.is_finite() && f > 0.0 && f <= 1.0) {
            return Err(TrackError::Invalid(format!(
                "speed {} is not a fraction of the robot's top speed in (0, 1]",
                Exact(f)
            )));
        }
    }
    if let Some(h) = study.history_s {
        if !(h.is_finite() && (0.0..=10.0).contains(&h)) {
            return Err(TrackError::Invalid(format!(
                "history {} s is not a number of seconds in [0, 10]",
                Exact(h)
            )));
        }
    }
    for (k, &m) in study.adaptive.iter().enumerate() {
        if m >= study.models.len() || study.adaptive[..k].contains(&m) {
            return Err(TrackError::Invalid(format!(
                "an adaptive model is model {m} of {} (or listed twice)",
                study.models.len()
            )));
        }
    }
    let mut last = 0.0;
    for c in &study.ground_changes {
        if !(c.at.is_finite() && c.at > last && c.at < 1.0) {
            return Err(TrackError::Invalid(format!(
                "the ground changes at {} of the path: each change must come after the one before, within (0, 1)",
                Exact(c.at)
            )));
        }
        last = c.at;
    }
    if let Some(t) = study.time_limit_s {
        if !(t.is_finite() && t > 0.0 && t <= MAX_RUN_S) {
            return Err(TrackError::Invalid(format!(
                "time limit {} s is not a positive number of seconds of at most {MAX_RUN_S}",
                Exact(t)
            )));
        }
    }
    let protocol_runs: Vec<f64> = study
        .training
        .iter()
        .filter_map(|t| match t {
            Training::Protocol { driving_s, .. } => Some(*driving_s),
            Training::Data { .. } => None,
        })
        .collect();
    if let Some(d) = protocol_runs
        .iter()
        .find(|d| !(d.is_finite() && **d <= MAX_TRAINING_S))
    {
        return Err(TrackError::Invalid(format!(
            "a simulated training run of {} s is longer than {MAX_TRAINING_S} s",
            Exact(*d)
        )));
    }
    let total: f64 = protocol_runs.iter().sum::<f64>() * study.seeds.len() as f64;
    if total > MAX_TRAINING_TOTAL_S {
        return Err(TrackError::Invalid(format!(
            "the study simulates {} s of training driving ({} runs: samplers x seeds); at most {MAX_TRAINING_TOTAL_S} s",
            Short(total),
            protocol_runs.len() * study.seeds.len()
        )));
    }
    let runs_planned = study.models.len()
        * study.training.len()
        * study.paths.len()
        * study.speeds.len()
        * study.seeds.len();
    drive_traits::limits::at_most(
        "the study's runs (models x training x paths x speeds x seeds)",
        runs_planned as f64,
        MAX_TRACK_RUNS as f64,
        "",
    )
    .map_err(ExperimentError::from)?;
    let d = driven(&study.robot, &study.terrain)?;
    // Each ground driven onto, a twin of another vehicle or of a robot of another geometry
    // refused as the first is (the robot and its controller stay the first ground's).
    for c in &study.ground_changes {
        driven(&study.robot, &c.terrain)?;
    }
    // A plant that keeps its ground is refused before anything is simulated.
    if let Some(c) = study.ground_changes.first() {
        let simulating =
            |reason: String| TrackError::Invalid(format!("simulating {}: {reason}", d.plant.name));
        plant_for(
            &registries.simulators,
            &d.plant,
            &study.terrain,
            study.seeds[0],
        )
        .map_err(|e| simulating(e.to_string()))?
        .change_ground(&c.terrain)
        .map_err(|e| simulating(e.to_string()))?;
    }
    let mut notes = Vec::new();
    for t in &study.training {
        if let Training::Data { name, dataset } = t {
            check_data(name, dataset, &d.plant, &mut notes)?;
        }
    }
    let top = top_speed(registries, &d, &study.terrain, study.seeds[0])?;
    let scale = (4.0 * top).max(2.0);
    // The paths, presets at the scale of the top speed.
    let paths: Vec<(String, ReferencePath)> = study
        .paths
        .iter()
        .map(|p| match p {
            PathChoice::Preset(shape) => Ok((p.name(), shape.at_scale(scale)?)),
            PathChoice::Given(path) => Ok((p.name(), path.clone())),
        })
        .collect::<Result<_, PathError>>()?;
    // Every path at every speed: longer than its goal tolerance, and within the longest run
    // unless a time limit is given; before any simulation.
    for (name, path) in &paths {
        for &fraction in &study.speeds {
            TrackerConfig::new(fraction * top)
                .check_path(path)
                .map_err(|e| TrackError::Invalid(format!("path '{name}': {e}")))?;
            let limit = default_time_limit(path.length(), fraction * top);
            if study.time_limit_s.is_none() && (limit.is_nan() || limit > MAX_RUN_S) {
                return Err(TrackError::Invalid(format!(
                    "path '{name}' ({} m) at {}% of the top speed ({} m/s) would take up to {} s (twice its length at that speed, plus 20 s); a run lasts at most {MAX_RUN_S} s: give a shorter path, a higher speed or --time-limit",
                    Short(path.length()),
                    Short(100.0 * fraction),
                    Short(fraction * top),
                    Short(limit)
                )));
            }
        }
    }
    // Whether the robot can drive each path at each speed on this ground: a path it cannot
    // is reported as such, not scored as the models' fault.
    let feasible = feasibility(
        registries,
        &d,
        &study.terrain,
        study.seeds[0],
        &paths,
        &study.speeds,
        top,
    )?;
    for f in feasible.iter().filter(|f| f.feasible == Some(false)) {
        notes.push(format!(
            "{} at {}% ({} m/s) is not drivable on this ground: its sharpest turn needs {} rad/s of yaw rate ({} m/s^2 lateral), the robot reaches {} rad/s turning as hard as it can at that speed; its errors there are the path's as much as the models'",
            f.path,
            Short(100.0 * f.speed_fraction),
            Short((f.speed_m_s * 100.0).round() / 100.0),
            Short((f.yaw_rate_needed_rad_s * 100.0).round() / 100.0),
            Short((f.lateral_acceleration_needed_m_s2 * 100.0).round() / 100.0),
            Short((f.yaw_rate_reached_rad_s.unwrap_or(0.0) * 100.0).round() / 100.0),
        ));
    }
    // The training data: a dataset once, a simulated run per seed.
    let mut sets: Vec<(usize, Option<u64>, Arc<Dataset>)> = Vec::new();
    let mut runs_to_simulate = Vec::new();
    for (i, t) in study.training.iter().enumerate() {
        match t {
            Training::Data { dataset, .. } => sets.push((i, None, Arc::clone(dataset))),
            Training::Protocol { sampler, driving_s } => {
                registries
                    .samplers
                    .get(sampler)
                    .map_err(ExperimentError::from)?;
                let intervals = crate::intervals_in(*driving_s)?;
                for &seed in &study.seeds {
                    runs_to_simulate.push((
                        i,
                        seed,
                        SimRun {
                            robot: d.plant.clone(),
                            terrain: study.terrain.clone(),
                            sampler: sampler.clone(),
                            runner: RunnerConfig {
                                max_intervals: Some(intervals),
                                ..RunnerConfig::default()
                            },
                            seed,
                        },
                    ));
                }
            }
        }
    }
    let simulated: Vec<(usize, u64, Arc<Dataset>)> = runs_to_simulate
        .par_iter()
        .map(|(i, seed, run)| {
            simulate_run(registries, run).map(|s| (*i, *seed, Arc::new(s.dataset)))
        })
        .collect::<Result<_, _>>()?;
    sets.extend(simulated.into_iter().map(|(i, s, d)| (i, Some(s), d)));
    // The fits: every model on every training set.
    let fits: Vec<Fitted> = sets
        .par_iter()
        .flat_map(|(i, seed, data)| {
            (0..study.models.len())
                .into_par_iter()
                .map(move |m| (*i, *seed, Arc::clone(data), m))
        })
        .map(|(i, seed, data, m)| {
            let spec = &study.models[m];
            // A model given fitted is driven as it is.
            if let Some((_, given)) = study.given.iter().find(|(g, _)| *g == m) {
                return Ok(Fitted {
                    training: i,
                    seed,
                    model: m,
                    fitted: Arc::clone(given),
                });
            }
            let train = WindowSet {
                robot: &data.robot,
                windows: data.windows.iter().collect(),
            };
            spec.fit_uncalibrated(&train)
                .map(|model| Fitted {
                    training: i,
                    seed,
                    model: m,
                    fitted: Arc::from(model),
                })
                .map_err(|reason| TrackError::Fit {
                    model: spec.name.clone(),
                    data: data.robot.name.clone(),
                    reason,
                })
        })
        .collect::<Result<_, _>>()?;
    // A model that adapts in the loop must be composed of a powertrain and a slip model.
    if let Some(f) = fits.iter().find(|f| {
        study.adaptive.contains(&f.model)
            && drive_models::adapt::composed_of(f.fitted.as_ref()).is_none()
    }) {
        return Err(TrackError::Invalid(format!(
            "{} ({}): only a model composed of a powertrain and a slip model adapts in the loop",
            study.models[f.model].name,
            f.fitted.name()
        )));
    }
    // Every run.
    let mut plans = Vec::new();
    for (i, t) in study.training.iter().enumerate() {
        for &seed in &study.seeds {
            for (m, spec) in study.models.iter().enumerate() {
                let model = fits
                    .iter()
                    .find(|f| {
                        f.training == i
                            && f.model == m
                            && (f.seed.is_none() || f.seed == Some(seed))
                    })
                    .map(|f| &f.fitted)
                    .ok_or_else(|| TrackError::Invalid("a fit is missing".into()))?;
                for (name, path) in &paths {
                    for &fraction in &study.speeds {
                        let speed = fraction * top;
                        plans.push(RunPlan {
                            model,
                            spec,
                            train: t.label(),
                            path,
                            path_name: name.clone(),
                            fraction,
                            speed,
                            seed,
                            time_limit_s: study
                                .time_limit_s
                                .unwrap_or(default_time_limit(path.length(), speed)),
                            window_len: window_len(&sets, i),
                            adapt_robot: study
                                .adaptive
                                .contains(&m)
                                .then(|| {
                                    sets.iter()
                                        .find(|(t, _, _)| *t == i)
                                        .map(|(_, _, d)| d.robot.clone())
                                })
                                .flatten(),
                        });
                    }
                }
            }
        }
    }
    let driven: Vec<(TrackRun, Vec<String>)> = plans
        .par_iter()
        .map(|plan| {
            let run = drive(registries, study, &d, plan);
            progress();
            run
        })
        .collect::<Result<_, _>>()?;
    let mut runs = Vec::with_capacity(driven.len());
    for (run, said) in driven {
        // The controller's notes, once each (every run of a model says the same).
        for note in said {
            if !notes.contains(&note) {
                notes.push(note);
            }
        }
        runs.push(run);
    }
    for r in runs.iter().filter(|r| !r.completed) {
        notes.push(format!(
            "{} ({}) on {} at {}% seed {}: the time limit ({} s) ended the run before the end of the path",
            r.model,
            r.train,
            r.path,
            Short(100.0 * r.speed_fraction),
            r.seed,
            Short(r.duration_s)
        ));
    }
    // The powertrain model (FOPDT, no slip), when it is among the models: every model is
    // compared with it (it completes the runs the naive model does not).
    let powertrain = registries
        .models()
        .resolve("powertrain")
        .ok()
        .map(|p| p.canonical())
        .and_then(|c| study.models.iter().position(|m| m.canonical() == c));
    let mut summary = summarise(study, &runs, &feasible, powertrain, &mut notes);
    open_loop_scores(study, &runs, &sets, &fits, &mut summary);
    let start = Pose::zeros();
    Ok(TrackResult {
        robot: study.robot.name.clone(),
        terrain: study.terrain.name.clone(),
        controller: study.controller_name.clone(),
        simulator: drive_sim::simulator_used(&registries.simulators, &study.robot),
        top_speed_m_s: top,
        path_scale_m: scale,
        schedule_s: study.schedule_s,
        models: study.models.iter().map(|m| m.name.clone()).collect(),
        training: study.training.iter().map(Training::label).collect(),
        runs,
        summary,
        paths: paths
            .iter()
            .map(|(name, p)| PlacedPath {
                path: name.clone(),
                points: p.placed_at(&start).points().to_vec(),
            })
            .collect(),
        feasibility: feasible,
        notes,
        ground_changes: study
            .ground_changes
            .iter()
            .map(|c| GroundChangeAt {
                at: c.at,
                terrain: c.terrain.name.clone(),
            })
            .collect(),
    })
}

/// A run's default time limit (s): twice the path's length at its speed, plus 20 s.
fn default_time_limit(length_m: f64, speed: f64) -> f64 {
    2.0 * length_m / speed + 20.0
}
