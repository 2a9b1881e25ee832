//! Model-predictive path integral control (MPPI; Williams, Drews, Goldfain, Rehg and
//! Theodorou, "Information-theoretic model predictive control: theory and applications to
//! autonomous driving", IEEE T-RO 34(6), 2018, the path-following controller the DRIVE paper
//! takes its 2 s horizon from), over any fitted [`MotionModel`].
//!
//! At each tick:
//! 1. **Sample** `samples` input sequences of `horizon` steps around the previous plan
//!    (shifted by one step): per input axis a Gauss-Markov noise of standard deviation
//!    `noise` times the half-range of the input space, correlated from step to step by
//!    `noise_correlation`, clamped to the input space. Two candidates carry no noise: the
//!    previous plan, and stopping. Each sequence is then sent through the robot's
//!    acceleration (or input-rate) limits from the command sent last
//!    ([`drive_traits::robot::next_command`]), so every candidate is one the robot may be sent.
//! 2. **Roll out** every candidate with the model's batch rollout
//!    ([`MotionModel::predict_batch_into`]). With a history ([`ControlState::past`]), from
//!    the state of a few ticks ago through the commands sent since, then the candidate:
//!    the commands still in flight (a dead time, a lagging powertrain) then act in the
//!    prediction as they will on the robot; the body's motion measured now (the IMU's yaw
//!    rate, the localization's velocity) is the model's state at now
//!    ([`drive_traits::ObservedMotion`], with `observe_now`), and the predicted poses are
//!    moved rigidly so that the prediction of now sits at the current pose estimate.
//! 3. **Score** each: over the horizon, the squared distance to the reference in units of
//!    the length scale `l = max(speed x 1 s, 0.1 m)` times `position_weight`, plus the
//!    squared heading error times `heading_weight` (the last step both times
//!    `terminal_weight`); the squared inputs (normalised by the input space's half-range)
//!    times `effort_weight`; the squared change of the normalised input from step to step
//!    (from the command sent last) times `smoothness_weight`. With `uncertainty_weight`
//!    above 0 and a model that carries a predictive covariance
//!    ([`MotionModel::predict_with_covariance_into`]: a calibrated one), the position and
//!    heading terms are their expectations under the predicted distribution: each adds
//!    `uncertainty_weight` times the variance the rollout accumulated since now (the
//!    position covariance's trace over `l^2`, the heading variance), so that of two
//!    candidates that end as close to the path, the one the model is surer of costs less
//!    (`uncertainty_weight = 1`: the expected squared error itself).
//! 4. **Average** the candidates with weights `exp(-(S - S_min) / lambda)`; `lambda` is
//!    `temperature` times the spread of this tick's costs (their median minus their
//!    minimum), so that the same temperature works for a 1 m/s Husky and a 5 m/s Warthog.
//!    The average is the new plan; its first input is the command.
//!
//! The control-cost term of the information-theoretic derivation (`lambda u' Sigma^-1 e`)
//! is left out, as in most path-following implementations: the effort and smoothness
//! costs take its place.

use crate::controller::{
    stop_input, ControlError, ControlSetup, ControlState, Controller, InputMap, MakeController,
};
use drive_traits::limits::Short;
use drive_traits::robot::{next_command, RobotSpec, SentCommand};
use drive_traits::{wrap_angle, Input, InputSpace, MotionModel, Pose, PoseCovariance, StartState};
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Most candidate sequences per tick.
pub const MAX_SAMPLES: usize = 1 << 16;
/// Longest horizon (steps).
pub const MAX_HORIZON: usize = 1000;
/// Most candidate steps per tick (`samples x horizon`): about 60 bytes of buffers each,
/// 250 MB at this limit.
pub const MAX_SAMPLE_STEPS: usize = 1 << 22;

