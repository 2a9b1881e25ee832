//! The fitted slip-ipem model: its slip function on the normalized commanded velocity, the body
//! dynamics (the lagging velocity carried through the body's rotation, the yaw disturbance)
//! and the rollouts of its mean and pose covariance.

use super::*;
use drive_traits::InvalidPart;

/// Fitted `slip-ipem`: the slip weights on [`slip_features`] and the uncertainty of its
/// rollouts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlipIpemModel {
    /// The largest commanded speed and yaw rate of the training windows (`s_x`, `s_w`):
    /// the normalization of the slip functions.
    pub scale: [f64; 2],
    /// The weights of the x, y and yaw slip, [`FEATURES`] each.
    pub weights: [Vec<f64>; 3],
    /// The body-velocity lag per step (x, y, yaw) as logits: the body velocity moves by
    /// `sigmoid(lag_logit)` of the way to its steady value `f - g` each step (1: no lag).
    pub lag_logit: [f64; 3],
    /// The yaw disturbance's trust and persistence as logits: `sigmoid(trust)` of the
    /// measured start yaw rate's difference from the model's (bounded by `scale[1]`, the
    /// largest commanded yaw rate: a larger one is a faulty IMU, not the ground) is added to
    /// the yaw rate, and decays by `sigmoid(persistence)` per step. Absent from files written
    /// before it (no disturbance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disturbance_logit: Option<[f64; 2]>,
    /// The start velocity's trust as a logit: when the body velocity is measured at the
    /// start ([`StartState::velocity`], the localization's), the lagging velocity starts
    /// `sigmoid(velocity_logit)` of the way from the steady velocity to it (the departure
    /// bounded by `scale[0]` per component: a larger one is a localization glitch). Absent
    /// from files written before it (the steady velocity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_logit: Option<f64>,
    /// Whether the lagging body velocity is carried through the body's rotation: true for
    /// every model fitted since it was introduced, false (absent) in files written before,
    /// which predict as they did.
    #[serde(default)]
    pub transport: bool,
    /// The step the body dynamics were fitted at (s): the lag shares and the disturbance's
    /// persistence are per step, and the transport turns the velocity by the yaw rate over
    /// one step. 0 (absent) in files written before the transport.
    #[serde(default)]
    pub dt: f64,
    /// The ridge strength chosen on the inner split.
    pub ridge: f64,
    /// The covariance of the fitted parameters, row-major [`PARAMETERS`] x [`PARAMETERS`]:
    /// the weights in the order of `weights` (x, y, yaw), then the three lag logits, the two
    /// disturbance logits and the start velocity's logit (in a file written before the
    /// start velocity, without its row: `(PARAMETERS - 1)^2` entries; before the
    /// disturbance, `(PARAMETERS - 3)^2`).
    pub weight_covariance: Vec<f64>,
    /// The variance of the body-velocity bias held over a rollout (x, y, yaw).
    pub bias_variance: [f64; 3],
}

impl Tagged for SlipIpemModel {
    const TAG: &'static str = "slip-ipem";
}

/// The body dynamics' coefficients: what moves the body velocity from one step to the
/// next besides the slip map (numbers, or dual numbers carrying their derivatives). `Y` is
/// the number type of the yaw path, `T` of the position path (see [`rollout`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Dynamics<Y, T = Y> {
    /// Share of the way to the steady body velocity covered per step along x and y (1:
    /// no lag).
    pub(super) lag_xy: [T; 2],
    /// The same for the yaw rate.
    pub(super) lag_yaw: Y,
    /// Share of the measured start yaw rate's difference from the model's taken as a
    /// disturbance (0: none).
    pub(super) trust: Y,
    /// Factor by which the disturbance decays per step.
    pub(super) persistence: Y,
    /// Share of the measured start velocity's difference from the model's steady one (x
    /// and y) that the lagging velocity starts from (0: the steady velocity).
    pub(super) velocity_trust: T,
    /// The largest departure of the measured start velocity from the model's, per
    /// component, taken as it is (m/s): beyond it, this much (the largest commanded speed
    /// of the training windows: a larger one is a localization glitch, not the ground).
    pub(super) velocity_limit: f64,
    /// The largest departure of the measured start yaw rate from the model's taken as it
    /// is (rad/s): beyond it, this much (the largest commanded yaw rate of the training
    /// windows: a larger disturbance is not one the ground causes but a faulty IMU).
    pub(super) disturbance_limit: f64,
    /// Whether the lagging velocity is carried through the body's rotation.
    pub(super) transport: bool,
}

