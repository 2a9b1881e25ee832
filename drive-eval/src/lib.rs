//! Evaluation of DRIVE motion models: the multi-step RMSE of paper eq. 8, the interval
//! split, robust summaries, and the analyses of the paper, all run by one experiment engine
//! over the parts of the [`Registries`].
//!
//! | file | job |
//! |---|---|
//! | `metric.rs`, `split.rs`, `stats.rs` | eq. 8, the interval split, quantiles |
//! | `registries.rs` | every registry of parts ([`Registries`]) and their catalog |
//! | `experiment.rs` | the engine: settings x models -> cells, simulated runs ([`run_cells`], [`simulate_runs`]) |
//! | `comparison.rs` | the model comparison (Fig. 6) |
//! | `uncertainty.rs` | coverage of the predicted pose covariance, NLL, reliability |
//! | `terrain.rs` | the terrain's unpredictability (energy-based, T-FR 2025) |
//! | `convergence.rs` | error against training time (Fig. 7) |
//! | `protocols.rs`, `regions.rs` | data-gathering protocols (Table I) on the simulator and on recorded data |
//! | `matrix/` | the evaluation matrix: sweep file, run, statistics, outputs |
//! | `bench.rs` | the benchmark: datasets x models, transfer between runs, leaderboard |
//! | `twin_check.rs` | a twin's runs against its real run: medians of four models, scatter |
//! | `closed_loop.rs` | a controller with a fitted model driving the simulator along paths (`drive track`) |
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

mod bench;
pub mod closed_loop;
mod compare;
mod comparison;
mod convergence;
mod experiment;
mod matrix;
mod metric;
mod protocols;
mod regions;
mod registries;
mod split;
mod stats;
mod terrain;
mod twin_check;
mod uncertainty;

pub use bench::{
    bench_units, run_bench, terrain_known, Bench, BenchConfig, BenchDataset, BenchError,
    BenchInput, BenchModel, BenchUnpredictability, ErrorGrowth, LeaderboardRow, Ratio,
    TransferCell, TransferGroup, TransferSummary, UnpredictabilityBin,
};
pub use closed_loop::{
    run_track, PathChoice, PlacedPath, TrackError, TrackResult, TrackRun, TrackStudy, TrackSummary,
    Training,
};
pub use compare::{
    evaluate_errors, evaluate_model, evaluate_model_from, ModelReport, WindowErrors,
};
pub use comparison::{
    check_names, compare, compare_specs, vehicle_type, CompareError, Comparison, ErrorSummary,
    ModelResult, PairedImprovement, PhaseSummary,
};
pub use convergence::{
    convergence, convergence_time, convergence_with, Convergence, ConvergenceConfig,
    ConvergencePoint, OrderSpread, SkippedPoint, SpreadPoint,
};
pub use experiment::{run_cells, simulate_run, simulate_runs, Cell, Scored, Setting, SimRun};
pub use matrix::{
    run_matrix, BootstrapConfig, DatasetSource, FrameChoice, Improvement, Matrix, MatrixCell,
    MatrixError, MatrixResult, Scenario, SimulatedPlan, SimulatedSweep, SummaryRow, SweepFile,
};
pub use metric::{mrmse, Mrmse};
pub use protocols::{
    compare_protocols, intervals_in, simulate_protocol, ExperimentError, ProtocolCell,
    ProtocolComparison, ProtocolRow, ProtocolStudy, INTERVAL_S, MIXED,
};
pub use regions::{compare_regions, RegionComparison, RegionResult, RegionStudy};
pub use registries::{Catalog, Listed, Registries};
pub use split::{split_by_interval, SplitError};
pub use stats::{
    average_ranks, improvement_percent, median_interval, paired_bootstrap, quantile, spearman,
    PairedErrors, Summary,
};
pub use terrain::{
    energy_unpredictability, unpredictability, Unpredictability, UnpredictabilityConfig,
    UnpredictabilitySummary, WindowUnpredictability,
};
pub use twin_check::{
    choose_variability, fit_twin, poor_twin, twin_check, CheckCommands, CheckDistance,
    ContactSpreadChoice, FittedTwin, ScatterCheck, SpreadTried, TwinCheck, TwinCheckRow,
    VariabilityChoice, CONTACT_SPREAD_MARGIN, TWIN_CHECK_MODELS, TWIN_TOLERANCE,
    VARIABILITY_CHOICE_SEEDS,
};
pub use uncertainty::{
    score_uncertainty, GroupCoverage, ReliabilityPoint, UncertaintyReport, COVERAGE_HORIZONS_S,
    RELIABILITY_LEVELS,
};
