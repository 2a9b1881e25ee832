//! A powertrain: a critically damped second-order response with dead time per input axis
//! (two equal first-order lags in cascade), saturated at the measured limits. Fitted by a
//! grid search over the time constant and the delay on the transient windows.

use drive::serde::{Deserialize, Serialize};
use drive::traits::InvalidPart;
use drive::traits::{
    FitError, Input, InputSpace, Phase, Powertrain, PowertrainLearner, Tagged, WindowSet,
};
use drive::typetag;

/// One axis: time constant of each lag (s) and dead time (whole samples).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
pub struct Axis {
    /// Time constant of each of the two lags (s).
    pub time_constant: f64,
    /// Dead time in samples.
    pub delay_samples: usize,
}

/// Sub-steps per sample of the cascade's integration.
const SUBSTEPS: usize = 10;

impl Axis {
    /// Runs the response from `initial` (both lags at rest there) for `commands`.
    fn run(&self, dt: f64, initial: f64, commands: &[f64], out: &mut Vec<f64>) {
        out.clear();
        let a = (-(dt / SUBSTEPS as f64) / self.time_constant).exp();
        let (mut x, mut w) = (initial, initial);
        for k in 0..commands.len() {
            out.push(w);
            let u = if k >= self.delay_samples {
                commands[k - self.delay_samples]
            } else {
                initial
            };
            for _ in 0..SUBSTEPS {
                x = u + (x - u) * a;
                w = x + (w - x) * a;
            }
        }
    }
}

/// The fitted powertrain.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
pub struct SecondOrderPowertrain {
    /// Per input axis.
    pub axes: [Axis; 2],
    /// Saturation limits.
    pub limits: InputSpace,
    /// Sample period (s).
    pub dt: f64,
}

impl Tagged for SecondOrderPowertrain {
    const TAG: &'static str = "second-order";
}

#[typetag::serde(name = "second-order")]
impl Powertrain for SecondOrderPowertrain {
    fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
        predicted.clear();
        predicted.resize(commands.len(), Input::zeros());
        let mut out = Vec::with_capacity(commands.len());
        for (i, axis) in self.axes.iter().enumerate() {
            let c: Vec<f64> = commands
                .iter()
                .map(|u| u[i].clamp(self.limits.min[i], self.limits.max[i]))
                .collect();
            axis.run(self.dt, initial[i], &c, &mut out);
            for (p, w) in predicted.iter_mut().zip(&out) {
                p[i] = *w;
            }
        }
    }

    fn check(&self) -> Result<(), InvalidPart> {
        if self
            .axes
            .iter()
            .all(|a| a.time_constant.is_finite() && a.time_constant > 0.0)
            && self.dt.is_finite()
            && self.dt > 0.0
        {
            Ok(())
        } else {
            Err(InvalidPart::from(
                "second-order powertrain: time constants and dt must be positive",
            ))
        }
    }

    /// What `drive report` lists for this powertrain (and its figure draws its response).
    fn parameters(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for (i, a) in self.axes.iter().enumerate() {
            out.push((
                format!("axis {i} second-order time constant [s]"),
                a.time_constant,
            ));
            out.push((
                format!("axis {i} second-order dead time [s]"),
                a.delay_samples as f64 * self.dt,
            ));
        }
        out
    }

    fn clone_box(&self) -> Box<dyn Powertrain> {
        Box::new(self.clone())
    }
}

/// The learner: a grid of 24 time constants from dt/2 to 3 s and delays of 0 to 10 samples.
#[derive(Debug, Clone, Copy, Default)]
pub struct SecondOrder;

impl PowertrainLearner for SecondOrder {
    type Fitted = SecondOrderPowertrain;

    fn fit(&self, train: &WindowSet<'_>) -> Result<SecondOrderPowertrain, FitError> {
        // This example models two axes; a vehicle of three is refused, not half-fitted.
        let dim = train.robot.vehicle.input_dim();
        if dim != 2 {
            return Err(FitError::DegenerateInputs {
                what: "second-order powertrain".into(),
                detail: format!("it models two input axes; this vehicle has {dim}"),
            });
        }
        let transient: Vec<_> = train.of_phase(Phase::Transient).collect();
        if transient.is_empty() {
            return Err(FitError::NoTransientWindow);
        }
        let dt = train.robot.dt();
        let mut min = Input::repeat(f64::INFINITY);
        let mut max = Input::repeat(f64::NEG_INFINITY);
        for w in &train.windows {
            for m in &w.measured {
                min = min.inf(m);
                max = max.sup(m);
            }
        }
        let limits = InputSpace::new(min, max).ok_or_else(|| FitError::DegenerateInputs {
            what: "second-order powertrain".into(),
            detail: "no finite measured input".into(),
        })?;
        let mut axes = [Axis {
            time_constant: 1.0,
            delay_samples: 0,
        }; 2];
        let mut out = Vec::new();
        for (i, slot) in axes.iter_mut().enumerate() {
            let mut best = f64::INFINITY;
            for t in 0..24 {
                let tc = (dt / 2.0) * (3.0 / (dt / 2.0)).powf(t as f64 / 23.0);
                for delay_samples in 0..=10 {
                    let axis = Axis {
                        time_constant: tc,
                        delay_samples,
                    };
                    let mut sse = 0.0;
                    for w in &transient {
                        let c: Vec<f64> = w
                            .command
                            .iter()
                            .map(|u| u[i].clamp(min[i], max[i]))
                            .collect();
                        axis.run(dt, w.measured[0][i], &c, &mut out);
                        sse += out
                            .iter()
                            .zip(&w.measured)
                            .map(|(p, m)| (p - m[i]).powi(2))
                            .sum::<f64>();
                    }
                    if sse < best {
                        best = sse;
                        *slot = axis;
                    }
                }
            }
        }
        Ok(SecondOrderPowertrain { axes, limits, dt })
    }
}