impl Dynamics<f64> {
    /// No lag, no disturbance: the body velocity is the steady one at every step.
    pub(super) const NONE: Dynamics<f64> = Dynamics {
        lag_xy: [1.0; 2],
        lag_yaw: 1.0,
        trust: 0.0,
        persistence: 0.0,
        velocity_trust: 0.0,
        velocity_limit: 0.0,
        disturbance_limit: 0.0,
        transport: true,
    };

    /// The same coefficients as dual numbers without derivatives.
    pub(super) fn constant<T: DualNum<f64> + Copy>(&self) -> Dynamics<T> {
        Dynamics {
            lag_xy: self.lag_xy.map(T::from),
            lag_yaw: T::from(self.lag_yaw),
            trust: T::from(self.trust),
            persistence: T::from(self.persistence),
            velocity_trust: T::from(self.velocity_trust),
            velocity_limit: self.velocity_limit,
            disturbance_limit: self.disturbance_limit,
            transport: self.transport,
        }
    }
}

/// The body velocity along a rollout: the lagging state, the yaw disturbance and the yaw
/// rate of the last step. One implementation for the fit (dual numbers), the mean
/// prediction and the covariance rollout, so that they never disagree.
pub(super) struct Body<Y, T> {
    pub(super) velocity: Option<([T; 2], Y)>,
    pub(super) disturbance: Y,
    pub(super) yaw_rate: Y,
}

impl<Y, T> Body<Y, T>
where
    Y: DualNum<f64> + Copy,
    T: DualNum<f64> + Copy + Mul<Y, Output = T>,
{
    pub(super) fn new() -> Self {
        Body {
            velocity: None,
            disturbance: Y::from(0.0),
            yaw_rate: Y::from(0.0),
        }
    }

    /// The body velocity (x and y, yaw rate) of the next step towards the steady velocity
    /// `target`; the first step starts at `target`, moved towards the velocity measured
    /// then (when given) by its trust, and the yaw rate measured then (when given) sets the
    /// disturbance.
    #[inline]
    pub(super) fn step(
        &mut self,
        target: ([T; 2], Y),
        dynamics: &Dynamics<Y, T>,
        measured: &Measured,
        dt: f64,
    ) -> ([T; 2], Y) {
        let (xy, yaw_rate) = match self.velocity {
            None => {
                if let Some(w) = measured.yaw_rate {
                    let limit = dynamics.disturbance_limit;
                    let departure = Y::from(w) - target.1;
                    let departure = if departure.re().abs() > limit {
                        Y::from(limit.copysign(departure.re()))
                    } else {
                        departure
                    };
                    self.disturbance = dynamics.trust * departure;
                }
                let xy = match measured.velocity {
                    Some(v) => std::array::from_fn(|i| {
                        let limit = dynamics.velocity_limit;
                        let departure = T::from(v[i]) - target.0[i];
                        let departure = if departure.re().abs() > limit {
                            T::from(limit.copysign(departure.re()))
                        } else {
                            departure
                        };
                        target.0[i] + dynamics.velocity_trust * departure
                    }),
                    None => target.0,
                };
                (xy, target.1)
            }
            Some(([mut px, mut py], pz)) => {
                if dynamics.transport {
                    // The body turned by yaw_rate * dt: a velocity that the ground has not
                    // yet changed turns the other way in the body frame.
                    let (s, c) = (self.yaw_rate * dt).sin_cos();
                    (px, py) = (px * c + py * s, py * c - px * s);
                }
                let [lx, ly] = dynamics.lag_xy;
                let [tx, ty] = target.0;
                (
                    [px + lx * (tx - px), py + ly * (ty - py)],
                    pz + dynamics.lag_yaw * (target.1 - pz),
                )
            }
        };
        self.velocity = Some((xy, yaw_rate));
        let yaw_rate = yaw_rate + self.disturbance;
        self.disturbance *= dynamics.persistence;
        self.yaw_rate = yaw_rate;
        (xy, yaw_rate)
    }
}