/// MPPI's settings: the unfitted configuration that [`MakeController::make`]s a
/// controller for a model and a robot.
///
/// ```
/// use drive_control::Mppi;
/// let m = Mppi::default();
/// assert_eq!((m.samples, m.horizon), (1024, 40)); // 1024 candidates over 2 s at 20 Hz
/// assert!(m.check().is_ok());
/// assert!(Mppi { temperature: 0.0, ..m }.check().unwrap_err().to_string().contains("temperature"));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Mppi {
    /// Candidate input sequences per tick (K).
    pub samples: usize,
    /// Steps of the horizon (40: the paper's 2 s windows at 20 Hz).
    pub horizon: usize,
    /// Temperature, relative to the spread of a tick's costs (smaller: the best candidates
    /// weigh more).
    pub temperature: f64,
    /// Standard deviation of the sampling noise per input axis, as a fraction of the
    /// input space's half-range.
    pub noise: f64,
    /// Correlation of the noise from one step to the next, in [0, 1).
    pub noise_correlation: f64,
    /// Weight of the squared position error (in units of the length scale).
    pub position_weight: f64,
    /// Weight of the squared heading error (rad^2).
    pub heading_weight: f64,
    /// Factor on the last step's position and heading costs.
    pub terminal_weight: f64,
    /// Weight of the squared normalised input.
    pub effort_weight: f64,
    /// Weight of the squared change of the normalised input per step.
    pub smoothness_weight: f64,
    /// Seed of the sampling noise (mixed with the run's, [`ControlSetup::seed`]).
    pub seed: u64,
    /// Weight of the predicted variance in the position and heading costs (0: the mean
    /// poses only; 1: their expected squared errors under the model's predictive
    /// distribution). A model without a covariance is scored on its mean poses whatever
    /// this is ([`MppiController::uses_uncertainty`]).
    pub uncertainty_weight: f64,
    /// Whether a rollout with a history takes the body's motion measured now (the IMU's
    /// yaw rate, the localization's velocity: what the model starts from) as the model's
    /// state after the history's commands ([`drive_traits::ObservedMotion`]; slip-ipem's
    /// lagging body velocity), rather than the state the history's replay ran to.
    pub observe_now: bool,
}

impl Default for Mppi {
    fn default() -> Self {
        Mppi {
            samples: 1024,
            horizon: 40,
            temperature: 0.1,
            noise: 0.25,
            noise_correlation: 0.8,
            position_weight: 1.0,
            heading_weight: 0.5,
            terminal_weight: 5.0,
            effort_weight: 0.01,
            smoothness_weight: 0.2,
            seed: 0,
            uncertainty_weight: 0.0,
            observe_now: true,
        }
    }
}

impl Mppi {
    /// Settings from a TOML text (any of the fields, the others at their defaults),
    /// checked; `file` names it in messages.
    ///
    /// ```
    /// let m = drive_control::Mppi::from_toml("m.toml", "samples = 256\nsmoothness_weight = 1.0\n").unwrap();
    /// assert_eq!((m.samples, m.smoothness_weight, m.horizon), (256, 1.0, 40));
    /// assert!(drive_control::Mppi::from_toml("m.toml", "sample = 2").unwrap_err().to_string().contains("unknown field"));
    /// ```
    pub fn from_toml(file: &str, text: &str) -> Result<Self, ControlError> {
        let m: Mppi = toml::from_str(text).map_err(|e| ControlError::BadSetting {
            field: "file",
            message: format!(
                "{file}: {}",
                drive_traits::exact::parse_message(text, e.message(), e.span().map(|s| s.start))
                    .trim()
                    .replace('\n', " ")
            ),
        })?;
        m.check()?;
        Ok(m)
    }

