//! The studies of DRIVE, the application layer: every analysis that fits models and scores
//! them, each returning a typed result that the command line, Python and `drive-report`
//! render. The parts they combine come from the [`Registries`]; the metrics are
//! `drive-eval`'s.
//!
//! | file | job |
//! |---|---|
//! | `registries.rs` | every registry of parts ([`Registries`]) and their catalog |
//! | `experiment.rs` | the engine: settings x models -> cells, simulated runs ([`run_cells`], [`simulate_runs`]) |
//! | `comparison.rs` | the model comparison (Fig. 6) |
//! | `convergence.rs` | error against training time (Fig. 7) |
//! | `protocols.rs`, `regions.rs` | data-gathering protocols (Table I) on the simulator and on recorded data |
//! | `matrix/` | the evaluation matrix: sweep file, run, statistics, outputs |
//! | `bench.rs` | the benchmark: datasets x models, transfer between runs, leaderboard |
//! | `adapt.rs` | a prior adapting to a new run's ground against frozen, scratch and own models (`drive adapt`) |
//! | `twin_check.rs` | a twin fitted (with the simulator's fit) and its runs against its real run |
//! | `closed_loop/` | a controller with a fitted model driving the simulator along paths (`drive track`) |
//!
//! ```
//! use drive_studies::{compare, Registries};
//! let data = drive_studies::simulate_protocol(&Registries::builtin(), "husky", "gravel", "uniform", 12, 1)
//!     .unwrap()
//!     .dataset;
//! let cmp = compare(&Registries::builtin(), &data, 0.5, &["naive", "slip-blr"]).unwrap();
//! assert_eq!(cmp.models.len(), 2);
//! ```

#![warn(missing_docs)]

mod adapt;
mod bench;
pub mod closed_loop;
mod comparison;
mod convergence;
mod experiment;
mod matrix;
mod protocols;
mod regions;
mod registries;
pub mod report;
mod score;
mod terrain_library;
mod twin_check;

/// The models compared by default (`drive eval`, `report`, Python's `compare`): the paper's
/// four (Fig. 6), comma-separated.
///
/// ```
/// assert_eq!(drive_studies::PAPER_MODELS.split(',').count(), 4);
/// ```
pub const PAPER_MODELS: &str = "naive,powertrain,slip-blr,acc-blr";

/// The models of the benchmark by default (`drive bench`, Python's `bench`): the paper's four
/// and slip-ipem, comma-separated.
///
/// ```
/// assert!(drive_studies::BENCH_MODELS.starts_with(drive_studies::PAPER_MODELS));
/// ```
pub const BENCH_MODELS: &str = "naive,powertrain,slip-blr,acc-blr,slip-ipem";

pub use adapt::{
    adapt, adapt_with_progress, AdaptPoint, AdaptPrior, AdaptStudy, Adaptation, AdaptiveFit,
    Extrapolation, ADAPTIVE_STATE_FORMAT, ADAPT_MODELS, ADAPT_TIMES_S, EXTRAPOLATION_MARGIN,
    MAX_ADAPTIVE_STATE_BYTES, REFIT_GROWTH, REFIT_MEMORY_WINDOWS, REFIT_MIN_SCORED,
};
pub use bench::{
    bench_units, run_bench, terrain_known, AdaptPair, AdaptSummary, Bench, BenchAdaptation,
    BenchConfig, BenchDataset, BenchError, BenchInput, BenchModel, BenchUnpredictability,
    ErrorGrowth, LeaderboardRow, LibrarySummary, Ratio, SkippedDataset, TransferCell,
    TransferGroup, TransferSummary, UnpredictabilityBin, LEADERBOARD_ADAPT_T_S,
};
pub use closed_loop::{
    run_track, GroundChange, GroundChangeAt, LoopAdaptation, PathChoice, PlacedPath, TrackError,
    TrackResult, TrackRun, TrackStudy, TrackSummary, Training,
};
pub use comparison::{
    check_names, compare, compare_specs, compare_specs_with_progress, vehicle_type, CompareError,
    Comparison, ErrorSummary, ModelResult, PairedImprovement, PhaseSummary,
};
pub use convergence::{
    convergence, convergence_time, convergence_with, Convergence, ConvergenceConfig,
    ConvergencePoint, OrderSpread, SkippedPoint, SpreadPoint,
};
pub use experiment::{run_cells, simulate_run, simulate_runs, Cell, Scored, Setting, SimRun};
pub use matrix::{
    run_matrix, DatasetLoadError, DatasetSource, FrameChoice, Matrix, MatrixCell, MatrixError,
    MatrixResult, Scenario, SimulatedPlan, SimulatedSweep, SummaryRow, SweepFile,
};
pub use protocols::{
    compare_protocols, intervals_in, simulate_protocol, BestOnTest, ExperimentError, ProtocolCell,
    ProtocolComparison, ProtocolRow, ProtocolStudy, ProtocolWinners, RobotSimulator, WinCount,
    WinnerBlock, INTERVAL_S, MIXED,
};
pub use regions::{compare_regions, RegionComparison, RegionResult, RegionStudy};
pub use registries::{Catalog, Listed, Registries};
pub use score::{
    geometry_difference, same_geometry, score_model, ByPhase, ErrorQuartiles, Score, ScoreError,
};
pub use terrain_library::{TerrainLibrary, LOG_LIKELIHOOD_FLOOR, PRIOR_LOG_ODDS};
pub use twin_check::{
    choose_variability, fit_twin, fit_twin_with, poor_twin, twin_check, CheckCommands,
    CheckDistance, ContactSpreadChoice, ContactSpreads, FittedTwin, ScatterCheck, SpreadTried,
    TwinCheck, TwinCheckRow, VariabilityChoice, CONTACT_SPREAD_MARGIN, TWIN_CHECK_MODELS,
    TWIN_TOLERANCE, VARIABILITY_CHOICE_SEEDS,
};
