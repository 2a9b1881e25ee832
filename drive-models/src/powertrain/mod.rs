//! Powertrains (implementations of [`drive_traits::Powertrain`]) and their learners: a new
//! powertrain is a new file here (or in a plug-in crate) and one registration.
//!
//! | registry name | learner | fitted | model |
//! |---|---|---|---|
//! | `commanded` | [`Commanded`] | [`CommandedPowertrain`] | the commands, reached at once (naive) |
//! | `fopdt` | [`Fopdt`] | [`FopdtPowertrain`] | first order plus dead time per axis (eq. 3) |
//! | `rate-limited` | [`RateLimited`] | [`RateLimitedPowertrain`] | eq. 3 with a rate (acceleration) limit |

use drive_traits::InvalidPart;
mod commanded;
mod delay;
mod fopdt;
mod rate_limited;

pub use commanded::{Commanded, CommandedPowertrain};
pub use fopdt::{Fopdt, FopdtPowertrain, SideResponse};
pub use rate_limited::{RateLimited, RateLimitedPowertrain, RateLimitedResponse};

/// `Err` unless a powertrain of `axes` responses (one per input axis, 2 or 3) has limits of
/// as many axes.
pub(crate) fn check_axes(
    axes: usize,
    limits: &drive_traits::InputSpace,
) -> Result<(), InvalidPart> {
    if !(2..=drive_traits::MAX_INPUTS).contains(&axes) || limits.dim() != axes {
        return Err(InvalidPart::from(format!(
            "the powertrain has {axes} axis responses for limits of {} axes (2 or 3 expected, one per input axis)",
            limits.dim()
        )));
    }
    Ok(())
}

/// `Err` when a powertrain's number of axis responses is not its vehicle's number of input
/// axes.
pub(crate) fn check_vehicle_axes(
    powertrain: &dyn drive_traits::Powertrain,
    vehicle: &dyn drive_traits::CommandModel,
) -> Result<(), InvalidPart> {
    match powertrain.input_dim() {
        Some(axes) if axes != vehicle.input_dim() => Err(InvalidPart::from(format!(
            "the powertrain models {axes} input axes; the vehicle has {}",
            vehicle.input_dim()
        ))),
        _ => Ok(()),
    }
}

pub(crate) fn check_step_and_limits(
    dt: f64,
    limits: &drive_traits::InputSpace,
) -> Result<(), InvalidPart> {
    drive_traits::check_step(dt).map_err(|e| format!("powertrain {e}"))?;
    if drive_traits::InputSpace::new(limits.min, limits.max).is_none() {
        return Err(InvalidPart::from(
            "powertrain limits are not a valid box (finite, min <= max)",
        ));
    }
    // A fit refuses data that never drives an axis: limits of no width describe a robot
    // that cannot drive it (every command of that axis saturated to one value).
    if let Some(i) = (0..limits.dim()).find(|&i| limits.max[i] - limits.min[i] <= 0.0) {
        return Err(InvalidPart::from(format!(
            "powertrain limits of axis {i} are [{}, {}]: a robot that cannot drive that axis (no fit writes limits of no width)",
            drive_traits::limits::Short(limits.min[i]),
            drive_traits::limits::Short(limits.max[i])
        )));
    }
    // The limits are measured inputs (wheel velocities, speeds): no fit writes one beyond
    // what the data readers accept.
    let bound = drive_traits::limits::MAX_ABS_MEASUREMENT;
    if let Some(v) = limits
        .min
        .iter()
        .chain(limits.max.iter())
        .find(|v| v.abs() > bound)
    {
        return Err(InvalidPart::from(format!(
            "powertrain limit {} is beyond +-{} (an input the data readers would refuse)",
            drive_traits::limits::Short(*v),
            drive_traits::limits::Short(bound)
        )));
    }
    Ok(())
}