    /// Checks every setting's range.
    pub fn check(&self) -> Result<(), ControlError> {
        let bad =
            |field: &'static str, message: String| Err(ControlError::BadSetting { field, message });
        if !(2..=MAX_SAMPLES).contains(&self.samples) {
            return bad(
                "samples",
                format!("{} is not in 2..={MAX_SAMPLES}", self.samples),
            );
        }
        if !(1..=MAX_HORIZON).contains(&self.horizon) {
            return bad(
                "horizon",
                format!("{} steps is not in 1..={MAX_HORIZON}", self.horizon),
            );
        }
        if self.samples.saturating_mul(self.horizon) > MAX_SAMPLE_STEPS {
            return bad(
                "samples",
                format!(
                    "{} samples of {} steps is more than {MAX_SAMPLE_STEPS} candidate steps per tick",
                    self.samples, self.horizon
                ),
            );
        }
        let positive = [("temperature", self.temperature), ("noise", self.noise)];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0 && v <= 1e6) {
                return bad(
                    field,
                    format!("{} is not a positive number (at most 1e6)", Short(v)),
                );
            }
        }
        if !(self.noise_correlation.is_finite() && (0.0..1.0).contains(&self.noise_correlation)) {
            return bad(
                "noise_correlation",
                format!("{} is not in [0, 1)", Short(self.noise_correlation)),
            );
        }
        let weights = [
            ("position_weight", self.position_weight),
            ("heading_weight", self.heading_weight),
            ("terminal_weight", self.terminal_weight),
            ("effort_weight", self.effort_weight),
            ("smoothness_weight", self.smoothness_weight),
            ("uncertainty_weight", self.uncertainty_weight),
        ];
        for (field, v) in weights {
            if !(v.is_finite() && (0.0..=1e6).contains(&v)) {
                return bad(field, format!("{} is not a weight in [0, 1e6]", Short(v)));
            }
        }
        if self.position_weight == 0.0 {
            return bad(
                "position_weight",
                "0 leaves nothing to follow the path by: it must be positive".into(),
            );
        }
        Ok(())
    }
}

impl MakeController for Mppi {
    fn make(&self, setup: &ControlSetup) -> Result<Box<dyn Controller>, ControlError> {
        Ok(Box::new(MppiController::new(*self, setup)?))
    }
}

/// A running MPPI controller: its plan and its buffers (nothing is allocated per tick).
pub struct MppiController {
    config: Mppi,
    model: Arc<dyn MotionModel>,
    robot: RobotSpec,
    to_vehicle: InputMap,
    space: InputSpace,
    /// The vehicle's number of input axes.
    dim: usize,
    center: Input,
    half_range: Input,
    stop: Input,
    length_scale: f64,
    rng: Xoshiro256PlusPlus,
    plan: Vec<Input>,
    /// The candidates in the controller's coordinates, `samples x horizon`.
    candidates: Vec<Input>,
    /// The same in the vehicle's, after the commands of the history and with one more
    /// step (the last repeated, so that every command of the horizon moves a predicted
    /// pose): `samples x (history + horizon + 1)`.
    commands: Vec<Input>,
    /// Ticks of history of the current buffers.
    history: usize,
    starts: Vec<StartState>,
    poses: Vec<Pose>,
    costs: Vec<f64>,
    sorted: Vec<f64>,
    /// Whether the model gives a predictive covariance (asked once, at the start).
    has_covariance: bool,
    /// Per candidate and step of the horizon, the position covariance's trace and the
    /// heading variance accumulated since now (`samples x horizon`; empty unless the
    /// uncertainty is used).
    variances: Vec<[f64; 2]>,
}

impl std::fmt::Debug for MppiController {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MppiController")
            .field("config", &self.config)
            .field("model", &self.model.name())
            .finish_non_exhaustive()
    }
}

