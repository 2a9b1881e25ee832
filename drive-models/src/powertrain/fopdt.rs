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

use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use drive_traits::{FitError, Input, InputSpace, Phase, Powertrain, PowertrainLearner, WindowSet};
use serde::{Deserialize, Serialize};

/// The response of one side: time constant and dead time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
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
    /// exp(-phi / tau_c)
    e_a: f64,
    /// exp(-(dt - phi) / tau_c)
    e_b: f64,
}

impl SideResponse {
    fn discrete(&self, dt: f64) -> Discrete {
        let steps = self.delay / dt;
        // Guard the floor against representation error (0.1 / 0.05 = 2.0000000000000004).
        let m = (steps + 1e-9).floor().max(0.0);
        let phi = (self.delay - m * dt).clamp(0.0, dt);
        Discrete {
            m: m as usize,
            e_a: (-phi / self.time_constant).exp(),
            e_b: (-(dt - phi) / self.time_constant).exp(),
        }
    }
}

impl Discrete {
    /// Response of one side. `command(i)` is the (saturated) command at sample i.
    #[inline]
    fn run(
        &self,
        initial: f64,
        n: usize,
        command: impl Fn(usize) -> f64,
        mut out: impl FnMut(usize, f64),
    ) {
        if n == 0 {
            return;
        }
        let u = |i: isize| if i < 0 { initial } else { command(i as usize) };
        let m = self.m as isize;
        let mut w = initial;
        out(0, w);
        for k in 1..n {
            let j = (k - 1) as isize;
            let ua = u(j - m - 1);
            let ub = u(j - m);
            let w1 = ua + (w - ua) * self.e_a;
            w = ub + (w1 - ub) * self.e_b;
            out(k, w);
        }
    }
}

/// A fitted FOPDT powertrain: one response per side, commands saturated at the wheel
/// velocity limits seen in training.
///
/// ```
/// use drive_models::powertrain::{FopdtPowertrain, SideResponse};
/// use drive_traits::{Input, InputSpace, Powertrain};
/// let side = SideResponse { time_constant: 0.5, delay: 0.1 };
/// let limits = InputSpace::new(Input::new(-5.0, -5.0), Input::new(5.0, 5.0)).unwrap();
/// let pt = FopdtPowertrain { left: side, right: side, limits, dt: 0.05 };
/// let w = pt.predict(&Input::zeros(), &vec![Input::new(4.0, 8.0); 40]);
/// assert_eq!(w[2], Input::zeros());                                  // dead time: 0.1 s
/// let expected = 4.0 * (1.0 - (-(1.0f64 - 0.1) / 0.5).exp());         // eq. 3 at t = 1 s
/// assert!((w[20].x - expected).abs() < 1e-12);
/// assert!(w[39].y <= 5.0);                                           // saturated right side
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FopdtPowertrain {
    /// Left side response.
    pub left: SideResponse,
    /// Right side response.
    pub right: SideResponse,
    /// Wheel velocity limits (the commands are saturated to them).
    pub limits: InputSpace,
    /// Sample period (s).
    pub dt: f64,
}

#[typetag::serde(name = "fopdt")]
impl Powertrain for FopdtPowertrain {
    fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
        let n = commands.len();
        predicted.clear();
        predicted.resize(n, Input::zeros());
        let (lo, hi) = (self.limits.min, self.limits.max);
        self.left.discrete(self.dt).run(
            initial.x,
            n,
            |i| commands[i].x.clamp(lo.x, hi.x),
            |k, w| predicted[k].x = w,
        );
        self.right.discrete(self.dt).run(
            initial.y,
            n,
            |i| commands[i].y.clamp(lo.y, hi.y),
            |k, w| predicted[k].y = w,
        );
    }

    fn clone_box(&self) -> Box<dyn Powertrain> {
        Box::new(self.clone())
    }
}

/// The FOPDT powertrain learner (Sec. III-B.1): time constant and delay fitted
/// independently for the left and right sides on the transient windows, by least squares
/// between predicted and encoder velocities, with argmin's Nelder-Mead seeded by a coarse
/// grid. The saturation limits are the extreme encoder velocities of the training set.
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

