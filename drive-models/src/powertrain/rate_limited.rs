//! A rate-limited first-order powertrain with dead time: the FOPDT of eq. 3 whose rate of
//! change is bounded, as a motor controller with an acceleration limit behaves (the DRIVE
//! schedule itself respects acceleration limits, Sec. III-A).
//!
//! Per axis, `dw/dt = clamp((u(t - tau_d) - w) / tau_c, -a, a)`: far from the command the
//! input ramps at the rate limit `a`, close to it (within `a tau_c`) it settles as a
//! first-order lag. With `a` large it is the FOPDT. Commands are a zero-order hold at the
//! command rate, and each step is solved exactly for that input (a ramp, then an
//! exponential), with the fractional delay handled as in the FOPDT: two sub-steps per
//! sample, towards the command delayed by `m + 1` samples then by `m` samples.

use super::delay::DelayLine;
use super::fopdt::{measured_limits, Fopdt};
use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use drive_traits::InvalidPart;
use drive_traits::{
    FitError, Input, InputSpace, Phase, Powertrain, PowertrainLearner, PowertrainStepper, Tagged,
    WindowSet, MAX_INPUTS,
};
use serde::{Deserialize, Serialize};

/// The response of one input axis: time constant, dead time and rate limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RateLimitedResponse {
    /// Time constant tau_c (s).
    pub time_constant: f64,
    /// Dead time tau_d (s).
    pub delay: f64,
    /// Largest rate of change `a` (input units per second: rad/s^2 for wheel velocities).
    pub max_rate: f64,
}

impl RateLimitedResponse {
    /// The input after `h` seconds from `w` towards a command `u` held constant.
    ///
    /// ```
    /// use drive_models::powertrain::RateLimitedResponse;
    /// let r = RateLimitedResponse { time_constant: 0.5, delay: 0.0, max_rate: 2.0 };
    /// // Far from the command: a ramp at the rate limit.
    /// assert!((r.step(0.0, 10.0, 1.0) - 2.0).abs() < 1e-12);
    /// // Within a tau_c = 1 of the command: the first-order lag.
    /// assert!((r.step(0.0, 0.5, 1.0) - 0.5 * (1.0 - (-2.0f64).exp())).abs() < 1e-12);
    /// ```
    #[inline]
    pub fn step(&self, w: f64, u: f64, h: f64) -> f64 {
        let e = u - w;
        let boundary = self.max_rate * self.time_constant;
        let mut w = w;
        let mut h = h;
        if e.abs() > boundary {
            // Ramp at the limit until the error is down to the boundary.
            let ramp = (e.abs() - boundary) / self.max_rate;
            if ramp >= h {
                return w + e.signum() * self.max_rate * h;
            }
            w = u - e.signum() * boundary;
            h -= ramp;
        }
        u - (u - w) * (-h / self.time_constant).exp()
    }

    /// The whole-sample part `m` and the fractional part `phi` of the dead time at step `dt`.
    fn delay_parts(&self, dt: f64) -> (usize, f64) {
        // Guard the floor against representation error (0.1 / 0.05 = 2.0000000000000004).
        let m = (self.delay / dt + 1e-9).floor().max(0.0);
        let phi = (self.delay - m * dt).clamp(0.0, dt);
        (m as usize, phi)
    }

    /// Runs the response from `initial` under `command(i)` (already saturated) for `n`
    /// samples, reporting `out(k, w)`.
    fn run(
        &self,
        dt: f64,
        initial: f64,
        n: usize,
        command: impl Fn(usize) -> f64,
        mut out: impl FnMut(usize, f64),
    ) {
        if n == 0 {
            return;
        }
        let (m, phi) = self.delay_parts(dt);
        let (mut w, mut older) = (initial, initial);
        out(0, w);
        for k in 1..n {
            let j = k - 1;
            let newer = if j >= m { command(j - m) } else { initial };
            if phi > 0.0 {
                w = self.step(w, older, phi);
            }
            w = self.step(w, newer, dt - phi);
            out(k, w);
            older = newer;
        }
    }
}

