//! `sim-fit`: identifies the simulator's controller, powertrain, terrain and sensor noise
//! from a real DRIVE dataset of a differential-drive robot, so that the simulator becomes a
//! twin of that robot on that ground.
//!
//! Each stage fits a statistic a user cares about, with argmin's Nelder-Mead:
//! 0. **Turn stall** (steady windows): how often a command starting or reversing a turn
//!    leaves the wheels turning together ([`TurnStall`](crate::TurnStall)); the stalled
//!    turn commands are left out of stages 1 and 2 when a stall is fitted (and, from
//!    stage 2, the transients that follow them).
//! 1. **Controller** (steady windows): the mean encoder velocities against the mean
//!    commands, through the controller's body-velocity gains and limits, the right side's
//!    gain and the wheel limit.
//! 2. **Powertrain** (transient windows): the encoder trajectories after a command change,
//!    a first-order response to the controller's targets with rising and falling time
//!    constants and a dead time.
//! 3. **Terrain** (steady windows): the body velocity the localization measured against the
//!    one the simulated ground gives for the same wheel speeds (forward speed and yaw rate:
//!    the steady-state slip in every input region the data covers).
//! 4. **Sensors**: the localization's update rate, noise and timestamp jitter, the
//!    encoders' and the IMU's noise and the IMU's bias, from the windows' residuals.
//!
//! 5. **Protocol**: the input space the real run sampled and whether its commands stepped
//!    or ramped ([`TwinProtocol`]).
//! 6. **Variability**: how the ground changes from moment to moment, fitted by simulating the
//!    twin, driven by the data's own commands, until its steady windows scatter as the
//!    data's ([`Scatter`]).

use crate::parameters::{
    correlation_time_for, CORRELATION_RANGE, MAX_DEAD_TIME_S, MAX_ICP_JITTER_S, MAX_ROLLING,
    MAX_VARIABILITY, MIN_ICP_RATE_HZ, MOUNT_RANGE, RIGHT_GAIN_RANGE, SLIP_MODULUS_RANGE,
    TRACTION_RANGE,
};
use crate::vehicle::{step_body, VehicleParams, VehicleState};
use crate::{
    builtin_plants, scale_difference, simulate, ControllerParams, PowertrainParams, Sensors,
    SimError, Simulation, SimulationConfig, Terrain, TwinProtocol, Variability,
};
use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use drive_models::DifferentialDrive;
use drive_samplers::RobotSpec;
use drive_samplers::{ReplaySampler, RunnerConfig, UniformSampler};
use drive_traits::InputSampler;
use drive_traits::{vehicle_as, Dataset, Input, Phase, Pose};
use serde::Serialize;
use thiserror::Error;

mod any_vehicle;
mod controller;
mod ground;
mod protocol;
mod sensors;
mod stall;
#[cfg(test)]
mod test_runs;
mod variability;

pub use any_vehicle::{check_any_vehicle_run, fit_any_vehicle, AnyVehicleFit, AnyVehicleFitReport};
use controller::*;
use ground::*;
use protocol::*;
use sensors::*;
pub use stall::TurnStallFit;
use stall::*;
#[cfg(test)]
use test_runs::husky_run;
use variability::*;
pub use variability::{command_scatter, scatter, speeds_kept, Scatter, ScatterFit};

/// Why a twin cannot be fitted.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimFitError {
    /// The data's or the robot's vehicle is not a differential drive (the skid-steer
    /// plant's).
    #[error("sim-fit fits the parameters of the skid-steer simulator (wheel speeds, track geometry, ground contact), so it needs a differential-drive dataset and robot; the {what}'s vehicle is '{vehicle}': the twin of a vehicle of another type is its ground's only (fit_any_vehicle, what drive sim-fit runs for it)")]
    NotDifferential {
        /// `data` or `robot`.
        what: &'static str,
        /// The vehicle type found.
        vehicle: String,
    },
    /// The robot's geometry is not the data's (the twin would run with the robot's).
    #[error("the robot '{robot}' has wheel radius {robot_radius} m and baseline {robot_baseline} m, the data {data_radius} m and {data_baseline} m: give a robot (file) with the data's geometry")]
    Geometry {
        /// robot name
        robot: String,
        /// robot's wheel radius
        robot_radius: f64,
        /// robot's baseline
        robot_baseline: f64,
        /// data's wheel radius
        data_radius: f64,
        /// data's baseline
        data_baseline: f64,
    },
    /// Too few usable windows of a kind.
    #[error("too few {what} to fit the {stage}: {found}, at least {needed}")]
    TooFew {
        /// windows of which kind
        what: &'static str,
        /// stage
        stage: &'static str,
        /// found
        found: usize,
        /// needed
        needed: usize,
    },
    /// The data cannot tell a twin: what a stage found, and what to look at.
    #[error("the data cannot tell a twin: {0}")]
    Unfit(String),
    /// The optimizer failed or gave a non-finite result.
    #[error("fitting the {stage}: {reason}")]
    Optimizer {
        /// stage
        stage: &'static str,
        /// cause
        reason: String,
    },
}

