//! The ridge strength's path on an inner split of the training windows (middle-out, warm
//! started), the one-standard-error choice, and the final fit on every training window.

use super::*;

/// One fit of the ridge path: its strength, held-out losses per interval and parameters.
pub(super) struct PathPoint {
    pub(super) ridge: f64,
    pub(super) losses: Vec<f64>,
    pub(super) u: DVector<f64>,
}

impl PathPoint {
    /// The total held-out loss (infinite when not finite).
    pub(super) fn held_out(&self) -> f64 {
        let sum: f64 = self.losses.iter().sum();
        if sum.is_finite() {
            sum
        } else {
            f64::INFINITY
        }
    }
}

/// The strength chosen on the ridge path, and its parameters: the strongest penalty whose
/// held-out loss exceeds the best one's by at most one standard error of the paired
/// difference over the held-out intervals (the "one-standard-error rule", Hastie,
/// Tibshirani and Friedman, *The Elements of Statistical Learning*, 7.10): of the strengths
/// the held-out intervals cannot tell apart, the simplest model, so that the choice does
/// not jump as intervals are added. `None` when no held-out loss is finite.
pub(super) fn one_standard_error(path: &[PathPoint]) -> Option<(f64, DVector<f64>)> {
    let best = path
        .iter()
        .filter(|p| p.held_out().is_finite())
        .min_by(|a, b| a.held_out().total_cmp(&b.held_out()))?;
    let within = |p: &PathPoint| {
        let n = p.losses.len();
        if !p.held_out().is_finite() || n != best.losses.len() || n < 2 {
            return false;
        }
        let d: Vec<f64> = p
            .losses
            .iter()
            .zip(&best.losses)
            .map(|(a, b)| a - b)
            .collect();
        let mean = d.iter().sum::<f64>() / n as f64;
        let variance = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        mean <= (variance / n as f64).sqrt()
    };
    let chosen = path
        .iter()
        .filter(|p| p.ridge > best.ridge && within(p))
        .max_by(|a, b| a.ridge.total_cmp(&b.ridge))
        .unwrap_or(best);
    Some((chosen.ridge, chosen.u.clone()))
}

/// What both fits start from: the rollout tracks, the input scales, the residual weights
/// (inverse slip-free error scales), the weights' units and the step.
pub(super) struct Prepared {
    pub(super) tracks: Vec<Track>,
    pub(super) scale: [f64; 2],
    pub(super) weights: [f64; 2],
    pub(super) unit: [f64; 3],
    pub(super) dt: f64,
}

impl SlipIpem {
    /// Validates the settings and prepares the training windows of `data`.
    pub(super) fn prepare(&self, data: &SlipData<'_>) -> Result<Prepared, FitError> {
        self.validate()?;
        if data.windows.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let dt = data.dt();
        let (tracks, scale) = self.tracks(data)?;
        let all: Vec<&Track> = tracks.iter().collect();
        let weights = error_scales(&all, dt).map(|s| 1.0 / s);
        Ok(Prepared {
            scale,
            weights,
            unit: [scale[0], scale[0], scale[1]],
            dt,
            tracks,
        })
    }

    /// The ridge path on the inner split: the fits on `fit_on` at the strengths of the grid,
    /// from its middle to the weaker ones, then from the middle to the stronger ones, each
    /// warm-started from its neighbour (the middle from `u0`); a direction ends after two
    /// strengths in a row whose held-out loss is not below that direction's best. Each
    /// fit's strength, held-out losses per interval of `check_on`, and parameters.
    pub(super) fn ridge_path(
        &self,
        fit_on: &[&Track],
        check_on: &[&Track],
        weights: [f64; 2],
        unit: [f64; 3],
        dt: f64,
        u0: DVector<f64>,
    ) -> Result<Vec<PathPoint>, FitError> {
        let mid = (self.ridge.len() - 1) / 2;
        let weaker = self.ridge[mid..].iter().copied();
        let stronger = self.ridge[..mid].iter().rev().copied();
        let mut path: Vec<PathPoint> = Vec::with_capacity(self.ridge.len());
        for (direction, strengths) in [weaker.collect::<Vec<_>>(), stronger.collect()]
            .into_iter()
            .enumerate()
        {
            // The stronger direction starts from the middle's fit.
            let mut u = if direction == 0 {
                u0.clone()
            } else {
                path[0].u.clone()
            };
            let mut best = if direction == 0 {
                f64::INFINITY
            } else {
                path[0].held_out()
            };
            let mut worse = 0;
            for ridge in strengths {
                let problem = Ipem::new(fit_on.to_vec(), weights, unit, ridge, dt);
                u = solve(problem, u, self.path_iterations, self.path_tolerance)?;
                let losses = Ipem::new(check_on.to_vec(), weights, unit, ridge, dt)
                    .losses_by_interval(u.as_slice());
                let point = PathPoint {
                    ridge,
                    losses,
                    u: u.clone(),
                };
                let held_out = point.held_out();
                path.push(point);
                if held_out < best {
                    best = held_out;
                    worse = 0;
                } else {
                    worse += 1;
                    if worse >= 2 {
                        break;
                    }
                }
            }
        }
        Ok(path)
    }

