//! Stages 1 and 2: the low-level controller (gains, caps, the right side's gain, the wheel
//! limit) from the steady windows, and the motors (rising and falling time constants, dead
//! time, the controller's acceleration limits) from the transient windows replayed.

use super::*;

/// The controller's parameters from `p` = [ln k_v, ln k_w, ln v_max, ln w_max, ln wheel
/// limit, right gain].
pub(super) fn controller_of(p: &[f64]) -> (ControllerParams, f64, f64) {
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
pub(super) fn targets(
    c: &ControllerParams,
    limit: f64,
    right: f64,
    u: Input,
    g: &DifferentialDrive,
) -> Input {
    let t = c.targets(u, g.wheel_radius, g.baseline);
    Input::new(
        t.x.clamp(-limit, limit),
        (right * t.y).clamp(-limit, limit),
        0.0,
    )
}

#[derive(Clone)]
pub(super) struct ControllerProblem<'a> {
    pub(super) steady: &'a [Steady],
    pub(super) geometry: DifferentialDrive,
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
pub(super) struct PowertrainProblem<'a> {
    pub(super) transients: &'a [Transient],
    pub(super) geometry: DifferentialDrive,
    pub(super) controller: ControllerParams,
    pub(super) limit: f64,
    pub(super) right: f64,
    pub(super) dt: f64,
}

/// Substeps per command tick in the powertrain stage's replay.
pub(super) const REPLAY_SUBSTEPS: usize = 4;

impl PowertrainProblem<'_> {
    /// The controller with the acceleration limits of `p` (none beyond 1000).
    pub(super) fn controller(&self, p: &[f64]) -> ControllerParams {
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
    pub(super) fn error(&self, p: &[f64]) -> f64 {
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
            let e0 = Input::new(w.encoders[0].x, w.encoders[0].y / self.right, 0.0);
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
                        0.0,
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