/// How well each stage fits, and the statistics it was fitted on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimFitReport {
    /// Steady windows used (controller, terrain, sensors).
    pub steady_windows: usize,
    /// Transient windows used (powertrain).
    pub transient_windows: usize,
    /// RMS error of the steady encoder velocities (rad/s).
    pub controller_rms: f64,
    /// RMS error of the transient encoder trajectories (rad/s).
    pub powertrain_rms: f64,
    /// RMS error of the forward speed (m/s) and yaw rate (rad/s) over the steady windows,
    /// then over the transient windows replayed with their measured wheel speeds.
    pub terrain_rms: [[f64; 2]; 2],
    /// The same before the terrain was fitted (the starting terrain).
    pub terrain_rms_start: [[f64; 2]; 2],
    /// The steady windows' scatter: real, twin without and with the fitted variability
    /// (none with fewer than 30 steady windows).
    pub scatter: Option<ScatterFit>,
    /// The mean absolute forward speed (m/s) and yaw rate (rad/s) of the steady windows:
    /// the data's, then the fitted twin's on its own runs.
    pub motion: [[f64; 2]; 2],
    /// The same of the twin without variability on its own runs (the fitted twin's when it
    /// has none).
    pub motion_without_variability: [f64; 2],
    /// Fitted values that ended at a bound of their range: what the data does not pin
    /// down (`name = value`).
    pub at_bounds: Vec<String>,
    /// The largest log deviation the variability's fit searched for each grip process
    /// (traction, lateral, rolling): the simulator's largest, or less where the twin no
    /// longer drove like itself with more (`None` without a variability fit, or once the
    /// twin dropped it: [`SimFit::without_variability`]). A process at its limit is at a
    /// bound.
    pub variability_limits: Option<[f64; 3]>,
    /// The turn stall's counts on the real run, and the stall fitted from them.
    pub turn_stall: TurnStallFit,
}

/// The twin and how it fits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimFit {
    /// The twin: ground, controller, powertrain, sensors, input space.
    pub terrain: Terrain,
    /// The fit's report.
    pub report: SimFitReport,
}

impl SimFit {
    /// The same twin without its ground's variability, its report saying so: the twin's
    /// scatter and motion those of its runs without it, no variability limits, no
    /// variability parameter at a bound. (`drive sim-fit` drops a variability that takes the
    /// twin's model errors further from the real run's: `drive_studies::choose_variability`.)
    ///
    /// ```
    /// # use drive_sim::{SimFit, SimFitReport, Terrain, Variability};
    /// let variability = Variability { traction: 0.5, lateral: 0.5, rolling: 3.0, correlation_time: 0.2 };
    /// let fit = SimFit {
    ///     terrain: Terrain { variability: Some(variability), ..Terrain::preset("gravel").unwrap() },
    ///     report: SimFitReport {
    ///         steady_windows: 200, transient_windows: 100, controller_rms: 0.1, powertrain_rms: 0.2,
    ///         terrain_rms: [[0.1; 2]; 2], terrain_rms_start: [[0.2; 2]; 2], scatter: None,
    ///         motion: [[1.0, 0.5], [1.1, 0.6]], motion_without_variability: [1.2, 0.4],
    ///         at_bounds: vec!["traction = 0.1".into(), "variability.rolling = 3".into()],
    ///         variability_limits: Some([0.5, 0.5, 3.0]), turn_stall: Default::default(),
    ///     },
    /// };
    /// let plain = fit.without_variability();
    /// assert_eq!(plain.terrain.variability, None);
    /// assert_eq!(plain.report.motion[1], [1.2, 0.4]);
    /// assert_eq!(plain.report.at_bounds, ["traction = 0.1"]);
    /// assert_eq!(plain.report.variability_limits, None);
    /// ```
    pub fn without_variability(mut self) -> SimFit {
        self.terrain.variability = None;
        let r = &mut self.report;
        if let Some(s) = r.scatter.as_mut() {
            s.twin = s.without;
        }
        r.motion[1] = r.motion_without_variability;
        r.variability_limits = None;
        r.at_bounds.retain(|b| !b.starts_with("variability."));
        self
    }
}

/// One steady window's statistics.
#[derive(Debug, Clone, Copy)]
struct Steady {
    interval: usize,
    command: Input,
    encoders: Input,
    /// Forward speed (m/s) and yaw rate (rad/s) from localization.
    body: [f64; 2],
}

/// One transient window: the command held before it, its commands and encoders, the body
/// velocity the previous window measured and its own (forward speed, yaw rate).
#[derive(Debug, Clone)]
struct Transient {
    interval: usize,
    before: Input,
    command: Vec<Input>,
    encoders: Vec<Input>,
    start_body: [f64; 2],
    body: [f64; 2],
}

