//! What the fit minimizes: every training window rolled out as a track, the robust
//! (Cauchy) residuals of its poses, the ridge penalty, and argmin's trust region on their
//! Gauss-Newton model, iterated to convergence.

use super::*;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use rayon::prelude::*;

/// One training window as the fit uses it.
pub(super) struct Track {
    pub(super) interval: usize,
    /// Commanded body velocity per sample.
    pub(super) f: Vec<BodyVelocity>,
    /// Slip functions per sample.
    pub(super) features: Vec<[f64; FEATURES]>,
    /// Measured poses, yaw unwrapped along the window.
    pub(super) target: Vec<Pose>,
    /// What was measured at the window start besides the pose.
    pub(super) measured: Measured,
}

impl Track {
    /// [`rollout`] of this window from its first measured pose and what was measured at
    /// its start.
    #[inline]
    pub(super) fn rollout<Y, T>(
        &self,
        dt: f64,
        dynamics: &Dynamics<Y, T>,
        slip: impl FnMut(usize) -> ([T; 2], Y),
        visit: impl FnMut(usize, &[T; 2], &Y),
    ) where
        Y: DualNum<f64> + Copy,
        T: DualNum<f64> + Copy + Mul<Y, Output = T>,
    {
        rollout(
            &self.target[0],
            &self.measured,
            &self.f,
            dt,
            dynamics,
            slip,
            visit,
        );
    }
}

/// What a rollout starts from besides the pose, when measured: the yaw rate (the IMU) and
/// the body's velocity (the localization just before the start), each when finite; and
/// the body's motion measured at a later step (a controller's now), when there is one.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Measured {
    pub(super) yaw_rate: Option<f64>,
    pub(super) velocity: Option<[f64; 2]>,
    pub(super) observed: Option<ObservedMotion>,
}

impl Measured {
    /// The finite measurements of `start`.
    pub(super) fn of(start: &StartState) -> Self {
        Measured {
            yaw_rate: start.yaw_rate.filter(|w| w.is_finite()),
            velocity: start.velocity.filter(|v| v.iter().all(|x| x.is_finite())),
            observed: start.observed.and_then(|o| o.finite()),
        }
    }

    /// What is measured at step `k` after the start (`k >= 1`), when anything is.
    #[inline]
    pub(super) fn at(&self, k: usize) -> Option<&ObservedMotion> {
        self.observed.as_ref().filter(|o| o.step == k)
    }
}

/// The scale `c` of the robust loss, in units of the residuals' robust error scale (the
/// slip-free model's median error, as a standard deviation): a residual of `3c` weighs a
/// tenth of a small one, so the fit follows the typical window, as the median of eq. 8
/// judges it, rather than a few windows with localization glitches or spin-outs.
pub(super) const ROBUST_SCALE: f64 = 1.0;

/// The robust loss of a squared residual `s`: Cauchy's `c^2 ln(1 + s / c^2)`.
#[inline]
pub(super) fn robust_loss(s: f64) -> f64 {
    const C2: f64 = ROBUST_SCALE * ROBUST_SCALE;
    C2 * (s / C2).ln_1p()
}

/// The derivative of [`robust_loss`]: the weight of a residual.
#[inline]
pub(super) fn robust_weight(s: f64) -> f64 {
    const C2: f64 = ROBUST_SCALE * ROBUST_SCALE;
    1.0 / (1.0 + s / C2)
}

/// The weighted pose error of a predicted pose against the measured one: position over
/// `w[0]`, yaw (wrapped to the nearest turn) over `w[1]`.
#[inline]
pub(super) fn residual<Y: DualNum<f64> + Copy, T: DualNum<f64> + Copy>(
    xy: &[T; 2],
    yaw: &Y,
    target: &Pose,
    w: &[f64; 2],
) -> ([T; 2], Y) {
    let d = *yaw - target.z;
    let turns = (d.re() / TAU).round();
    (
        [(xy[0] - target.x) * w[0], (xy[1] - target.y) * w[0]],
        (d - turns * TAU) * w[1],
    )
}

