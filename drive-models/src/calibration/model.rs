//! The calibrated model: the per-step scales (with the learned difficulty and the errors'
//! shape) and the wrapped model whose covariance they scale.

use super::*;
use drive_traits::InvalidPart;

/// The per-horizon-step scales of a calibrated model's covariance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HorizonCalibration {
    /// The coverage calibrated to.
    pub level: f64,
    /// Smallest ratio of the position covariance's eigenvalues.
    pub shape_floor: f64,
    /// Held-out windows the scales come from.
    pub windows: usize,
    /// Scale of the position block at each step (index 0, the start, is 1).
    pub position_scale: Vec<f64>,
    /// Scale of the yaw variance at each step.
    pub yaw_scale: Vec<f64>,
    /// The learned difficulty of the position at each step ([`crate::difficulty`]; empty:
    /// none, every prediction's region sized alike).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub position_difficulty: Vec<StepDifficulty>,
    /// The learned difficulty of the yaw at each step (empty: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub yaw_difficulty: Vec<StepDifficulty>,
    /// The shape of the position region at each step in the frame of the predicted heading,
    /// `[a, b, d]` for `[[along^2, along across], [along across, across^2]]` scaled to
    /// determinant 1, where the held-out errors' own shape gave smaller regions than the
    /// model's covariance (empty: the model's covariance shapes the region).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub heading_shape: Vec<[f64; 3]>,
}

impl HorizonCalibration {
    /// Checks values read from a file.
    pub fn check(&self) -> Result<(), InvalidPart> {
        if !(self.level > 0.0 && self.level < 1.0) {
            return Err(InvalidPart::from(format!(
                "calibration level {} is not in (0, 1)",
                Short(self.level)
            )));
        }
        if !(self.shape_floor >= 0.0 && self.shape_floor < 1.0) {
            return Err(InvalidPart::from(format!(
                "calibration shape_floor {} is not in [0, 1)",
                Short(self.shape_floor)
            )));
        }
        if self.position_scale.is_empty() || self.position_scale.len() != self.yaw_scale.len() {
            return Err(InvalidPart::from(
                "calibration scales are empty or of different lengths",
            ));
        }
        if let Some(s) = self
            .position_scale
            .iter()
            .chain(&self.yaw_scale)
            .find(|s| !(s.is_finite() && **s > 0.0))
        {
            return Err(InvalidPart::from(format!(
                "calibration scale {} is not a finite number > 0",
                Short(*s)
            )));
        }
        for d in [&self.position_difficulty, &self.yaw_difficulty] {
            if !d.is_empty() && d.len() != self.position_scale.len() {
                return Err(InvalidPart::from(
                    "calibration difficulties and scales are of different lengths",
                ));
            }
            d.iter().try_for_each(StepDifficulty::check)?;
        }
        if !self.heading_shape.is_empty() {
            if self.heading_shape.len() != self.position_scale.len() {
                return Err(InvalidPart::from(
                    "calibration heading shapes and scales are of different lengths",
                ));
            }
            for &[a, b, d] in &self.heading_shape {
                let det = a * d - b * b;
                if !(a > 0.0 && d > 0.0 && (det - 1.0).abs() < 1e-6 && a < 1e6 && d < 1e6) {
                    return Err(InvalidPart::from(format!(
                        "calibration heading shape [{}, {}, {}] is not positive definite of determinant 1",
                        Short(a),
                        Short(b),
                        Short(d)
                    )));
                }
            }
        }
        Ok(())
    }

    /// The calibrated covariance at step `k` (beyond the calibrated horizon: the last
    /// step's scales) of a prediction whose motion features at `k` are `x`
    /// ([`crate::difficulty::motion_features`]; unused without a difficulty) and whose
    /// predicted heading at `k` is `yaw` (unused without a heading shape). With a heading
    /// shape, the position block is that shape turned to `yaw` and scaled, and the position
    /// is uncorrelated with the yaw; beyond the calibrated horizon that block is held at
    /// the last step's size: [`HorizonCalibration::apply_beyond`] grows it with the model's
    /// own covariance.
    pub fn apply(&self, k: usize, c: &PoseCovariance, x: &Features, yaw: f64) -> PoseCovariance {
        self.apply_grown(k, c, x, yaw, 1.0)
    }

    /// The last step the scales were calibrated at (the horizon of the held-out windows).
    pub fn last_step(&self) -> usize {
        self.position_scale.len() - 1
    }

    /// The size of a covariance's position block (the square root of its determinant, m^2),
    /// floored as the calibration floors it: what the model's own uncertainty grows by.
    pub fn position_size(&self, c: &PoseCovariance) -> f64 {
        let f = floored(c, self.shape_floor);
        (f[(0, 0)] * f[(1, 1)] - f[(0, 1)] * f[(1, 0)])
            .max(0.0)
            .sqrt()
    }

