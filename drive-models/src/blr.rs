//! Bayesian linear regression with a normal-inverse-gamma posterior (paper eq. 6) and a
//! Student-t predictive (paper eq. 7), after Murphy (2012), Sec. 7.6.3.

use drive_traits::limits::{Short, MAX_ABS_MEASUREMENT};
use drive_traits::FitError;
use drive_traits::InvalidPart;
use faer::linalg::solvers::SolveLstsq;
use faer::Mat;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// The largest noise shape `a` a posterior read from a file may hold: a fit writes `a0 + n /
/// 2` for `n` samples, far below this.
pub const MAX_NOISE_SHAPE: f64 = 1e12;

/// The largest noise variance `b / a` and covariance entry a posterior read from a file
/// may hold (the square of the largest measurement, [`MAX_ABS_MEASUREMENT`]).
pub const MAX_VARIANCE: f64 = MAX_ABS_MEASUREMENT * MAX_ABS_MEASUREMENT;

/// The prior of a BLR fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Prior {
    /// The paper's uninformative prior (Sec. III-B.2): `a0 = b0 = 0`, `gamma0 = 0`,
    /// `K0 = phi (X^T X)^-1`. The posterior mean is `phi / (1 + phi)` times the ordinary
    /// least-squares solution.
    Uninformative {
        /// Prior scale phi > 0; large means "trust the data".
        phi: f64,
    },
    /// A fixed normal-inverse-gamma prior `NIG(gamma0, K0, a0, b0)`, given by its mean and
    /// its precision `K0^-1` (row-major k x k), for instance a previous posterior.
    Fixed {
        /// gamma0
        mean: Vec<f64>,
        /// K0^-1, row-major
        precision: Vec<f64>,
        /// a0 >= 0
        a: f64,
        /// b0 >= 0
        b: f64,
    },
}

impl Default for Prior {
    /// The paper's uninformative prior with phi = 1e12 (the paper's own code behaves so).
    fn default() -> Self {
        Prior::Uninformative { phi: 1e12 }
    }
}

impl Prior {
    /// Checks the prior's values for `k` inputs.
    pub fn validate(&self, k: usize) -> Result<(), FitError> {
        let invalid = |name, value, expected| {
            Err(FitError::InvalidHyperparameter {
                name,
                value,
                expected,
            })
        };
        match self {
            Prior::Uninformative { phi } => {
                if !(phi.is_finite() && *phi > 0.0) {
                    return invalid("phi", *phi, "a finite positive number");
                }
            }
            Prior::Fixed {
                mean,
                precision,
                a,
                b,
            } => {
                if mean.len() != k {
                    return invalid(
                        "prior mean length",
                        mean.len() as f64,
                        "one value per slip input",
                    );
                }
                if precision.len() != k * k {
                    return invalid(
                        "prior precision length",
                        precision.len() as f64,
                        "k x k values",
                    );
                }
                if mean.iter().chain(precision).any(|v| !v.is_finite()) {
                    return invalid("prior", f64::NAN, "finite values");
                }
                if !(a.is_finite() && *a >= 0.0) {
                    return invalid("a0", *a, "a finite number >= 0");
                }
                if !(b.is_finite() && *b >= 0.0) {
                    return invalid("b0", *b, "a finite number >= 0");
                }
            }
        }
        Ok(())
    }
}

/// A BLR posterior `NIG(gamma, K, a, b)` (paper eq. 6) for one output dimension.
///
/// ```
/// use drive_models::blr::{BlrPosterior, Prior};
/// // g = 2 x exactly, three samples, the paper's prior with phi = 1e12.
/// let x = [1.0, 2.0, 3.0];
/// let g = [2.0, 4.0, 6.0];
/// let post = BlrPosterior::fit(&x, 1, &g, &Prior::default(), "example").unwrap();
/// assert!((post.mean[0] - 2.0).abs() < 1e-9);
/// assert!((post.predict_mean(&[10.0]) - 20.0).abs() < 1e-8);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlrPosterior {
    /// Posterior mean gamma (k).
    pub mean: Vec<f64>,
    /// Posterior covariance factor K (k x k, row-major).
    pub covariance: Vec<f64>,
    /// Posterior shape a.
    pub a: f64,
    /// Posterior scale b.
    pub b: f64,
}