impl MppiController {
    /// A controller for `setup` with the settings `config` (checked), its plan at rest.
    pub fn new(config: Mppi, setup: &ControlSetup) -> Result<Self, ControlError> {
        config.check()?;
        if !(setup.speed.is_finite() && setup.speed > 0.0) {
            return Err(ControlError::BadSetting {
                field: "speed",
                message: format!("{} m/s is not a positive speed", setup.speed),
            });
        }
        let space = setup.robot.input_space();
        let dim = setup
            .robot
            .vehicle
            .input_dim()
            .min(drive_traits::MAX_INPUTS);
        let mut half_range = (space.max - space.min) * 0.5;
        if half_range
            .iter()
            .take(dim)
            .any(|h| !(h.is_finite() && *h > 0.0))
        {
            let axes: Vec<String> = (0..dim)
                .map(|i| format!("[{}, {}]", space.min[i], space.max[i]))
                .collect();
            return Err(ControlError::BadSetting {
                field: "input space",
                message: format!(
                    "the robot's input space {} is not a box of positive size",
                    axes.join(" x ")
                ),
            });
        }
        // The axes beyond the vehicle's are zero: a unit scale keeps their normalized
        // effort at zero.
        for h in half_range.iter_mut().skip(dim) {
            *h = 1.0;
        }
        let stop = stop_input(&setup.robot);
        let (k, h) = (config.samples, config.horizon);
        let has_covariance = setup
            .model
            .predict_with_covariance_into(
                &StartState::at_rest(Pose::zeros()),
                &[stop; 2],
                &mut Vec::new(),
                &mut Vec::new(),
            )
            .is_ok();
        Ok(MppiController {
            config,
            dim,
            model: Arc::clone(&setup.model),
            robot: setup.robot.clone(),
            to_vehicle: setup.to_vehicle.clone(),
            space,
            center: space.center(),
            half_range,
            stop,
            length_scale: (setup.speed * 1.0).max(0.1),
            rng: Xoshiro256PlusPlus::seed_from_u64(sampling_seed(config.seed, setup.seed)),
            plan: vec![stop; h],
            candidates: vec![Input::zeros(); k * h],
            commands: vec![Input::zeros(); k * (h + 1)],
            history: 0,
            starts: Vec::with_capacity(k),
            poses: vec![Pose::zeros(); k * (h + 1)],
            costs: vec![0.0; k],
            sorted: Vec::with_capacity(k),
            has_covariance,
            variances: Vec::new(),
        })
    }

    /// Whether the candidates are scored with the model's predicted variance: an
    /// `uncertainty_weight` above 0 and a model that gives a covariance.
    ///
    /// ```
    /// use drive_control::{ControlSetup, InputMap, Mppi, MppiController};
    /// use drive_models::{powertrain::CommandedPowertrain, slip::NoSlipModel, ComposedModel, DifferentialDrive};
    /// use std::sync::Arc;
    /// let robot = drive_traits::robot::builtin_robots().get("husky").unwrap().part().as_ref().clone();
    /// let naive = ComposedModel { label: "naive".into(), vehicle: Arc::new(DifferentialDrive::new(0.165, 0.55)),
    ///     powertrain: Box::new(CommandedPowertrain), slip: Box::new(NoSlipModel), dt: 0.05 };
    /// let setup = ControlSetup { model: Arc::new(naive), robot, to_vehicle: InputMap::identity(), speed: 0.5, seed: 0 };
    /// let asked = Mppi { samples: 8, uncertainty_weight: 1.0, ..Mppi::default() };
    /// // The naive model has no covariance: scored on its mean poses.
    /// assert!(!MppiController::new(asked, &setup).unwrap().uses_uncertainty());
    /// ```
    pub fn uses_uncertainty(&self) -> bool {
        self.has_covariance && self.config.uncertainty_weight > 0.0
    }

    /// [`Self::variances`] of every candidate: each rolled out with its covariance from
    /// `from`, the variance accumulated since now (the step after the history's `past`
    /// commands) kept per step of the horizon. The candidates on rayon's threads, each
    /// alone: the same numbers on any number of threads.
    fn roll_out_variances(&mut self, from: &StartState, past: usize) -> Result<(), ControlError> {
        let (k_n, h) = (self.config.samples, self.config.horizon);
        let len = past + h + 1;
        self.variances.resize(k_n * h, [0.0; 2]);
        let (model, commands) = (&self.model, &self.commands);
        self.variances
            .par_chunks_mut(h)
            .zip(commands.par_chunks(len))
            .try_for_each_init(
                || (Vec::new(), Vec::new()),
                |(poses, covariances), (out, candidate)| {
                    model.predict_with_covariance_into(from, candidate, poses, covariances)?;
                    let c: &Vec<PoseCovariance> = covariances;
                    if c.len() != len {
                        return Err(ControlError::BadState(format!(
                            "model '{}' gave {} covariances for {len} commands",
                            model.name(),
                            c.len()
                        )));
                    }
                    let now = &c[past];
                    let (trace0, yaw0) = (now[(0, 0)] + now[(1, 1)], now[(2, 2)]);
                    for (t, v) in out.iter_mut().enumerate() {
                        let q = &c[past + t + 1];
                        *v = [
                            (q[(0, 0)] + q[(1, 1)] - trace0).max(0.0),
                            (q[(2, 2)] - yaw0).max(0.0),
                        ];
                    }
                    Ok(())
                },
            )
    }

