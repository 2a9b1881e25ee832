//! Traits and shared types of the DRIVE framework (Baril et al., "DRIVE: Data-driven Robot
//! Input Vector Exploration").
//!
//! Every plug-in point of the project is a small trait here:
//!
//! | trait | job | paper |
//! |---|---|---|
//! | [`CommandModel`] | input vector -> commanded body velocity, its inverse, the input space | eq. 4 |
//! | [`Powertrain`] | commanded -> predicted actuator (wheel) velocities over a horizon | eq. 3 |
//! | [`PowertrainLearner`] | fits a [`Powertrain`] on training windows | Sec. III-B.1 |
//! | [`Learner`] | an unfitted configuration that fits a [`MotionModel`] | Sec. III-B |
//! | [`MotionModel`] | predicts poses (and covariances) over a horizon | eq. 1, 2, 7 |
//! | [`InputSampler`] | draws the next input of the protocol, seeded | Sec. III-A |
//!
//! The dataset types ([`Window`], [`RobotDescription`], [`WindowSet`]) are what every
//! loader produces and every learner and metric consumes.

#![warn(missing_docs)]

mod dataset;
mod error;
mod learner;
mod motion;
mod pose;
mod powertrain;
mod sampler;
mod vehicle;

pub use dataset::{
    assign_intervals, Dataset, Phase, RobotDescription, Window, WindowSet, WINDOWS_PER_INTERVAL,
    WINDOW_S,
};
pub use error::{FitError, MotionError};
pub use learner::Learner;
pub use motion::{MotionModel, StartState};
pub use pose::{
    euler_step, relative_pose, unwrap_angles, wrap_angle, BodyVelocity, Input, Pose, PoseCovariance,
};
pub use powertrain::{Powertrain, PowertrainLearner};
pub use sampler::InputSampler;
pub use vehicle::{CommandModel, InputSpace};
