//! `sim-fit`: identifies the simulator's controller, powertrain, terrain and sensor noise
//! from a real DRIVE dataset of a differential-drive robot, so that the simulator becomes a
//! twin of that robot on that ground.
//!
//! Each stage fits a statistic a user cares about, with argmin's Nelder-Mead:
//! 1. **Controller** (steady windows): the mean encoder velocities against the mean
//!    commands, through the controller's body-velocity gains and limits, the right side's
//!    gain and the wheel limit.
//! 2. **Powertrain** (transient windows): the encoder trajectories after a command change,
//!    a first-order response to the controller's targets with rising and falling time
//!    constants and a dead time.
//! 3. **Terrain** (steady windows): the body velocity the localization measured against the
//!    one the simulated ground gives for the same wheel speeds (forward speed and yaw rate:
//!    the steady-state slip in every input region the data covers).
//! 4. **Sensors**: the localization's update rate and noise, the encoders' and the IMU's
//!    noise and the IMU's bias, from the windows' residuals.
//!
//! 5. **Protocol**: the input space the real run sampled and whether its commands stepped
//!    or ramped ([`TwinProtocol`]).

use crate::parameters::{
    CORRELATION_WINDOWS, MAX_DEAD_TIME_S, MAX_ROLLING, MAX_VARIABILITY, MIN_ICP_RATE_HZ,
    MOUNT_RANGE, RIGHT_GAIN_RANGE, SLIP_MODULUS_RANGE, TRACTION_RANGE,
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
use drive_samplers::{RunnerConfig, UniformSampler};
use drive_traits::InputSampler;
use drive_traits::{vehicle_as, Dataset, Input, Phase, Pose};
use serde::Serialize;
use thiserror::Error;

/// Why a twin cannot be fitted.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimFitError {
    /// The data's or the robot's vehicle is not a differential drive (the skid-steer
    /// plant's).
    #[error("sim-fit needs a differential-drive dataset and robot (the skid-steer simulator's); this vehicle is another")]
    NotDifferential,
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
    /// Fitted values that ended at a bound of their range: what the data does not pin
    /// down (`name = value`).
    pub at_bounds: Vec<String>,
}

/// The twin and how it fits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimFit {
    /// The twin: ground, controller, powertrain, sensors, input space.
    pub terrain: Terrain,
    /// The fit's report.
    pub report: SimFitReport,
}

/// One steady window's statistics.
#[derive(Debug, Clone, Copy)]
struct Steady {
    command: Input,
    encoders: Input,
    /// Forward speed (m/s) and yaw rate (rad/s) from localization.
    body: [f64; 2],
}

/// One transient window: the command held before it, its commands and encoders, the body
/// velocity the previous window measured and its own (forward speed, yaw rate).
#[derive(Debug, Clone)]
struct Transient {
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

/// The median of `v`, 0 when it has none.
fn median(mut v: Vec<f64>) -> f64 {
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

/// The controller's parameters from `p` = [ln k_v, ln k_w, ln v_max, ln w_max, ln wheel
/// limit, right gain].
fn controller_of(p: &[f64]) -> (ControllerParams, f64, f64) {
    (
        ControllerParams {
            linear_gain: p[0].exp(),
            angular_gain: p[1].exp(),
            max_linear: Some(p[2].exp()),
            max_angular: Some(p[3].exp()),
            ..Default::default()
        },
        p[4].exp(),
        p[5],
    )
}

/// The wheel targets of a command through the controller, the right side's gain and the
/// wheel limit.
fn targets(c: &ControllerParams, limit: f64, right: f64, u: Input, g: &DifferentialDrive) -> Input {
    let t = c.targets(u, g.wheel_radius, g.baseline);
    Input::new(t.x.clamp(-limit, limit), (right * t.y).clamp(-limit, limit))
}

#[derive(Clone)]
struct ControllerProblem<'a> {
    steady: &'a [Steady],
    geometry: DifferentialDrive,
}

impl CostFunction for ControllerProblem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        let (c, limit, right) = controller_of(p);
        Ok(self
            .steady
            .iter()
            .map(|s| {
                (targets(&c, limit, right, s.command, &self.geometry) - s.encoders).norm_squared()
            })
            .sum::<f64>()
            / self.steady.len().max(1) as f64)
    }
}

#[derive(Clone)]
struct PowertrainProblem<'a> {
    transients: &'a [Transient],
    geometry: DifferentialDrive,
    controller: ControllerParams,
    limit: f64,
    right: f64,
    dt: f64,
}

/// Substeps per command tick in the powertrain stage's replay.
const REPLAY_SUBSTEPS: usize = 4;