/// The least-squares problem of one fit: the residuals of every step of every window, and
/// the ridge penalty. A plain struct, as argmin wants it; the Jacobian pass is shared by the
/// gradient and the Gauss-Newton Hessian through a one-entry cache.
pub(super) struct Ipem<'a> {
    pub(super) tracks: Vec<&'a Track>,
    /// Residual weights: 1 / the robust scale of the slip-free model's position and yaw
    /// errors.
    pub(super) weights: [f64; 2],
    /// Per body dimension, the weight of one unit of `u` (`s_x`, `s_x`, `s_w`).
    pub(super) scale: [f64; 3],
    pub(super) ridge: f64,
    /// Number of residuals.
    pub(super) count: f64,
    pub(super) dt: f64,
    pub(super) cache: RefCell<Option<Linearization>>,
}

/// Tracks per parallel task of [`Ipem::linearize`]: fixed, so that the sums do not depend
/// on the number of threads.
pub(super) const LINEARIZE_CHUNK: usize = 16;

/// The gradient and Gauss-Newton Hessian of the cost at `u`.
#[derive(Clone)]
pub(super) struct Linearization {
    pub(super) u: DVector<f64>,
    pub(super) gradient: DVector<f64>,
    pub(super) hessian: DMatrix<f64>,
}

impl<'a> Ipem<'a> {
    pub(super) fn new(
        tracks: Vec<&'a Track>,
        weights: [f64; 2],
        scale: [f64; 3],
        ridge: f64,
        dt: f64,
    ) -> Self {
        let count = tracks
            .iter()
            .map(|t| 3 * t.f.len().saturating_sub(1))
            .sum::<usize>() as f64;
        Ipem {
            tracks,
            weights,
            scale,
            ridge,
            count: count.max(1.0),
            dt,
            cache: RefCell::new(None),
        }
    }

    /// The bounds of the start velocity's departure (the largest commanded speed) and of
    /// the disturbance (the largest commanded yaw rate).
    pub(super) fn limits(&self) -> [f64; 2] {
        [self.scale[0], self.scale[2]]
    }

    /// The penalty at `u`: the ridge on the weights, the weak pull of the body dynamics'
    /// logits towards [`DYNAMICS_PRIOR`].
    pub(super) fn penalty(&self, u: &DVector<f64>) -> f64 {
        (0..PARAMETERS)
            .map(|j| {
                let (c, u0) = self.penalty_parts(j);
                c * (u[j] - u0).powi(2)
            })
            .sum()
    }

    /// The curvature and centre of the penalty of variable `j`.
    pub(super) fn penalty_parts(&self, j: usize) -> (f64, f64) {
        if j < WEIGHTS {
            (self.ridge, 0.0)
        } else {
            (DYNAMICS_PRIOR_WEIGHT, DYNAMICS_PRIOR[j - WEIGHTS])
        }
    }

    pub(super) fn penalty_gradient(&self, u: &DVector<f64>, j: usize) -> f64 {
        let (c, u0) = self.penalty_parts(j);
        c * (u[j] - u0)
    }

    pub(super) fn penalty_curvature(&self, j: usize) -> f64 {
        self.penalty_parts(j).0
    }

    /// The sum of the residuals' robust losses at `u`.
    pub(super) fn sum_of_losses(&self, u: &[f64]) -> f64 {
        self.losses_by_interval(u).iter().sum()
    }

    /// The sums of the residuals' robust losses at `u` per interval, in the tracks' order.
    pub(super) fn losses_by_interval(&self, u: &[f64]) -> Vec<f64> {
        let theta = theta_of(u, &self.scale);
        let dynamics = dynamics_of(&theta, self.limits());
        let mut out: Vec<f64> = Vec::new();
        let mut interval = None;
        for t in &self.tracks {
            if interval != Some(t.interval) {
                interval = Some(t.interval);
                out.push(0.0);
            }
            let mut sum = 0.0;
            let slip = |k: usize| split(slip_of(&theta, &t.features[k]));
            t.rollout(self.dt, &dynamics, slip, |k, xy, yaw| {
                let ([rx, ry], rz) = residual(xy, yaw, &t.target[k], &self.weights);
                sum += robust_loss(rx * rx) + robust_loss(ry * ry) + robust_loss(rz * rz);
            });
            // A value was pushed when the interval began.
            *out.last_mut().expect("pushed above") += sum;
        }
        out
    }

