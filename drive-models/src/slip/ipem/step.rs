//! slip-ipem stepped one commanded body velocity at a time: the lagging body velocity, the
//! yaw disturbance and what was measured at the start (the mean), and the rollout's dual
//! numbers (the covariance), each kept in a flat state.

use super::*;

/// Numbers of what was measured at the start: the yaw rate's flag and value, the velocity's
/// flag and two values.
const MEASURED: usize = 5;

fn put_measured(m: &Measured, out: &mut [f64]) {
    out[..MEASURED].fill(0.0);
    if let Some(w) = m.yaw_rate {
        (out[0], out[1]) = (1.0, w);
    }
    if let Some([x, y]) = m.velocity {
        (out[2], out[3], out[4]) = (1.0, x, y);
    }
}

fn get_measured(s: &[f64]) -> Measured {
    Measured {
        yaw_rate: (s[0] != 0.0).then_some(s[1]),
        velocity: (s[2] != 0.0).then_some([s[3], s[4]]),
        // A stepper is given no later measurement (the controller's own state estimate is
        // its to make).
        observed: None,
    }
}

/// The body of a mean rollout: the started flag, the lagging velocity (x, y, yaw), the
/// disturbance and the yaw rate of the last step.
const BODY: usize = 6;

fn put_body(b: &Body<f64, f64>, out: &mut [f64]) {
    let ([x, y], z) = b.velocity.unwrap_or(([0.0; 2], 0.0));
    out[..BODY].copy_from_slice(&[
        if b.velocity.is_some() { 1.0 } else { 0.0 },
        x,
        y,
        z,
        b.disturbance,
        b.yaw_rate,
    ]);
}

fn get_body(s: &[f64]) -> Body<f64, f64> {
    Body {
        velocity: (s[0] != 0.0).then_some(([s[1], s[2]], s[3])),
        disturbance: s[4],
        yaw_rate: s[5],
    }
}

/// slip-ipem's mean stepped: [`SlipIpemModel::velocities`] one step at a time.
pub(super) struct IpemStepper {
    theta: [f64; PARAMETERS],
    dynamics: Dynamics<f64>,
    scale: [f64; 2],
    dt: f64,
}

impl IpemStepper {
    pub(super) fn new(model: &SlipIpemModel) -> Self {
        IpemStepper {
            theta: model.theta(),
            dynamics: model.dynamics(),
            scale: model.scale,
            dt: model.dt,
        }
    }
}

impl SlipStepper for IpemStepper {
    fn state_len(&self) -> usize {
        BODY + MEASURED
    }

    fn init(&self, start: &StartState, state: &mut [f64]) {
        put_body(&Body::new(), &mut state[..BODY]);
        put_measured(&Measured::of(start), &mut state[BODY..]);
    }

    /// The body and what was measured read once for the whole sequence.
    fn step_seq(&self, state: &mut [f64], f: &[BodyVelocity], v: &mut [BodyVelocity]) {
        let measured = get_measured(&state[BODY..]);
        let mut body = get_body(state);
        // The steady velocities first (independent steps, side by side), then the body's
        // recursion through them: the same arithmetic as step after step.
        for (f, v) in f.iter().zip(v.iter_mut()) {
            let g = slip_of(&self.theta, &slip_features(f, &self.scale));
            *v = BodyVelocity::new(f.x - g[0], f.y - g[1], f.z - g[2]);
        }
        for v in v.iter_mut() {
            let ([x, y], z) = body.step(([v.x, v.y], v.z), &self.dynamics, &measured, self.dt);
            *v = BodyVelocity::new(x, y, z);
        }
        put_body(&body, &mut state[..BODY]);
    }

    #[inline]
    fn step(&self, state: &mut [f64], f: &BodyVelocity) -> BodyVelocity {
        let measured = get_measured(&state[BODY..]);
        let mut body = get_body(state);
        let g = slip_of(&self.theta, &slip_features(f, &self.scale));
        let target = ([f.x - g[0], f.y - g[1]], f.z - g[2]);
        let ([x, y], z) = body.step(target, &self.dynamics, &measured, self.dt);
        put_body(&body, &mut state[..BODY]);
        BodyVelocity::new(x, y, z)
    }
}

/// One dual number of the covariance rollout in a state: whether it carries derivatives,
/// its value, its derivatives.
const DUAL: usize = WITH_BIAS + 2;

type CovDual = DualSVec64<WITH_BIAS>;

fn put_dual(d: &CovDual, out: &mut [f64]) {
    let some = d.eps != Derivative::none();
    out[0] = if some { 1.0 } else { 0.0 };
    out[1] = d.re;
    let eps = d.eps.unwrap_generic(Const::<WITH_BIAS>, U1);
    out[2..DUAL].copy_from_slice(eps.as_slice());
}

fn get_dual(s: &[f64]) -> CovDual {
    let eps = (s[0] != 0.0).then(|| SVector::<f64, WITH_BIAS>::from_column_slice(&s[2..DUAL]));
    DualSVec64::new(s[1], Derivative::new(eps))
}