impl PowertrainProblem<'_> {
    /// The controller with the acceleration limits of `p` (none beyond 1000).
    fn controller(&self, p: &[f64]) -> ControllerParams {
        let limit = |x: f64| (x.exp() < 1e3).then(|| x.exp());
        ControllerParams {
            max_linear_acceleration: limit(p[3]),
            max_angular_acceleration: limit(p[4]),
            ..self.controller
        }
    }

    /// Mean squared error of the encoder trajectories for `p` = [ln tau_rise, ln tau_fall,
    /// dead time, ln linear acceleration limit, ln angular acceleration limit]: the commands
    /// replayed through the dead time, the controller (its output where the measured wheel
    /// speeds are at the window's start) and first-order motors from those speeds.
    fn error(&self, p: &[f64]) -> f64 {
        let (rise, fall, delay) = (p[0].exp(), p[1].exp(), p[2].clamp(0.0, 2.0));
        let c = self.controller(p);
        let (r, b) = (self.geometry.wheel_radius, self.geometry.baseline);
        let h = self.dt / REPLAY_SUBSTEPS as f64;
        let gains = [(-h / rise).exp(), (-h / fall).exp()];
        let lag = (delay / h).round() as usize;
        let (mut sum, mut n) = (0.0, 0usize);
        for w in self.transients {
            let mut e = w.encoders[0];
            // The controller's output where the wheels are (a run may resume from rest).
            let e0 = Input::new(w.encoders[0].x, w.encoders[0].y / self.right);
            let mut out = [r * (e0.x + e0.y) / 2.0, r * (e0.y - e0.x) / b];
            for k in 1..w.command.len() {
                for j in 0..REPLAY_SUBSTEPS {
                    // The command in force `delay` before this substep.
                    let at = ((k - 1) * REPLAY_SUBSTEPS + j).checked_sub(lag);
                    let u = at.map_or(w.before, |i| {
                        w.command[(i / REPLAY_SUBSTEPS).min(w.command.len() - 1)]
                    });
                    c.ramp(&mut out, c.body_target(u, r, b), h);
                    let t = ControllerParams::wheels(out, r, b);
                    let t = Input::new(
                        t.x.clamp(-self.limit, self.limit),
                        (self.right * t.y).clamp(-self.limit, self.limit),
                    );
                    for side in 0..2 {
                        let keep = if (t[side] - e[side]) * e[side] >= 0.0 {
                            gains[0]
                        } else {
                            gains[1]
                        };
                        e[side] = t[side] + (e[side] - t[side]) * keep;
                    }
                }
                sum += (e - w.encoders[k]).norm_squared();
                n += 1;
            }
        }
        sum / n.max(1) as f64
    }
}

impl CostFunction for PowertrainProblem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        Ok(self.error(p))
    }
}

#[derive(Clone)]
struct TerrainProblem<'a> {
    steady: &'a [Steady],
    transients: &'a [Transient],
    params: VehicleParams,
    dt: f64,
    /// The spread of the measured forward speeds and yaw rates: the errors' units.
    scale: [f64; 2],
    /// The measured slip per region of the input space ([`region_slips`]).
    slips: RegionSlips,
}

/// Regions of the input space by turn share (`|w| b / 2 / (|v| + |w| b / 2)` of the body
/// velocity the wheels give: 0 driving straight, 1 turning in place): quarters.
const REGIONS: usize = 4;

/// Per region, the share of the windows in it and the slopes of the forward speed and yaw
/// rate on the wheels' (through the origin): the steady-state slip of that region.
type RegionSlips = [(f64, [f64; 2]); REGIONS];

/// How much the region slips count in the ground's cost, against the per-window errors in
/// units of their spread: a slope off by 0.1 in every region weighs as a per-window error
/// of 0.2 spreads.
const REGION_WEIGHT: f64 = 4.0;

/// The steady-state slip per region, for windows whose wheels give the body velocity
/// `wheels[i]` and which moved at `moved[i]` (forward speed, yaw rate).
fn region_slips(wheels: &[[f64; 2]], moved: &[[f64; 2]], baseline: f64) -> RegionSlips {
    let mut sums = [([0.0; 2], [0.0; 2], 0usize); REGIONS];
    for (&[v, w], m) in wheels.iter().zip(moved) {
        let turn = w.abs() * baseline / 2.0;
        let share = turn / (v.abs() + turn).max(1e-9);
        let r = ((share * REGIONS as f64) as usize).min(REGIONS - 1);
        let (xy, xx, n) = &mut sums[r];
        for (axis, x) in [v, w].into_iter().enumerate() {
            xy[axis] += x * m[axis];
            xx[axis] += x * x;
        }
        *n += 1;
    }
    let total = wheels.len().max(1) as f64;
    sums.map(|(xy, xx, n)| {
        (
            n as f64 / total,
            [0, 1].map(|a| if xx[a] > 1e-12 { xy[a] / xx[a] } else { 0.0 }),
        )
    })
}

/// The physics step of the terrain stage (s).
const TERRAIN_STEP_S: f64 = 1e-3;