/// A window's mean lateral speed (its displacement across the heading at mid-window), from
/// poses `dt` apart.
fn window_lateral(pose: &[Pose], dt: f64) -> f64 {
    let n = pose.len();
    if n < 2 {
        return 0.0;
    }
    let mut yaw = 0.0;
    for k in 1..n {
        yaw += drive_traits::wrap_angle(pose[k].z - pose[k - 1].z);
    }
    let heading = pose[0].z + yaw / 2.0;
    let (dx, dy) = (pose[n - 1].x - pose[0].x, pose[n - 1].y - pose[0].y);
    (-heading.sin() * dx + heading.cos() * dy) / ((n - 1) as f64 * dt)
}

/// A window's mean forward speed (its displacement along the heading at mid-window) and
/// yaw rate (its yaw change, unwrapped), from poses `dt` apart.
fn window_motion(pose: &[Pose], dt: f64) -> [f64; 2] {
    let n = pose.len();
    if n < 2 {
        return [0.0; 2];
    }
    let duration = (n - 1) as f64 * dt;
    let mut yaw = 0.0;
    for k in 1..n {
        yaw += drive_traits::wrap_angle(pose[k].z - pose[k - 1].z);
    }
    let (first, last) = (pose[0], pose[n - 1]);
    let heading = first.z + yaw / 2.0;
    let (dx, dy) = (last.x - first.x, last.y - first.y);
    [
        (heading.cos() * dx + heading.sin() * dy) / duration,
        yaw / duration,
    ]
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        0.0
    } else {
        s / n as f64
    }
}

/// The median of `v` ([`drive_traits::median`]), 0 when it has none (a noise or a share
/// the data cannot tell is taken as none).
fn median_or_zero(mut v: Vec<f64>) -> f64 {
    let m = drive_traits::median(&mut v);
    if m.is_finite() {
        m
    } else {
        0.0
    }
}

/// Standard deviation of `y` around its least-squares polynomial of `degree` (1 or 2) in
/// the sample index.
fn detrended_sd(y: &[f64], degree: usize) -> f64 {
    let n = y.len();
    if n <= degree + 1 {
        return 0.0;
    }
    let cols = degree + 1;
    let x = |i: usize, j: usize| (i as f64 / n as f64).powi(j as i32);
    let a = drive_traits::nalgebra::DMatrix::from_fn(n, cols, x);
    let b = drive_traits::nalgebra::DVector::from_column_slice(y);
    let Ok(sol) = a.clone().svd(true, true).solve(&b, 1e-12) else {
        return 0.0;
    };
    let r = b - a * sol;
    (r.norm_squared() / (n - cols) as f64).sqrt()
}

/// Nelder-Mead from `start` with initial steps `steps`, restarted once from its best point.
fn minimize<P: CostFunction<Param = Vec<f64>, Output = f64> + Clone>(
    problem: P,
    start: Vec<f64>,
    steps: &[f64],
    iters: u64,
    stage: &'static str,
) -> Result<Vec<f64>, SimFitError> {
    let mut p = start;
    for scale in [1.0, 0.3] {
        let mut simplex = vec![p.clone()];
        for (i, s) in steps.iter().enumerate() {
            let mut q = p.clone();
            q[i] += s * scale;
            simplex.push(q);
        }
        let fail = |e: argmin::core::Error| SimFitError::Optimizer {
            stage,
            reason: e.to_string(),
        };
        let solver = NelderMead::new(simplex)
            .with_sd_tolerance(1e-10)
            .map_err(fail)?;
        let result = Executor::new(problem.clone(), solver)
            .configure(|s| s.max_iters(iters))
            .run()
            .map_err(fail)?;
        if let Some(best) = result.state().get_best_param() {
            p = best.clone();
        }
    }
    if p.iter().all(|v| v.is_finite()) {
        Ok(p)
    } else {
        Err(SimFitError::Optimizer {
            stage,
            reason: "a parameter is not finite".into(),
        })
    }
}

/// The steady windows' statistics, and the transient windows with the command before them.
fn extract(data: &Dataset) -> (Vec<Steady>, Vec<Transient>) {
    let dt = 1.0 / data.robot.rate_hz;
    let mut steady = Vec::new();
    let mut transients = Vec::new();
    for (i, w) in data.windows.iter().enumerate() {
        let n = w.len();
        if n < 3 {
            continue;
        }
        match w.phase {
            Phase::Steady => {
                steady.push(Steady {
                    interval: w.interval,
                    command: Input::new(
                        mean(w.command.iter().map(|c| c.x)),
                        mean(w.command.iter().map(|c| c.y)),
                        0.0,
                    ),
                    encoders: Input::new(
                        mean(w.measured.iter().map(|c| c.x)),
                        mean(w.measured.iter().map(|c| c.y)),
                        0.0,
                    ),
                    body: window_motion(&w.pose, dt),
                });
            }
            Phase::Transient => {
                // The command held before: the previous window's (at its middle: the new
                // command may start in its last sample), when it is the previous interval's.
                let (before, start_body) = match i.checked_sub(1).map(|j| &data.windows[j]) {
                    Some(p) if p.interval + 1 == w.interval && !p.command.is_empty() => {
                        (p.command[p.command.len() / 2], window_motion(&p.pose, dt))
                    }
                    _ => continue,
                };
                transients.push(Transient {
                    interval: w.interval,
                    before,
                    command: w.command.clone(),
                    encoders: w.measured.clone(),
                    start_body,
                    body: window_motion(&w.pose, dt),
                });
            }
        }
    }
    (steady, transients)
}

