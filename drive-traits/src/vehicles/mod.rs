//! Vehicles (implementations of [`CommandModel`](crate::CommandModel)): a new vehicle is a new file
//! here (or in a plug-in crate) and one registration in the vehicle registry.

mod ackermann;
mod differential;
mod omni;

pub use ackermann::Ackermann;
pub use differential::DifferentialDrive;
pub use omni::Omnidirectional;

/// The longest length a ground robot's geometry may give (m): no wheel radius, baseline or
/// wheelbase comes near it; a value beyond is in another unit (millimetres).
const MAX_LENGTH_M: f64 = 100.0;

/// Shortest length a vehicle's geometry may hold (m): below a millimetre is another unit
/// (kilometres?) or a typo, and its wheel speeds (v / r) leave every range a command has.
const MIN_LENGTH_M: f64 = 1e-3;

/// `Err` naming the first of `lengths` that is not a finite positive length within
/// [`MIN_LENGTH_M`] and [`MAX_LENGTH_M`].
fn positive_lengths(lengths: &[(&'static str, f64)]) -> Result<(), crate::InvalidPart> {
    match lengths.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
        Some((name, v)) => Err(format!(
            "vehicle {name} = {} is not a positive length",
            crate::limits::Short(*v)
        )
        .into()),
        None => match lengths.iter().find(|(_, v)| *v > MAX_LENGTH_M) {
            Some((name, v)) => Err(format!(
                "vehicle {name} = {} m is more than {MAX_LENGTH_M} m: a length in another unit (millimetres?)",
                crate::limits::Short(*v)
            )
            .into()),
            None => match lengths.iter().find(|(_, v)| *v < MIN_LENGTH_M) {
                Some((name, v)) => Err(format!(
                    "vehicle {name} = {} m is less than {MIN_LENGTH_M} m: a length in another unit (kilometres?)",
                    crate::limits::Short(*v)
                )
                .into()),
                None => Ok(()),
            },
        },
    }
}