    /// The final fit at `ridge` from `u` on `all`, the Laplace covariance of its weights
    /// and the held bias's variance (matched on `bias_on`'s windows under its parameters,
    /// or on `all` under the final ones).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn finish(
        &self,
        all: &[&Track],
        bias_on: Option<(Vec<&Track>, [f64; PARAMETERS])>,
        weights: [f64; 2],
        unit: [f64; 3],
        scale: [f64; 2],
        ridge: f64,
        u: DVector<f64>,
        iterations: u64,
        tolerance: f64,
        dt: f64,
    ) -> Result<SlipIpemModel, FitError> {
        let problem = Ipem::new(all.to_vec(), weights, unit, ridge, dt);
        let u = solve(problem, u, iterations, tolerance)?;
        let theta = theta_of(u.as_slice(), &unit);

        // Laplace covariance of the weights: a sandwich H^-1 B H^-1 / n^2 with B the sum
        // over windows of their score outer products (the steps of a window are not
        // independent), in the units of theta.
        let problem = Ipem::new(all.to_vec(), weights, unit, ridge, dt);
        let l = problem.linearize(&u);
        let mut meat = DMatrix::<f64>::zeros(PARAMETERS, PARAMETERS);
        problem.jacobians(u.as_slice(), |_, jt, r| {
            let mut s = DVector::<f64>::zeros(PARAMETERS);
            for (c, rc) in r.iter().enumerate() {
                for (acc, g) in s.iter_mut().zip(jt.col_as_slice(c)) {
                    *acc += g * rc;
                }
            }
            meat += &s * s.transpose();
        });
        let n = problem.count;
        let h_inv = l
            .hessian
            .clone()
            .try_inverse()
            .ok_or_else(|| FitError::NonFinite {
                what: "slip-ipem: the weights' covariance".into(),
            })?;
        let cov_u = &h_inv * meat * &h_inv / (n * n);
        // Without a measured start velocity in the training windows its trust is not
        // fitted: the model has none (its file is that of a model fitted before it).
        let with_velocity = all.iter().any(|t| t.measured.velocity.is_some());
        let size = if with_velocity {
            PARAMETERS
        } else {
            PARAMETERS_V2
        };
        let weight_covariance: Vec<f64> = (0..size)
            .flat_map(|i| {
                let cov_u = &cov_u;
                (0..size).map(move |j| {
                    let unit_of = |i: usize| if i < WEIGHTS { unit[i / FEATURES] } else { 1.0 };
                    cov_u[(i, j)] * unit_of(i) * unit_of(j)
                })
            })
            .collect();

        // The bias held over a rollout: its variance matched to the inner validation
        // windows' squared pose errors under the inner model (or the training windows'
        // when there was no inner split).
        let (bias_tracks, bias_theta) = match bias_on {
            Some((tracks, theta_inner)) => (tracks, theta_inner),
            None => (all.to_vec(), theta),
        };
        let bias_variance = bias_variance(&bias_tracks, &bias_theta, [unit[0], unit[2]], dt);

        let model = SlipIpemModel {
            scale,
            weights: [0, 1, 2].map(|d| theta[d * FEATURES..(d + 1) * FEATURES].to_vec()),
            lag_logit: std::array::from_fn(|d| theta[WEIGHTS + d]),
            disturbance_logit: Some([theta[WEIGHTS + 3], theta[WEIGHTS + 4]]),
            velocity_logit: with_velocity.then_some(theta[WEIGHTS + 5]),
            transport: true,
            dt,
            ridge,
            weight_covariance,
            bias_variance,
        };
        model.check().map_err(|_| FitError::NonFinite {
            what: "slip-ipem".into(),
        })?;
        Ok(model)
    }
}