impl TerrainProblem<'_> {
    fn terrain(p: &[f64]) -> Terrain {
        Terrain {
            name: "fit".into(),
            traction: p[0].exp().clamp(TRACTION_RANGE.0, TRACTION_RANGE.1),
            lateral: p[1].exp().clamp(TRACTION_RANGE.0, TRACTION_RANGE.1),
            slip_modulus: p[2].exp().clamp(SLIP_MODULUS_RANGE.0, SLIP_MODULUS_RANGE.1),
            lateral_slip_modulus: Some(
                p[4].exp().clamp(SLIP_MODULUS_RANGE.0, SLIP_MODULUS_RANGE.1),
            ),
            rolling: p[3].exp().clamp(0.0, MAX_ROLLING),
            powertrain: None,
            controller: None,
            sensors: None,
            variability: None,
            protocol: None,
        }
    }

    /// The steady body velocity (forward speed, yaw rate) of the plant with its wheels held
    /// at `wheels`: settled for 1.5 s from the no-slip velocity, averaged over 0.5 s.
    fn steady_body(&self, terrain: &Terrain, wheels: Input) -> [f64; 2] {
        let p = &self.params;
        let mut state = VehicleState {
            pose: Pose::zeros(),
            velocity: [
                p.wheel_radius * (wheels.x + wheels.y) / 2.0,
                0.0,
                p.wheel_radius * (wheels.y - wheels.x) / p.baseline,
            ],
            wheels,
        };
        let (mut v, mut w, mut n) = (0.0, 0.0, 0usize);
        for k in 0..2000 {
            // The wheels held at the measured speeds (reset after each step: the motors'
            // loop is not what this stage fits).
            step_body(p, terrain, &mut state, wheels, TERRAIN_STEP_S);
            state.wheels = wheels;
            if k >= 1500 {
                v += state.velocity[0];
                w += state.velocity[2];
                n += 1;
            }
        }
        [v / n as f64, w / n as f64]
    }

    /// A transient window replayed: the body from the previous window's velocity, the
    /// wheels made to follow the measured speeds; its mean forward speed and yaw rate.
    fn transient_body(&self, terrain: &Terrain, t: &Transient) -> [f64; 2] {
        let p = &self.params;
        let [v0, w0] = t.start_body;
        let mut state = VehicleState {
            pose: Pose::zeros(),
            velocity: [v0, 0.0, w0],
            wheels: t.encoders[0],
        };
        let per_tick = (self.dt / TERRAIN_STEP_S).round().max(1.0) as usize;
        let h = self.dt / per_tick as f64;
        let mut poses = vec![state.pose];
        for k in 1..t.encoders.len() {
            for j in 0..per_tick {
                let f = (j + 1) as f64 / per_tick as f64;
                let wheels = t.encoders[k - 1] * (1.0 - f) + t.encoders[k] * f;
                step_body(p, terrain, &mut state, wheels, h);
                state.wheels = wheels;
            }
            poses.push(state.pose);
        }
        window_motion(&poses, self.dt)
    }

    /// The body velocity (forward speed, yaw rate) the wheel speeds `u` give.
    fn wheel_body(&self, u: Input) -> [f64; 2] {
        let p = &self.params;
        [
            p.wheel_radius * (u.x + u.y) / 2.0,
            p.wheel_radius * (u.y - u.x) / p.baseline,
        ]
    }

    /// The cost of a ground: the per-window errors of the steady and transient windows in
    /// units of the measured spread, and the region slips' errors (weighted by
    /// [`REGION_WEIGHT`]).
    fn cost_of(&self, terrain: &Terrain) -> f64 {
        let sims: Vec<[f64; 2]> = self
            .steady
            .iter()
            .map(|s| self.steady_body(terrain, s.encoders))
            .collect();
        // Squared error in units of the spread.
        let error = |sim: [f64; 2], real: [f64; 2]| {
            (0..2)
                .map(|a| ((sim[a] - real[a]) / self.scale[a]).powi(2))
                .sum::<f64>()
        };
        let mut c = sims
            .iter()
            .zip(self.steady)
            .map(|(&sim, s)| error(sim, s.body))
            .sum::<f64>()
            / self.steady.len().max(1) as f64;
        c += self
            .transients
            .iter()
            .map(|tr| error(self.transient_body(terrain, tr), tr.body))
            .sum::<f64>()
            / self.transients.len().max(1) as f64;
        let wheels: Vec<[f64; 2]> = self
            .steady
            .iter()
            .map(|s| self.wheel_body(s.encoders))
            .collect();
        let simulated = region_slips(&wheels, &sims, self.params.baseline);
        for ((share, real), (_, sim)) in self.slips.iter().zip(simulated) {
            c += REGION_WEIGHT * share * ((sim[0] - real[0]).powi(2) + (sim[1] - real[1]).powi(2));
        }
        c
    }

    /// RMS errors of the forward speed and yaw rate over the steady windows, then over the
    /// transient windows.
    fn errors(&self, terrain: &Terrain) -> [[f64; 2]; 2] {
        let rms = |rows: &mut dyn Iterator<Item = ([f64; 2], [f64; 2])>| {
            let (mut ev, mut ew, mut n) = (0.0, 0.0, 0usize);
            for (sim, real) in rows {
                ev += (sim[0] - real[0]).powi(2);
                ew += (sim[1] - real[1]).powi(2);
                n += 1;
            }
            let n = n.max(1) as f64;
            [(ev / n).sqrt(), (ew / n).sqrt()]
        };
        [
            rms(&mut self
                .steady
                .iter()
                .map(|s| (self.steady_body(terrain, s.encoders), s.body))),
            rms(&mut self
                .transients
                .iter()
                .map(|t| (self.transient_body(terrain, t), t.body))),
        ]
    }
}

impl CostFunction for TerrainProblem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        let c = self.cost_of(&Self::terrain(p));
        // A terrain too stiff for the step diverges: the worst cost, not a NaN.
        Ok(if c.is_finite() { c } else { 1e12 })
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
                    command: Input::new(
                        mean(w.command.iter().map(|c| c.x)),
                        mean(w.command.iter().map(|c| c.y)),
                    ),
                    encoders: Input::new(
                        mean(w.measured.iter().map(|c| c.x)),
                        mean(w.measured.iter().map(|c| c.y)),
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

/// Where the localization sits on the body: the steady windows' lateral speed regressed on
/// the yaw rate, the forward speed and their product (the last is the body's own sideslip,
/// what the ground gives); a frame `x` ahead of the centre the body turns about sees a
/// lateral speed `x w`, a frame yawed by `d` sees `-d v`. The left offset is not told
/// apart from slip (it moves the forward speed with the yaw rate): 0.
fn localization_mount(data: &Dataset) -> [f64; 3] {
    use drive_traits::nalgebra::{DMatrix, DVector};
    let dt = 1.0 / data.robot.rate_hz;
    let rows: Vec<[f64; 4]> = data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() >= 3)
        .map(|w| {
            let [v, yaw_rate] = window_motion(&w.pose, dt);
            [yaw_rate, v, v * yaw_rate, window_lateral(&w.pose, dt)]
        })
        .collect();
    if rows.len() < 12 {
        return [0.0; 3];
    }
    let x = DMatrix::from_fn(rows.len(), 3, |i, j| rows[i][j]);
    let y = DVector::from_iterator(rows.len(), rows.iter().map(|r| r[3]));
    match x.svd(true, true).solve(&y, 1e-10) {
        Ok(c) if c.iter().all(|v| v.is_finite()) => [
            c[0].clamp(-MOUNT_RANGE.0, MOUNT_RANGE.0),
            0.0,
            (-c[1]).clamp(-MOUNT_RANGE.1, MOUNT_RANGE.1),
        ],
        _ => [0.0; 3],
    }
}

