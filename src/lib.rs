//! DRIVE: data-driven identification of how an uncrewed ground vehicle really moves on its
//! terrain, after Baril et al., "DRIVE: Data-driven Robot Input Vector Exploration".
//!
//! This facade re-exports the workspace crates and carries the bundled Husky dataset:
//!
//! - [`traits`] (drive-traits): the plug-in traits and dataset types;
//! - [`data`] (drive-data): window CSV + sidecar reading and writing;
//! - [`models`] (drive-models): vehicles, powertrains, BLR, learners;
//! - [`samplers`] (drive-samplers): input-space samplers of the protocol;
//! - [`eval`] (drive-eval): the eq. 8 metric, splits, comparisons;
//! - [`sim`] (drive-sim): a simulated UGV to run the protocol without a robot;
//! - [`report`] (drive-report): the paper's figures and a Markdown report for one dataset.
//!
//! ```
//! use drive::traits::Learner;
//! let data = drive::bundled::husky().unwrap();
//! let (train, eval) = drive::eval::split_by_interval(&data, 0.5).unwrap();
//! let model = drive::models::learners::SlipBlr::<drive::models::powertrain::Fopdt>::default().fit(&train).unwrap();
//! let report = drive::eval::evaluate_model(&model, &eval);
//! assert_eq!(report.windows.len(), 303);
//! assert!(report.translational(None).unwrap().median < 0.2);
//! ```

#![warn(missing_docs)]

pub use drive_data as data;
pub use drive_eval as eval;
pub use drive_models as models;
pub use drive_report as report;
pub use drive_samplers as samplers;
pub use drive_sim as sim;
pub use drive_traits as traits;

pub mod bundled;
pub mod fuzz;