/// A fitted rate-limited first-order powertrain: one response per input axis, commands
/// saturated at the limits seen in training.
///
/// ```
/// use drive_models::powertrain::{RateLimitedPowertrain, RateLimitedResponse};
/// use drive_traits::{Input, InputSpace, Powertrain};
/// let axis = RateLimitedResponse { time_constant: 0.2, delay: 0.1, max_rate: 4.0 };
/// let limits = InputSpace::new(Input::new(-5.0, -5.0, 0.0), Input::new(5.0, 5.0, 0.0)).unwrap();
/// let pt = RateLimitedPowertrain { axes: vec![axis, axis], limits, dt: 0.05 };
/// let w = pt.predict(&Input::zeros(), &vec![Input::new(4.0, 4.0, 0.0); 40]);
/// assert_eq!(w[2], Input::zeros());                 // dead time: 0.1 s
/// assert!((w[12].x - 4.0 * 0.5).abs() < 1e-12);      // 0.5 s of ramp at 4 rad/s^2
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RateLimitedPowertrain {
    /// The response of each input axis, one per axis of the vehicle.
    pub axes: Vec<RateLimitedResponse>,
    /// Input limits (the commands are saturated to them).
    pub limits: InputSpace,
    /// Sample period (s).
    pub dt: f64,
}

impl Tagged for RateLimitedPowertrain {
    const TAG: &'static str = "rate-limited";
}

#[typetag::serde(name = "rate-limited")]
impl Powertrain for RateLimitedPowertrain {
    fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
        predicted.clear();
        predicted.resize(commands.len(), Input::zeros());
        for (i, axis) in self.axes.iter().enumerate().take(drive_traits::MAX_INPUTS) {
            let (lo, hi) = (self.limits.min[i], self.limits.max[i]);
            axis.run(
                self.dt,
                initial[i],
                commands.len(),
                |j| commands[j][i].clamp(lo, hi),
                |k, w| predicted[k][i] = w,
            );
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
            for (name, v, min) in [
                ("time constant", r.time_constant, f64::MIN_POSITIVE),
                ("delay", r.delay, 0.0),
                ("rate limit", r.max_rate, f64::MIN_POSITIVE),
            ] {
                if !(v.is_finite() && v >= min) {
                    return Err(InvalidPart::from(format!(
                        "powertrain axis {i} {name} {} is not a {} number",
                        drive_traits::limits::Short(v),
                        if min > 0.0 {
                            "positive"
                        } else {
                            "non-negative"
                        }
                    )));
                }
            }
        }
        super::check_step_and_limits(self.dt, &self.limits)
    }

    fn parameters(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for (i, r) in self.axes.iter().enumerate() {
            out.push((format!("axis {i} time constant [s]"), r.time_constant));
            out.push((format!("axis {i} dead time [s]"), r.delay));
            out.push((format!("axis {i} rate limit [/s]"), r.max_rate));
            out.push((format!("axis {i} min"), self.limits.min[i]));
            out.push((format!("axis {i} max"), self.limits.max[i]));
        }
        out
    }

    fn stepper(&self) -> Option<Box<dyn PowertrainStepper + '_>> {
        let axes = self.axes.len().min(MAX_INPUTS);
        let parts: Vec<(usize, f64)> = self.axes[..axes]
            .iter()
            .map(|a| a.delay_parts(self.dt))
            .collect();
        let lags: Vec<usize> = parts.iter().map(|p| p.0).collect();
        Some(Box::new(RateLimitedStepper {
            powertrain: self,
            phi: std::array::from_fn(|i| parts.get(i).map_or(0.0, |p| p.1)),
            axes,
            delay: DelayLine::new(&lags),
        }))
    }

    fn clone_box(&self) -> Box<dyn Powertrain> {
        Box::new(self.clone())
    }
}

/// The rate-limited powertrain stepped one command at a time: the inputs reached (three
/// numbers; an axis without a response stays at 0, as a prediction leaves it), the commands
/// delayed by each axis's whole-sample delay + 1 at the last step (three), then the
/// [`DelayLine`]. The same two sub-steps per sample as [`RateLimitedResponse::run`].
struct RateLimitedStepper<'a> {
    powertrain: &'a RateLimitedPowertrain,
    phi: [f64; MAX_INPUTS],
    axes: usize,
    delay: DelayLine,
}

