//! Powertrains (implementations of [`drive_traits::Powertrain`]) and their learners: a new
//! powertrain is a new file here (or in a plug-in crate) and one registration.
//!
//! | registry name | learner | fitted | model |
//! |---|---|---|---|
//! | `commanded` | [`Commanded`] | [`CommandedPowertrain`] | the commands, reached at once (naive) |
//! | `fopdt` | [`Fopdt`] | [`FopdtPowertrain`] | first order plus dead time per axis (eq. 3) |
//! | `rate-limited` | [`RateLimited`] | [`RateLimitedPowertrain`] | eq. 3 with a rate (acceleration) limit |

mod commanded;
mod fopdt;
mod rate_limited;

pub use commanded::{Commanded, CommandedPowertrain};
pub use fopdt::{Fopdt, FopdtPowertrain, SideResponse};
pub use rate_limited::{RateLimited, RateLimitedPowertrain, RateLimitedResponse};

/// Checks a fitted part's sample period read from a file: `Err` when the `part` (the
/// powertrain, the slip model) was fitted at another command period `step` than the
/// model's `dt` (its time constants or lags would be read in the wrong unit of steps).
pub(crate) fn check_same_step(part: &str, step: Option<f64>, dt: f64) -> Result<(), String> {
    match step {
        Some(step) if (step - dt).abs() > 1e-9 * dt.abs().max(step.abs()) => Err(format!(
            "the {part}'s step {} s is not the model's {} s",
            drive_traits::limits::Short(step),
            drive_traits::limits::Short(dt)
        )),
        _ => Ok(()),
    }
}

pub(crate) fn check_step_and_limits(
    dt: f64,
    limits: &drive_traits::InputSpace,
) -> Result<(), String> {
    drive_traits::check_step(dt).map_err(|e| format!("powertrain {e}"))?;
    if drive_traits::InputSpace::new(limits.min, limits.max).is_none() {
        return Err("powertrain limits are not a valid box (finite, min <= max)".into());
    }
    Ok(())
}
