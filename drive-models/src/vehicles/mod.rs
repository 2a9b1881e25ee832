//! Vehicles (implementations of [`drive_traits::CommandModel`]): a new vehicle is a new file
//! here (or in a plug-in crate) and one registration in the vehicle registry.

mod differential;

pub use differential::DifferentialDrive;