/// Whether `data` is a real run a twin of `robot` can be fitted on or checked against:
/// the robot's geometry is the data's, the data has at least 12 steady windows and 6
/// transient windows after a previous interval, none of the quality checks' fatal findings
/// (a frozen localization, a dead encoder, ...) nor encoders and localization in different
/// units, its steady windows drive more than they turn in place, enough of its turns were
/// followed by the wheels, its steady encoder speeds follow the commands (the controller
/// stage of the fit: not swapped, sign-flipped or in other units) and its localization moves
/// the way the wheels drive (not mirrored). [`sim_fit`] asks the same; `drive sim-fit
/// --twin` asks it before checking a given twin, so that a checked twin is refused on the
/// data a fit is refused on. Data or a robot of another vehicle type than the differential
/// drive is asked what [`check_any_vehicle_run`] asks (the twin of its ground only).
///
/// ```
/// use drive_sim::{check_real_run, SimFitError};
/// let samplers = drive_samplers::builtin_robots();
/// let husky = drive_samplers::RobotSpec::load(&samplers, "husky").unwrap();
/// let warthog = drive_samplers::RobotSpec::load(&samplers, "warthog").unwrap();
/// let data = drive_traits::Dataset {
///     robot: drive_traits::RobotDescription {
///         name: "empty".into(),
///         robot: "husky".into(),
///         rate_hz: 20.0,
///         window_len: 40,
///         vehicle: husky.vehicle.clone(),
///         position_frame: Default::default(),
///         terrain: String::new(),
///         registered_robot: String::new(),
///     },
///     windows: Vec::new(),
/// };
/// // Another robot's geometry, then too few windows.
/// assert!(matches!(check_real_run(&data, &warthog), Err(SimFitError::Geometry { .. })));
/// assert!(matches!(check_real_run(&data, &husky), Err(SimFitError::TooFew { .. })));
/// ```
pub fn check_real_run(data: &Dataset, robot: &RobotSpec) -> Result<(), SimFitError> {
    // A vehicle of another type: a twin of its ground only ([`fit_any_vehicle`]).
    let differential =
        |v: &dyn drive_traits::CommandModel| vehicle_as::<DifferentialDrive>(v).is_some();
    if !differential(data.robot.vehicle.as_ref()) || !differential(robot.vehicle.as_ref()) {
        return check_any_vehicle_run(data, robot).map(|_| ());
    }
    let (g, steady, transients) = checked_run(data, robot)?;
    let (_, followed, _) = followed_runs(data, &steady, &transients)?;
    controller_stage(&g, &followed)?;
    check_direction(&steady, &g)
}

/// Stage 0: the turns the ground held at their start ([`fit_turn_stall`]), and the steady
/// and transient windows of the turns the wheels followed (the controller's and the
/// powertrain's data); refuses too few of them.
fn followed_runs(
    data: &Dataset,
    steady: &[Steady],
    transients: &[Transient],
) -> Result<(TurnStallFit, Vec<Steady>, Vec<Transient>), SimFitError> {
    let (turn_stall, stalled) = fit_turn_stall(data);
    let followed: Vec<Steady> = steady
        .iter()
        .filter(|s| !stalled.contains(&s.interval))
        .copied()
        .collect();
    // A transient replays the previous interval's command through the dead time: not one
    // that stalled either.
    let followed_transients: Vec<Transient> = transients
        .iter()
        .filter(|t| {
            !stalled.contains(&t.interval)
                && !t
                    .interval
                    .checked_sub(1)
                    .is_some_and(|p| stalled.contains(&p))
        })
        .cloned()
        .collect();
    at_least(&[
        (
            "steady windows of turns the wheels followed",
            "controller",
            followed.len(),
            12,
        ),
        (
            "transient windows of turns the wheels followed",
            "powertrain",
            followed_transients.len(),
            6,
        ),
    ])?;
    Ok((turn_stall, followed, followed_transients))
}

