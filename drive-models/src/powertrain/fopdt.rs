//! First-order plus dead time powertrain (paper eq. 3, after Seegmiller et al. 2013).
//!
//! For a command held from `t0`, eq. 3 (with the minus sign the printed exponent lacks) is
//! `w(t) = w(t0)` for `t < t0 + tau_d`, then
//! `w(t) = w_cmd + (w(t0) - w_cmd) exp(-(t - t0 - tau_d) / tau_c)`.
//! The commands arrive as a zero-order hold at the command rate, so the response is the
//! exact solution of `tau_c dw/dt = w_cmd(t - tau_d) - w` for that piecewise-constant
//! input: with `tau_d = m dt + phi`, each step is two exact exponential sub-steps, one of
//! length `phi` towards the command delayed by m + 1 samples, one of length `dt - phi`
//! towards the command delayed by m samples. For a single step command this reproduces
//! eq. 3 at every sample time. Before the window the command is taken to be the measured
//! start velocity (the wheels hold it until the delay has passed, as in eq. 3).

use super::delay::DelayLine;
use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use drive_traits::InvalidPart;
use drive_traits::{
    FitError, Input, InputSpace, Phase, Powertrain, PowertrainLearner, PowertrainStepper, Tagged,
    WindowSet, MAX_INPUTS,
};
use serde::{Deserialize, Serialize};

/// Longest time constant a powertrain file may hold (s): an hour, beyond any wheel's
/// response (the fit's own ceiling, [`Fopdt::max_time_constant`], is at most this).
pub const MAX_TIME_CONSTANT_S: f64 = 3600.0;

/// Longest dead time a powertrain file may hold (s): a minute, far beyond any drive's
/// (the fit searches up to one window).
pub const MAX_DEAD_TIME_S: f64 = 60.0;

/// The response of one input axis (one side of a skid-steer): time constant and dead time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SideResponse {
    /// Time constant tau_c (s).
    pub time_constant: f64,
    /// Dead time tau_d (s).
    pub delay: f64,
}

/// Precomputed discretization of a [`SideResponse`] at a sample period.
#[derive(Debug, Clone, Copy)]
struct Discrete {
    /// Whole samples of delay.
    m: usize,
    /// Weight of the current velocity: exp(-dt / tau_c) = e_a e_b, with
    /// e_a = exp(-phi / tau_c) and e_b = exp(-(dt - phi) / tau_c).
    own: f64,
    /// Weight of the command delayed by m + 1 samples: (1 - e_a) e_b.
    older: f64,
    /// Weight of the command delayed by m samples: 1 - e_b.
    newer: f64,
}

impl SideResponse {
    fn discrete(&self, dt: f64) -> Discrete {
        let steps = self.delay / dt;
        // Guard the floor against representation error (0.1 / 0.05 = 2.0000000000000004).
        let m = (steps + 1e-9).floor().max(0.0);
        let phi = (self.delay - m * dt).clamp(0.0, dt);
        let e_a = (-phi / self.time_constant).exp();
        let e_b = (-(dt - phi) / self.time_constant).exp();
        Discrete {
            m: m as usize,
            own: e_a * e_b,
            older: (1.0 - e_a) * e_b,
            newer: 1.0 - e_b,
        }
    }
}

/// Runs `L` independent responses in lock step (left and right sides, or several windows):
/// lane `l` follows `d[l]` from `initial[l]` under `command(l, i)` (the saturated command of
/// lane l at sample i; before the window the command is the lane's initial velocity) and
/// reports `out(l, k, w)`. Interleaving independent lanes lets the CPU overlap their
/// dependency chains; each lane's arithmetic is the same as on its own.
#[inline]
fn run_lanes<const L: usize>(
    d: &[Discrete; L],
    initial: [f64; L],
    n: usize,
    command: impl Fn(usize, usize) -> f64,
    mut out: impl FnMut(usize, usize, f64),
) {
    if n == 0 {
        return;
    }
    let mut w = initial;
    // Step j moves from sample j to j + 1 under the commands delayed by m + 1 samples
    // (`older`) then m samples (`newer`); the next step's older one is this step's newer.
    let mut older = initial;
    for (l, w) in w.iter().enumerate() {
        out(l, 0, *w);
    }
    for k in 1..n {
        let j = k - 1;
        for l in 0..L {
            let newer = if j >= d[l].m {
                command(l, j - d[l].m)
            } else {
                initial[l]
            };
            // The two exact sub-steps (towards `older` for phi, then towards `newer` for
            // dt - phi) combined: only one multiply-add stays on the dependency chain.
            w[l] = d[l].own * w[l] + (d[l].older * older[l] + d[l].newer * newer);
            out(l, k, w[l]);
            older[l] = newer;
        }
    }
}