    /// The current plan (the inputs it expects to send over the horizon).
    pub fn plan(&self) -> &[Input] {
        &self.plan
    }

    /// Fills the candidates from the plan and the noise, within the limits from `sent`,
    /// after the commands `past` sent already.
    fn sample(&mut self, sent: &SentCommand, past: &[Input]) {
        let (k_n, h, p) = (self.config.samples, self.config.horizon, past.len());
        let len = p + h + 1;
        if self.history != p || self.commands.len() != k_n * len {
            self.history = p;
            self.commands.resize(k_n * len, Input::zeros());
            self.poses.resize(k_n * len, Pose::zeros());
        }
        let a = self.config.noise_correlation;
        let keep = (1.0 - a * a).sqrt();
        let sd = self.half_range * self.config.noise;
        for k in 0..k_n {
            self.commands[k * len..k * len + p].copy_from_slice(past);
            let mut limits = *sent;
            let mut e = Input::zeros();
            for t in 0..h {
                let target = match k {
                    0 => self.plan[t],
                    1 => self.stop,
                    _ => {
                        for i in 0..self.dim {
                            let n: f64 = StandardNormal.sample(&mut self.rng);
                            e[i] = if t == 0 {
                                sd[i] * n
                            } else {
                                a * e[i] + keep * sd[i] * n
                            };
                        }
                        self.space.clamp(&(self.plan[t] + e))
                    }
                };
                let u = self
                    .space
                    .clamp(&next_command(&self.robot, &mut limits, &target));
                self.candidates[k * h + t] = u;
                self.commands[k * len + p + t] = self.to_vehicle.apply(&u);
            }
            self.commands[k * len + p + h] = self.commands[k * len + p + h - 1];
        }
    }

    /// The cost of candidate `k` against `reference`, from the normalised input sent last,
    /// its predicted poses moved so that the prediction of now sits at `now`.
    fn cost(&self, k: usize, reference: &[Pose], last: Input, now: &Pose) -> f64 {
        let c = &self.config;
        let (h, p) = (c.horizon, self.history);
        let len = p + h + 1;
        let poses = &self.poses[k * len + p..(k + 1) * len];
        let inputs = &self.candidates[k * h..(k + 1) * h];
        let l2 = self.length_scale * self.length_scale;
        // The rigid move from the predicted now to the estimated now.
        let anchor = poses[0];
        let turn = now.z - anchor.z;
        let (sin, cos) = turn.sin_cos();
        let mut total = 0.0;
        let mut previous = last;
        for t in 0..h {
            let (q, r) = (&poses[t + 1], &reference[t.min(reference.len() - 1)]);
            let (dx, dy) = (q.x - anchor.x, q.y - anchor.y);
            let (x, y) = (now.x + cos * dx - sin * dy, now.y + sin * dx + cos * dy);
            let d2 = ((x - r.x).powi(2) + (y - r.y).powi(2)) / l2;
            let yaw = wrap_angle(q.z + turn - r.z);
            let w = if t + 1 == h { c.terminal_weight } else { 1.0 };
            // The expected squared errors: the mean's plus the predicted variance.
            let [position_var, yaw_var] = match self.variances.get(k * h + t) {
                Some(v) if self.uses_uncertainty() => [
                    c.uncertainty_weight * v[0] / l2,
                    c.uncertainty_weight * v[1],
                ],
                _ => [0.0; 2],
            };
            let u = (inputs[t] - self.center).component_div(&self.half_range);
            total += w
                * (c.position_weight * (d2 + position_var)
                    + c.heading_weight * (yaw * yaw + yaw_var))
                + c.effort_weight * u.norm_squared()
                + c.smoothness_weight * (u - previous).norm_squared();
            previous = u;
        }
        if total.is_finite() {
            total
        } else {
            f64::INFINITY
        }
    }
}

impl Controller for MppiController {
    fn name(&self) -> String {
        "mppi".into()
    }