/// Stage 1: the controller's parameters from regression slopes and the largest speeds
/// measured, and its RMS miss (rad/s); refuses steady encoder speeds that do not follow the
/// commands (swapped or sign-flipped encoder columns, other units).
fn controller_stage(
    g: &DifferentialDrive,
    followed: &[Steady],
) -> Result<(Vec<f64>, f64), SimFitError> {
    let body = |u: Input| wheel_body(g, u);
    let slope = |i: usize| {
        let (mut xy, mut xx) = (0.0, 0.0);
        for s in followed {
            let (c, e) = (body(s.command)[i], body(s.encoders)[i]);
            xy += c * e;
            xx += c * c;
        }
        (xy / xx.max(1e-12)).clamp(0.05, 20.0)
    };
    let top = |i: usize| {
        followed
            .iter()
            .map(|s| body(s.encoders)[i].abs())
            .fold(1e-3, f64::max)
    };
    let wheel_top = followed
        .iter()
        .map(|s| s.encoders.x.abs().max(s.encoders.y.abs()))
        .fold(1e-3, f64::max);
    let start = vec![
        slope(0).ln(),
        slope(1).ln(),
        (1.05 * top(0)).ln(),
        (1.05 * top(1)).ln(),
        (1.02 * wheel_top).ln(),
        1.0,
    ];
    let cp = ControllerProblem {
        steady: followed,
        geometry: g.clone(),
    };
    let p = minimize(
        cp.clone(),
        start,
        &[0.1, 0.1, 0.1, 0.1, 0.05, 0.03],
        2000,
        "controller",
    )?;
    let controller_rms = cp.cost(&p).map_or(f64::NAN, f64::sqrt);
    let encoder_spread = spread_of(followed.iter().flat_map(|s| [s.encoders.x, s.encoders.y]));
    // NaN counts as a miss.
    if controller_rms.is_nan() || controller_rms > 0.5 * encoder_spread {
        return Err(SimFitError::Unfit(format!(
            "the steady encoder speeds do not follow the commands (the controller's fit misses by {:.3} rad/s RMS, of a spread of {:.3} rad/s): are the encoder columns swapped, or in other units?",
            controller_rms, encoder_spread
        )));
    }
    Ok((p, controller_rms))
}

/// [`check_real_run`], with the data's geometry and its steady and transient windows.
fn checked_run(
    data: &Dataset,
    robot: &RobotSpec,
) -> Result<(DifferentialDrive, Vec<Steady>, Vec<Transient>), SimFitError> {
    let not = |what, vehicle: &dyn drive_traits::CommandModel| SimFitError::NotDifferential {
        what,
        vehicle: drive_traits::vehicle_tag(vehicle).unwrap_or_else(|| format!("{vehicle:?}")),
    };
    let g: DifferentialDrive = vehicle_as(data.robot.vehicle.as_ref())
        .ok_or_else(|| not("data", data.robot.vehicle.as_ref()))?;
    let own: DifferentialDrive =
        vehicle_as(robot.vehicle.as_ref()).ok_or_else(|| not("robot", robot.vehicle.as_ref()))?;
    let off = |a: f64, b: f64| (a - b).abs() > 0.01 * b.abs();
    if off(own.wheel_radius, g.wheel_radius) || off(own.baseline, g.baseline) {
        return Err(SimFitError::Geometry {
            robot: robot.name.clone(),
            robot_radius: own.wheel_radius,
            robot_baseline: own.baseline,
            data_radius: g.wheel_radius,
            data_baseline: g.baseline,
        });
    }
    let (steady, transients) = extract(data);
    at_least(&[
        ("steady windows", "controller and terrain", steady.len(), 12),
        (
            "transient windows after a previous interval",
            "powertrain",
            transients.len(),
            6,
        ),
    ])?;
    // Data a twin cannot come from: the quality checks' fatal findings, and encoders and
    // localization in different units (positions in millimetres: the fit would run minutes
    // before finding that the speeds do not follow the wheels).
    if let Some(f) = drive_data::quality::check(data, None)
        .into_iter()
        .find(|f| {
            f.severity == drive_data::quality::Severity::Fatal
                || f.check == drive_data::quality::Check::EncoderUnits
        })
    {
        return Err(SimFitError::Unfit(format!("{} ({})", f.message, f.check)));
    }
    check_coverage(&steady, &g)?;
    Ok((g, steady, transients))
}

/// Fits a twin of the robot `robot` (its mass and build; its geometry must be the data's)
/// from `data`, named `name`: the stages of this module, each on a statistic of the data.
/// Deterministic (the variability stage's runs are seeded).
///
/// ```
/// use drive_sim::{sim_fit, SimFitError};
/// let robot = drive_samplers::RobotSpec::load(&drive_samplers::builtin_robots(), "husky").unwrap();
/// // A dataset without a window says why no twin can be fitted.
/// let empty = drive_traits::Dataset {
///     robot: drive_traits::RobotDescription {
///         name: "empty".into(),
///         robot: "husky".into(),
///         rate_hz: 20.0,
///         window_len: 40,
///         vehicle: robot.vehicle.clone(),
///         position_frame: Default::default(),
///         terrain: String::new(),
///         registered_robot: String::new(),
///     },
///     windows: Vec::new(),
/// };
/// assert!(matches!(sim_fit(&empty, &robot, "twin"), Err(SimFitError::TooFew { .. })));
/// ```
pub fn sim_fit(data: &Dataset, robot: &RobotSpec, name: &str) -> Result<SimFit, SimFitError> {
    sim_fit_with_contact_spread(data, robot, name, None)
}

