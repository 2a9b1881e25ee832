//! A library of terrain models blended by their recent likelihood (issue 61's second way to
//! follow a change of ground, the anchors' approach): models of one robot fitted on
//! several grounds, each weighed by how likely its calibrated predictive distribution made
//! the windows just driven.

use crate::ExperimentError;
use drive_models::calibration::{pose_errors, position_score};
use drive_models::BlendedModel;
use drive_traits::{MotionModel, Pose, RobotDescription, StartInfo, StartState, Window};
use std::sync::Arc;

/// The least log-likelihood a window adds to a model's sum: a window far outside a model's
/// predictive distribution (a glitch, a bump) counts as a 10-sigma miss, not as ruling the
/// model out for the rest of the memory. The most it adds is as far above zero (a
/// covariance that vanishes gives no infinite evidence).
pub const LOG_LIKELIHOOD_FLOOR: f64 = -50.0;

/// The evidence (nats) the other models of a library need beyond the first (the prior, the
/// ground the robot was on) to weigh as much as it: "decisive" on Jeffreys' scale, a Bayes
/// factor of 100. Where nothing changed, the prior keeps the weight.
pub const PRIOR_LOG_ODDS: f64 = 4.605_170_185_988_091;

/// Models of one robot on several grounds, blended by their recent likelihood.
///
/// Every window added is predicted by each model with its covariance (eq. 8's horizon, the
/// window's own length); its log-likelihood is that of the window's last pose under the
/// model's predictive Gaussian (position and heading, within [`LOG_LIKELIHOOD_FLOOR`] of zero).
/// Each model's sum forgets with the time constant `selection_s` (a window of `T` seconds
/// keeps `exp(-T / selection_s)` of what came before), and the weights are the sums'
/// softmax, the first model's (the prior's) raised by [`PRIOR_LOG_ODDS`]: the posterior of
/// "this model's ground" under a prior that forgets and favours the ground the robot was on.
/// Before any window the first model weighs 100 times any other.
///
/// ```
/// use drive_models::{ComposedModel, DifferentialDrive};
/// use drive_models::powertrain::CommandedPowertrain;
/// use drive_models::slip::NoSlipModel;
/// use drive_studies::TerrainLibrary;
/// use drive_traits::{MotionModel, StartInfo};
/// use std::sync::Arc;
/// let data = drive_data::bundled::load("husky_drive").unwrap();
/// let naive: Arc<dyn MotionModel> = Arc::new(ComposedModel {
///     label: "naive".into(),
///     vehicle: data.robot.vehicle.clone(),
///     powertrain: Box::new(CommandedPowertrain),
///     slip: Box::new(NoSlipModel),
///     dt: 0.05,
/// });
/// // A model without a predictive covariance has no likelihood to weigh it by.
/// let err = TerrainLibrary::new(vec![("naive".into(), naive)], &data.robot, StartInfo::Encoders, 30.0)
///     .unwrap_err();
/// assert!(err.to_string().contains("covariance"), "{err}");
/// ```
pub struct TerrainLibrary {
    names: Vec<String>,
    models: Vec<Arc<dyn MotionModel>>,
    robot: RobotDescription,
    start: StartInfo,
    selection_s: f64,
    log_likelihood: Vec<f64>,
    windows: usize,
}

impl std::fmt::Debug for TerrainLibrary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TerrainLibrary")
            .field("models", &self.names)
            .field("weights", &self.weights())
            .field("windows", &self.windows)
            .finish_non_exhaustive()
    }
}

