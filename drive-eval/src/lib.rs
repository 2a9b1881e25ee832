//! The metrics of DRIVE motion models: the multi-step RMSE of paper eq. 8, the interval
//! split, evaluation of one fitted model on a dataset's evaluation windows, robust
//! statistics (quantiles, paired bootstrap), the predicted covariance's coverage and the
//! terrain's unpredictability. The studies built on them (bench, matrix, track, twins,
//! protocols, convergence) are the application layer's, in `drive-studies`.
//!
//! | file | job |
//! |---|---|
//! | `metric.rs`, `split.rs`, `stats.rs` | eq. 8, the interval split, quantiles, the paired bootstrap |
//! | `compare.rs` | one fitted model's errors on the evaluation windows ([`evaluate_model`]) |
//! | `uncertainty.rs` | coverage of the predicted pose covariance, NLL, reliability |
//! | `terrain.rs` | the terrain's unpredictability (energy-based, T-FR 2025) |
//!
//! ```
//! use drive_eval::{mrmse, Mrmse};
//! use drive_traits::Pose;
//! let measured = vec![Pose::new(0.0, 0.0, 0.0), Pose::new(1.0, 0.0, 0.1), Pose::new(2.0, 0.0, 0.2)];
//! let predicted = vec![Pose::new(0.0, 0.0, 0.0), Pose::new(1.0, 1.0, 0.0), Pose::new(2.0, 3.0, 0.2)];
//! let e = mrmse(&predicted, &measured);
//! assert!((e.translational - 2.0).abs() < 1e-12);  // mean of 1 and 3
//! assert!((e.rotational - 0.05).abs() < 1e-12);    // mean of 0.1 and 0
//! ```

#![warn(missing_docs)]

mod compare;
mod metric;
mod split;
mod stats;
mod terrain;
mod uncertainty;

pub use compare::{
    evaluate_errors, evaluate_model, evaluate_model_from, ModelReport, WindowErrors,
};
pub use metric::{mrmse, Mrmse};
pub use split::{split_by_interval, SplitError};
pub use stats::{
    average_ranks, improvement_percent, median_interval, paired_bootstrap, quantile, spearman,
    BootstrapConfig, Improvement, PairedErrors, Summary,
};
pub use terrain::{
    energy_unpredictability, unpredictability, Unpredictability, UnpredictabilityConfig,
    UnpredictabilitySummary, WindowUnpredictability,
};
pub use uncertainty::{
    score_uncertainty, GroupCoverage, ReliabilityPoint, UncertaintyReport, COVERAGE_HORIZONS_S,
    RELIABILITY_LEVELS,
};