/// [`sim_fit`] with the ground holding the wheels over `contact_spread` of the baseline
/// along each side ([`Terrain::contact_spread`]; the vehicle's own when `None`): the ground's
/// coefficients and its variability are fitted for that spread, and the twin keeps it.
/// `drive_studies::fit_twin` fits with the vehicle's own spread and with
/// [`CONTACT_SPREAD_CHOICES`](crate::CONTACT_SPREAD_CHOICES), and keeps another only when
/// its twin's models' errors come clearly closer to the real run's.
///
/// ```
/// use drive_sim::{sim_fit_with_contact_spread, SimFitError};
/// let robot = drive_samplers::RobotSpec::load(&drive_samplers::builtin_robots(), "husky").unwrap();
/// let empty = drive_traits::Dataset {
///     robot: drive_traits::RobotDescription {
///         name: "empty".into(),
///         robot: "husky".into(),
///         rate_hz: 20.0,
///         window_len: 40,
///         vehicle: robot.vehicle.clone(),
///         position_frame: Default::default(),
///         terrain: String::new(),
///         registered_robot: String::new(),
///     },
///     windows: Vec::new(),
/// };
/// // A spread outside the simulator's range is refused before the data is read.
/// let err = sim_fit_with_contact_spread(&empty, &robot, "twin", Some(5.0)).unwrap_err();
/// assert!(err.to_string().contains("contact spread"), "{err}");
/// ```
pub fn sim_fit_with_contact_spread(
    data: &Dataset,
    robot: &RobotSpec,
    name: &str,
    contact_spread: Option<f64>,
) -> Result<SimFit, SimFitError> {
    if let Some(s) = contact_spread {
        if !(s.is_finite() && (crate::MIN_CONTACT_SPREAD..=crate::MAX_CONTACT_SPREAD).contains(&s))
        {
            return Err(SimFitError::Unfit(format!(
                "a contact spread of {} of the baseline is outside the simulator's [{}, {}]",
                drive_traits::limits::Short(s),
                crate::MIN_CONTACT_SPREAD,
                crate::MAX_CONTACT_SPREAD
            )));
        }
    }
    let (g, steady, transients) = checked_run(data, robot)?;
    let dt = 1.0 / data.robot.rate_hz;
    // 0. The turns the ground held at their start: the commands the wheels followed are
    // the controller's and the powertrain's data (all of them when no stall is fitted).
    let (turn_stall, followed, followed_transients) = followed_runs(data, &steady, &transients)?;
    // 1. Controller, from regression slopes and the largest speeds measured.
    let (p, controller_rms) = controller_stage(&g, &followed)?;
    let (controller, limit, right) = controller_of(&p);
    // 2. Powertrain: a coarse grid, then Nelder-Mead.
    let pp = PowertrainProblem {
        transients: &followed_transients,
        geometry: g.clone(),
        controller,
        limit,
        right,
        dt,
    };
    let mut best = (f64::INFINITY, vec![0.0; 5]);
    for tau in [0.05f64, 0.2, 0.5, 1.0] {
        for delay in [0.0, 0.1, 0.2, 0.35, 0.5] {
            for linear in [0.5f64, 2.0, 1e4] {
                for angular in [0.5f64, 2.0, 1e4] {
                    let q = vec![tau.ln(), tau.ln(), delay, linear.ln(), angular.ln()];
                    let c = pp.error(&q);
                    if c < best.0 {
                        best = (c, q);
                    }
                }
            }
        }
    }
    let q = minimize(
        pp.clone(),
        best.1,
        &[0.2, 0.2, 0.05, 0.3, 0.3],
        1500,
        "powertrain",
    )?;
    let powertrain_rms = pp.error(&q).sqrt();
    let controller = pp.controller(&q);
    let mut powertrain = PowertrainParams::for_robot(robot, g.wheel_radius);
    powertrain.time_constant = [q[0].exp(), q[1].exp()];
    powertrain.dead_time = q[2].clamp(0.0, MAX_DEAD_TIME_S);
    powertrain.right_lag = 1.0;
    // The right side's gain and the wheel limit are the controller stage's.
    powertrain.right_gain = right.clamp(RIGHT_GAIN_RANGE.0, RIGHT_GAIN_RANGE.1);
    powertrain.wheel_limit = limit;
    // The encoders follow the commands (the controller's check above); the localization
    // must follow the encoders.
    check_direction(&steady, &g)?;
    // 3. Terrain, on at most 60 steady and 60 transient windows spread over the data.
    let stride = steady.len().div_ceil(60).max(1);
    let sample: Vec<Steady> = steady.iter().step_by(stride).copied().collect();
    let stride = transients.len().div_ceil(60).max(1);
    let replayed: Vec<Transient> = transients.iter().step_by(stride).cloned().collect();
    let spread = |i: usize| {
        let m = mean(sample.iter().map(|s| s.body[i]));
        mean(sample.iter().map(|s| (s.body[i] - m).powi(2)))
            .sqrt()
            .max(1e-3)
    };
    let mut spec = robot.clone();
    spec.max_speed = limit * g.wheel_radius;
    let mut params = VehicleParams::from_spec(&spec, &g);
    if let Some(share) = contact_spread {
        params = params.with_contact_spread(share);
    }
    params.powertrain = powertrain;
    let wheels: Vec<[f64; 2]> = sample.iter().map(|s| wheel_body(&g, s.encoders)).collect();
    let moved: Vec<[f64; 2]> = sample.iter().map(|s| s.body).collect();
    let tp = TerrainProblem {
        steady: &sample,
        transients: &replayed,
        params,
        dt,
        scale: [spread(0), spread(1)],
        slips: region_slips(&wheels, &moved, g.baseline),
    };
    let start = Terrain::preset("gravel").unwrap_or_else(|| TerrainProblem::terrain(&[0.0; 5]));
    let t0 = vec![
        start.traction.ln(),
        start.lateral.ln(),
        start.slip_modulus.ln(),
        start.rolling.ln(),
        start.slip_modulus.ln(),
    ];
    let terrain_rms_start = tp.errors(&TerrainProblem::terrain(&t0));
    let t = minimize(tp.clone(), t0, &[0.4, 0.4, 0.4, 0.4, 0.4], 400, "terrain")?;
    let fitted = Terrain {
        contact_spread,
        ..TerrainProblem::terrain(&t)
    };
    let terrain_rms = tp.errors(&fitted);
    for (axis, what, unit) in [(0, "forward speed", "m/s"), (1, "yaw rate", "rad/s")] {
        let miss = terrain_rms[0][axis];
        if miss.is_nan() || miss > 0.7 * tp.scale[axis] {
            return Err(SimFitError::Unfit(format!(
                "the measured {what} does not follow the wheel speeds (the ground's fit misses by {miss:.3} {unit} RMS, of a spread of {:.3} {unit}): is the localization mirrored, in other units, or another robot's?",
                tp.scale[axis]
            )));
        }
    }
    // 4. Sensors.
    let mut held = Vec::new();
    let (mut enc, mut imu_sd, mut imu_bias) = (Vec::new(), Vec::new(), Vec::new());
    for w in data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() > 4)
    {
        let n = w.len();
        let same = (1..n).filter(|&k| w.pose[k] == w.pose[k - 1]).count();
        held.push(same as f64 / (n - 1) as f64);
        let mut unwrapped = vec![w.pose[0].z];
        for k in 1..n {
            let last = unwrapped[k - 1];
            unwrapped.push(last + drive_traits::wrap_angle(w.pose[k].z - w.pose[k - 1].z));
        }
        let l: Vec<f64> = w.measured.iter().map(|m| m.x).collect();
        let r: Vec<f64> = w.measured.iter().map(|m| m.y).collect();
        enc.push(detrended_sd(&l, 1));
        enc.push(detrended_sd(&r, 1));
        imu_sd.push(detrended_sd(&w.imu_yaw_rate, 1));
        let rate = (unwrapped[n - 1] - unwrapped[0]) / ((n - 1) as f64 * dt);
        imu_bias.push(mean(w.imu_yaw_rate.iter().copied()) - rate);
    }
    let (icp_noise, icp_jitter) = localization_noise(data);
    let sensors = Sensors {
        icp_mount: localization_mount(data),
        encoder_noise: median_or_zero(enc),
        icp_rate_hz: (data.robot.rate_hz * (1.0 - median_or_zero(held)))
            .clamp(MIN_ICP_RATE_HZ, data.robot.rate_hz),
        icp_noise,
        icp_latency: 0.0,
        icp_jitter: icp_jitter.min(MAX_ICP_JITTER_S),
        imu_noise: median_or_zero(imu_sd),
        imu_bias: median_or_zero(imu_bias),
        icp_gaps: localization_gaps(data),
    };
    let protocol = fit_protocol(data, &g);
    let mut terrain = Terrain {
        name: name.to_string(),
        powertrain: Some(powertrain),
        controller: Some(controller),
        sensors: Some(sensors),
        protocol: Some(protocol),
        fitted_for: None,
        turn_stall: turn_stall.stall,
        ..fitted
    };
    // 6. Variability, by simulating the twin.
    let FittedVariability {
        variability,
        scatter,
        motion: twin_motion,
        motion_without,
        limits: variability_limits,
    } = fit_variability(data, &g, robot, &terrain)?;
    terrain.variability = variability;
    // The twin as a file: within the simulator's ranges, and driving like the data.
    Terrain::from_toml(name, &terrain.to_toml()).map_err(|e| {
        SimFitError::Unfit(format!(
            "the fitted twin is outside the simulator's ranges ({e})"
        ))
    })?;
    let motion = [steady_motion(data), twin_motion];
    for (axis, what, unit) in [(0, "forward speed", "m/s"), (1, "yaw rate", "rad/s")] {
        let (real, twin) = (motion[0][axis], motion[1][axis]);
        if !(twin >= 0.5 * real && twin <= 2.0 * real) {
            return Err(SimFitError::Unfit(format!(
                "the fitted twin does not drive like the data: its steady windows' mean absolute {what} is {twin:.3} {unit}, the data's {real:.3} {unit}"
            )));
        }
    }
    let window_s = data.robot.window_len as f64 / data.robot.rate_hz;
    let at_bounds = crate::fitted_parameters_within(&terrain, window_s, variability_limits)
        .into_iter()
        .filter(|p| p.at_bound)
        .map(|p| format!("{} = {}", p.name, drive_traits::limits::Short(p.value)))
        .collect();
    Ok(SimFit {
        terrain,
        report: SimFitReport {
            steady_windows: steady.len(),
            transient_windows: transients.len(),
            controller_rms,
            powertrain_rms,
            terrain_rms,
            terrain_rms_start,
            scatter,
            motion,
            motion_without_variability: motion_without,
            at_bounds,
            variability_limits,
            turn_stall,
        },
    })
}