impl PowertrainStepper for RateLimitedStepper<'_> {
    fn state_len(&self) -> usize {
        2 * MAX_INPUTS + self.delay.state_len()
    }

    fn init(&self, initial: &Input, history: &[Input], state: &mut [f64]) {
        let (lo, hi) = (self.powertrain.limits.min, self.powertrain.limits.max);
        let (w, rest) = state.split_at_mut(MAX_INPUTS);
        for (a, w) in w.iter_mut().enumerate() {
            *w = if a < self.axes { initial[a] } else { 0.0 };
        }
        let (older, line) = rest.split_at_mut(MAX_INPUTS);
        let o = self
            .delay
            .init(initial, history, |a, v| v.clamp(lo[a], hi[a]), line);
        older.copy_from_slice(&o);
    }

    fn step(&self, state: &mut [f64], command: &Input) -> Input {
        let p = self.powertrain;
        let (lo, hi) = (p.limits.min, p.limits.max);
        let reached = Input::new(state[0], state[1], state[2]);
        let saturated: [f64; MAX_INPUTS] = std::array::from_fn(|a| {
            if a < self.axes {
                command[a].clamp(lo[a], hi[a])
            } else {
                0.0
            }
        });
        let newer = self.delay.step(&mut state[2 * MAX_INPUTS..], &saturated);
        for (a, axis) in p.axes.iter().enumerate().take(self.axes) {
            let (phi, older) = (self.phi[a], state[MAX_INPUTS + a]);
            let mut w = state[a];
            if phi > 0.0 {
                w = axis.step(w, older, phi);
            }
            state[a] = axis.step(w, newer[a], p.dt - phi);
            state[MAX_INPUTS + a] = newer[a];
        }
        reached
    }
}

/// The rate-limited powertrain's learner: per input axis, the FOPDT fit (time constant and
/// dead time, [`Fopdt`]) and a grid of rate limits around the 99th percentile of the
/// measured rates of change start a Nelder-Mead search (argmin) over time constant, dead
/// time and rate limit, by least squares between predicted and measured inputs on the
/// transient windows. Where no limit binds, the fit is the FOPDT's.
/// The saturation limits are the extreme measured inputs of the training set.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RateLimited {
    /// The FOPDT search that gives the starting point (and the bounds of time constant
    /// and dead time).
    pub fopdt: Fopdt,
}

/// One axis's fitting problem: a plain struct, as argmin wants it.
struct AxisFit {
    /// (start, saturated commands, measured) per transient window.
    windows: Vec<(f64, Vec<f64>, Vec<f64>)>,
    dt: f64,
    min_tc: f64,
    max_tc: f64,
    max_delay: f64,
    rate_bounds: [f64; 2],
    samples: f64,
}

impl AxisFit {
    /// Parameters `[ln tau_c, tau_d, ln a]` clamped into their box, and the distance
    /// outside it.
    fn response(&self, p: &[f64]) -> (RateLimitedResponse, f64) {
        let ln_tc = p[0].clamp(self.min_tc.ln(), self.max_tc.ln());
        let td = p[1].clamp(0.0, self.max_delay);
        let ln_a = p[2].clamp(self.rate_bounds[0].ln(), self.rate_bounds[1].ln());
        let penalty =
            (p[0] - ln_tc).powi(2) + ((p[1] - td) / self.dt).powi(2) + (p[2] - ln_a).powi(2);
        (
            RateLimitedResponse {
                time_constant: ln_tc.exp(),
                delay: td,
                max_rate: ln_a.exp(),
            },
            penalty,
        )
    }

    fn mse(&self, r: &RateLimitedResponse) -> f64 {
        let mut sse = 0.0;
        for (start, command, measured) in &self.windows {
            r.run(
                self.dt,
                *start,
                command.len(),
                |j| command[j],
                |k, w| sse += (w - measured[k]).powi(2),
            );
        }
        sse / self.samples
    }
}

