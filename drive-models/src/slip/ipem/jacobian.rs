//! The Jacobian's forward-mode dual numbers (num-dual): the seeded slip, lags and
//! disturbance, in two column groups (the yaw path's variables, then the position path's).

use super::*;

/// The slip at the slip functions `phi` as dual numbers whose derivative parts are seeded
/// with its tangent: the slip is linear in the weights, so the derivative of dimension `d`
/// with respect to variable `d * FEATURES + j` is `unit[d] * phi[j]` (the weights being
/// `unit[d]` times the variables), and with respect to variable `bias + d`, when given, 1.
/// The same dual numbers as [`slip_of`] on seeded weights (a test checks it), without
/// carrying every weight through the sum; num-dual then differentiates the rollout.
#[inline]
pub(super) fn seeded_slip<const N: usize>(
    theta: &[f64; PARAMETERS],
    phi: &[f64; FEATURES],
    unit: &[f64; 3],
    bias: Option<usize>,
) -> [DualSVec64<N>; 3] {
    std::array::from_fn(|d| {
        let w = &theta[d * FEATURES..(d + 1) * FEATURES];
        let mut g = seeded_dimension::<N>(w, phi, unit[d], d * FEATURES);
        if let Some(b) = bias {
            g += DualSVec64::from(0.0).derivative(b + d);
        }
        g
    })
}

/// One dimension's slip `sum_j w_j phi_j` as a dual number seeded on its weights, variables
/// `offset + j` (derivative `unit * phi_j`: the weights are `unit` times the variables).
#[inline]
pub(super) fn seeded_dimension<const N: usize>(
    w: &[f64],
    phi: &[f64; FEATURES],
    unit: f64,
    offset: usize,
) -> DualSVec64<N> {
    let mut eps = SVector::<f64, N>::zeros();
    for (j, p) in phi.iter().enumerate() {
        eps[offset + j] = unit * p;
    }
    DualSVec64::new(dot(w, phi), Derivative::some(eps))
}

/// The dual numbers of the Jacobian's yaw-path group: the yaw weights, the yaw lag, the
/// disturbance's trust and persistence.
pub(super) const YAW_VARIABLES: usize = FEATURES + 3;

/// The dual numbers of the Jacobian's position-path group: the x and y weights, the x and
/// y lags, the start velocity's trust.
pub(super) const POSITION_VARIABLES: usize = 2 * FEATURES + 3;

pub(super) type YawDual = DualSVec64<YAW_VARIABLES>;
pub(super) type PositionDual = DualSVec64<POSITION_VARIABLES>;

/// The parameter of variable `j` of the yaw-path group.
#[inline]
pub(super) fn yaw_variable(j: usize) -> usize {
    if j < FEATURES {
        2 * FEATURES + j
    } else {
        WEIGHTS + 2 + (j - FEATURES)
    }
}

/// The parameter of variable `j` of the position-path group.
#[inline]
pub(super) fn position_variable(j: usize) -> usize {
    if j < 2 * FEATURES {
        j
    } else {
        [WEIGHTS, WEIGHTS + 1, WEIGHTS + 5][j - 2 * FEATURES]
    }
}

/// The dual number of a coefficient `sigmoid(logit)` seeded on its logit, variable `index`.
pub(super) fn seeded_sigmoid<const N: usize>(logit: f64, index: usize) -> DualSVec64<N> {
    sigmoid(DualSVec64::<N>::from(logit).derivative(index))
}

/// The body dynamics as dual numbers seeded on their logits in `theta` (variables
/// `WEIGHTS + j`); without `disturbance` (`velocity`), no disturbance (start velocity) and
/// no derivative for it; bounded by `limits` as in [`dynamics_of`].
pub(super) fn seeded_dynamics<const N: usize>(
    theta: &[f64; PARAMETERS],
    [disturbance, velocity]: [bool; 2],
    limits: [f64; 2],
    transport: bool,
) -> Dynamics<DualSVec64<N>> {
    let c = |j: usize| seeded_sigmoid::<N>(theta[WEIGHTS + j], WEIGHTS + j);
    let zero = DualSVec64::<N>::from(0.0);
    Dynamics {
        lag_xy: [c(0), c(1)],
        lag_yaw: c(2),
        trust: if disturbance { c(3) } else { zero },
        persistence: if disturbance { c(4) } else { zero },
        velocity_trust: if velocity { c(5) } else { zero },
        velocity_limit: limits[0],
        disturbance_limit: limits[1],
        transport,
    }
}
