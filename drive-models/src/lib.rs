//! The DRIVE motion models (Sec. III-B of Baril et al.): vehicles, powertrains, the
//! Bayesian linear regression and the learners.
//!
//! | model | learner | fitted |
//! |---|---|---|
//! | naive (eq. 4 on the commands) | [`learners::Naive`] | [`learners::NaiveModel`] |
//! | powertrain-aware (eq. 3 + 4) | [`learners::PowertrainAware`] | [`learners::PowertrainAwareModel`] |
//! | slip-BLR (eq. 3-7) | [`learners::SlipBlr`] | [`learners::SlipBlrModel`] |
//! | acceleration BLR (McKinnon 2019) | [`learners::AccBlr`] | [`learners::AccBlrModel`] |
//!
//! Every learner is an unfitted configuration implementing [`drive_traits::Learner`]; its
//! `fit` returns a separate fitted type implementing [`drive_traits::MotionModel`].

#![warn(missing_docs)]

pub mod batch;
pub mod blr;
pub mod learners;
pub mod model_file;
pub mod powertrain;
mod registry;
pub mod rollout;
pub mod vehicles;
pub mod velocity;

pub use registry::{
    fit_named, LearnerEntry, LearnerRegistry, PowertrainChoice, RegistryError, MODEL_NAMES,
};
pub use vehicles::DifferentialDrive;