    /// Runs the rollouts with dual numbers at `u`: `visit(window, jt, r)` with each
    /// window's transposed residual Jacobian (`PARAMETERS` x residuals) and residuals.
    pub(super) fn jacobians(&self, u: &[f64], visit: impl FnMut(usize, &Mat<f64>, &[f64])) {
        self.residuals().jacobians(&self.tracks, u, visit)
    }

    /// What the residuals of a track depend on besides the track (shared by the threads of
    /// [`Ipem::linearize`]).
    fn residuals(&self) -> Residuals {
        Residuals {
            weights: self.weights,
            scale: self.scale,
            dt: self.dt,
            limits: self.limits(),
        }
    }

    /// The gradient and Gauss-Newton Hessian at `u` (cached for the last `u`).
    pub(super) fn linearize(&self, u: &DVector<f64>) -> Linearization {
        if let Some(l) = self.cache.borrow().as_ref() {
            if &l.u == u {
                return l.clone();
            }
        }
        // J^T J is symmetric: only its lower triangle is accumulated (half the work of
        // the full product), then read for both halves. The tracks in fixed chunks on
        // rayon's threads, the chunks' sums added in the chunks' order: the same numbers
        // on any number of threads.
        let residuals = self.residuals();
        let parts: Vec<(Mat<f64>, Vec<f64>)> = self
            .tracks
            .par_chunks(LINEARIZE_CHUNK)
            .map(|tracks| {
                let mut jtj = Mat::<f64>::zeros(PARAMETERS, PARAMETERS);
                let mut jtr = vec![0.0; PARAMETERS];
                residuals.jacobians(tracks, u.as_slice(), |_, jt, r| {
                    triangular::matmul(
                        jtj.as_mut(),
                        BlockStructure::TriangularLower,
                        Accum::Add,
                        jt.as_ref(),
                        BlockStructure::Rectangular,
                        jt.transpose(),
                        BlockStructure::Rectangular,
                        1.0,
                        Par::Seq,
                    );
                    for (c, rc) in r.iter().enumerate() {
                        for (acc, g) in jtr.iter_mut().zip(jt.col_as_slice(c)) {
                            *acc += g * rc;
                        }
                    }
                });
                (jtj, jtr)
            })
            .collect();
        let mut jtj = Mat::<f64>::zeros(PARAMETERS, PARAMETERS);
        let mut jtr = vec![0.0; PARAMETERS];
        for (part_jtj, part_jtr) in &parts {
            jtj += part_jtj;
            for (acc, g) in jtr.iter_mut().zip(part_jtr) {
                *acc += g;
            }
        }
        let n = self.count;
        let gradient =
            DVector::from_fn(PARAMETERS, |j, _| jtr[j] / n + self.penalty_gradient(u, j));
        let hessian = DMatrix::from_fn(PARAMETERS, PARAMETERS, |i, j| {
            jtj[(i.max(j), i.min(j))] / n
                + if i == j {
                    self.penalty_curvature(j)
                } else {
                    0.0
                }
        });
        let l = Linearization {
            u: u.clone(),
            gradient,
            hessian,
        };
        *self.cache.borrow_mut() = Some(l.clone());
        l
    }
}

/// What a track's residuals depend on besides the track: the residual weights, the unit of
/// the variables, the step and the bounds of the start velocity and disturbance. Plain
/// numbers, shared by the threads of [`Ipem::linearize`].
#[derive(Clone, Copy)]
pub(super) struct Residuals {
    weights: [f64; 2],
    scale: [f64; 3],
    dt: f64,
    limits: [f64; 2],
}