impl BlrPosterior {
    /// Number of inputs k.
    pub fn inputs(&self) -> usize {
        self.mean.len()
    }

    /// Fits the posterior of eq. 6 on `x` (n x k, row-major: one row of k inputs per
    /// observation) and observations `g` (n), under `prior`. `what` names the regression in
    /// errors.
    ///
    /// Degenerate data is refused, never turned into a NaN model: fewer observations than
    /// inputs, an input that is zero on every row, inputs that are collinear.
    pub fn fit(
        x: &[f64],
        k: usize,
        g: &[f64],
        prior: &Prior,
        what: &str,
    ) -> Result<Self, FitError> {
        prior.validate(k)?;
        let n = g.len();
        if k == 0 || x.len() != n * k {
            return Err(FitError::DegenerateInputs {
                what: what.into(),
                detail: format!("{} values for {n} rows of {k} inputs", x.len()),
            });
        }
        if x.iter().chain(g).any(|v| !v.is_finite()) {
            return Err(FitError::NonFinite { what: what.into() });
        }
        if n <= k {
            return Err(FitError::TooFewSamples {
                what: what.into(),
                samples: n,
                parameters: k + 1,
            });
        }
        let xm = Mat::<f64>::from_fn(n, k, |i, j| x[i * k + j]);
        let gm = Mat::<f64>::from_fn(n, 1, |i, _| g[i]);
        // Column scales, for the rank checks below.
        let norms: Vec<f64> = (0..k)
            .map(|j| (0..n).map(|i| x[i * k + j].powi(2)).sum::<f64>().sqrt())
            .collect();
        if let Some(j) = norms.iter().position(|v| *v == 0.0) {
            return Err(FitError::DegenerateInputs {
                what: what.into(),
                detail: format!("input {j} is zero on every row"),
            });
        }
        match prior {
            Prior::Uninformative { phi } => Self::fit_uninformative(&xm, &gm, &norms, *phi, what),
            Prior::Fixed {
                mean,
                precision,
                a,
                b,
            } => Self::fit_fixed(
                &xm,
                &gm,
                &DVector::from_column_slice(mean),
                &DMatrix::from_row_slice(k, k, precision),
                *a,
                *b,
                what,
            ),
        }
    }

    /// The paper's prior: closed form through a thin QR of X (faer), which stays accurate
    /// where the normal equations would square the condition number.
    fn fit_uninformative(
        x: &Mat<f64>,
        g: &Mat<f64>,
        norms: &[f64],
        phi: f64,
        what: &str,
    ) -> Result<Self, FitError> {
        let (n, k) = (x.nrows(), x.ncols());
        let qr = x.qr();
        let r_faer = qr.thin_R();
        let r = DMatrix::from_fn(k, k, |i, j| if j >= i { r_faer[(i, j)] } else { 0.0 });
        for j in 0..k {
            if r[(j, j)].abs() <= 1e-10 * norms[j] {
                return Err(FitError::DegenerateInputs {
                    what: what.into(),
                    detail: format!("input {j} is collinear with the others"),
                });
            }
        }
        let sol = qr.solve_lstsq(g);
        let ls = DVector::from_fn(k, |i, _| sol[(i, 0)]);
        let fitted = x * &Mat::<f64>::from_fn(k, 1, |i, _| ls[i]);
        let mut rss = 0.0;
        let mut explained = 0.0;
        for i in 0..n {
            rss += (g[(i, 0)] - fitted[(i, 0)]).powi(2);
            explained += fitted[(i, 0)].powi(2);
        }
        let shrink = phi / (1.0 + phi);
        // (X^T X)^-1 = R^-1 R^-T; R is upper triangular with a non-zero diagonal (checked above).
        let r_inv = r
            .solve_upper_triangular(&DMatrix::identity(k, k))
            .ok_or_else(|| FitError::DegenerateInputs {
                what: what.into(),
                detail: "singular R factor".into(),
            })?;
        let k_post = (&r_inv * r_inv.transpose()) * shrink;
        let post = BlrPosterior {
            mean: (ls * shrink).iter().copied().collect(),
            covariance: row_major(&k_post),
            a: n as f64 / 2.0,
            // b = 1/2 (g^T g - gamma^T K^-1 gamma) = 1/2 (RSS + |X gamma_ls|^2 / (1 + phi)).
            b: 0.5 * (rss + explained / (1.0 + phi)),
        };
        post.checked(what)
    }