/// A fitted FOPDT powertrain: one response per input axis (per side of a skid-steer, paper
/// Sec. III-B.1), commands saturated at the limits seen in training.
///
/// ```
/// use drive_models::powertrain::{FopdtPowertrain, SideResponse};
/// use drive_traits::{Input, InputSpace, Powertrain};
/// let side = SideResponse { time_constant: 0.5, delay: 0.1 };
/// let limits = InputSpace::new(Input::new(-5.0, -5.0, 0.0), Input::new(5.0, 5.0, 0.0)).unwrap();
/// let pt = FopdtPowertrain { axes: vec![side, side], limits, dt: 0.05 };
/// let w = pt.predict(&Input::zeros(), &vec![Input::new(4.0, 8.0, 0.0); 40]);
/// assert_eq!(w[2], Input::zeros());                                  // dead time: 0.1 s
/// let expected = 4.0 * (1.0 - (-(1.0f64 - 0.1) / 0.5).exp());         // eq. 3 at t = 1 s
/// assert!((w[20].x - expected).abs() < 1e-12);
/// assert!(w[39].y <= 5.0);                                           // saturated right side
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FopdtPowertrain {
    /// The response of each input axis (left and right side for a skid-steer), one per axis
    /// of the vehicle.
    pub axes: Vec<SideResponse>,
    /// Input limits (the commands are saturated to them).
    pub limits: InputSpace,
    /// Sample period (s).
    pub dt: f64,
}

impl Tagged for FopdtPowertrain {
    const TAG: &'static str = "fopdt";
}

#[typetag::serde(name = "fopdt")]
impl Powertrain for FopdtPowertrain {
    fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
        // The recursion of `run_lanes`, written out for the two sides (the hot path of
        // every rollout).
        predicted.clear();
        predicted.reserve(commands.len());
        if commands.is_empty() {
            return;
        }
        let (lo, hi) = (self.limits.min, self.limits.max);
        let (l, r) = match self.axes.as_slice() {
            [l, r] => (l.discrete(self.dt), r.discrete(self.dt)),
            axes => return predict_axes(axes, &self.limits, self.dt, initial, commands, predicted),
        };
        // The two sides' states as scalars; the third axis (absent) stays at its start.
        let (mut wl, mut wr, rest) = (initial.x, initial.y, initial.z);
        let (mut older_l, mut older_r) = (initial.x, initial.y);
        predicted.push(*initial);
        for j in 0..commands.len() - 1 {
            let newer_l = if j >= l.m {
                commands[j - l.m].x.clamp(lo.x, hi.x)
            } else {
                initial.x
            };
            let newer_r = if j >= r.m {
                commands[j - r.m].y.clamp(lo.y, hi.y)
            } else {
                initial.y
            };
            wl = l.own * wl + (l.older * older_l + l.newer * newer_l);
            wr = r.own * wr + (r.older * older_r + r.newer * newer_r);
            (older_l, older_r) = (newer_l, newer_r);
            predicted.push(Input::new(wl, wr, rest));
        }
    }

    fn step(&self) -> Option<f64> {
        Some(self.dt)
    }

    fn input_dim(&self) -> Option<usize> {
        Some(self.axes.len())
    }

    fn check(&self) -> Result<(), InvalidPart> {
        super::check_axes(self.axes.len(), &self.limits)?;
        for (i, r) in self.axes.iter().enumerate() {
            if !(r.time_constant.is_finite()
                && r.time_constant > 0.0
                && r.time_constant <= MAX_TIME_CONSTANT_S)
            {
                return Err(InvalidPart::from(format!(
                    "powertrain axis {i} time constant {} is not a positive number of seconds up to {MAX_TIME_CONSTANT_S}",
                    drive_traits::limits::Short(r.time_constant)
                )));
            }
            if !(r.delay.is_finite() && r.delay >= 0.0 && r.delay <= MAX_DEAD_TIME_S) {
                return Err(InvalidPart::from(format!(
                    "powertrain axis {i} delay {} is not a number of seconds in [0, {MAX_DEAD_TIME_S}]",
                    drive_traits::limits::Short(r.delay)
                )));
            }
        }
        super::check_step_and_limits(self.dt, &self.limits)
    }

    fn parameters(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for (i, r) in self.axes.iter().enumerate() {
            out.push((format!("axis {i} time constant [s]"), r.time_constant));
            out.push((format!("axis {i} dead time [s]"), r.delay));
            out.push((format!("axis {i} min"), self.limits.min[i]));
            out.push((format!("axis {i} max"), self.limits.max[i]));
        }
        out
    }

    fn stepper(&self) -> Option<Box<dyn PowertrainStepper + '_>> {
        let axes = self.axes.len().min(MAX_INPUTS);
        let d: Vec<Discrete> = self.axes[..axes]
            .iter()
            .map(|a| a.discrete(self.dt))
            .collect();
        let lags: Vec<usize> = d.iter().map(|d| d.m).collect();
        let none = Discrete {
            m: 0,
            own: 1.0,
            older: 0.0,
            newer: 0.0,
        };
        Some(Box::new(FopdtStepper {
            d: std::array::from_fn(|i| d.get(i).copied().unwrap_or(none)),
            axes,
            limits: self.limits,
            delay: DelayLine::new(&lags),
        }))
    }

    fn clone_box(&self) -> Box<dyn Powertrain> {
        Box::new(self.clone())
    }
}