impl<Y, T> Body<Y, T>
where
    Y: DualNum<f64> + Copy,
    T: DualNum<f64> + Copy + Mul<Y, Output = T>,
{
    /// Takes the body's motion measured before the next step ([`ObservedMotion`]) as the
    /// lagging velocity's state: the yaw rate measured (less the disturbance still acting,
    /// so that the model turns at the measured rate), the velocity measured, each only
    /// when measured and, as at a start, at most the dynamics' limits away from the steady
    /// velocity `target` (a larger departure is a glitch, not the ground). Before the first
    /// step there is no state to correct: the start's own measurements set it.
    #[inline]
    pub(super) fn observe(
        &mut self,
        target: &([T; 2], Y),
        dynamics: &Dynamics<Y, T>,
        observed: &ObservedMotion,
    ) {
        let Some((mut xy, mut z)) = self.velocity else {
            return;
        };
        // A measurement carries no derivative with respect to the parameters; one clamped
        // to the limit is the steady velocity's, moved by it.
        if let Some(w) = observed.yaw_rate {
            let limit = dynamics.disturbance_limit;
            let departure = w - target.1.re();
            let measured = if departure.abs() <= limit {
                Y::from(w)
            } else {
                target.1 + Y::from(limit.copysign(departure))
            };
            z = measured - self.disturbance;
            self.yaw_rate = measured;
        }
        if let Some(v) = observed.velocity {
            let limit = dynamics.velocity_limit;
            xy = std::array::from_fn(|i| {
                let departure = v[i] - target.0[i].re();
                if departure.abs() <= limit {
                    T::from(v[i])
                } else {
                    target.0[i] + T::from(limit.copysign(departure))
                }
            });
        }
        self.velocity = Some((xy, z));
    }
}

/// Euler rollout of eq. 1 over the commanded body velocities `f` from `start`, with the
/// slip `slip(k)` (x and y, yaw) at each step (`v = f - g`, eq. 2) through the body
/// dynamics: `visit(k, position_k, yaw_k)` for every `k >= 1`. Generic over the number
/// types, so that the same code gives poses (`f64`) and their derivatives (num-dual's dual
/// numbers): `Y` for the yaw path (the yaw rate and the heading), `T` for the position path.
/// The yaw path never depends on the position path, so a Jacobian with respect to
/// parameters of the position path only can run the yaw path in plain numbers (`Y = f64`).
#[inline]
pub(super) fn rollout<Y, T>(
    start: &Pose,
    measured: &Measured,
    f: &[BodyVelocity],
    dt: f64,
    dynamics: &Dynamics<Y, T>,
    mut slip: impl FnMut(usize) -> ([T; 2], Y),
    mut visit: impl FnMut(usize, &[T; 2], &Y),
) where
    Y: DualNum<f64> + Copy,
    T: DualNum<f64> + Copy + Mul<Y, Output = T>,
{
    let (mut x, mut y, mut yaw) = (T::from(start.x), T::from(start.y), Y::from(start.z));
    let n = f.len();
    let mut body = Body::new();
    for (k, fk) in f.iter().enumerate() {
        if k > 0 {
            visit(k, &[x, y], &yaw);
        }
        if k + 1 == n {
            break;
        }
        let (g, gz) = slip(k);
        let target = (
            [T::from(fk.x) - g[0], T::from(fk.y) - g[1]],
            Y::from(fk.z) - gz,
        );
        if let Some(o) = measured.at(k) {
            body.observe(&target, dynamics, o);
        }
        let ([vx, vy], vz) = body.step(target, dynamics, measured, dt);
        let (s, c) = yaw.sin_cos();
        x += (vx * c - vy * s) * dt;
        y += (vx * s + vy * c) * dt;
        yaw += vz * dt;
    }
}