    /// A fixed prior: eq. 6 as printed, on the sufficient statistics X^T X, X^T g, g^T g.
    fn fit_fixed(
        x: &Mat<f64>,
        g: &Mat<f64>,
        mean0: &DVector<f64>,
        prec0: &DMatrix<f64>,
        a0: f64,
        b0: f64,
        what: &str,
    ) -> Result<Self, FitError> {
        let k = x.ncols();
        let xtx_f = x.transpose() * x;
        let xtg_f = x.transpose() * g;
        let gtg: f64 = (0..g.nrows()).map(|i| g[(i, 0)].powi(2)).sum();
        let xtx = DMatrix::from_fn(k, k, |i, j| xtx_f[(i, j)]);
        let xtg = DVector::from_fn(k, |i, _| xtg_f[(i, 0)]);
        Self::from_statistics(&xtx, &xtg, gtg, g.nrows(), mean0, prec0, a0, b0, what)
    }

    /// Eq. 6 from sufficient statistics and a fixed prior.
    #[allow(clippy::too_many_arguments)]
    fn from_statistics(
        xtx: &DMatrix<f64>,
        xtg: &DVector<f64>,
        gtg: f64,
        n: usize,
        mean0: &DVector<f64>,
        prec0: &DMatrix<f64>,
        a0: f64,
        b0: f64,
        what: &str,
    ) -> Result<Self, FitError> {
        let prec = prec0 + xtx;
        let chol = prec
            .clone()
            .cholesky()
            .ok_or_else(|| FitError::DegenerateInputs {
                what: what.into(),
                detail:
                    "K0^-1 + X^T X is not positive definite (collinear inputs and a flat prior)"
                        .into(),
            })?;
        let k_post = chol.inverse();
        let mean = chol.solve(&(prec0 * mean0 + xtg));
        let b = b0 + 0.5 * (mean0.dot(&(prec0 * mean0)) + gtg - mean.dot(&(&prec * &mean)));
        BlrPosterior {
            mean: mean.iter().copied().collect(),
            covariance: row_major(&k_post),
            a: a0 + n as f64 / 2.0,
            b: b.max(0.0),
        }
        .checked(what)
    }

    fn all_finite(&self) -> bool {
        self.mean
            .iter()
            .chain(&self.covariance)
            .all(|v| v.is_finite())
            && self.a.is_finite()
            && self.b.is_finite()
    }

    fn checked(self, what: &str) -> Result<Self, FitError> {
        if self.all_finite() {
            Ok(self)
        } else {
            Err(FitError::NonFinite { what: what.into() })
        }
    }