/// The FOPDT stepped one command at a time: the state is the inputs reached (three
/// numbers; an axis without a response keeps the measured start, as a prediction does), the
/// commands delayed by each axis's whole-sample delay + 1 at the last step (three), then
/// the [`DelayLine`]. The same recursion as [`FopdtPowertrain::predict_into`], value for
/// value.
struct FopdtStepper {
    d: [Discrete; MAX_INPUTS],
    axes: usize,
    limits: InputSpace,
    delay: DelayLine,
}

impl PowertrainStepper for FopdtStepper {
    fn state_len(&self) -> usize {
        2 * MAX_INPUTS + self.delay.state_len()
    }

    fn init(&self, initial: &Input, history: &[Input], state: &mut [f64]) {
        let (lo, hi) = (self.limits.min, self.limits.max);
        let (w, rest) = state.split_at_mut(MAX_INPUTS);
        w.copy_from_slice(initial.as_slice());
        let (older, line) = rest.split_at_mut(MAX_INPUTS);
        let o = self
            .delay
            .init(initial, history, |a, v| v.clamp(lo[a], hi[a]), line);
        older.copy_from_slice(&o);
    }

    fn step_seq(&self, state: &mut [f64], commands: &[Input], reached: &mut [Input]) {
        if self.axes == 2 {
            return self.step_seq_two(state, commands, reached);
        }
        for (u, r) in commands.iter().zip(reached.iter_mut()) {
            *r = self.step(state, u);
        }
    }

    #[inline]
    fn step(&self, state: &mut [f64], command: &Input) -> Input {
        if self.axes == 2 {
            return self.step_two(state, command);
        }
        let (lo, hi) = (self.limits.min, self.limits.max);
        let reached = Input::new(state[0], state[1], state[2]);
        let saturated: [f64; MAX_INPUTS] = std::array::from_fn(|a| {
            if a < self.axes {
                command[a].clamp(lo[a], hi[a])
            } else {
                0.0
            }
        });
        let newer = self.delay.step(&mut state[2 * MAX_INPUTS..], &saturated);
        for (a, d) in self.d.iter().enumerate().take(self.axes) {
            let older = state[MAX_INPUTS + a];
            state[a] = d.own * state[a] + (d.older * older + d.newer * newer[a]);
            state[MAX_INPUTS + a] = newer[a];
        }
        reached
    }
}

