//! A slip learner: ridge regression of the slip on a basis with saturating terms
//! (`f |f|`), per body dimension, with a constant predictive variance (the residual
//! variance). A slip model beyond the paper's linear one, written against the slip traits
//! only: the framework supplies the commanded body velocities and the labels.

use drive::nalgebra::{DMatrix, DVector};
use drive::serde::{Deserialize, Serialize};
use drive::traits::InvalidPart;
use drive::traits::{
    BodyVelocity, BodyVelocityEstimator, FitError, SlipData, SlipLearner, SlipModel, Tagged,
};
use drive::typetag;

/// The basis of each dimension at a commanded body velocity `f`.
fn basis(f: &BodyVelocity) -> [Vec<f64>; 3] {
    let (x, w) = (f.x, f.z);
    [
        vec![x, x * x.abs()],
        vec![x * w],
        vec![w, w * w.abs(), x * w, x],
    ]
}

/// The fitted model: weights and residual variance per dimension.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
pub struct RidgeSlipModel {
    /// Weights of the x, y and yaw bases.
    pub weights: [Vec<f64>; 3],
    /// Residual variance per dimension.
    pub variance: [f64; 3],
}

impl Tagged for RidgeSlipModel {
    const TAG: &'static str = "ridge-slip";
}

#[typetag::serde(name = "ridge-slip")]
impl SlipModel for RidgeSlipModel {
    fn slip(&self, f: &BodyVelocity) -> BodyVelocity {
        let b = basis(f);
        let dot = |d: usize| -> f64 { self.weights[d].iter().zip(&b[d]).map(|(w, x)| w * x).sum() };
        BodyVelocity::new(dot(0), dot(1), dot(2))
    }

    fn slip_variance(&self, _f: &BodyVelocity) -> Option<BodyVelocity> {
        Some(BodyVelocity::new(
            self.variance[0],
            self.variance[1],
            self.variance[2],
        ))
    }

    fn check(&self) -> Result<(), InvalidPart> {
        let sizes = [2, 1, 4];
        if self.weights.iter().zip(sizes).any(|(w, k)| w.len() != k) {
            return Err(InvalidPart::from("ridge-slip: wrong number of weights"));
        }
        if self
            .weights
            .iter()
            .flatten()
            .chain(&self.variance)
            .any(|v| !v.is_finite())
        {
            return Err(InvalidPart::from("ridge-slip: non-finite parameter"));
        }
        Ok(())
    }

    /// What `drive report` lists for this slip model.
    fn parameters(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for (d, (weights, variance)) in ["x", "y", "yaw"]
            .iter()
            .zip(self.weights.iter().zip(self.variance))
        {
            for (j, w) in weights.iter().enumerate() {
                out.push((format!("ridge {d} slip: w[{j}]"), *w));
            }
            out.push((format!("ridge {d} slip: noise variance"), variance));
        }
        out
    }

    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}

/// The learner: ridge strength relative to the diagonal of X^T X.
#[derive(Debug, Clone, Copy)]
pub struct RidgeSlip {
    /// Relative ridge strength.
    pub lambda: f64,
}

impl Default for RidgeSlip {
    fn default() -> Self {
        RidgeSlip { lambda: 1e-3 }
    }
}

impl SlipLearner for RidgeSlip {
    type Fitted = RidgeSlipModel;

    fn fit(&self, data: &SlipData<'_>) -> Result<RidgeSlipModel, FitError> {
        let samples = data.samples(&BodyVelocityEstimator::default());
        let mut weights: [Vec<f64>; 3] = Default::default();
        let mut variance = [0.0; 3];
        for d in 0..3 {
            let rows: Vec<Vec<f64>> = samples
                .iter()
                .map(|s| basis(&s.commanded)[d].clone())
                .collect();
            let k = rows.first().map_or(0, Vec::len);
            let n = rows.len();
            if n <= k {
                return Err(FitError::TooFewSamples {
                    what: "ridge-slip".into(),
                    samples: n,
                    parameters: k,
                });
            }
            let x = DMatrix::from_fn(n, k, |i, j| rows[i][j]);
            let g = DVector::from_iterator(n, samples.iter().map(|s| s.slip()[d]));
            let mut xtx = x.transpose() * &x;
            for j in 0..k {
                xtx[(j, j)] *= 1.0 + self.lambda;
            }
            let chol = xtx.cholesky().ok_or_else(|| FitError::DegenerateInputs {
                what: "ridge-slip".into(),
                detail: format!("dimension {d}: an input is zero on every sample"),
            })?;
            let w = chol.solve(&(x.transpose() * &g));
            let residual = &g - &x * &w;
            variance[d] = residual.norm_squared() / (n - k) as f64;
            weights[d] = w.iter().copied().collect();
        }
        Ok(RidgeSlipModel { weights, variance })
    }
}