/// One side's fitting problem: a plain struct, as argmin wants it.
struct SideFit<'a> {
    /// (start velocity, saturated commands, encoder velocities) per transient window.
    windows: Vec<(f64, Vec<f64>, &'a [Input], usize)>,
    dt: f64,
    min_tc: f64,
    max_tc: f64,
    max_delay: f64,
    samples: f64,
}

impl SideFit<'_> {
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
        let mut sse = 0.0;
        for (w0, cmd, enc, side) in &self.windows {
            d.run(
                *w0,
                cmd.len(),
                |i| cmd[i],
                |k, w| sse += (w - enc[k][*side]).powi(2),
            );
        }
        sse / self.samples
    }
}

impl CostFunction for SideFit<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> Result<f64, argmin::core::Error> {
        let (r, penalty) = self.response(p);
        let mse = self.mse(&r);
        Ok(mse * (1.0 + penalty) + penalty)
    }
}

impl Fopdt {
    fn validate(&self) -> Result<(), FitError> {
        if !(self.max_time_constant.is_finite() && self.max_time_constant > 0.0) {
            return Err(FitError::InvalidHyperparameter {
                name: "max_time_constant",
                value: self.max_time_constant,
                expected: "a positive number of seconds",
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

    fn fit_side(
        &self,
        train: &WindowSet<'_>,
        side: usize,
        lo: f64,
        hi: f64,
    ) -> Result<SideResponse, FitError> {
        let what = format!("powertrain ({} side)", ["left", "right"][side]);
        let dt = train.robot.dt();
        let windows: Vec<_> = train
            .of_phase(Phase::Transient)
            .map(|w| {
                (
                    w.encoder[0][side],
                    w.command
                        .iter()
                        .map(|c| c[side].clamp(lo, hi))
                        .collect::<Vec<_>>(),
                    w.encoder.as_slice(),
                    side,
                )
            })
            .collect();
        if windows.is_empty() {
            return Err(FitError::NoTransientWindow);
        }
        let samples: usize = windows.iter().map(|w| w.1.len()).sum();
        let duration = train.robot.window_len as f64 * dt;
        let problem = SideFit {
            windows,
            dt,
            min_tc: dt / 20.0,
            max_tc: self.max_time_constant,
            max_delay: self.max_delay_fraction * duration,
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
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let mut min = Input::repeat(f64::INFINITY);
        let mut max = Input::repeat(f64::NEG_INFINITY);
        for w in &train.windows {
            for e in &w.encoder {
                min = min.inf(e);
                max = max.sup(e);
            }
        }
        for (side, name) in ["left", "right"].iter().enumerate() {
            if min[side] >= max[side] {
                return Err(FitError::DegenerateInputs {
                    what: "powertrain".into(),
                    detail: format!(
                        "the {name} encoder velocity never changes in the training set"
                    ),
                });
            }
        }
        // min < max on both axes was checked just above, so the box is valid.
        let limits = InputSpace::new(min, max).expect("min < max on both sides");
        let left = self.fit_side(train, 0, min.x, max.x)?;
        let right = self.fit_side(train, 1, min.y, max.y)?;
        Ok(FopdtPowertrain {
            left,
            right,
            limits,
            dt: train.robot.dt(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_eq3_for_a_step_with_fractional_delay() {
        let r = SideResponse {
            time_constant: 0.37,
            delay: 0.123,
        };
        let dt = 0.05;
        let mut out = vec![0.0; 40];
        r.discrete(dt).run(1.0, 40, |_| 5.0, |k, w| out[k] = w);
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
    fn zero_delay_first_order_lag() {
        let r = SideResponse {
            time_constant: 0.1,
            delay: 0.0,
        };
        let mut out = [0.0; 3];
        r.discrete(0.1).run(0.0, 3, |_| 1.0, |k, w| out[k] = w);
        let e = (-1.0f64).exp();
        assert!((out[1] - (1.0 - e)).abs() < 1e-15);
        assert!((out[2] - (1.0 - e * e)).abs() < 1e-15);
    }
}
