//! Motion-model learners (unfitted configurations) and the fitted models they return.

mod acc_blr;
mod naive;
mod powertrain_aware;
mod slip_blr;

pub use acc_blr::{AccBlr, AccBlrModel};
pub use naive::{Naive, NaiveModel};
pub use powertrain_aware::{PowertrainAware, PowertrainAwareModel};
pub use slip_blr::{slip_inputs, SlipBlr, SlipBlrModel, SlipInputs};

/// The checks every fitted model shares: a positive finite step and a valid geometry.
pub(crate) fn check_common(dt: f64, vehicle: &crate::DifferentialDrive) -> Result<(), String> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(format!("dt = {dt} is not a positive number of seconds"));
    }
    for (name, v) in [
        ("wheel_radius", vehicle.wheel_radius),
        ("baseline", vehicle.baseline),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("vehicle {name} = {v} is not a positive length"));
        }
    }
    Ok(())
}