impl FopdtStepper {
    /// [`PowertrainStepper::step_seq`] for two axes, the recursion's values in registers
    /// between steps (the ring of delayed commands in the state): the same arithmetic as
    /// [`FopdtStepper::step_two`] command after command.
    fn step_seq_two(&self, state: &mut [f64], commands: &[Input], reached: &mut [Input]) {
        let (lo, hi) = (self.limits.min, self.limits.max);
        let (l, r) = (self.d[0], self.d[1]);
        let (mut wl, mut wr, rest) = (state[0], state[1], state[2]);
        let (mut older_l, mut older_r) = (state[MAX_INPUTS], state[MAX_INPUTS + 1]);
        let line = &mut state[2 * MAX_INPUTS..];
        let (len, lag_l, lag_r) = self.delay.two_lags();
        let head = drive_traits::step::index_of(line[0], len);
        // The command `k` samples before this sequence's first (1 <= k <= len), from the ring:
        // slot (head - k) mod len (head holds the oldest), without a division.
        let before = |line: &[f64], k: usize, axis: usize| {
            let slot = if head >= k { head - k } else { head + len - k };
            line[1 + MAX_INPUTS * slot + axis]
        };
        let saturated = |u: &Input| (u.x.clamp(lo.x, hi.x), u.y.clamp(lo.y, hi.y));
        // Within the sequence the delayed command is the sequence's own (as a prediction
        // reads it); before it, the ring's.
        for (j, out) in reached.iter_mut().enumerate().take(commands.len()) {
            *out = Input::new(wl, wr, rest);
            let newer_l = if j >= lag_l {
                commands[j - lag_l].x.clamp(lo.x, hi.x)
            } else {
                before(line, lag_l - j, 0)
            };
            let newer_r = if j >= lag_r {
                commands[j - lag_r].y.clamp(lo.y, hi.y)
            } else {
                before(line, lag_r - j, 1)
            };
            wl = l.own * wl + (l.older * older_l + l.newer * newer_l);
            wr = r.own * wr + (r.older * older_r + r.newer * newer_r);
            (older_l, older_r) = (newer_l, newer_r);
        }
        // The ring after the sequence: its last `len` commands, the oldest at the head the
        // sequence's pushes leave, as step after step leaves it.
        if len > 0 {
            let n = commands.len().min(reached.len());
            let mut last = [[0.0; 2]; 64];
            let mut spill = Vec::new();
            let values: &mut [[f64; 2]] = if len <= last.len() {
                &mut last[..len]
            } else {
                spill.resize(len, [0.0; 2]);
                &mut spill
            };
            for (e, v) in values.iter_mut().enumerate() {
                // The command at index n - len + e of this sequence.
                *v = if n + e >= len {
                    let (a, b) = saturated(&commands[n + e - len]);
                    [a, b]
                } else {
                    let k = len - n - e;
                    [before(line, k, 0), before(line, k, 1)]
                };
            }
            let end = (head + n % len) % len;
            for (e, [a, b]) in values.iter().enumerate() {
                let slot = (end + e) % len;
                line[1 + MAX_INPUTS * slot..1 + MAX_INPUTS * (slot + 1)]
                    .copy_from_slice(&[*a, *b, 0.0]);
            }
            line[0] = end as f64;
        }
        state[0] = wl;
        state[1] = wr;
        state[MAX_INPUTS] = older_l;
        state[MAX_INPUTS + 1] = older_r;
    }

    /// [`PowertrainStepper::step`] written out for two axes, as the two-axis
    /// [`FopdtPowertrain::predict_into`] is (the hot path of every stepped skid-steer).
    #[inline]
    fn step_two(&self, state: &mut [f64], command: &Input) -> Input {
        let (lo, hi) = (self.limits.min, self.limits.max);
        let (l, r) = (&self.d[0], &self.d[1]);
        let reached = Input::new(state[0], state[1], state[2]);
        let (newer_l, newer_r) = self.delay.step_two(
            &mut state[2 * MAX_INPUTS..],
            command.x.clamp(lo.x, hi.x),
            command.y.clamp(lo.y, hi.y),
        );
        let (older_l, older_r) = (state[MAX_INPUTS], state[MAX_INPUTS + 1]);
        state[0] = l.own * reached.x + (l.older * older_l + l.newer * newer_l);
        state[1] = r.own * reached.y + (r.older * older_r + r.newer * newer_r);
        state[MAX_INPUTS] = newer_l;
        state[MAX_INPUTS + 1] = newer_r;
        reached
    }
}