/// The protocol the real run followed: the box its sampler drew from, in the geometry that
/// makes the drawn wheel speeds independent, and whether its commands stepped or ramped.
///
/// Each interval's held command (the mean of its steady windows' commands) is one draw.
/// Drawn uniformly in a box, the two wheel speeds are independent; through a protocol
/// baseline `b_p` they are `(v -+ w b_p / 2) / r` for the recorded forward speed `v` and yaw
/// rate `w`, whose covariance `var v - b_p^2 var w / 4` vanishes at `b_p = 2 sd(v) / sd(w)`.
/// From there, the baseline whose draws fill their bounding box best (see
/// [`tightest_box`]). The box's bounds are the draws' extremes widened by one expected gap (range / (n - 1)),
/// the unbiased estimate of a uniform's bounds. The commands step when, in most transient
/// windows whose command changed, one tick carries 90% of the change; otherwise they ramp,
/// at the largest body accelerations the transients show.
fn fit_protocol(data: &Dataset, g: &DifferentialDrive) -> TwinProtocol {
    let dt = 1.0 / data.robot.rate_hz;
    let body = |u: Input| {
        [
            g.wheel_radius * (u.x + u.y) / 2.0,
            g.wheel_radius * (u.y - u.x) / g.baseline,
        ]
    };
    // One draw per interval: the mean command of its steady windows.
    let mut draws: Vec<Input> = Vec::new();
    let mut last: Option<(usize, Input, usize)> = None;
    for w in data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && !w.command.is_empty())
    {
        let c = w.command.iter().sum::<Input>() / w.command.len() as f64;
        match last.as_mut() {
            Some((i, sum, n)) if *i == w.interval => {
                *sum += c;
                *n += 1;
            }
            _ => {
                if let Some((_, sum, n)) = last {
                    draws.push(sum / n as f64);
                }
                last = Some((w.interval, c, 1));
            }
        }
    }
    if let Some((_, sum, n)) = last {
        draws.push(sum / n as f64);
    }
    let sd = |i: usize| {
        let m = mean(draws.iter().map(|&u| body(u)[i]));
        mean(draws.iter().map(|&u| (body(u)[i] - m).powi(2))).sqrt()
    };
    let moments = 2.0 * sd(0) / sd(1);
    // A run that barely turned (or barely drove) cannot tell its geometry: the nominal one.
    let baseline =
        if moments.is_finite() && moments > 0.1 * g.baseline && moments < 10.0 * g.baseline {
            tightest_box(&draws, g, moments)
        } else {
            g.baseline
        };
    let gain = g.baseline / baseline;
    let (mut lo, mut hi) = (
        Input::from_element(f64::INFINITY),
        Input::from_element(f64::NEG_INFINITY),
    );
    for &u in &draws {
        let p = scale_difference(u, 1.0 / gain);
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    let gap = (hi - lo) / (draws.len().max(2) - 1) as f64;
    let (lo, hi) = (lo - gap, hi + gap);
    // Stepped or ramped: the share of a transient's change its largest tick carries.
    let (mut stepped, mut changed) = (0usize, 0usize);
    let (mut dv, mut dw) = (Vec::new(), Vec::new());
    for (i, w) in data.windows.iter().enumerate() {
        if w.phase != Phase::Transient || w.command.len() < 2 {
            continue;
        }
        let before = match i.checked_sub(1).map(|j| &data.windows[j]) {
            Some(p) if p.interval + 1 == w.interval && !p.command.is_empty() => {
                p.command[p.command.len() / 2]
            }
            _ => w.command[0],
        };
        let mut seq = vec![body(before)];
        seq.extend(w.command.iter().map(|&u| body(u)));
        let total = [
            seq[seq.len() - 1][0] - seq[0][0],
            seq[seq.len() - 1][1] - seq[0][1],
        ];
        let scale = [g.wheel_radius, g.wheel_radius * 2.0 / g.baseline];
        let size = (total[0] / scale[0]).hypot(total[1] / scale[1]);
        if size < 0.5 {
            continue;
        }
        changed += 1;
        let biggest = seq
            .windows(2)
            .map(|p| ((p[1][0] - p[0][0]) / scale[0]).hypot((p[1][1] - p[0][1]) / scale[1]))
            .fold(0.0, f64::max);
        if biggest >= 0.9 * size {
            stepped += 1;
        }
        for p in seq.windows(2) {
            dv.push((p[1][0] - p[0][0]).abs() / dt);
            dw.push((p[1][1] - p[0][1]).abs() / dt);
        }
    }
    let ramped = changed > 0 && 2 * stepped < changed;
    // The largest ramp seen; none when that axis never changed (nothing to tell).
    let largest = |v: Vec<f64>| Some(v.into_iter().fold(0.0, f64::max)).filter(|a| *a > 0.0);
    TwinProtocol {
        baseline,
        input_limits: [[lo.x, hi.x], [lo.y, hi.y]],
        max_linear_acceleration: if ramped { largest(dv) } else { None },
        max_angular_acceleration: if ramped { largest(dw) } else { None },
        robot_wheel_radius: g.wheel_radius,
        robot_baseline: g.baseline,
    }
}

