//! DRIVE: data-driven identification of how an uncrewed ground vehicle really moves on its
//! terrain, after Baril et al., "DRIVE: Data-driven Robot Input Vector Exploration".
//!
//! This facade re-exports the workspace crates, carries the bundled Husky dataset and, with
//! the `cli` feature (on by default), the `drive` command line as a library:
//!
//! - [`traits`] (drive-traits): the plug-in traits, the registries and dataset types;
//! - [`data`] (drive-data): window CSV + sidecar reading and writing, raw-log import;
//! - [`models`] (drive-models): vehicles, powertrains, slip models, the composed model,
//!   baselines;
//! - [`samplers`] (drive-samplers): robots, input-space samplers, the protocol runner;
//! - [`eval`] (drive-eval): the eq. 8 metric, the split, statistics and coverage;
//! - [`studies`] (drive-studies): the application layer: the [`Registries`], the
//!   experiment engine and every study (bench, matrix, track, twins, protocols, convergence);
//! - [`sim`] (drive-sim): simulated UGVs to run the protocol without a robot;
//! - [`control`] (drive-control): reference paths, the controller trait, MPPI and the
//!   one-tick path follower ([`control::Tracker`]);
//! - [`report`] (drive-report): the paper's figures and a Markdown report for one dataset;
//! - [`cli`]: the command line, runnable with a researcher's own [`Registries`].
//!
//! [`serde`], [`typetag`] and [`nalgebra`] are re-exported for plug-ins (see docs/plugins.md).
//!
//! ```
//! use drive::traits::Learner;
//! use drive::models::{Composed, powertrain::Fopdt, slip::SlipBlr};
//! let data = drive::bundled::husky().unwrap();
//! let (train, eval) = drive::eval::split_by_interval(&data, 0.5).unwrap();
//! // The paper's slip-BLR: slip-BLR on the FOPDT powertrain, on the data's vehicle.
//! let model = Composed::new(Fopdt::default(), SlipBlr::default()).fit(&train).unwrap();
//! let report = drive::eval::evaluate_model(&model, &eval);
//! assert_eq!(report.windows.len(), 303);
//! assert!(report.translational(None).unwrap().median < 0.2);
//! ```

#![warn(missing_docs)]

pub use drive_control as control;
pub use drive_data as data;
pub use drive_eval as eval;
pub use drive_models as models;
pub use drive_report as report;
pub use drive_samplers as samplers;
pub use drive_sim as sim;
pub use drive_studies as studies;
pub use drive_traits as traits;

pub use drive_studies::Registries;
pub use drive_traits::{nalgebra, serde, typetag};

pub mod bundled;
#[cfg(feature = "cli")]
pub mod cli;
pub mod fuzz;
pub mod import;
pub mod suite;
