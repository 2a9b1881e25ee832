//! Powertrain models (implementations of [`drive_traits::Powertrain`]) and their learners.

mod fopdt;
mod ideal;

pub use fopdt::{Fopdt, FopdtPowertrain, SideResponse};
pub use ideal::{Ideal, IdealPowertrain};