/// A slip (x, y, yaw) as the rollout takes it: x and y, then yaw.
#[inline]
pub(super) fn split<T: Copy>(g: [T; 3]) -> ([T; 2], T) {
    ([g[0], g[1]], g[2])
}

/// The slip (x, y, yaw) of the weights `theta` at the slip functions `phi`. Always inlined:
/// a call of its own (as rustc left it in one codegen unit) costs 28% more per step.
#[inline(always)]
pub(super) fn slip_of<T: DualNum<f64> + Copy>(
    theta: &[T; PARAMETERS],
    phi: &[f64; FEATURES],
) -> [T; 3] {
    let dim = |d: usize| {
        theta[d * FEATURES..(d + 1) * FEATURES]
            .iter()
            .zip(phi)
            .fold(T::from(0.0), |acc, (w, p)| acc + *w * *p)
    };
    [dim(0), dim(1), dim(2)]
}

/// `sum_j w_j phi_j`.
#[inline]
pub(super) fn dot(w: &[f64], phi: &[f64; FEATURES]) -> f64 {
    w.iter().zip(phi).map(|(w, p)| w * p).sum()
}

/// The weights of the unitless parameters `u`: `theta = scale * u` per body dimension.
pub(super) fn theta_of(u: &[f64], scale: &[f64; 3]) -> [f64; PARAMETERS] {
    std::array::from_fn(|j| {
        if j < WEIGHTS {
            u[j] * scale[j / FEATURES]
        } else {
            u[j]
        }
    })
}

/// `1 / (1 + e^-x)`: a coefficient in (0, 1) of its logit.
pub(super) fn sigmoid<T: DualNum<f64> + Copy>(x: T) -> T {
    (T::from(1.0) + (-x).exp()).recip()
}

/// The body dynamics of the logits in `theta` (with the disturbance, start velocity and
/// transport of a model fitted now), the start velocity's departure bounded by `limits[0]`
/// (m/s), the disturbance by `limits[1]` (rad/s).
pub(super) fn dynamics_of(theta: &[f64; PARAMETERS], limits: [f64; 2]) -> Dynamics<f64> {
    let c = |j: usize| sigmoid(theta[WEIGHTS + j]);
    Dynamics {
        lag_xy: [c(0), c(1)],
        lag_yaw: c(2),
        trust: c(3),
        persistence: c(4),
        velocity_trust: c(5),
        velocity_limit: limits[0],
        disturbance_limit: limits[1],
        transport: true,
    }
}

impl SlipIpemModel {
    /// The parameters as one fixed-size array: the weights (x, y, yaw), the lag logits, the
    /// disturbance logits and the start velocity's logit (0 in a file written before them,
    /// where they are off);
    /// NaN where a loaded file lacks a weight, so that a malformed model never predicts
    /// plausible numbers.
    pub(super) fn theta(&self) -> [f64; PARAMETERS] {
        std::array::from_fn(|j| {
            if j < WEIGHTS {
                self.weights[j / FEATURES]
                    .get(j % FEATURES)
                    .copied()
                    .unwrap_or(f64::NAN)
            } else if j < WEIGHTS + 3 {
                self.lag_logit[j - WEIGHTS]
            } else if j < WEIGHTS + 5 {
                self.disturbance_logit.map_or(0.0, |d| d[j - WEIGHTS - 3])
            } else {
                self.velocity_logit.unwrap_or(0.0)
            }
        })
    }