impl Residuals {
    /// [`Ipem::jacobians`] over `tracks` (`visit`'s window index counts in `tracks`).
    /// Inlined into its one caller per chunk: left to rustc's split of the crate into
    /// codegen units, it was a call of its own whenever unrelated code moved that split,
    /// copying its dual numbers through memcpy (+28% instructions in the fit).
    #[inline(always)]
    pub(super) fn jacobians(
        &self,
        tracks: &[&Track],
        u: &[f64],
        mut visit: impl FnMut(usize, &Mat<f64>, &[f64]),
    ) {
        let theta = theta_of(u, &self.scale);
        let weights = |d: usize| &theta[d * FEATURES..(d + 1) * FEATURES];
        let logit = |j: usize| theta[WEIGHTS + j];
        let fixed = dynamics_of(&theta, self.limits);
        // The Jacobian in two groups of columns, each by forward-mode differentiation of the
        // rollout: the yaw path's variables (the yaw weights, the yaw lag, the disturbance's
        // trust and persistence), on which every residual depends; then the position path's
        // (the x and y weights and lags), on which the yaw never depends, so that its yaw
        // path runs in plain numbers.
        let yaw_dynamics: Dynamics<YawDual> = Dynamics {
            lag_xy: fixed.lag_xy.map(YawDual::from),
            lag_yaw: seeded_sigmoid(logit(2), FEATURES),
            trust: seeded_sigmoid(logit(3), FEATURES + 1),
            persistence: seeded_sigmoid(logit(4), FEATURES + 2),
            velocity_trust: YawDual::from(fixed.velocity_trust),
            velocity_limit: fixed.velocity_limit,
            disturbance_limit: fixed.disturbance_limit,
            transport: true,
        };
        let position_dynamics: Dynamics<f64, PositionDual> = Dynamics {
            lag_xy: [
                seeded_sigmoid(logit(0), 2 * FEATURES),
                seeded_sigmoid(logit(1), 2 * FEATURES + 1),
            ],
            lag_yaw: fixed.lag_yaw,
            trust: fixed.trust,
            persistence: fixed.persistence,
            velocity_trust: seeded_sigmoid(logit(5), 2 * FEATURES + 2),
            velocity_limit: fixed.velocity_limit,
            disturbance_limit: fixed.disturbance_limit,
            transport: true,
        };
        let mut jt = Mat::<f64>::zeros(PARAMETERS, 0);
        let (mut r, mut row_weights) = (Vec::new(), Vec::new());
        for (i, t) in tracks.iter().enumerate() {
            // Every entry zero: the groups write their own rows only.
            jt.resize_with(PARAMETERS, 0, |_, _| 0.0);
            jt.resize_with(PARAMETERS, 3 * t.f.len().saturating_sub(1), |_, _| 0.0);
            r.clear();
            row_weights.clear();
            let slip = |k: usize| {
                let phi = &t.features[k];
                (
                    [dot(weights(0), phi), dot(weights(1), phi)].map(YawDual::from),
                    seeded_dimension(weights(2), phi, self.scale[2], 0),
                )
            };
            t.rollout(self.dt, &yaw_dynamics, slip, |k, xy, yaw| {
                let ([rx, ry], rz) = residual(xy, yaw, &t.target[k], &self.weights);
                for ri in [rx, ry, rz] {
                    let col = r.len();
                    // Iteratively reweighted: the Gauss-Newton model of the robust loss
                    // weighs each residual's row by sqrt(rho'(r^2)).
                    let w = robust_weight(ri.re * ri.re).sqrt();
                    let g = ri.eps.unwrap_generic(Const::<YAW_VARIABLES>, U1);
                    let column = jt.col_as_slice_mut(col);
                    for (j, gj) in g.iter().enumerate() {
                        column[yaw_variable(j)] = gj * w;
                    }
                    r.push(ri.re * w);
                    row_weights.push(w);
                }
            });
            let slip = |k: usize| {
                let phi = &t.features[k];
                (
                    [
                        seeded_dimension(weights(0), phi, self.scale[0], 0),
                        seeded_dimension(weights(1), phi, self.scale[1], FEATURES),
                    ],
                    dot(weights(2), phi),
                )
            };
            let mut col = 0;
            t.rollout(self.dt, &position_dynamics, slip, |k, xy, yaw| {
                let (rxy, _) = residual(xy, yaw, &t.target[k], &self.weights);
                for (c, ri) in rxy.iter().enumerate() {
                    let w = row_weights[col + c];
                    let g = ri.eps.unwrap_generic(Const::<POSITION_VARIABLES>, U1);
                    let column = jt.col_as_slice_mut(col + c);
                    for (j, gj) in g.iter().enumerate() {
                        column[position_variable(j)] = gj * w;
                    }
                }
                col += 3;
            });
            visit(i, &jt, &r);
        }
    }
}