    /// [`apply`](Self::apply) at a step `k` beyond the calibrated horizon, where the model's
    /// own position covariance had the size `at_last` ([`position_size`](Self::position_size))
    /// at the last calibrated step: a heading-shaped position block grows from the last
    /// step's calibrated size as the model's own does (held at the last step's size, a
    /// prediction 10 s ahead was given the region of one 2 s ahead, its heading's variance
    /// 13.8 rad^2); without a heading shape the model's own covariance grows already.
    pub fn apply_beyond(
        &self,
        k: usize,
        c: &PoseCovariance,
        x: &Features,
        yaw: f64,
        at_last: f64,
    ) -> PoseCovariance {
        let now = self.position_size(c);
        let growth = if k > self.last_step() && at_last > 0.0 && now.is_finite() {
            (now / at_last).max(1.0)
        } else {
            1.0
        };
        self.apply_grown(k, c, x, yaw, growth)
    }

    fn apply_grown(
        &self,
        k: usize,
        c: &PoseCovariance,
        x: &Features,
        yaw: f64,
        growth: f64,
    ) -> PoseCovariance {
        if k == 0 {
            return *c;
        }
        let i = k.min(self.position_scale.len() - 1);
        let f = floored(c, self.shape_floor);
        let (mut sp, mut sy) = (self.position_scale[i], self.yaw_scale[i]);
        if let (Some(dp), Some(dy)) = (self.position_difficulty.get(i), self.yaw_difficulty.get(i))
        {
            let (size, yaw_size) = log_sizes(&f);
            let mut x = *x;
            x[FEATURES - 1] = size;
            sp *= dp.multiplier(&x);
            x[FEATURES - 1] = yaw_size;
            sy *= dy.multiplier(&x);
        }
        let d = [sp.sqrt(), sp.sqrt(), sy.sqrt()];
        let mut out = PoseCovariance::from_fn(|r, col| f[(r, col)] * d[r] * d[col]);
        if let Some(&[a, b, d]) = self.heading_shape.get(i) {
            // R S R^T with R the rotation by `yaw`.
            let (s, c) = yaw.sin_cos();
            let xx = c * c * a - 2.0 * c * s * b + s * s * d;
            let xy = c * s * (a - d) + (c * c - s * s) * b;
            let yy = s * s * a + 2.0 * c * s * b + c * c * d;
            let sp = sp * growth;
            out[(0, 0)] = sp * xx;
            out[(0, 1)] = sp * xy;
            out[(1, 0)] = sp * xy;
            out[(1, 1)] = sp * yy;
            for j in 0..2 {
                out[(j, 2)] = 0.0;
                out[(2, j)] = 0.0;
            }
        }
        out
    }

    /// Whether the regions follow a learned difficulty.
    pub fn has_difficulty(&self) -> bool {
        !self.position_difficulty.is_empty()
    }
}

/// A fitted model whose pose covariance is calibrated per horizon step
/// ([`Uncertainty::Calibrated`]); its mean prediction is the inner model's.
///
/// ```
/// use drive_models::calibration::{CalibratedModel, HorizonCalibration};
/// use drive_traits::{Input, MotionError, MotionModel, Pose, PoseCovariance, StartState, Tagged};
/// # use serde::{Deserialize, Serialize};
/// /// Stands still, unsure by 1 m^2 and 1 rad^2 at every step after the start.
/// #[derive(Debug, Serialize, Deserialize)]
/// struct Unsure;
/// #[typetag::serde(name = "unsure-doc")]
/// impl MotionModel for Unsure {
///     fn name(&self) -> String { "unsure".into() }
///     fn dt(&self) -> f64 { 0.1 }
///     fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) { p.clear(); p.resize(c.len(), s.pose); }
///     fn predict_with_covariance_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>,
///         cov: &mut Vec<PoseCovariance>) -> Result<(), MotionError> {
///         self.predict_into(s, c, p);
///         cov.clear();
///         cov.extend((0..c.len()).map(|k| if k == 0 { PoseCovariance::zeros() } else { PoseCovariance::identity() }));
///         Ok(())
///     }
/// }
/// let calibration = HorizonCalibration {
///     level: 0.95, shape_floor: 0.0, windows: 20,
///     position_scale: vec![1.0, 4.0], yaw_scale: vec![1.0, 9.0],
///     position_difficulty: vec![], yaw_difficulty: vec![], heading_shape: vec![],
/// };
/// let model = CalibratedModel { model: Box::new(Unsure), calibration };
/// let (mut p, mut c) = (vec![], vec![]);
/// model.predict_with_covariance_into(&StartState::at_rest(Pose::zeros()), &[Input::zeros(); 3], &mut p, &mut c).unwrap();
/// assert_eq!(c[0], PoseCovariance::zeros());
/// assert_eq!((c[1][(0, 0)], c[1][(1, 1)], c[1][(2, 2)]), (4.0, 4.0, 9.0));
/// assert_eq!(c[2][(2, 2)], 9.0); // beyond the calibrated horizon: the last step's scales
/// assert_eq!(model.name(), "unsure");
/// ```
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibratedModel {
    /// The model (its mean prediction and covariance shape).
    pub model: Box<dyn MotionModel>,
    /// The per-step scales.
    pub calibration: HorizonCalibration,
}

