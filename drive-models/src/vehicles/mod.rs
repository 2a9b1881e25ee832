//! Vehicle command models (implementations of [`drive_traits::CommandModel`]).

mod differential;

pub use differential::DifferentialDrive;
