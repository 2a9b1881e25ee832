//! Vehicles (implementations of [`drive_traits::CommandModel`]): a new vehicle is a new file
//! here (or in a plug-in crate) and one registration in the vehicle registry.

mod ackermann;
mod differential;
mod omni;

pub use ackermann::Ackermann;
pub use differential::DifferentialDrive;
pub use omni::Omnidirectional;