    /// The body dynamics: the lags, the disturbance and the start velocity (none in a file
    /// written before them) and the transport.
    pub(super) fn dynamics(&self) -> Dynamics<f64> {
        let [lx, ly, lz] = self.lag_logit.map(sigmoid);
        let [trust, persistence] = self.disturbance_logit.map_or([0.0; 2], |d| d.map(sigmoid));
        Dynamics {
            lag_xy: [lx, ly],
            lag_yaw: lz,
            trust,
            persistence,
            velocity_trust: self.velocity_logit.map_or(0.0, sigmoid),
            velocity_limit: self.scale[0],
            disturbance_limit: self.scale[1],
            transport: self.transport,
        }
    }

    /// The parameters' covariance (a file written before the disturbance or the start
    /// velocity holds the parameters it had only: the others' rows are zero, they are off);
    /// `None` for a covariance of another size.
    pub(super) fn covariance(&self) -> Option<SMatrix<f64, PARAMETERS, PARAMETERS>> {
        let c = &self.weight_covariance;
        let size = self.covariance_size();
        (c.len() == size * size).then(|| {
            SMatrix::from_fn(|i, j| {
                if i < size && j < size {
                    c[i * size + j]
                } else {
                    0.0
                }
            })
        })
    }

    /// The body velocities of a rollout through `f` (eq. 2 through the body dynamics) from
    /// what was measured at the start.
    pub(super) fn velocities(
        &self,
        measured: &Measured,
        f: &[BodyVelocity],
        out: &mut Vec<BodyVelocity>,
    ) {
        let theta = self.theta();
        let dynamics = self.dynamics();
        let mut body = Body::new();
        out.clear();
        out.extend(f.iter().enumerate().map(|(k, f)| {
            let g = slip_of(&theta, &slip_features(f, &self.scale));
            let target = ([f.x - g[0], f.y - g[1]], f.z - g[2]);
            if let Some(o) = measured.at(k) {
                body.observe(&target, &dynamics, o);
            }
            let ([x, y], z) = body.step(target, &dynamics, measured, self.dt);
            BodyVelocity::new(x, y, z)
        }));
    }

    /// The size the covariance of this model's file has: the parameters it holds (the
    /// disturbance and start velocity came later; a file with the start velocity has both).
    pub(super) fn covariance_size(&self) -> usize {
        match (self.disturbance_logit, self.velocity_logit) {
            (_, Some(_)) => PARAMETERS,
            (Some(_), None) => PARAMETERS_V2,
            (None, None) => PARAMETERS_V1,
        }
    }
}

#[typetag::serde(name = "slip-ipem")]
impl SlipModel for SlipIpemModel {
    fn slip(&self, f: &BodyVelocity) -> BodyVelocity {
        let phi = slip_features(f, &self.scale);
        let dot = |w: &[f64]| w.iter().zip(&phi).map(|(w, p)| w * p).sum::<f64>();
        BodyVelocity::new(
            dot(&self.weights[0]),
            dot(&self.weights[1]),
            dot(&self.weights[2]),
        )
    }

