//! The DRIVE motion models (Sec. III-B of Baril et al.), as parts composed into one model:
//!
//! | part | here | paper |
//! |---|---|---|
//! | vehicle | [`vehicles`]: [`DifferentialDrive`] (eq. 4), [`vehicles::Ackermann`] (a car) | eq. 4 |
//! | powertrain | [`powertrain`]: commanded, FOPDT, rate-limited | eq. 3 |
//! | slip model | [`slip`]: none, slip-BLR | eq. 5-7 |
//! | the composed model | [`Composed`] -> [`ComposedModel`] | eq. 1-2 |
//! | baselines | [`baselines`]: acc-BLR | Fig. 6 |
//!
//! Learners are unfitted configurations implementing the learner traits of
//! [`drive_traits`]; their `fit` returns a separate fitted type. [`registry`] names every part
//! and resolves model names such as `slip-blr+fopdt`.

#![warn(missing_docs)]

pub mod baselines;
pub mod batch;
pub mod blr;
pub mod calibration;
mod composed;
pub mod model_file;
pub mod powertrain;
pub mod registry;
pub mod rollout;
pub mod slip;
pub mod vehicles;

pub use composed::{Composed, ComposedModel, GrowingFit};
pub use registry::{LearnerKind, ModelAlias, ModelSpec, Models};
pub use vehicles::DifferentialDrive;