/// `TooFew` for the first of `(what, stage, found, needed)` with fewer found than needed.
fn at_least(counts: &[(&'static str, &'static str, usize, usize)]) -> Result<(), SimFitError> {
    match counts.iter().find(|c| c.2 < c.3) {
        Some(&(what, stage, found, needed)) => Err(SimFitError::TooFew {
            what,
            stage,
            found,
            needed,
        }),
        None => Ok(()),
    }
}

/// The spread (standard deviation) of `values`.
fn spread_of(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.collect();
    let m = mean(v.iter().copied());
    mean(v.iter().map(|x| (x - m).powi(2))).sqrt()
}

/// The body velocity (forward speed, yaw rate) the wheel speeds `u` give (eq. 4).
fn wheel_body(g: &DifferentialDrive, u: Input) -> [f64; 2] {
    [
        g.wheel_radius * (u.x + u.y) / 2.0,
        g.wheel_radius * (u.y - u.x) / g.baseline,
    ]
}

/// A twin needs the run to have both driven and turned: at least a tenth of the steady
/// windows on each side of the turn share one half (see [`REGIONS`]).
fn check_coverage(steady: &[Steady], g: &DifferentialDrive) -> Result<(), SimFitError> {
    let turning = steady
        .iter()
        .filter(|s| {
            let [v, w] = wheel_body(g, s.encoders);
            let turn = w.abs() * g.baseline / 2.0;
            turn > v.abs()
        })
        .count();
    let share = turning as f64 / steady.len().max(1) as f64;
    if !(0.1..=0.9).contains(&share) {
        return Err(SimFitError::Unfit(format!(
            "{:.0}% of the steady windows turn more than they drive (their wheel speeds): a twin needs both, at least 10% of each (a DRIVE run over the whole input space)",
            100.0 * share
        )));
    }
    Ok(())
}

