//! Traits and shared types of the DRIVE framework (Baril et al., "DRIVE: Data-driven Robot
//! Input Vector Exploration").
//!
//! A motion model is composed from parts, each a small trait here, each with one job:
//!
//! | trait | job | paper |
//! |---|---|---|
//! | [`CommandModel`] | vehicle: input -> commanded body velocity, its inverse, input axes, characterization | eq. 2, 4 |
//! | [`Powertrain`] / [`PowertrainLearner`] | commanded -> reached inputs over a horizon | eq. 3 |
//! | [`SlipModel`] / [`SlipLearner`] | slip velocity from the commanded body velocity | eq. 5-7 |
//! | [`MotionModel`] / [`Learner`] | poses (and covariances) over a horizon | eq. 1, 2, 7 |
//! | [`step::Stepper`] | a fitted model stepped one command at a time, its state a flat vector | eq. 1 |
//! | [`Baseline`] | a whole-model learner that is not built from a slip model (acc-BLR) | |
//! | [`InputSampler`] | draws the next input of the protocol, seeded | Sec. III-A |
//! | [`Tagged`] | the name a part's type is saved under | |
//!
//! Learners are unfitted configurations whose `fit` returns a separate fitted type (the
//! linfa split). Fitted parts are saved as trait objects with typetag: an implementation
//! carries `#[typetag::serde(name = "...")]` and [`Tagged`] with the same name; a
//! [`Registry`] checks both when the part is registered. This crate re-exports [`serde`],
//! [`typetag`] and [`nalgebra`] so that a plug-in needs no other dependency.
//!
//! The dataset types ([`Window`], [`RobotDescription`], [`WindowSet`]) are what every
//! loader produces and every learner and metric consumes. The robots ([`robot`]: a
//! vehicle with its limits, rates and acceleration limits, the presets and robot files)
//! are what the protocol, the simulators and the controllers run.

#![warn(missing_docs)]

mod dataset;
mod error;
pub mod exact;
pub mod files;
mod learner;
pub mod limits;
mod motion;
mod pose;
mod powertrain;
mod reach;
mod registry;
pub mod robot;
mod sampler;
mod slip;
mod slip_basis;
mod stats;
pub mod step;
mod tag;
mod vehicle;
pub mod vehicles;
mod velocity;

pub use dataset::{
    assign_intervals, Dataset, Phase, PositionFrame, RobotDescription, StartInfo, Window,
    WindowSet, END_VELOCITY_SPAN_S, PAPER_FRAME_SAMPLES, WINDOWS_PER_INTERVAL, WINDOW_S,
};
pub use error::{CharacterizationError, FitError, InvalidPart, MotionError, UnknownName};
pub use learner::{Baseline, Learner};
pub use motion::{check_step, MotionModel, ObservedMotion, StartState};
pub use pose::{
    euler_step, input_serde, net_turn, relative_pose, unwrap_angles, wrap_angle, BodyVelocity,
    Input, Pose, PoseCovariance, MAX_INPUTS,
};
pub use powertrain::{FitPowertrain, Powertrain, PowertrainLearner, PowertrainStepper};
pub use reach::{search_reach, Extreme, Reach};
pub use registry::{
    is_part_name, Entry, Registry, RegistryError, RegistryItem, TagCollision, TagProblem,
};
pub use sampler::{InputSampler, SlipLeverage};
pub use slip::{
    FitSlip, OnlineSlip, SlipCovarianceStepper, SlipData, SlipLearner, SlipModel, SlipSample,
    SlipStepper, SlipWindow, StatelessSlip,
};
pub use slip_basis::{check_slip_features, SlipFeatures, SlipInputRows, MAX_SLIP_INPUTS};
pub use stats::{from_total_order_key, median, quantile, total_order_key};
pub use tag::{PartTag, TagProbe, Tagged};
pub use vehicle::{
    spanned_space, vehicle_as, vehicle_tag, Characterization, CommandModel, InputAxis, InputSpace,
    Probe, ProbeMotion, ProbeResult, Steering,
};
pub use velocity::BodyVelocityEstimator;

pub use nalgebra;
pub use serde;
pub use typetag;