impl CostFunction for AxisFit {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> Result<f64, argmin::core::Error> {
        let (r, penalty) = self.response(p);
        Ok(self.mse(&r) * (1.0 + penalty) + penalty)
    }
}

impl RateLimited {
    fn fit_axis(
        &self,
        train: &WindowSet<'_>,
        side: usize,
        lo: f64,
        hi: f64,
    ) -> Result<RateLimitedResponse, FitError> {
        let seed = self.fopdt.fit_side(train, side, lo, hi)?;
        let axes = train.robot.vehicle.axes();
        let axis = axes.get(side).map_or("?", |a| a.name);
        let what = format!("rate-limited powertrain (axis '{axis}')");
        let dt = train.robot.dt();
        let windows: Vec<(f64, Vec<f64>, Vec<f64>)> = train
            .of_phase(Phase::Transient)
            .map(|w| {
                (
                    w.measured[0][side],
                    w.command.iter().map(|c| c[side].clamp(lo, hi)).collect(),
                    w.measured.iter().map(|e| e[side]).collect(),
                )
            })
            .collect();
        // The starting rate limit: what the data shows (99th percentile of |dw/dt|).
        let mut rates: Vec<f64> = windows
            .iter()
            .flat_map(|(_, _, m)| m.windows(2).map(|p| ((p[1] - p[0]) / dt).abs()))
            .filter(|r| r.is_finite())
            .collect();
        rates.sort_by(f64::total_cmp);
        let range = hi - lo;
        let rate_bounds = [range * 1e-3, range / dt * 1e3];
        let observed = rates
            .get(((rates.len() as f64 - 1.0) * 0.99).round().max(0.0) as usize)
            .copied()
            .unwrap_or(range / dt)
            .clamp(rate_bounds[0], rate_bounds[1]);
        let duration = train.robot.window_len as f64 * dt;
        let problem = AxisFit {
            samples: windows.iter().map(|w| w.1.len()).sum::<usize>().max(1) as f64,
            windows,
            dt,
            // Below the longest time constant even for a command period of minutes.
            min_tc: (dt / 20.0).min(0.5 * self.fopdt.max_time_constant),
            max_tc: self.fopdt.max_time_constant,
            max_delay: self.fopdt.max_delay_fraction * duration,
            rate_bounds,
        };
        // Starts: the FOPDT (no effective limit) and rate limits from an eighth to eight
        // times the observed one in steps of sqrt 2, with the FOPDT's time constant and delay
        // and, as a binding limit makes the lag look slower, a time constant halved.
        // Nelder-Mead, restarted once with a smaller simplex, refines both the best start
        // and the best start with a binding limit (a limit that binds rarely improves the
        // cost little, and a search from the unlimited start does not find it); the lower
        // cost wins.
        let start = |ln_tc: f64, ln_a: f64| vec![ln_tc, seed.delay, ln_a];
        let ln_tc = seed.time_constant.ln();
        let unlimited = start(ln_tc, rate_bounds[1].ln());
        let mut limited = Vec::new();
        for k in -6..=6 {
            let ln_a = observed.ln() + 0.5 * k as f64 * std::f64::consts::LN_2;
            limited.push(start(ln_tc, ln_a));
            limited.push(start(ln_tc - std::f64::consts::LN_2, ln_a));
        }
        let cost = |p: &Vec<f64>| problem.cost(p).unwrap_or(f64::INFINITY);
        let best_limited = limited
            .iter()
            .min_by(|a, b| cost(a).total_cmp(&cost(b)))
            .cloned()
            .unwrap_or_else(|| start(ln_tc, observed.ln()));
        let first = if cost(&unlimited) < cost(&best_limited) {
            unlimited
        } else {
            best_limited.clone()
        };
        let mut problem = Some(problem);
        let mut best: Option<(Vec<f64>, f64)> = None;
        for mut p in [first, best_limited] {
            if best.as_ref().is_some_and(|(b, _)| *b == p) {
                continue;
            }
            for scale in [1.0, 0.2] {
                let simplex = vec![
                    p.clone(),
                    vec![p[0] + 0.25 * scale, p[1], p[2]],
                    vec![p[0], p[1] + 0.5 * dt * scale, p[2]],
                    vec![p[0], p[1], p[2] + 0.5 * scale],
                ];
                let optimizer = |e: argmin::core::Error| FitError::Optimizer {
                    what: what.clone(),
                    reason: e.to_string(),
                };
                let solver = NelderMead::new(simplex)
                    .with_sd_tolerance(1e-14)
                    .map_err(optimizer)?;
                let current = problem.take().ok_or_else(|| FitError::Optimizer {
                    what: what.clone(),
                    reason: "the solver returned no problem".into(),
                })?;
                let mut result = Executor::new(current, solver)
                    .configure(|s| s.max_iters(self.fopdt.max_iters))
                    .run()
                    .map_err(optimizer)?;
                if let Some(b) = result.state().get_best_param() {
                    p = b.clone();
                }
                problem = result.problem.problem.take();
            }
            let c = problem
                .as_ref()
                .and_then(|pr| pr.cost(&p).ok())
                .unwrap_or(f64::INFINITY);
            if best.as_ref().is_none_or(|(_, b)| c < *b) {
                best = Some((p, c));
            }
        }
        let problem = problem.ok_or_else(|| FitError::Optimizer {
            what: what.clone(),
            reason: "the solver returned no problem".into(),
        })?;
        let (p, _) = best.ok_or_else(|| FitError::Optimizer {
            what: what.clone(),
            reason: "no start was refined".into(),
        })?;
        let (r, _) = problem.response(&p);
        if !(r.time_constant.is_finite() && r.delay.is_finite() && r.max_rate.is_finite()) {
            return Err(FitError::NonFinite { what });
        }
        Ok(r)
    }
}