impl Tagged for CalibratedModel {
    const TAG: &'static str = "calibrated";
}

#[typetag::serde(name = "calibrated")]
impl MotionModel for CalibratedModel {
    fn name(&self) -> String {
        self.model.name()
    }

    fn dt(&self) -> f64 {
        self.model.dt()
    }

    fn check(&self) -> Result<(), InvalidPart> {
        self.model.check()?;
        self.calibration.check()
    }

    fn parameters(&self) -> Vec<(String, f64)> {
        self.model.parameters()
    }

    fn powertrain(&self) -> Option<&dyn drive_traits::Powertrain> {
        self.model.powertrain()
    }

    /// Without the covariance, the wrapped model's stepper; with it, the wrapped model's
    /// stepped with its own covariance, calibrated at every step as a prediction is.
    fn stepper(&self, options: StepOptions) -> Result<Box<dyn Stepper + '_>, MotionError> {
        let inner = self.model.stepper(options)?;
        if !options.covariance {
            return Ok(inner);
        }
        Ok(Box::new(CalibratedStepper {
            calibration: &self.calibration,
            dt: self.model.dt(),
            inner,
        }))
    }

    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        self.model.predict_into(start, commands, poses)
    }

    fn predict_batch_into(
        &self,
        starts: &[StartState],
        commands: &[Input],
        horizon: usize,
        poses: &mut [Pose],
    ) -> Result<(), MotionError> {
        self.model
            .predict_batch_into(starts, commands, horizon, poses)
    }

    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        self.model
            .predict_with_covariance_into(start, commands, poses, covariances)?;
        // The difficulty's features walked along the prediction (no buffer per call).
        let mut walk = FeatureWalk::new(start, self.model.dt());
        let last = self.calibration.last_step();
        let at_last = covariances
            .get(last)
            .map_or(0.0, |c| self.calibration.position_size(c));
        for (k, c) in covariances.iter_mut().enumerate() {
            let x = match (k, poses.get(k)) {
                (1.., Some(p)) if self.calibration.has_difficulty() => walk.step(&poses[k - 1], p),
                _ => [0.0; FEATURES],
            };
            let yaw = poses.get(k).map_or(start.pose.z, |p| p.z);
            *c = self.calibration.apply_beyond(k, c, &x, yaw, at_last);
        }
        Ok(())
    }
}

/// A calibrated model stepped with its covariance: after the header, the difficulty's
/// feature walk ([`FeatureWalk::NUMBERS`]), then the wrapped model's state, whose header
/// holds its own covariance; the header holds the calibrated one.
struct CalibratedStepper<'a> {
    calibration: &'a HorizonCalibration,
    dt: f64,
    inner: Box<dyn Stepper + 'a>,
}

const WALK: usize = layout::HEADER;
/// The model's own position size at the last calibrated step (0 before it).
const AT_LAST: usize = WALK + FeatureWalk::NUMBERS;
const INNER: usize = AT_LAST + 1;

impl Stepper for CalibratedStepper<'_> {
    fn state_len(&self) -> usize {
        INNER + self.inner.state_len()
    }

    fn with_covariance(&self) -> bool {
        true
    }

    fn init(
        &self,
        start: &StartState,
        history: &[Input],
        state: &mut [f64],
    ) -> Result<(), MotionError> {
        check_state(self.state_len(), state)?;
        let (outer, inner) = state.split_at_mut(INNER);
        self.inner.init(start, history, inner)?;
        outer.fill(0.0);
        outer[..layout::HEADER].copy_from_slice(&inner[..layout::HEADER]);
        FeatureWalk::new(start, self.dt).write(&mut outer[WALK..]);
        Ok(())
    }

    fn step(&self, state: &mut [f64], command: &Input) -> Result<(), MotionError> {
        check_state(self.state_len(), state)?;
        let (outer, inner) = state.split_at_mut(INNER);
        let before = layout::pose(inner);
        self.inner.step(inner, command)?;
        let after = layout::pose(inner);
        let k = layout::steps(inner);
        let x = if self.calibration.has_difficulty() && k >= 1 {
            let mut walk = FeatureWalk::read(&outer[WALK..]);
            let x = walk.step(&before, &after);
            walk.write(&mut outer[WALK..]);
            x
        } else {
            [0.0; FEATURES]
        };
        let own = layout::covariance(inner);
        if k == self.calibration.last_step() {
            outer[AT_LAST] = self.calibration.position_size(&own);
        }
        let c = self
            .calibration
            .apply_beyond(k, &own, &x, after.z, outer[AT_LAST]);
        outer[..layout::HEADER].copy_from_slice(&inner[..layout::HEADER]);
        layout::write_covariance(outer, &c);
        Ok(())
    }
}