/// The protocol baseline within a factor of two of `start` under which the draws' bounding
/// box in wheel speeds is smallest for the area they cover: the draws of a box fill it, and
/// a wrong baseline shears the box into a parallelogram whose bounding box is larger (the
/// covered area grows as the baseline, the map from body velocity to wheel speeds having
/// determinant `b_p / r^2`). The extremes make it sharper than the moments with ~200 draws.
fn tightest_box(draws: &[Input], g: &DifferentialDrive, start: f64) -> f64 {
    let r = g.wheel_radius;
    let body: Vec<[f64; 2]> = draws
        .iter()
        .map(|u| [r * (u.x + u.y) / 2.0, r * (u.y - u.x) / g.baseline])
        .collect();
    let cost = |b: f64| {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for [v, w] in &body {
            for (side, u) in [(v - w * b / 2.0) / r, (v + w * b / 2.0) / r]
                .into_iter()
                .enumerate()
            {
                lo[side] = lo[side].min(u);
                hi[side] = hi[side].max(u);
            }
        }
        (hi[0] - lo[0]) * (hi[1] - lo[1]) / b
    };
    // A fine grid in log space (the cost is piecewise smooth, with kinks).
    let steps = 2000;
    (0..=steps)
        .map(|i| start * (2.0f64).powf(2.0 * i as f64 / steps as f64 - 1.0))
        .map(|b| (cost(b), b))
        .fold(
            (f64::INFINITY, start),
            |best, c| if c.0 < best.0 { c } else { best },
        )
        .1
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
///     },
///     windows: Vec::new(),
/// };
/// assert!(matches!(sim_fit(&empty, &robot, "twin"), Err(SimFitError::TooFew { .. })));
/// ```
pub fn sim_fit(data: &Dataset, robot: &RobotSpec, name: &str) -> Result<SimFit, SimFitError> {
    let g: DifferentialDrive =
        vehicle_as(data.robot.vehicle.as_ref()).ok_or(SimFitError::NotDifferential)?;
    let own: DifferentialDrive =
        vehicle_as(robot.vehicle.as_ref()).ok_or(SimFitError::NotDifferential)?;
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
    let dt = 1.0 / data.robot.rate_hz;
    let (steady, transients) = extract(data);
    for (what, stage, found, needed) in [
        ("steady windows", "controller and terrain", steady.len(), 12),
        (
            "transient windows after a previous interval",
            "powertrain",
            transients.len(),
            6,
        ),
    ] {
        if found < needed {
            return Err(SimFitError::TooFew {
                what,
                stage,
                found,
                needed,
            });
        }
    }
    // Data a twin cannot come from: the quality checks' fatal findings, and encoders and
    // localization in different units (positions in millimetres: the fit would run minutes
    // before finding that the speeds do not follow the wheels).
    if let Some(f) = drive_data::quality::check(data, None)
        .into_iter()
        .find(|f| f.severity == drive_data::quality::Severity::Fatal || f.check == "encoder-units")
    {
        return Err(SimFitError::Unfit(format!("{} ({})", f.message, f.check)));
    }
    check_coverage(&steady, &g)?;
    // 1. Controller, from regression slopes and the largest speeds measured.
    let body = |u: Input| {
        [
            g.wheel_radius * (u.x + u.y) / 2.0,
            g.wheel_radius * (u.y - u.x) / g.baseline,
        ]
    };
    let slope = |i: usize| {
        let (mut xy, mut xx) = (0.0, 0.0);
        for s in &steady {
            let (c, e) = (body(s.command)[i], body(s.encoders)[i]);
            xy += c * e;
            xx += c * c;
        }
        (xy / xx.max(1e-12)).clamp(0.05, 20.0)
    };
    let top = |i: usize| {
        steady
            .iter()
            .map(|s| body(s.encoders)[i].abs())
            .fold(1e-3, f64::max)
    };
    let wheel_top = steady
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
        steady: &steady,
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
    let encoder_spread = spread_of(steady.iter().flat_map(|s| [s.encoders.x, s.encoders.y]));
    // NaN counts as a miss.
    if controller_rms.is_nan() || controller_rms > 0.5 * encoder_spread {
        return Err(SimFitError::Unfit(format!(
            "the steady encoder speeds do not follow the commands (the controller's fit misses by {:.3} rad/s RMS, of a spread of {:.3} rad/s): are the encoder columns swapped, or in other units?",
            controller_rms, encoder_spread
        )));
    }
    let (controller, limit, right) = controller_of(&p);
    // 2. Powertrain: a coarse grid, then Nelder-Mead.
    let pp = PowertrainProblem {
        transients: &transients,
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
    params.powertrain = powertrain;
    let wheels: Vec<[f64; 2]> = sample
        .iter()
        .map(|s| {
            let u = s.encoders;
            [
                g.wheel_radius * (u.x + u.y) / 2.0,
                g.wheel_radius * (u.y - u.x) / g.baseline,
            ]
        })
        .collect();
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
    let fitted = TerrainProblem::terrain(&t);
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
    let (mut pos, mut yaw, mut enc, mut imu_sd, mut imu_bias) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for w in data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() > 4)
    {
        let n = w.len();
        let same = (1..n).filter(|&k| w.pose[k] == w.pose[k - 1]).count();
        held.push(same as f64 / (n - 1) as f64);
        let xs: Vec<f64> = w.pose.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = w.pose.iter().map(|p| p.y).collect();
        let mut unwrapped = vec![w.pose[0].z];
        for k in 1..n {
            let last = unwrapped[k - 1];
            unwrapped.push(last + drive_traits::wrap_angle(w.pose[k].z - w.pose[k - 1].z));
        }
        pos.push(detrended_sd(&xs, 2));
        pos.push(detrended_sd(&ys, 2));
        yaw.push(detrended_sd(&unwrapped, 2));
        let l: Vec<f64> = w.measured.iter().map(|m| m.x).collect();
        let r: Vec<f64> = w.measured.iter().map(|m| m.y).collect();
        enc.push(detrended_sd(&l, 1));
        enc.push(detrended_sd(&r, 1));
        imu_sd.push(detrended_sd(&w.imu_yaw_rate, 1));
        let rate = (unwrapped[n - 1] - unwrapped[0]) / ((n - 1) as f64 * dt);
        imu_bias.push(mean(w.imu_yaw_rate.iter().copied()) - rate);
    }
    let sensors = Sensors {
        icp_mount: localization_mount(data),
        encoder_noise: median(enc),
        icp_rate_hz: (data.robot.rate_hz * (1.0 - median(held)))
            .clamp(MIN_ICP_RATE_HZ, data.robot.rate_hz),
        icp_noise: [median(pos), median(yaw)],
        icp_latency: 0.0,
        icp_jitter: 0.0,
        imu_noise: median(imu_sd),
        imu_bias: median(imu_bias),
    };
    let protocol = fit_protocol(data, &g);
    let mut terrain = Terrain {
        name: name.to_string(),
        powertrain: Some(powertrain),
        controller: Some(controller),
        sensors: Some(sensors),
        protocol: Some(protocol),
        ..fitted
    };
    // 6. Variability, by simulating the twin.
    let (variability, scatter, twin_motion) = fit_variability(data, &g, robot, &terrain)?;
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
    let at_bounds = at_bounds(&terrain, data.robot.window_len as f64 / data.robot.rate_hz);
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
            at_bounds,
        },
    })
}