    /// Checks a posterior read from a file: `k` inputs, finite values, `a, b >= 0`.
    pub fn check(&self, k: usize, what: &str) -> Result<(), InvalidPart> {
        if self.mean.len() != k || self.covariance.len() != k * k {
            return Err(InvalidPart::from(format!(
                "{what}: expected {k} weights and a {k}x{k} covariance, found {} and {}",
                self.mean.len(),
                self.covariance.len()
            )));
        }
        if !self.all_finite() {
            return Err(InvalidPart::from(format!(
                "{what}: a posterior parameter is not a finite number"
            )));
        }
        if !(self.a > 0.0 && self.b > 0.0) {
            return Err(InvalidPart::from(format!(
                "{what}: the noise parameters a = {} and b = {} must be positive",
                Short(self.a),
                Short(self.b)
            )));
        }
        // The predictive of eq. 7 is a Student t with 2a degrees of freedom: its variance,
        // which the covariance propagation uses, is finite only for 2a > 2.
        if self.a <= 1.0 {
            return Err(InvalidPart::from(format!(
                "{what}: the noise shape a = {} must be above 1 (the predictive has 2a degrees of freedom and a finite variance only above 2; a fit writes a0 + n / 2 for n samples)",
                Short(self.a)
            )));
        }
        // What a fit writes: a = a0 + n / 2 for n samples, a noise variance b / a of a
        // slip (m/s or rad/s, squared) and weights of the size of a measurement.
        if self.a > MAX_NOISE_SHAPE {
            return Err(InvalidPart::from(format!(
                "{what}: the noise shape a = {} is beyond {} (a fit writes a0 + n / 2 for n samples)",
                Short(self.a),
                Short(MAX_NOISE_SHAPE)
            )));
        }
        if self.b / self.a > MAX_VARIANCE {
            return Err(InvalidPart::from(format!(
                "{what}: the noise variance b / a = {} is beyond {}",
                Short(self.b / self.a),
                Short(MAX_VARIANCE)
            )));
        }
        if let Some(m) = self.mean.iter().find(|m| m.abs() > MAX_ABS_MEASUREMENT) {
            return Err(InvalidPart::from(format!(
                "{what}: weight {} is beyond +-{}",
                Short(*m),
                Short(MAX_ABS_MEASUREMENT)
            )));
        }
        if let Some(c) = self.covariance.iter().find(|c| c.abs() > MAX_VARIANCE) {
            return Err(InvalidPart::from(format!(
                "{what}: covariance entry {} is beyond +-{}",
                Short(*c),
                Short(MAX_VARIANCE)
            )));
        }
        let c = DMatrix::from_row_slice(k, k, &self.covariance);
        let scale = c.amax().max(f64::MIN_POSITIVE);
        if (&c - c.transpose()).amax() > 1e-9 * scale {
            return Err(InvalidPart::from(format!(
                "{what}: the covariance is not symmetric"
            )));
        }
        if k > 0 && c.cholesky().is_none() {
            return Err(InvalidPart::from(format!(
                "{what}: the covariance is not positive definite"
            )));
        }
        Ok(())
    }

    /// This posterior as a fixed prior, for a sequential update with new data.
    pub fn as_prior(&self) -> Prior {
        let k = self.inputs();
        let precision = DMatrix::from_row_slice(k, k, &self.covariance)
            .try_inverse()
            .map(|m| row_major(&m))
            .unwrap_or_else(|| vec![0.0; k * k]);
        Prior::Fixed {
            mean: self.mean.clone(),
            precision,
            a: self.a,
            b: self.b,
        }
    }

    /// Predictive mean `x^T gamma`.
    #[inline]
    pub fn predict_mean(&self, x: &[f64]) -> f64 {
        self.mean.iter().zip(x).map(|(g, x)| g * x).sum()
    }

    /// `x^T K x`: how much the uncertainty of the weights adds to the noise at input `x`,
    /// relative to the noise (the share of eq. 7's predictive variance that more data at
    /// `x` would shrink). Unitless.
    ///
    /// ```
    /// use drive_models::blr::{BlrPosterior, Prior};
    /// // y = 2x from x = 1, 2, 3 under a fixed prior: K = (1 + 14)^-1.
    /// let prior = Prior::Fixed { mean: vec![0.0], precision: vec![1.0], a: 1.0, b: 1.0 };
    /// let p = BlrPosterior::fit(&[1.0, 2.0, 3.0], 1, &[2.0, 4.0, 6.0], &prior, "example").unwrap();
    /// assert!((p.leverage(&[3.0]) - 9.0 / 15.0).abs() < 1e-12);
    /// ```
    pub fn leverage(&self, x: &[f64]) -> f64 {
        let k = self.inputs();
        let mut xkx = 0.0;
        for i in 0..k {
            for j in 0..k {
                xkx += x[i] * self.covariance[i * k + j] * x[j];
            }
        }
        xkx
    }

    /// Squared scale of the Student-t predictive of eq. 7: `b / a (1 + x^T K x)`.
    pub fn predictive_scale2(&self, x: &[f64]) -> f64 {
        if self.a > 0.0 {
            self.b / self.a * (1.0 + self.leverage(x))
        } else {
            f64::INFINITY
        }
    }

    /// Degrees of freedom of the predictive, `2a`.
    pub fn degrees_of_freedom(&self) -> f64 {
        2.0 * self.a
    }

