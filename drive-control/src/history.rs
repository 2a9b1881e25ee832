//! How far back a controller's rollouts start by default: long enough that the commands
//! still acting through the model's powertrain (its dead time and lag) act in them, and
//! that the start state's error has faded by now.

use drive_traits::{Input, MotionModel};

/// The shortest default history (s): half a second.
pub const MIN_HISTORY_S: f64 = 0.5;
/// The longest default history (s): beyond it a rollout is mostly past.
pub const MAX_HISTORY_S: f64 = 3.0;
/// The share of a step the powertrain has reached when its history is long enough:
/// `1 - e^-1`, one time constant past the dead time of a first-order powertrain (eq. 3).
pub const SETTLED_SHARE: f64 = 0.632_120_558_828_557_7;

/// The default history of a controller over `model` (s): the time the model's powertrain
/// takes to reach [`SETTLED_SHARE`] of a step from rest to `step` (in the model's inputs),
/// on the slowest input that moves; for the FOPDT powertrain of eq. 3, the dead time plus
/// one time constant. At least [`MIN_HISTORY_S`] and at most [`MAX_HISTORY_S`];
/// [`MIN_HISTORY_S`] for a model without a powertrain or one that does not move.
///
/// Why: a rollout starts from the state estimate this long ago, then runs the commands
/// sent since through the model. Where it starts is noisy (the encoders, the IMU); through
/// the powertrain that error fades as its step response settles, while the commands sent
/// since come in. Too short a history leaves the start's error in the prediction of now,
/// and a controller chasing it weaves; too long a one lets the model's own error build up
/// over the past (docs/closed-loop.md measures both).
///
/// ```
/// use drive_control::{settling_history_s, MIN_HISTORY_S};
/// use drive_models::powertrain::{CommandedPowertrain, FopdtPowertrain, SideResponse};
/// use drive_models::{slip::NoSlipModel, ComposedModel};
/// use drive_traits::Input;
/// let husky = drive_traits::robot::builtin_robots().get("husky").unwrap().part().as_ref().clone();
/// let instant = ComposedModel { label: "naive".into(), vehicle: husky.vehicle.clone(),
///     powertrain: Box::new(CommandedPowertrain), slip: Box::new(NoSlipModel), dt: 0.05 };
/// let step = Input::new(3.0, 3.0, 0.0);
/// assert_eq!(settling_history_s(&instant, &step), MIN_HISTORY_S);
/// // A dead time of 0.3 s and a time constant of 0.6 s: 0.3 + 0.6 = 0.9 s.
/// let side = SideResponse { time_constant: 0.6, delay: 0.3 };
/// let limits = husky.input_space();
/// let fopdt = ComposedModel {
///     powertrain: Box::new(FopdtPowertrain { axes: vec![side, side], limits, dt: 0.05 }),
///     ..instant
/// };
/// assert!((settling_history_s(&fopdt, &step) - 0.9).abs() <= 0.05);
/// ```
pub fn settling_history_s(model: &dyn MotionModel, step: &Input) -> f64 {
    let Some(powertrain) = model.powertrain() else {
        return MIN_HISTORY_S;
    };
    let dt = model.dt();
    if !(dt.is_finite() && dt > 0.0) {
        return MIN_HISTORY_S;
    }
    // Past the longest history, where it settles no longer matters.
    let n = (2.0 * MAX_HISTORY_S / dt).ceil() as usize + 1;
    let commands = vec![*step; n];
    let reached = powertrain.predict(&Input::zeros(), &commands);
    let Some(last) = reached.last() else {
        return MIN_HISTORY_S;
    };
    let mut slowest = 0usize;
    for axis in 0..step.len() {
        let end = last[axis];
        if !(end.is_finite() && step[axis] != 0.0 && end.abs() > 1e-9 * step[axis].abs()) {
            continue;
        }
        let settled = reached
            .iter()
            .position(|u| u[axis] / end >= SETTLED_SHARE)
            .unwrap_or(n);
        slowest = slowest.max(settled);
    }
    (slowest as f64 * dt).clamp(MIN_HISTORY_S, MAX_HISTORY_S)
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_models::powertrain::{CommandedPowertrain, FopdtPowertrain, SideResponse};
    use drive_models::{slip::NoSlipModel, ComposedModel};

    fn model(powertrain: Box<dyn drive_traits::Powertrain>) -> ComposedModel {
        let husky = drive_traits::robot::builtin_robots()
            .get("husky")
            .unwrap()
            .part()
            .as_ref()
            .clone();
        ComposedModel {
            label: "test".into(),
            vehicle: husky.vehicle.clone(),
            powertrain,
            slip: Box::new(NoSlipModel),
            dt: 0.05,
        }
    }

    fn fopdt(tau: f64, delay: f64) -> ComposedModel {
        // Both bounds finite and ordered.
        let limits =
            drive_traits::InputSpace::new(Input::new(-6.0, -6.0, 0.0), Input::new(6.0, 6.0, 0.0))
                .unwrap();
        let side = SideResponse {
            time_constant: tau,
            delay,
        };
        model(Box::new(FopdtPowertrain {
            axes: vec![side, side],
            limits,
            dt: 0.05,
        }))
    }

    #[test]
    fn the_history_is_the_dead_time_plus_one_time_constant_within_a_tick_and_bounded() {
        let step = Input::new(2.0, -3.0, 0.0);
        for (tau, delay) in [(0.55, 0.28), (0.87, 0.31), (0.3, 0.6), (1.2, 0.0)] {
            let h = settling_history_s(&fopdt(tau, delay), &step);
            // The first tick at or past the crossing of 1 - 1/e.
            assert!(
                h >= tau + delay - 1e-9 && h < tau + delay + 0.05 + 1e-9,
                "{tau} {delay}: {h}"
            );
        }
        // A fast powertrain: the floor; a slow one: the ceiling.
        assert_eq!(settling_history_s(&fopdt(0.05, 0.0), &step), MIN_HISTORY_S);
        assert_eq!(settling_history_s(&fopdt(5.0, 1.0), &step), MAX_HISTORY_S);
        // No dynamics, or a step that moves nothing: the floor.
        assert_eq!(
            settling_history_s(&model(Box::new(CommandedPowertrain)), &step),
            MIN_HISTORY_S
        );
        assert_eq!(
            settling_history_s(&fopdt(0.87, 0.31), &Input::zeros()),
            MIN_HISTORY_S
        );
    }
}