/// [`FopdtPowertrain::predict_into`] for any number of axes (the two-axis case is written
/// out there): each axis's eq. 3 recursion in turn.
fn predict_axes(
    axes: &[SideResponse],
    limits: &InputSpace,
    dt: f64,
    initial: &Input,
    commands: &[Input],
    predicted: &mut Vec<Input>,
) {
    predicted.resize(commands.len(), *initial);
    for (i, axis) in axes.iter().enumerate().take(drive_traits::MAX_INPUTS) {
        let d = axis.discrete(dt);
        let (lo, hi) = (limits.min[i], limits.max[i]);
        let (mut w, mut older) = (initial[i], initial[i]);
        for j in 0..commands.len() - 1 {
            let newer = if j >= d.m {
                commands[j - d.m][i].clamp(lo, hi)
            } else {
                initial[i]
            };
            w = d.own * w + (d.older * older + d.newer * newer);
            older = newer;
            predicted[j + 1][i] = w;
        }
    }
}

/// The FOPDT powertrain learner (Sec. III-B.1): time constant and delay fitted
/// independently for each input axis (the left and right sides of a skid-steer) on the
/// transient windows, by least squares between predicted and measured inputs, with argmin's
/// Nelder-Mead seeded by a coarse grid. The saturation limits are the extreme measured
/// inputs of the training set.
#[derive(Debug, Clone, PartialEq)]
pub struct Fopdt {
    /// Largest time constant searched (s).
    pub max_time_constant: f64,
    /// Largest delay searched, as a fraction of the window duration.
    pub max_delay_fraction: f64,
    /// Nelder-Mead iterations.
    pub max_iters: u64,
}

impl Default for Fopdt {
    fn default() -> Self {
        Fopdt {
            max_time_constant: 20.0,
            max_delay_fraction: 0.5,
            max_iters: 300,
        }
    }
}

/// Windows fitted together: transient windows of equal length packed four to a group,
/// sample-major, so that one cost evaluation runs four independent responses in lock step.
/// Unused lanes are zero (a response from rest under a zero command stays at zero and adds
/// nothing to the error).
struct LaneGroup {
    start: [f64; 4],
    command: Vec<[f64; 4]>,
    encoder: Vec<[f64; 4]>,
}

impl LaneGroup {
    /// Packs (start velocity, saturated commands, encoder velocities) per window.
    fn pack(mut windows: Vec<(f64, Vec<f64>, Vec<f64>)>) -> Vec<LaneGroup> {
        windows.sort_by_key(|w| w.1.len());
        let mut groups: Vec<LaneGroup> = Vec::new();
        let mut lane = 4;
        for (start, command, encoder) in windows {
            let n = command.len();
            if lane == 4 || groups.last().is_some_and(|g| g.command.len() != n) {
                groups.push(LaneGroup {
                    start: [0.0; 4],
                    command: vec![[0.0; 4]; n],
                    encoder: vec![[0.0; 4]; n],
                });
                lane = 0;
            }
            // A group was pushed just above when none was open.
            let g = groups.last_mut().expect("an open group");
            g.start[lane] = start;
            for k in 0..n {
                g.command[k][lane] = command[k];
                g.encoder[k][lane] = encoder[k];
            }
            lane += 1;
        }
        groups
    }
}

/// One side's fitting problem: a plain struct, as argmin wants it.
struct SideFit {
    groups: Vec<LaneGroup>,
    dt: f64,
    min_tc: f64,
    max_tc: f64,
    max_delay: f64,
    samples: f64,
}