    /// Variance of the Student-t predictive: `scale^2 nu / (nu - 2)` (infinite for nu <= 2).
    pub fn predictive_variance(&self, x: &[f64]) -> f64 {
        let nu = self.degrees_of_freedom();
        if nu > 2.0 {
            self.predictive_scale2(x) * nu / (nu - 2.0)
        } else {
            f64::INFINITY
        }
    }
}

/// The sufficient statistics of a BLR fit in square-root form, updated recursively as
/// observations arrive (online BLR): the upper-triangular `R` with `R^T R = X^T X`,
/// `z = Q^T g` with `R^T z = X^T g`, the residual sum of squares of the least-squares fit
/// and the number of observations. New rows are rotated into `R` by Givens rotations (as
/// stable as the batch QR of [`BlrPosterior::fit`]); [`BlrStatistics::posterior`] gives
/// the same posterior as the batch fit on all the rows added (to rounding), at a cost that
/// does not grow with the data already seen.
///
/// ```
/// use drive_models::blr::{BlrPosterior, BlrStatistics, Prior};
/// let x = [1.0, 0.5, 2.0, -1.0, 3.0, 0.25, -1.0, 2.0];
/// let g = [1.1, 2.3, 2.9, -2.2];
/// let mut online = BlrStatistics::new(2);
/// online.add_rows(&x[..4], &g[..2]);
/// online.add_rows(&x[4..], &g[2..]);
/// let batch = BlrPosterior::fit(&x, 2, &g, &Prior::default(), "x").unwrap();
/// let recursive = online.posterior(&Prior::default(), "x").unwrap();
/// for (a, b) in batch.mean.iter().zip(&recursive.mean) {
///     assert!((a - b).abs() < 1e-12);
/// }
/// assert_eq!(online.observations(), 4);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct BlrStatistics {
    k: usize,
    /// R, k x k row-major, upper triangular.
    r: Vec<f64>,
    /// Q^T g, k.
    z: Vec<f64>,
    /// Residual sum of squares of the least-squares fit.
    rss: f64,
    /// Observations added.
    n: usize,
    /// Sum of squares of each input column (for the degeneracy checks).
    column_ss: Vec<f64>,
    /// False once a non-finite value was added.
    finite: bool,
}

impl BlrStatistics {
    /// No observation yet, `k` inputs.
    pub fn new(k: usize) -> Self {
        BlrStatistics {
            k,
            r: vec![0.0; k * k],
            z: vec![0.0; k],
            rss: 0.0,
            n: 0,
            column_ss: vec![0.0; k],
            finite: true,
        }
    }

    /// Number of inputs k.
    pub fn inputs(&self) -> usize {
        self.k
    }

    /// Observations added so far.
    pub fn observations(&self) -> usize {
        self.n
    }

    /// Adds observations: `x` is n x k row-major (one row of k inputs per observation),
    /// `g` the n outputs. Rows beyond `min(x.len() / k, g.len())` are ignored.
    pub fn add_rows(&mut self, x: &[f64], g: &[f64]) {
        let k = self.k;
        if k == 0 {
            return;
        }
        let mut row = vec![0.0; k];
        for (xi, gi) in x.chunks_exact(k).zip(g) {
            if !(xi.iter().all(|v| v.is_finite()) && gi.is_finite()) {
                self.finite = false;
            }
            row.copy_from_slice(xi);
            for (ss, v) in self.column_ss.iter_mut().zip(xi) {
                *ss += v * v;
            }
            let rest = self.rotate_in(&mut row, *gi);
            self.rss += rest * rest;
            self.n += 1;
        }
    }

    /// Adds the observations behind `other` (the statistics of other rows): as if its rows
    /// had been added here.
    pub fn merge(&mut self, other: &BlrStatistics) {
        let k = self.k;
        if other.k != k {
            // Statistics of another regression cannot be merged; mark them unusable.
            self.finite = false;
            return;
        }
        let mut row = vec![0.0; k];
        for i in 0..k {
            row.copy_from_slice(&other.r[i * k..(i + 1) * k]);
            let rest = self.rotate_in(&mut row, other.z[i]);
            self.rss += rest * rest;
        }
        self.rss += other.rss;
        self.n += other.n;
        self.finite &= other.finite;
        for (a, b) in self.column_ss.iter_mut().zip(&other.column_ss) {
            *a += b;
        }
    }