/// The spread (standard deviation) of `values`.
fn spread_of(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.collect();
    let m = mean(v.iter().copied());
    mean(v.iter().map(|x| (x - m).powi(2))).sqrt()
}

/// A twin needs the run to have both driven and turned: at least a tenth of the steady
/// windows on each side of the turn share one half (see [`REGIONS`]).
fn check_coverage(steady: &[Steady], g: &DifferentialDrive) -> Result<(), SimFitError> {
    let turning = steady
        .iter()
        .filter(|s| {
            let (v, w) = (
                g.wheel_radius * (s.encoders.x + s.encoders.y) / 2.0,
                g.wheel_radius * (s.encoders.y - s.encoders.x) / g.baseline,
            );
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

/// The fitted values at a bound of their range (`name = value`).
fn at_bounds(t: &Terrain, window_s: f64) -> Vec<String> {
    crate::fitted_parameters(t, window_s)
        .into_iter()
        .filter(|p| p.at_bound)
        .map(|p| format!("{} = {}", p.name, drive_traits::limits::Short(p.value)))
        .collect()
}

/// How the steady windows' body velocity scatters around a smooth function of the measured
/// wheel speeds: what the grip's variability produces (see [`crate::Variability`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scatter {
    /// RMS residual of the forward speed (m/s) and of the yaw rate (rad/s) around their
    /// least-squares fit on `1, v, w, v w, v^2, w^2, |v|, |w|, v |w|, w |v|` of the body
    /// velocity the encoders give.
    pub rms: [f64; 2],
    /// Correlation of the yaw-rate residuals of an interval's consecutive steady windows.
    pub within_interval: f64,
}

/// The scatter of a dataset's steady windows; `None` with fewer than 30 of them.
///
/// On the bundled Husky data the yaw rate's is 0.143 rad/s (`drive sim-fit` prints it).
///
/// ```
/// let g = drive_models::DifferentialDrive::new(0.165, 0.55);
/// let few = drive_traits::Dataset {
///     robot: drive_traits::RobotDescription {
///         name: "few".into(),
///         robot: "husky".into(),
///         rate_hz: 20.0,
///         window_len: 40,
///         vehicle: std::sync::Arc::new(g.clone()),
///         position_frame: Default::default(),
///         terrain: String::new(),
///     },
///     windows: Vec::new(),
/// };
/// assert!(drive_sim::scatter(&few, &g).is_none());
/// ```
pub fn scatter(data: &Dataset, g: &DifferentialDrive) -> Option<Scatter> {
    use drive_traits::nalgebra::{DMatrix, DVector};
    let dt = 1.0 / data.robot.rate_hz;
    let rows: Vec<(usize, [f64; 2], [f64; 2])> = data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() >= 3)
        .map(|w| {
            let e = w.measured.iter().sum::<Input>() / w.len() as f64;
            let body = [
                g.wheel_radius * (e.x + e.y) / 2.0,
                g.wheel_radius * (e.y - e.x) / g.baseline,
            ];
            (w.interval, body, window_motion(&w.pose, dt))
        })
        .collect();
    if rows.len() < 30 {
        return None;
    }
    let basis = DMatrix::from_fn(rows.len(), 10, |i, j| {
        let [v, w] = rows[i].1;
        [
            1.0,
            v,
            w,
            v * w,
            v * v,
            w * w,
            v.abs(),
            w.abs(),
            v * w.abs(),
            w * v.abs(),
        ][j]
    });
    let svd = basis.clone().svd(true, true);
    let mut residuals = [Vec::new(), Vec::new()];
    for (axis, out) in residuals.iter_mut().enumerate() {
        let y = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.2[axis]));
        let fit = svd.solve(&y, 1e-10).ok()?;
        *out = (y - &basis * fit).iter().copied().collect();
    }
    let rms = residuals
        .each_ref()
        .map(|r| (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt());
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    let yaw = &residuals[1];
    for i in 1..rows.len() {
        if rows[i].0 == rows[i - 1].0 {
            sab += yaw[i] * yaw[i - 1];
            saa += yaw[i - 1] * yaw[i - 1];
            sbb += yaw[i] * yaw[i];
        }
    }
    let within = if saa > 0.0 && sbb > 0.0 {
        sab / (saa * sbb).sqrt()
    } else {
        0.0
    };
    Some(Scatter {
        rms,
        within_interval: within,
    })
}