/// The covariance rollout's dual numbers: x, y, yaw, then the body's started flag, its
/// lagging velocity (x, y, yaw), disturbance and last yaw rate.
const COV_DUALS: usize = 8;
const COV_STATE: usize = 1 + COV_DUALS * DUAL + MEASURED;

/// slip-ipem's pose covariance stepped: [`SlipModel::rollout_covariances_into`] one step at
/// a time, its forward-mode derivatives kept in the state.
pub(super) struct IpemCovarianceStepper {
    theta: [f64; PARAMETERS],
    dynamics: Dynamics<CovDual>,
    covariance: SMatrix<f64, PARAMETERS, PARAMETERS>,
    bias: SMatrix<f64, 3, 3>,
    scale: [f64; 2],
    dt: f64,
}

impl IpemCovarianceStepper {
    /// `None` for a model whose covariance is malformed (its file check says so), as the
    /// rollout gives none.
    pub(super) fn new(model: &SlipIpemModel, dt: f64) -> Option<Self> {
        let covariance = model.covariance()?;
        let theta = model.theta();
        Some(IpemCovarianceStepper {
            theta,
            dynamics: seeded_dynamics::<WITH_BIAS>(
                &theta,
                [
                    model.disturbance_logit.is_some(),
                    model.velocity_logit.is_some(),
                ],
                model.scale,
                model.transport,
            ),
            covariance,
            bias: SMatrix::<f64, 3, 3>::from_diagonal(&SVector::from(model.bias_variance)),
            scale: model.scale,
            dt,
        })
    }
}

impl SlipCovarianceStepper for IpemCovarianceStepper {
    fn state_len(&self) -> usize {
        COV_STATE
    }

    fn init(&self, start: &StartState, state: &mut [f64]) {
        let zero = CovDual::from(0.0);
        let values = [
            CovDual::from(start.pose.x),
            CovDual::from(start.pose.y),
            CovDual::from(start.pose.z),
            zero,
            zero,
            zero,
            zero,
            zero,
        ];
        state[0] = 0.0;
        for (i, d) in values.iter().enumerate() {
            put_dual(d, &mut state[1 + i * DUAL..1 + (i + 1) * DUAL]);
        }
        put_measured(&Measured::of(start), &mut state[1 + COV_DUALS * DUAL..]);
    }

    fn step(&self, state: &mut [f64], f: &BodyVelocity) -> PoseCovariance {
        let d = |i: usize| get_dual(&state[1 + i * DUAL..1 + (i + 1) * DUAL]);
        let (mut x, mut y, mut yaw) = (d(0), d(1), d(2));
        let mut body: Body<CovDual, CovDual> = Body {
            velocity: (state[0] != 0.0).then(|| ([d(3), d(4)], d(5))),
            disturbance: d(6),
            yaw_rate: d(7),
        };
        let measured = get_measured(&state[1 + COV_DUALS * DUAL..]);
        let features = slip_features(f, &self.scale);
        let (g, gz) = split(seeded_slip::<WITH_BIAS>(
            &self.theta,
            &features,
            &[1.0; 3],
            Some(PARAMETERS),
        ));
        let target = (
            [CovDual::from(f.x) - g[0], CovDual::from(f.y) - g[1]],
            CovDual::from(f.z) - gz,
        );
        // The step of `rollout`.
        let ([vx, vy], vz) = body.step(target, &self.dynamics, &measured, self.dt);
        let (s, c) = yaw.sin_cos();
        x += (vx * c - vy * s) * self.dt;
        y += (vx * s + vy * c) * self.dt;
        yaw += vz * self.dt;
        // The covariance `rollout_covariances_into` visits at the next step.
        let j: SMatrix<f64, 3, WITH_BIAS> = SMatrix::from_rows(&[
            x.eps.unwrap_generic(Const::<WITH_BIAS>, U1).transpose(),
            y.eps.unwrap_generic(Const::<WITH_BIAS>, U1).transpose(),
            yaw.eps.unwrap_generic(Const::<WITH_BIAS>, U1).transpose(),
        ]);
        let jw = j.fixed_columns::<PARAMETERS>(0);
        let jb = j.fixed_columns::<3>(PARAMETERS);
        let cov = jw * self.covariance * jw.transpose() + jb * self.bias * jb.transpose();
        // Back into the state.
        let ([bx, by], bz) = body
            .velocity
            .unwrap_or(([CovDual::from(0.0); 2], CovDual::from(0.0)));
        state[0] = if body.velocity.is_some() { 1.0 } else { 0.0 };
        let values = [x, y, yaw, bx, by, bz, body.disturbance, body.yaw_rate];
        for (i, v) in values.iter().enumerate() {
            put_dual(v, &mut state[1 + i * DUAL..1 + (i + 1) * DUAL]);
        }
        0.5 * (cov + cov.transpose())
    }
}