impl CostFunction for Ipem<'_> {
    type Param = DVector<f64>;
    type Output = f64;

    fn cost(&self, u: &Self::Param) -> Result<f64, ArgminError> {
        Ok(0.5 * (self.sum_of_losses(u.as_slice()) / self.count + self.penalty(u)))
    }
}

impl Gradient for Ipem<'_> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;

    fn gradient(&self, u: &Self::Param) -> Result<Self::Gradient, ArgminError> {
        Ok(self.linearize(u).gradient)
    }
}

impl Hessian for Ipem<'_> {
    type Param = DVector<f64>;
    type Hessian = DMatrix<f64>;

    fn hessian(&self, u: &Self::Param) -> Result<Self::Hessian, ArgminError> {
        Ok(self.linearize(u).hessian)
    }
}

/// The state of argmin's trust region on nalgebra vectors.
pub(super) type TrState = IterState<DVector<f64>, DVector<f64>, (), DMatrix<f64>, (), f64>;

/// An argmin solver that runs another and stops it once the Gauss-Newton model at the
/// current point promises less than `tolerance` of the cost (half the Newton decrement
/// `g^T H^-1 g`): argmin's trust region itself stops only at its iteration limit.
#[derive(Clone)]
pub(super) struct UntilConverged<S> {
    pub(super) inner: S,
    pub(super) tolerance: f64,
}

impl<O, S: Solver<O, TrState>> Solver<O, TrState> for UntilConverged<S> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: TrState,
    ) -> Result<(TrState, Option<KV>), ArgminError> {
        self.inner.init(problem, state)
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: TrState,
    ) -> Result<(TrState, Option<KV>), ArgminError> {
        self.inner.next_iter(problem, state)
    }

    fn terminate(&mut self, state: &TrState) -> TerminationStatus {
        if let (Some(g), Some(h)) = (state.get_gradient(), state.get_hessian()) {
            if let Some(chol) = h.clone().cholesky() {
                let decrement = g.dot(&chol.solve(g));
                if 0.5 * decrement <= self.tolerance * state.get_cost().abs().max(1e-300) {
                    return TerminationStatus::Terminated(TerminationReason::SolverConverged);
                }
            }
        }
        self.inner.terminate(state)
    }
}

/// Fits the unitless weights `u` of `problem` from `start`.
pub(super) fn solve(
    problem: Ipem<'_>,
    start: DVector<f64>,
    iterations: u64,
    tolerance: f64,
) -> Result<DVector<f64>, FitError> {
    let optimizer = |e: ArgminError| FitError::Optimizer {
        what: "slip-ipem".into(),
        reason: e.to_string(),
    };
    let solver = UntilConverged {
        inner: TrustRegion::new(Dogleg::new()),
        tolerance,
    };
    let result = Executor::new(problem, solver)
        .configure(|state| state.param(start).max_iters(iterations))
        .run()
        .map_err(optimizer)?;
    let u = result
        .state()
        .get_best_param()
        .cloned()
        .ok_or_else(|| FitError::NonFinite {
            what: "slip-ipem".into(),
        })?;
    if u.iter().all(|v| v.is_finite()) {
        Ok(u)
    } else {
        Err(FitError::NonFinite {
            what: "slip-ipem".into(),
        })
    }
}