    fn body_velocities_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) {
        self.velocities(&Measured::default(), f, out);
    }

    /// The body dynamics from the yaw rate and the velocity measured at the start, when
    /// there are.
    fn rollout_velocities_into(
        &self,
        start: &StartState,
        f: &[BodyVelocity],
        out: &mut Vec<BodyVelocity>,
    ) {
        self.velocities(&Measured::of(start), f, out);
    }

    /// The weights' covariance and the held bias pushed through the rollout (first order,
    /// by forward-mode differentiation of eq. 1).
    fn rollout_covariances_into(
        &self,
        start: &StartState,
        f: &[BodyVelocity],
        dt: f64,
        out: &mut Vec<PoseCovariance>,
    ) -> bool {
        out.clear();
        let Some(cov) = self.covariance() else {
            // A malformed model (its file check says so): no covariance rather than a panic.
            return false;
        };
        if f.is_empty() {
            return true;
        }
        let theta = self.theta();
        let features: Vec<[f64; FEATURES]> =
            f.iter().map(|f| slip_features(f, &self.scale)).collect();
        let slip = |k: usize| {
            split(seeded_slip::<WITH_BIAS>(
                &theta,
                &features[k],
                &[1.0; 3],
                Some(PARAMETERS),
            ))
        };
        let dynamics = seeded_dynamics::<WITH_BIAS>(
            &theta,
            [
                self.disturbance_logit.is_some(),
                self.velocity_logit.is_some(),
            ],
            self.scale,
            self.transport,
        );
        let q = self.bias_variance;
        out.push(PoseCovariance::zeros());
        rollout(
            &start.pose,
            &Measured::of(start),
            f,
            dt,
            &dynamics,
            slip,
            |_, xy, yaw| {
                let j: SMatrix<f64, 3, WITH_BIAS> = SMatrix::from_rows(&[
                    xy[0].eps.unwrap_generic(Const::<WITH_BIAS>, U1).transpose(),
                    xy[1].eps.unwrap_generic(Const::<WITH_BIAS>, U1).transpose(),
                    yaw.eps.unwrap_generic(Const::<WITH_BIAS>, U1).transpose(),
                ]);
                let jw = j.fixed_columns::<PARAMETERS>(0);
                let jb = j.fixed_columns::<3>(PARAMETERS);
                let qb = SMatrix::<f64, 3, 3>::from_diagonal(&SVector::from(q));
                let c = jw * cov * jw.transpose() + jb * qb * jb.transpose();
                out.push(0.5 * (c + c.transpose()));
            },
        );
        true
    }

    /// The slip weights per dimension and slip function, the body-velocity lag shares per
    /// step, the yaw disturbance's trust and persistence and the start velocity's trust
    /// (as the shares they are, not their logits), and the ridge strength.
    fn parameters(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for (dimension, weights) in ["longitudinal", "lateral", "angular"]
            .into_iter()
            .zip(&self.weights)
        {
            for (name, w) in FEATURE_NAMES.iter().zip(weights) {
                out.push((format!("{dimension} slip: w[{name}]"), *w));
            }
        }
        for (axis, logit) in ["x", "y", "yaw"].into_iter().zip(self.lag_logit) {
            out.push((
                format!("{axis} velocity lag share per step"),
                sigmoid(logit),
            ));
        }
        if let Some([trust, persistence]) = self.disturbance_logit {
            out.push(("yaw disturbance trust".into(), sigmoid(trust)));
            out.push((
                "yaw disturbance persistence per step".into(),
                sigmoid(persistence),
            ));
        }
        if let Some(v) = self.velocity_logit {
            out.push(("start velocity trust".into(), sigmoid(v)));
        }
        out.push(("ridge strength".into(), self.ridge));
        out
    }

    fn check(&self) -> Result<(), InvalidPart> {
        if !self
            .scale
            .iter()
            .all(|s| s.is_finite() && *s > 0.0 && *s <= MAX_ABS_MEASUREMENT)
        {
            return Err(InvalidPart::from(format!(
                "slip-ipem: scale [{}, {}] is not two positive numbers up to {}",
                Short(self.scale[0]),
                Short(self.scale[1]),
                Short(MAX_ABS_MEASUREMENT)
            )));
        }
        for (d, w) in ["x", "y", "yaw"].iter().zip(&self.weights) {
            if w.len() != FEATURES {
                return Err(InvalidPart::from(format!(
                    "slip-ipem: {} {d} weights, expected {FEATURES}",
                    w.len()
                )));
            }
            if let Some(v) = w
                .iter()
                .find(|v| !(v.is_finite() && v.abs() <= MAX_ABS_MEASUREMENT))
            {
                return Err(InvalidPart::from(format!(
                    "slip-ipem: {d} weight {} is not a number within +-{} (a slip velocity)",
                    Short(*v),
                    Short(MAX_ABS_MEASUREMENT)
                )));
            }
        }
        let logits = self
            .lag_logit
            .iter()
            .map(|v| ("lag", v))
            .chain(
                self.disturbance_logit
                    .iter()
                    .flatten()
                    .map(|v| ("disturbance", v)),
            )
            .chain(self.velocity_logit.iter().map(|v| ("start velocity", v)));
        for (what, v) in logits {
            if !(v.is_finite() && v.abs() <= MAX_LOGIT) {
                return Err(InvalidPart::from(format!(
                    "slip-ipem: {what} logit {} is not a number within +-{MAX_LOGIT}",
                    Short(*v)
                )));
            }
        }
        if self.transport && !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(InvalidPart::from(format!(
                "slip-ipem: dt (the step its body dynamics were fitted at) is {}: missing or not a positive number of seconds",
                Short(self.dt)
            )));
        }
        if !(self.ridge.is_finite() && self.ridge >= 0.0) {
            return Err(InvalidPart::from(format!(
                "slip-ipem: ridge {} is not a finite number >= 0",
                self.ridge
            )));
        }
        let size = self.covariance_size();
        if self.weight_covariance.len() != size * size {
            return Err(InvalidPart::from(format!(
                "slip-ipem: {} weight covariance entries, expected {}",
                self.weight_covariance.len(),
                size * size
            )));
        }
        let c = |i: usize, j: usize| self.weight_covariance[i * size + j];
        let variance = |v: f64| v.is_finite() && (0.0..=MAX_VARIANCE).contains(&v);
        for i in 0..size {
            if !variance(c(i, i)) {
                return Err(InvalidPart::from(format!(
                    "slip-ipem: weight variance {i} is {}, not a number in [0, {}]",
                    Short(c(i, i)),
                    Short(MAX_VARIANCE)
                )));
            }
            for j in 0..i {
                let (a, b) = (c(i, j), c(j, i));
                if !(a.is_finite() && (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))) {
                    return Err(InvalidPart::from(
                        "slip-ipem: the weight covariance is not symmetric",
                    ));
                }
            }
        }
        // Positive semi-definite: no direction of the weights with a negative variance.
        if size > 0 {
            let eigen = DMatrix::from_row_slice(size, size, &self.weight_covariance)
                .symmetric_eigenvalues();
            let top = eigen.amax().max(f64::MIN_POSITIVE);
            if let Some(l) = eigen.iter().find(|l| **l < -1e-9 * top) {
                return Err(InvalidPart::from(format!(
                    "slip-ipem: the weight covariance has the eigenvalue {}: not positive semi-definite",
                    Short(*l)
                )));
            }
        }
        if let Some(v) = self.bias_variance.iter().find(|v| !variance(**v)) {
            return Err(InvalidPart::from(format!(
                "slip-ipem: bias variance {} is not a number in [0, {}]",
                Short(*v),
                Short(MAX_VARIANCE)
            )));
        }
        Ok(())
    }

    /// The lagging body velocity, the disturbance and what was measured at the start,
    /// stepped.
    fn stepper(&self) -> Option<Box<dyn SlipStepper + '_>> {
        Some(Box::new(IpemStepper::new(self)))
    }

    /// The rollout's derivatives stepped (`None` for a malformed covariance, which the
    /// rollout does not give either).
    fn covariance_stepper(&self, dt: f64) -> Option<Box<dyn SlipCovarianceStepper + '_>> {
        IpemCovarianceStepper::new(self, dt).map(|s| Box::new(s) as Box<dyn SlipCovarianceStepper>)
    }

    /// The step the body dynamics were fitted at, for a model with the transport (files
    /// written before it do not record theirs).
    fn step(&self) -> Option<f64> {
        self.transport.then_some(self.dt)
    }

    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}