impl TerrainLibrary {
    /// A library of `models` (named) for `robot`'s windows, predicted from `start`,
    /// forgetting with the time constant `selection_s` (s). `Err` when there is no model, a
    /// model steps otherwise than the robot's data or has no predictive covariance, or
    /// `selection_s` is not a positive time.
    pub fn new(
        models: Vec<(String, Arc<dyn MotionModel>)>,
        robot: &RobotDescription,
        start: StartInfo,
        selection_s: f64,
    ) -> Result<Self, ExperimentError> {
        if models.is_empty() {
            return Err(ExperimentError::Empty("library"));
        }
        if !(selection_s.is_finite() && selection_s > 0.0) {
            return Err(ExperimentError::Incompatible(format!(
                "the library's memory of {selection_s} s is not a positive time"
            )));
        }
        let dt = robot.dt();
        let probe = StartState::at_rest(Pose::zeros());
        let command = [drive_traits::Input::zeros(); 2];
        for (name, m) in &models {
            if (m.dt() - dt).abs() > 1e-9 * dt {
                return Err(ExperimentError::Incompatible(format!(
                    "library model {name} steps {} s, the data {dt} s",
                    m.dt()
                )));
            }
            let (mut p, mut c) = (Vec::new(), Vec::new());
            if m.predict_with_covariance_into(&probe, &command, &mut p, &mut c)
                .is_err()
            {
                return Err(ExperimentError::Incompatible(format!(
                    "library model {name} has no predictive covariance: it cannot be weighed by the likelihood of what the robot drives (fit it with an uncertainty)"
                )));
            }
        }
        let n = models.len();
        let (names, models) = models.into_iter().unzip();
        Ok(TerrainLibrary {
            names,
            models,
            robot: robot.clone(),
            start,
            selection_s,
            log_likelihood: vec![0.0; n],
            windows: 0,
        })
    }

    /// Adds one window just driven (in time order): each model's sum forgets, then adds
    /// the window's log-likelihood under it.
    pub fn add(&mut self, window: &Window) {
        let span = window.len().saturating_sub(1) as f64 * self.robot.dt();
        let keep = (-span / self.selection_s).exp();
        let vehicle = self.robot.vehicle.as_ref();
        let start = window.start_state_with(vehicle, self.start);
        for (sum, model) in self.log_likelihood.iter_mut().zip(&self.models) {
            *sum = *sum * keep + window_log_likelihood(model.as_ref(), &start, window);
        }
        self.windows += 1;
    }

    /// The models' weights now (summing to 1), in their order.
    pub fn weights(&self) -> Vec<f64> {
        let odds: Vec<f64> = self
            .log_likelihood
            .iter()
            .enumerate()
            .map(|(i, l)| if i == 0 { l + PRIOR_LOG_ODDS } else { *l })
            .collect();
        let top = odds.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let raw: Vec<f64> = odds.iter().map(|l| (l - top).exp()).collect();
        let total: f64 = raw.iter().sum();
        raw.iter().map(|w| w / total).collect()
    }

    /// The models' names, in their order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The windows added so far.
    pub fn windows(&self) -> usize {
        self.windows
    }

    /// The blend now: the models weighed by [`TerrainLibrary::weights`].
    pub fn model(&self) -> BlendedModel {
        // The weights are shares of finite sums: the blend is valid.
        BlendedModel {
            models: self.models.clone(),
            weights: self.weights(),
        }
    }
}

/// The log-likelihood of `window`'s last pose under `model`'s predictive Gaussian from
/// `start` (position and heading blocks), within [`LOG_LIKELIHOOD_FLOOR`] of zero.
fn window_log_likelihood(model: &dyn MotionModel, start: &StartState, window: &Window) -> f64 {
    let (mut poses, mut covs) = (Vec::new(), Vec::new());
    if model
        .predict_with_covariance_into(start, &window.command, &mut poses, &mut covs)
        .is_err()
    {
        return LOG_LIKELIHOOD_FLOOR;
    }
    let errors = pose_errors(&poses, &window.pose);
    let Some(k) = errors
        .len()
        .checked_sub(1)
        .filter(|k| *k > 0 && *k < covs.len())
    else {
        return 0.0;
    };
    let (e, c) = (&errors[k], &covs[k]);
    let det = c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(1, 0)];
    let yaw_var = c[(2, 2)];
    let ll = -0.5 * (position_score(e, c) + det.ln() + e.z * e.z / yaw_var + yaw_var.ln())
        - 1.5 * (2.0 * std::f64::consts::PI).ln();
    if ll.is_nan() {
        LOG_LIKELIHOOD_FLOOR
    } else {
        ll.clamp(LOG_LIKELIHOOD_FLOOR, -LOG_LIKELIHOOD_FLOOR)
    }
}