impl SideFit {
    fn response(&self, p: &[f64]) -> (SideResponse, f64) {
        let tc = p[0].exp();
        let td = p[1];
        let tc_c = tc.clamp(self.min_tc, self.max_tc);
        let td_c = td.clamp(0.0, self.max_delay);
        // Quadratic penalty outside the box keeps the simplex inside it.
        let penalty = (p[0] - tc_c.ln()).powi(2) + ((td - td_c) / self.dt).powi(2);
        (
            SideResponse {
                time_constant: tc_c,
                delay: td_c,
            },
            penalty,
        )
    }

    fn mse(&self, r: &SideResponse) -> f64 {
        let d = r.discrete(self.dt);
        let lanes = [d; 4];
        let mut sse = 0.0;
        for g in &self.groups {
            run_lanes(
                &lanes,
                g.start,
                g.command.len(),
                |l, i| g.command[i][l],
                |l, k, w| sse += (w - g.encoder[k][l]).powi(2),
            );
        }
        sse / self.samples
    }
}

impl CostFunction for SideFit {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> Result<f64, argmin::core::Error> {
        let (r, penalty) = self.response(p);
        let mse = self.mse(&r);
        Ok(mse * (1.0 + penalty) + penalty)
    }
}

impl Fopdt {
    pub(crate) fn validate(&self) -> Result<(), FitError> {
        if !(self.max_time_constant.is_finite()
            && self.max_time_constant > 0.0
            && self.max_time_constant <= MAX_TIME_CONSTANT_S)
        {
            return Err(FitError::InvalidHyperparameter {
                name: "max_time_constant",
                value: self.max_time_constant,
                expected: "a positive number of seconds up to 3600",
            });
        }
        if !(self.max_delay_fraction.is_finite() && (0.0..=1.0).contains(&self.max_delay_fraction))
        {
            return Err(FitError::InvalidHyperparameter {
                name: "max_delay_fraction",
                value: self.max_delay_fraction,
                expected: "a fraction in [0, 1]",
            });
        }
        Ok(())
    }

    /// Fits the response of axis `side` (commands saturated to `[lo, hi]`).
    pub(crate) fn fit_side(
        &self,
        train: &WindowSet<'_>,
        side: usize,
        lo: f64,
        hi: f64,
    ) -> Result<SideResponse, FitError> {
        let axes = train.robot.vehicle.axes();
        let axis = axes.get(side).map_or("?", |a| a.name);
        let what = format!("powertrain (axis '{axis}')");
        let dt = train.robot.dt();
        let windows: Vec<_> = train
            .of_phase(Phase::Transient)
            .map(|w| {
                (
                    w.measured[0][side],
                    w.command
                        .iter()
                        .map(|c| c[side].clamp(lo, hi))
                        .collect::<Vec<_>>(),
                    w.measured.iter().map(|e| e[side]).collect::<Vec<_>>(),
                )
            })
            .collect();
        if windows.is_empty() {
            return Err(FitError::NoTransientWindow);
        }
        let samples: usize = windows.iter().map(|w| w.1.len()).sum();
        let groups = LaneGroup::pack(windows);
        let duration = train.robot.window_len as f64 * dt;
        let problem = SideFit {
            groups,
            dt,
            // Below the longest time constant even for a command period of minutes.
            min_tc: (dt / 20.0).min(0.5 * self.max_time_constant),
            max_tc: self.max_time_constant,
            max_delay: (self.max_delay_fraction * duration).min(MAX_DEAD_TIME_S),
            samples: samples as f64,
        };
        // Coarse grid seed: time constants geometric from dt/2 to the maximum, delays every
        // sample up to the maximum.
        let mut best = (f64::INFINITY, 0.0, 0.0);
        let n_tc = 16;
        let (tc_lo, tc_hi) = ((dt / 2.0).ln(), problem.max_tc.ln());
        let n_td = ((problem.max_delay / dt).round() as usize).min(40);
        for i in 0..n_tc {
            let ln_tc = tc_lo + (tc_hi - tc_lo) * i as f64 / (n_tc - 1) as f64;
            for j in 0..=n_td {
                let td = if n_td == 0 {
                    0.0
                } else {
                    problem.max_delay * j as f64 / n_td as f64
                };
                let c = problem.mse(&SideResponse {
                    time_constant: ln_tc.exp(),
                    delay: td,
                });
                if c < best.0 {
                    best = (c, ln_tc, td);
                }
            }
        }
        // Nelder-Mead from the grid's best point, restarted once from its own best point
        // with a fresh, smaller simplex (a collapsed simplex otherwise stops short).
        let (_, ln_tc, td) = best;
        let mut p = vec![ln_tc, td];
        let mut problem = Some(problem);
        for scale in [1.0, 0.2] {
            let simplex = vec![
                p.clone(),
                vec![p[0] + 0.25 * scale, p[1]],
                vec![p[0], p[1] + 0.5 * dt * scale],
            ];
            let optimizer = |e: argmin::core::Error| FitError::Optimizer {
                what: what.clone(),
                reason: e.to_string(),
            };
            let solver = NelderMead::new(simplex)
                .with_sd_tolerance(1e-14)
                .map_err(optimizer)?;
            // `problem` is put back after every run below, so it is always present here.
            let current = problem.take().expect("the problem is returned by each run");
            let mut result = Executor::new(current, solver)
                .configure(|s| s.max_iters(self.max_iters))
                .run()
                .map_err(optimizer)?;
            if let Some(best) = result.state().get_best_param() {
                p = best.clone();
            }
            problem = result.problem.problem.take();
        }
        let problem = problem.ok_or_else(|| FitError::Optimizer {
            what: what.clone(),
            reason: "the solver returned no problem".into(),
        })?;
        let (r, _) = problem.response(&p);
        if !(r.time_constant.is_finite() && r.delay.is_finite()) {
            return Err(FitError::NonFinite { what });
        }
        Ok(r)
    }
}

