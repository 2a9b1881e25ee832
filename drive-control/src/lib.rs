//! The learned motion model inside a controller: reference paths ([`path`]), the
//! controller plug-in point ([`Controller`], [`MakeController`], the registry
//! [`builtin_controllers`]), a sampling-based model-predictive controller over any fitted
//! model ([`Mppi`], Williams et al.), and the one-tick path follower a robot runs online
//! ([`Tracker`]).
//!
//! The closed-loop experiment that drives a simulated robot with it (`drive track`) is
//! `drive_studies::closed_loop`: this crate needs no simulator.

#![warn(missing_docs)]

mod controller;
mod history;
pub mod mppi;
pub mod path;
mod tracker;

pub use controller::{
    builtin_controllers, stop_input, ControlError, ControlSetup, ControlState, Controller,
    InputMap, MakeController,
};
pub use history::{settling_history_s, MAX_HISTORY_S, MIN_HISTORY_S, SETTLED_SHARE};
pub use mppi::{Mppi, MppiController};
pub use path::{PathError, PathPoint, PathShape, Projection, ReferencePath};
pub use tracker::{Observation, Tick, Tracker, TrackerConfig, MAX_FUTURE_STAMP_S};
