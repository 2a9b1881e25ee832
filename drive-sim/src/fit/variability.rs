//! Stage 6: the ground's variability, fitted by simulating the twin so that its steady
//! windows scatter as the data's; the scatter statistic itself.

use super::*;

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
pub(super) fn adjacent_window_correlation(t: f64, tau: f64) -> f64 {
    let x = t / tau;
    (1.0 - (-x).exp()).powi(2) / (2.0 * (x - 1.0 + (-x).exp()))
}

/// Holds the robot still (stands in for a sampler that cannot be built).
pub(super) struct Still;

impl InputSampler for Still {
    fn next_input(&mut self) -> Input {
        Input::zeros()
    }
}

/// Seeds of the twin's runs in the variability stage.
pub(super) const VARIABILITY_SEEDS: [u64; 2] = [101, 202];

/// The variability stage's outcome: the variability (if any), the scatters it was fitted
/// on, and the fitted twin's mean motion.
pub(super) type FittedVariability = (Option<Variability>, Option<ScatterFit>, [f64; 2]);

/// What the twin's own runs show (as many intervals as the data, at least 100, at most
/// 300, per seed; the runs pooled): their scatter (`None` with too few steady windows) and
/// the steady windows' mean absolute forward speed and yaw rate.
pub(super) struct TwinRuns {
    pub(super) scatter: Option<Scatter>,
    pub(super) motion: [f64; 2],
}

impl TwinRuns {
    /// The scatter, or why there is none.
    pub(super) fn scatter(&self) -> Result<Scatter, SimFitError> {
        self.scatter.ok_or(SimFitError::TooFew {
            what: "steady windows in the twin's runs",
            stage: "variability",
            found: 0,
            needed: 30,
        })
    }
}

pub(super) fn twin_runs(
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
pub(super) fn twin_scatter(
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
pub(super) fn fit_variability(
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
    let variances = nonnegative_fit(
        &columns,
        [excess[0] / vr[0], excess[1] / vr[1]],
        MAX_VARIABILITY * MAX_VARIABILITY,
    );
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

/// Non-negative `x` (3), each at most `cap`, minimizing `|sum_j x_j columns[j] - target|` in
/// two dimensions: the best of the one- and two-column least-squares solutions, each
/// non-negative and brought within `cap`. (Unbounded, a column that barely moves the
/// scatter would be given a huge variance to reach the target exactly: a process the
/// simulator cannot run, which is then cut to its cap and misses.)
pub(super) fn nonnegative_fit(columns: &[[f64; 2]; 3], target: [f64; 2], cap: f64) -> [f64; 3] {
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
            let x = x.map(|v| v.min(cap));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_that_barely_moves_the_scatter_is_not_stretched_past_its_cap() {
        // What the variability stage measured on a run whose turning resistance varies,
        // localized with a jittery clock: traction and lateral move both scatters alike,
        // rolling the yaw rate's a little; the forward speed's needs nothing more.
        let columns = [[2.63, 10.85], [2.38, 9.24], [0.0, 0.0157]];
        let target = [0.0, 0.872];
        // Unbounded, rolling alone would reach the target with a variance of 55.
        let unbounded = nonnegative_fit(&columns, target, f64::INFINITY);
        assert!(unbounded[2] > 50.0, "{unbounded:?}");
        // Within the simulator's cap (a log standard deviation of 3), traction alone is the
        // fit (lateral alone misses by a little more): its least-squares variance.
        let x = nonnegative_fit(&columns, target, 9.0);
        assert_eq!((x[1], x[2]), (0.0, 0.0), "{x:?}");
        assert!((x[0] - 10.85 * 0.872 / (2.63f64.powi(2) + 10.85f64.powi(2))).abs() < 1e-9);
    }
}