/// The localization must move the way the wheels drive: over the steady windows, the
/// slope (through the origin) of the measured forward speed and of the measured yaw rate on
/// those the wheel speeds give must be positive. A mirrored or sign-flipped localization
/// fails here, before the ground's fit (the most expensive stage) would miss it.
fn check_direction(steady: &[Steady], g: &DifferentialDrive) -> Result<(), SimFitError> {
    for (axis, what) in [(0, "forward speed"), (1, "yaw rate")] {
        let (mut xy, mut xx) = (0.0, 0.0);
        for s in steady {
            let wheels = wheel_body(g, s.encoders)[axis];
            xy += wheels * s.body[axis];
            xx += wheels * wheels;
        }
        let slope = xy / xx;
        // NaN (no motion, non-finite data) counts as a failure too.
        if slope.is_nan() || slope <= 0.0 {
            return Err(SimFitError::Unfit(format!(
                "the measured {what} goes against the one the wheel speeds give (slope {slope:.3} over the steady windows): is the localization mirrored, or another robot's?"
            )));
        }
    }
    Ok(())
}

/// The mean absolute forward speed and yaw rate of the steady windows (localization).
fn steady_motion(data: &Dataset) -> [f64; 2] {
    let dt = 1.0 / data.robot.rate_hz;
    let motions: Vec<[f64; 2]> = data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() >= 3)
        .map(|w| window_motion(&w.pose, dt))
        .collect();
    [0, 1].map(|a| mean(motions.iter().map(|m| m[a].abs())))
}
