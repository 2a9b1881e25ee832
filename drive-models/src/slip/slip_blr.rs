use crate::blr::{BlrPosterior, Prior};
use drive_traits::{
    BodyVelocity, BodyVelocityEstimator, FitError, SlipData, SlipLearner, SlipModel, Tagged,
};
use serde::{Deserialize, Serialize};

/// The slip inputs of eq. 5 for a commanded body velocity `f`, per slip dimension
/// (Sec. III-B.2): longitudinal `[f_x]` (rolling resistance), lateral `[f_x f_w]`
/// (centrifugal force), angular `[f_x f_w, f_x, f_w]` (centrifugal force, asymmetry, skid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipInputs {
    /// x_x
    pub x: [f64; 1],
    /// x_y
    pub y: [f64; 1],
    /// x_w
    pub yaw: [f64; 3],
}

/// Slip inputs of a commanded body velocity.
///
/// ```
/// use drive_models::slip::slip_inputs;
/// use drive_traits::BodyVelocity;
/// let s = slip_inputs(&BodyVelocity::new(2.0, 0.0, 0.5));
/// assert_eq!(s.x, [2.0]);
/// assert_eq!(s.y, [1.0]);
/// assert_eq!(s.yaw, [1.0, 2.0, 0.5]);
/// ```
#[inline]
pub fn slip_inputs(f: &BodyVelocity) -> SlipInputs {
    let psi = f.x * f.z;
    SlipInputs {
        x: [f.x],
        y: [psi],
        yaw: [psi, f.x, f.z],
    }
}

/// The paper's slip-based BLR learner (Sec. III-B.2): one Bayesian linear regression per
/// body dimension (eq. 5-7) of the slip `g = f - v` on the slip inputs of the commanded
/// body velocity `f`, with `v` the body velocity measured by localization (see
/// [`BodyVelocityEstimator`]). The commanded body velocity comes from the powertrain and the
/// vehicle it is composed with (`slip-blr+fopdt` is the paper's model).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SlipBlr {
    /// Priors of the x, y and yaw slip regressions (the paper's uninformative prior by default).
    pub priors: [Prior; 3],
    /// How the measured body velocities are derived from the poses.
    pub velocity: BodyVelocityEstimator,
}

impl SlipBlr {
    /// The same learner with the paper's uninformative prior of scale `phi` on every dimension.
    ///
    /// ```
    /// use drive_models::{blr::Prior, slip::SlipBlr};
    /// assert_eq!(SlipBlr::default().with_phi(1.0).priors[0], Prior::Uninformative { phi: 1.0 });
    /// ```
    pub fn with_phi(mut self, phi: f64) -> Self {
        self.priors = [
            Prior::Uninformative { phi },
            Prior::Uninformative { phi },
            Prior::Uninformative { phi },
        ];
        self
    }
}

/// Fitted slip-BLR: the posteriors of the three slip regressions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SlipBlrModel {
    /// Posterior of the longitudinal slip.
    pub slip_x: BlrPosterior,
    /// Posterior of the lateral slip.
    pub slip_y: BlrPosterior,
    /// Posterior of the angular slip.
    pub slip_yaw: BlrPosterior,
}

impl Tagged for SlipBlrModel {
    const TAG: &'static str = "slip-blr";
}

impl SlipLearner for SlipBlr {
    type Fitted = SlipBlrModel;

    fn fit(&self, data: &SlipData<'_>) -> Result<SlipBlrModel, FitError> {
        self.velocity.validate()?;
        for (prior, k) in self.priors.iter().zip([1, 1, 3]) {
            prior.validate(k)?;
        }
        if data.windows.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let mut xs: [Vec<f64>; 3] = Default::default();
        let mut gs: [Vec<f64>; 3] = Default::default();
        data.for_each_sample(&self.velocity, |sample| {
            let g = sample.slip();
            let s = slip_inputs(&sample.commanded);
            xs[0].extend_from_slice(&s.x);
            xs[1].extend_from_slice(&s.y);
            xs[2].extend_from_slice(&s.yaw);
            for d in 0..3 {
                gs[d].push(g[d]);
            }
        });
        let fit = |d: usize, k: usize, name: &str| {
            BlrPosterior::fit(&xs[d], k, &gs[d], &self.priors[d], name)
        };
        Ok(SlipBlrModel {
            slip_x: fit(0, 1, "slip-BLR, longitudinal slip")?,
            slip_y: fit(1, 1, "slip-BLR, lateral slip")?,
            slip_yaw: fit(2, 3, "slip-BLR, angular slip")?,
        })
    }
}

/// The slip posterior means in fixed-size form, read once per rollout.
#[derive(Debug, Clone, Copy)]
struct SlipWeights {
    x: f64,
    y: f64,
    yaw: [f64; 3],
}

impl SlipWeights {
    /// The slip `g` of eq. 5 (posterior mean) at the slip inputs `s`.
    #[inline]
    fn slip(&self, s: &SlipInputs) -> BodyVelocity {
        BodyVelocity::new(
            self.x * s.x[0],
            self.y * s.y[0],
            self.yaw[0] * s.yaw[0] + self.yaw[1] * s.yaw[1] + self.yaw[2] * s.yaw[2],
        )
    }
}

impl SlipBlrModel {
    /// The weight-uncertainty share of the slip's predictive variance at the commanded
    /// body velocity `f`, relative to each regression's noise and summed over the three
    /// ([`BlrPosterior::leverage`]): large where the data seen so far says little.
    pub fn leverage(&self, f: &BodyVelocity) -> f64 {
        let s = slip_inputs(f);
        self.slip_x.leverage(&s.x) + self.slip_y.leverage(&s.y) + self.slip_yaw.leverage(&s.yaw)
    }

    /// The posterior means. The dimensions (1, 1, 3) hold by construction in `fit` and are
    /// checked by [`SlipModel::check`] for loaded files; a missing weight reads as NaN so
    /// that a malformed model can never predict plausible numbers.
    fn weights(&self) -> SlipWeights {
        let at = |m: &[f64], i: usize| m.get(i).copied().unwrap_or(f64::NAN);
        SlipWeights {
            x: at(&self.slip_x.mean, 0),
            y: at(&self.slip_y.mean, 0),
            yaw: [
                at(&self.slip_yaw.mean, 0),
                at(&self.slip_yaw.mean, 1),
                at(&self.slip_yaw.mean, 2),
            ],
        }
    }
}

#[typetag::serde(name = "slip-blr")]
impl SlipModel for SlipBlrModel {
    fn slip(&self, f: &BodyVelocity) -> BodyVelocity {
        self.weights().slip(&slip_inputs(f))
    }

    fn body_velocities_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) {
        let w = self.weights();
        out.clear();
        out.extend(f.iter().map(|f| f - w.slip(&slip_inputs(f))));
    }

    /// The Student-t predictive variance of eq. 7 per slip dimension.
    fn slip_variance(&self, f: &BodyVelocity) -> Option<BodyVelocity> {
        let s = slip_inputs(f);
        Some(BodyVelocity::new(
            self.slip_x.predictive_variance(&s.x),
            self.slip_y.predictive_variance(&s.y),
            self.slip_yaw.predictive_variance(&s.yaw),
        ))
    }

    fn check(&self) -> Result<(), String> {
        self.slip_x.check(1, "slip_x")?;
        self.slip_y.check(1, "slip_y")?;
        self.slip_yaw.check(3, "slip_yaw")
    }

    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}