impl PowertrainLearner for RateLimited {
    type Fitted = RateLimitedPowertrain;

    fn fit(&self, train: &WindowSet<'_>) -> Result<RateLimitedPowertrain, FitError> {
        self.fopdt.validate()?;
        let limits = measured_limits(train)?;
        let axes = (0..train
            .robot
            .vehicle
            .input_dim()
            .min(drive_traits::MAX_INPUTS))
            .map(|i| self.fit_axis(train, i, limits.min[i], limits.max[i]))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(RateLimitedPowertrain {
            axes,
            limits,
            dt: train.robot.dt(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_large_rate_limit_is_the_first_order_lag() {
        let r = RateLimitedResponse {
            time_constant: 0.3,
            delay: 0.0,
            max_rate: 1e12,
        };
        for (w, u, h) in [(0.0, 5.0, 0.05), (2.0, -3.0, 0.2), (1.0, 1.5, 1.0)] {
            let lag = u - (u - w) * (-h / 0.3f64).exp();
            assert!((r.step(w, u, h) - lag).abs() < 1e-12);
        }
    }

    #[test]
    fn ramp_then_lag_is_continuous_and_splits_like_one_step() {
        let r = RateLimitedResponse {
            time_constant: 0.2,
            delay: 0.0,
            max_rate: 3.0,
        };
        // One long step equals two half steps (the solution of a time-invariant ODE).
        for (w, u) in [(0.0, 4.0), (3.0, -2.0), (0.0, 0.5)] {
            let one = r.step(w, u, 0.8);
            let two = r.step(r.step(w, u, 0.4), u, 0.4);
            assert!((one - two).abs() < 1e-12, "{w} -> {u}: {one} vs {two}");
        }
        // While ramping, the rate is exactly the limit.
        assert!((r.step(0.0, 4.0, 0.1) - 0.3).abs() < 1e-12);
    }

    #[test]
    fn the_fractional_delay_holds_the_start_then_follows() {
        let r = RateLimitedResponse {
            time_constant: 0.1,
            delay: 0.075,
            max_rate: 100.0,
        };
        let mut out = [0.0; 6];
        r.run(0.05, 1.0, 6, |_| 1.0 + 2.0, |k, w| out[k] = w);
        // Samples 0 and 1 (t < 0.075 s) still hold the start.
        assert_eq!((out[0], out[1]), (1.0, 1.0));
        assert!(out[2] > 1.0 && out[5] > out[2]);
    }
}