impl PowertrainLearner for Fopdt {
    type Fitted = FopdtPowertrain;

    fn fit(&self, train: &WindowSet<'_>) -> Result<FopdtPowertrain, FitError> {
        self.validate()?;
        let limits = measured_limits(train)?;
        let (min, max) = (limits.min, limits.max);
        let axes = (0..train
            .robot
            .vehicle
            .input_dim()
            .min(drive_traits::MAX_INPUTS))
            .map(|i| self.fit_side(train, i, min[i], max[i]))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(FopdtPowertrain {
            axes,
            limits,
            dt: train.robot.dt(),
        })
    }
}

/// The extreme measured inputs of a training set, per axis: the saturation limits of a
/// powertrain fitted on it. Refused when an axis never changes.
pub(crate) fn measured_limits(train: &WindowSet<'_>) -> Result<InputSpace, FitError> {
    if train.is_empty() {
        return Err(FitError::EmptyTrainingSet);
    }
    let mut min = Input::repeat(f64::INFINITY);
    let mut max = Input::repeat(f64::NEG_INFINITY);
    for w in &train.windows {
        for e in &w.measured {
            min = min.inf(e);
            max = max.sup(e);
        }
    }
    let axes = train.robot.vehicle.axes();
    for (side, axis) in axes.iter().enumerate().take(drive_traits::MAX_INPUTS) {
        if min[side] >= max[side] || min[side].is_nan() || max[side].is_nan() {
            return Err(FitError::DegenerateInputs {
                what: "powertrain".into(),
                detail: format!(
                    "the measured '{}' input never changes in the training set",
                    axis.name
                ),
            });
        }
    }
    InputSpace::new(min, max).ok_or_else(|| FitError::NonFinite {
        what: "powertrain limits".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_axes_each_follow_their_own_response_as_the_two_axis_recursion_does() {
        let axes = vec![
            SideResponse {
                time_constant: 0.3,
                delay: 0.12,
            },
            SideResponse {
                time_constant: 0.7,
                delay: 0.0,
            },
            SideResponse {
                time_constant: 0.2,
                delay: 0.31,
            },
        ];
        let limits =
            InputSpace::new(Input::new(-2.0, -1.0, -3.0), Input::new(2.0, 1.0, 3.0)).unwrap();
        let commands: Vec<Input> = (0..40)
            .map(|k| {
                let t = k as f64 * 0.05;
                Input::new(3.0 * t.sin(), -0.5 + t, 4.0 * (2.0 * t).cos())
            })
            .collect();
        let start = Input::new(0.5, -0.2, 1.0);
        let three = FopdtPowertrain {
            axes: axes.clone(),
            limits,
            dt: 0.05,
        }
        .predict(&start, &commands);
        // Axes (0, 1) through the written-out two-axis recursion, axes (2, 0) likewise.
        let pair = |a: usize, b: usize| {
            let limits = InputSpace::new(
                Input::new(limits.min[a], limits.min[b], 0.0),
                Input::new(limits.max[a], limits.max[b], 0.0),
            )
            .unwrap();
            let cmd: Vec<Input> = commands
                .iter()
                .map(|u| Input::new(u[a], u[b], 0.0))
                .collect();
            FopdtPowertrain {
                axes: vec![axes[a], axes[b]],
                limits,
                dt: 0.05,
            }
            .predict(&Input::new(start[a], start[b], 0.0), &cmd)
        };
        let (first, last) = (pair(0, 1), pair(2, 0));
        for k in 0..40 {
            assert!((three[k].x - first[k].x).abs() < 1e-12, "{k}");
            assert!((three[k].y - first[k].y).abs() < 1e-12, "{k}");
            assert!((three[k].z - last[k].x).abs() < 1e-12, "{k}");
        }
        // The third axis moved, saturated at its limit.
        assert!(three[39].z.abs() <= 3.0 && three.iter().any(|u| u.z != start.z));
        // A file's powertrain of two responses for a box of three axes is refused.
        let short = FopdtPowertrain {
            axes: axes[..2].to_vec(),
            limits,
            dt: 0.05,
        };
        assert!(short.check().unwrap_err().contains("2 axis responses"));
    }

    #[test]
    fn matches_eq3_for_a_step_with_fractional_delay() {
        let r = SideResponse {
            time_constant: 0.37,
            delay: 0.123,
        };
        let dt = 0.05;
        let mut out = vec![0.0; 40];
        run_lanes(
            &[r.discrete(dt)],
            [1.0],
            40,
            |_, _| 5.0,
            |_, k, w| out[k] = w,
        );
        for (k, w) in out.iter().enumerate() {
            let t = k as f64 * dt;
            let expected = if t < r.delay {
                1.0
            } else {
                5.0 + (1.0 - 5.0) * (-(t - r.delay) / r.time_constant).exp()
            };
            assert!((w - expected).abs() < 1e-12, "k = {k}: {w} vs {expected}");
        }
    }

    #[test]
    fn two_side_prediction_equals_the_lane_recursion() {
        let pt = FopdtPowertrain {
            axes: vec![
                SideResponse {
                    time_constant: 0.3,
                    delay: 0.17,
                },
                SideResponse {
                    time_constant: 0.9,
                    delay: 0.0,
                },
            ],
            limits: InputSpace::new(Input::new(-3.0, -2.0, 0.0), Input::new(3.0, 2.5, 0.0))
                .unwrap(),
            dt: 0.05,
        };
        let cmds: Vec<Input> = (0..40)
            .map(|k| {
                Input::new(
                    (k as f64 * 0.7).sin() * 5.0,
                    (k as f64 * 0.3).cos() * 4.0,
                    0.0,
                )
            })
            .collect();
        let start = Input::new(0.4, -0.2, 0.0);
        let got = pt.predict(&start, &cmds);
        let mut want = vec![Input::zeros(); 40];
        let d = [pt.axes[0].discrete(pt.dt), pt.axes[1].discrete(pt.dt)];
        run_lanes(
            &d,
            [start.x, start.y],
            40,
            |l, i| cmds[i][l].clamp(pt.limits.min[l], pt.limits.max[l]),
            |l, k, w| want[k][l] = w,
        );
        assert_eq!(got, want);
    }

    #[test]
    fn zero_delay_first_order_lag() {
        let r = SideResponse {
            time_constant: 0.1,
            delay: 0.0,
        };
        let mut out = [0.0; 3];
        run_lanes(
            &[r.discrete(0.1)],
            [0.0],
            3,
            |_, _| 1.0,
            |_, k, w| out[k] = w,
        );
        let e = (-1.0f64).exp();
        assert!((out[1] - (1.0 - e)).abs() < 1e-15);
        assert!((out[2] - (1.0 - e * e)).abs() < 1e-15);
    }
}