/// The correlation of the means of two adjacent windows of length `t` of a stationary
/// first-order Gauss-Markov process of correlation time `tau`.
fn adjacent_window_correlation(t: f64, tau: f64) -> f64 {
    let x = t / tau;
    (1.0 - (-x).exp()).powi(2) / (2.0 * (x - 1.0 + (-x).exp()))
}

/// Holds the robot still (stands in for a sampler that cannot be built).
struct Still;

impl InputSampler for Still {
    fn next_input(&mut self) -> Input {
        Input::zeros()
    }
}

/// Seeds of the twin's runs in the variability stage.
const VARIABILITY_SEEDS: [u64; 2] = [101, 202];

/// The variability stage's outcome: the variability (if any), the scatters it was fitted
/// on, and the fitted twin's mean motion.
type FittedVariability = (Option<Variability>, Option<ScatterFit>, [f64; 2]);

/// What the twin's own runs show (as many intervals as the data, at least 100, at most
/// 300, per seed; the runs pooled): their scatter (`None` with too few steady windows) and
/// the steady windows' mean absolute forward speed and yaw rate.
struct TwinRuns {
    scatter: Option<Scatter>,
    motion: [f64; 2],
}

impl TwinRuns {
    /// The scatter, or why there is none.
    fn scatter(&self) -> Result<Scatter, SimFitError> {
        self.scatter.ok_or(SimFitError::TooFew {
            what: "steady windows in the twin's runs",
            stage: "variability",
            found: 0,
            needed: 30,
        })
    }
}

fn twin_runs(
    data: &Dataset,
    g: &DifferentialDrive,
    robot: &RobotSpec,
    terrain: &Terrain,
) -> Result<TwinRuns, SimFitError> {
    let intervals = data.interval_count().clamp(100, 300);
    let mut pooled = Dataset {
        robot: data.robot.clone(),
        windows: Vec::new(),
    };
    // The seeds' runs side by side.
    let runs: Vec<Result<Simulation, SimError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = VARIABILITY_SEEDS
            .iter()
            .map(|&seed| {
                scope.spawn(move || {
                    let config = SimulationConfig {
                        robot: robot.clone(),
                        terrain: terrain.clone(),
                        seed,
                        runner: RunnerConfig {
                            max_intervals: Some(intervals),
                            ..RunnerConfig::default()
                        },
                        events: Vec::new(),
                        name: "twin".into(),
                    };
                    let factory = move |space| -> Box<dyn InputSampler> {
                        match UniformSampler::new(space, seed) {
                            Ok(s) => Box::new(s),
                            // A protocol's box is validated non-empty; a point stands in.
                            Err(_) => Box::new(Still),
                        }
                    };
                    simulate(config, &builtin_plants(), factory, None)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join().unwrap_or_else(|_| {
                    Err(SimError::Plant {
                        robot: robot.name.clone(),
                        reason: "a twin's run panicked".into(),
                    })
                })
            })
            .collect()
    });
    for run in runs {
        let run = run.map_err(|e| SimFitError::Optimizer {
            stage: "variability",
            reason: e.to_string(),
        })?;
        let offset = pooled.windows.last().map_or(0, |w| w.interval + 1);
        pooled
            .windows
            .extend(run.dataset.windows.into_iter().map(|mut w| {
                w.interval += offset;
                w
            }));
    }
    Ok(TwinRuns {
        scatter: scatter(&pooled, g),
        motion: steady_motion(&pooled),
    })
}

/// The scatter of the twin's own runs ([`twin_runs`]).
fn twin_scatter(
    data: &Dataset,
    g: &DifferentialDrive,
    robot: &RobotSpec,
    terrain: &Terrain,
) -> Result<Scatter, SimFitError> {
    twin_runs(data, g, robot, terrain)?.scatter()
}

