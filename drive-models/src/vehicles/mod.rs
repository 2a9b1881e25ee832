//! Vehicles (implementations of [`drive_traits::CommandModel`]): a new vehicle is a new file
//! here (or in a plug-in crate) and one registration in the vehicle registry.

mod ackermann;
mod differential;
mod omni;

pub use ackermann::Ackermann;
pub use differential::DifferentialDrive;
pub use omni::Omnidirectional;

/// `Err` naming the first of `lengths` that is not a finite positive length.
fn positive_lengths(lengths: &[(&'static str, f64)]) -> Result<(), String> {
    match lengths.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
        Some((name, v)) => Err(format!(
            "vehicle {name} = {} is not a positive length",
            drive_traits::limits::Short(*v)
        )),
        None => Ok(()),
    }
}