    fn horizon(&self) -> usize {
        self.config.horizon
    }

    fn command(
        &mut self,
        state: &ControlState<'_>,
        reference: &[Pose],
    ) -> Result<Input, ControlError> {
        let (start, sent) = (&state.now, &state.sent);
        let finite = start
            .pose
            .iter()
            .chain(start.input.iter())
            .chain(start.body_velocity.iter())
            .all(|v| v.is_finite());
        if !finite {
            return Err(ControlError::BadState(format!(
                "pose {:?}, inputs {:?}",
                start.pose.as_slice(),
                start.input.as_slice()
            )));
        }
        if reference.is_empty() || reference.iter().any(|r| !r.iter().all(|v| v.is_finite())) {
            return Err(ControlError::BadSetting {
                field: "reference",
                message: "the reference must hold at least one pose of finite numbers".into(),
            });
        }
        let (k_n, h) = (self.config.samples, self.config.horizon);
        let (from, past) = match state.past {
            // What is measured now is the model's state after the commands replayed.
            Some((s, commands)) if self.config.observe_now => (
                s.with_observed(commands.len(), start.yaw_rate, start.velocity),
                commands,
            ),
            Some((s, commands)) => (s, commands),
            None => (*start, &[][..]),
        };
        self.sample(sent, past);
        self.starts.clear();
        self.starts.resize(k_n, from);
        let len = past.len() + h + 1;
        self.model
            .predict_batch_into(&self.starts, &self.commands, len, &mut self.poses)?;
        if self.uses_uncertainty() {
            self.roll_out_variances(&from, past.len())?;
        }
        let last = (sent.input - self.center).component_div(&self.half_range);
        for k in 0..k_n {
            self.costs[k] = self.cost(k, reference, last, &start.pose);
        }
        self.sorted.clear();
        self.sorted
            .extend(self.costs.iter().copied().filter(|c| c.is_finite()));
        if self.sorted.is_empty() {
            return Err(ControlError::NoFiniteCost);
        }
        let mid = self.sorted.len() / 2;
        let (_, median, _) = self.sorted.select_nth_unstable_by(mid, f64::total_cmp);
        let median = *median;
        let min = self.sorted.iter().copied().fold(f64::INFINITY, f64::min);
        let lambda = self.config.temperature * (median - min).max(1e-12 * (1.0 + min.abs()));
        let mut total = 0.0;
        for c in self.plan.iter_mut() {
            *c = Input::zeros();
        }
        for k in 0..k_n {
            let w = (-(self.costs[k] - min) / lambda).exp();
            if w > 0.0 {
                total += w;
                for t in 0..h {
                    self.plan[t] += self.candidates[k * h + t] * w;
                }
            }
        }
        // The best candidate has weight one, so the total is at least one.
        for c in self.plan.iter_mut() {
            *c /= total;
        }
        let command = self.plan[0];
        // Warm start: the plan shifted by one step, its last input held.
        self.plan.rotate_left(1);
        if h > 1 {
            self.plan[h - 1] = self.plan[h - 2];
        }
        Ok(command)
    }

    fn reset(&mut self) {
        self.plan.fill(self.stop);
    }

    fn notes(&self) -> Vec<String> {
        if self.config.uncertainty_weight > 0.0 && !self.has_covariance {
            vec![format!(
                "the model gives no predictive covariance: MPPI scored its candidates on their mean poses (uncertainty_weight {} has no effect on it)",
                Short(self.config.uncertainty_weight)
            )]
        } else {
            Vec::new()
        }
    }
}

/// The seed of the sampling noise: the settings' `own`, mixed with the run's `run` (a
/// SplitMix64 step of it, so that consecutive run seeds give unrelated streams); `own`
/// itself for run 0.
///
/// ```
/// # use drive_control::mppi::sampling_seed;
/// assert_eq!(sampling_seed(7, 0), 7);
/// assert_ne!(sampling_seed(0, 1), sampling_seed(0, 2));
/// ```
pub fn sampling_seed(own: u64, run: u64) -> u64 {
    if run == 0 {
        return own;
    }
    let mut z = run.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    own ^ z ^ (z >> 31)
}