/// The ground's variability: the twin without it is simulated, and what its scatter lacks
/// of the real data's is added. The correlation time comes from the correlation of the
/// excess yaw-rate scatter between an interval's two steady windows; the three standard
/// deviations from the twin's response to each process alone (the scatter's variances are
/// about linear in their squares), fitted non-negative on both axes relative to what is
/// missing, then one common correction on the whole twin. `None` when the twin already
/// scatters as much as the data (within 10% in variance), or the data has too few steady
/// windows to tell. With the fitted twin's mean motion ([`TwinRuns`]).
fn fit_variability(
    data: &Dataset,
    g: &DifferentialDrive,
    robot: &RobotSpec,
    terrain: &Terrain,
) -> Result<FittedVariability, SimFitError> {
    let without = twin_runs(data, g, robot, terrain)?;
    let Some(real) = scatter(data, g) else {
        return Ok((None, None, without.motion));
    };
    let base = without.scatter()?;
    let var = |s: &Scatter| s.rms.map(|r| r * r);
    let (vr, vb) = (var(&real), var(&base));
    let excess = [(vr[0] - vb[0]).max(0.0), (vr[1] - vb[1]).max(0.0)];
    let report = |twin: Scatter| {
        Some(ScatterFit {
            real,
            without: base,
            twin,
        })
    };
    if excess[0] <= 0.1 * vr[0] && excess[1] <= 0.1 * vr[1] {
        return Ok((None, report(base), without.motion));
    }
    // The correlation time: the excess yaw-rate scatter's own correlation, inverted.
    let window = data.robot.window_len as f64 / data.robot.rate_hz;
    let rho = if excess[1] > 0.0 {
        ((real.within_interval * vr[1] - base.within_interval * vb[1]) / excess[1])
            .clamp(0.05, 0.95)
    } else {
        0.5
    };
    let (mut lo, mut hi) = (window / CORRELATION_WINDOWS, window * CORRELATION_WINDOWS);
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        // The correlation grows with the correlation time.
        if adjacent_window_correlation(window, mid) < rho {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let correlation_time = (lo * hi).sqrt();
    let with = |sd: [f64; 3]| Terrain {
        variability: Some(Variability {
            traction: sd[0],
            lateral: sd[1],
            rolling: sd[2],
            correlation_time,
        }),
        ..terrain.clone()
    };
    // What each process adds to the two variances per unit of its variance, relative to
    // the real variances (so that both axes count alike).
    let probe: f64 = 0.3;
    let mut columns = [[0.0; 2]; 3];
    for (j, column) in columns.iter_mut().enumerate() {
        let mut sd = [0.0; 3];
        sd[j] = probe;
        let got = var(&twin_scatter(data, g, robot, &with(sd))?);
        for axis in 0..2 {
            column[axis] = (got[axis] - vb[axis]).max(0.0) / (probe * probe) / vr[axis];
        }
    }
    let variances = nonnegative_fit(&columns, [excess[0] / vr[0], excess[1] / vr[1]]);
    // One correction for what the response's curvature leaves: all variances scaled by the
    // factor that best matches the excess.
    let sd = variances.map(f64::sqrt);
    let got = var(&twin_scatter(data, g, robot, &with(sd))?);
    let (num, den) = (0..2).fold((0.0, 0.0), |(n, d), axis| {
        let added = (got[axis] - vb[axis]).max(0.0) / vr[axis];
        (n + added * excess[axis] / vr[axis], d + added * added)
    });
    let k = if den > 0.0 {
        (num / den).clamp(0.25, 4.0)
    } else {
        1.0
    };
    let sd = variances.map(|v| (k * v).sqrt().min(MAX_VARIABILITY));
    let variability = Variability {
        traction: sd[0],
        lateral: sd[1],
        rolling: sd[2],
        correlation_time,
    };
    let twin = twin_runs(data, g, robot, &with(sd))?;
    Ok((Some(variability), report(twin.scatter()?), twin.motion))
}

/// Non-negative `x` (3) minimizing `|sum_j x_j columns[j] - target|` in two dimensions: the
/// best of the one- and two-column least-squares solutions that are non-negative.
fn nonnegative_fit(columns: &[[f64; 2]; 3], target: [f64; 2]) -> [f64; 3] {
    let miss = |x: &[f64; 3]| {
        (0..2)
            .map(|i| {
                let got: f64 = (0..3).map(|j| x[j] * columns[j][i]).sum();
                (got - target[i]).powi(2)
            })
            .sum::<f64>()
    };
    let mut best = ([0.0; 3], miss(&[0.0; 3]));
    let mut consider = |x: [f64; 3]| {
        if x.iter().all(|v| v.is_finite() && *v >= 0.0) {
            let m = miss(&x);
            if m < best.1 {
                best = (x, m);
            }
        }
    };
    for j in 0..3 {
        let c = columns[j];
        let norm = c[0] * c[0] + c[1] * c[1];
        if norm > 0.0 {
            let mut x = [0.0; 3];
            x[j] = (c[0] * target[0] + c[1] * target[1]) / norm;
            consider(x);
        }
    }
    for (a, b) in [(0, 1), (0, 2), (1, 2)] {
        let (p, q) = (columns[a], columns[b]);
        let det = p[0] * q[1] - q[0] * p[1];
        if det.abs() > 1e-12 {
            let mut x = [0.0; 3];
            x[a] = (target[0] * q[1] - q[0] * target[1]) / det;
            x[b] = (p[0] * target[1] - target[0] * p[1]) / det;
            consider(x);
        }
    }
    best.0
}

/// The scatter of the real data, of the twin without variability and of the fitted twin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScatterFit {
    /// The real data's.
    pub real: Scatter,
    /// The twin's before the variability was fitted.
    pub without: Scatter,
    /// The fitted twin's.
    pub twin: Scatter,
}