    /// Rotates one row `(row, g)` into `(R, z)`; returns what is left of `g` (its residual
    /// component).
    fn rotate_in(&mut self, row: &mut [f64], mut g: f64) -> f64 {
        let k = self.k;
        for j in 0..k {
            let (a, b) = (self.r[j * k + j], row[j]);
            if b == 0.0 {
                continue;
            }
            let h = a.hypot(b);
            let (c, s) = (a / h, b / h);
            let r_row = &mut self.r[j * k + j..(j + 1) * k];
            for (rm, xm) in r_row.iter_mut().zip(&mut row[j..]) {
                let (a, b) = (*rm, *xm);
                *rm = c * a + s * b;
                *xm = -s * a + c * b;
            }
            let zj = self.z[j];
            self.z[j] = c * zj + s * g;
            g = -s * zj + c * g;
        }
        g
    }

    /// The posterior of eq. 6 on everything added, under `prior`; the same checks and
    /// errors as [`BlrPosterior::fit`] (too few observations, an input zero on every row,
    /// collinear inputs, non-finite values).
    pub fn posterior(&self, prior: &Prior, what: &str) -> Result<BlrPosterior, FitError> {
        let k = self.k;
        prior.validate(k)?;
        if k == 0 {
            return Err(FitError::DegenerateInputs {
                what: what.into(),
                detail: "no input".into(),
            });
        }
        if !self.finite {
            return Err(FitError::NonFinite { what: what.into() });
        }
        if self.n <= k {
            return Err(FitError::TooFewSamples {
                what: what.into(),
                samples: self.n,
                parameters: k + 1,
            });
        }
        let norms: Vec<f64> = self.column_ss.iter().map(|v| v.sqrt()).collect();
        if let Some(j) = norms.iter().position(|v| *v == 0.0) {
            return Err(FitError::DegenerateInputs {
                what: what.into(),
                detail: format!("input {j} is zero on every row"),
            });
        }
        let r = DMatrix::from_fn(k, k, |i, j| if j >= i { self.r[i * k + j] } else { 0.0 });
        let z = DVector::from_column_slice(&self.z);
        match prior {
            Prior::Uninformative { phi } => {
                for j in 0..k {
                    if r[(j, j)].abs() <= 1e-10 * norms[j] {
                        return Err(FitError::DegenerateInputs {
                            what: what.into(),
                            detail: format!("input {j} is collinear with the others"),
                        });
                    }
                }
                let singular = || FitError::DegenerateInputs {
                    what: what.into(),
                    detail: "singular R factor".into(),
                };
                let ls = r.solve_upper_triangular(&z).ok_or_else(singular)?;
                let r_inv = r
                    .solve_upper_triangular(&DMatrix::identity(k, k))
                    .ok_or_else(singular)?;
                let shrink = phi / (1.0 + phi);
                BlrPosterior {
                    mean: (ls * shrink).iter().copied().collect(),
                    covariance: row_major(&((&r_inv * r_inv.transpose()) * shrink)),
                    a: self.n as f64 / 2.0,
                    // |X gamma_ls|^2 = |R gamma_ls|^2 = |z|^2.
                    b: 0.5 * (self.rss + z.norm_squared() / (1.0 + phi)),
                }
                .checked(what)
            }
            Prior::Fixed {
                mean,
                precision,
                a,
                b,
            } => {
                let xtx = r.transpose() * &r;
                let xtg = r.transpose() * &z;
                let gtg = self.rss + z.norm_squared();
                BlrPosterior::from_statistics(
                    &xtx,
                    &xtg,
                    gtg,
                    self.n,
                    &DVector::from_column_slice(mean),
                    &DMatrix::from_row_slice(k, k, precision),
                    *a,
                    *b,
                    what,
                )
            }
        }
    }
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    let mut out = Vec::with_capacity(m.nrows() * m.ncols());
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            out.push(m[(i, j)]);
        }
    }
    out
}

#[cfg(test)]
mod tests;
