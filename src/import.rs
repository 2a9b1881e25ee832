//! A recording (the DRIVE logger's raw CSV, or a rosbag2 bag in MCAP storage) into windows:
//! what `drive import`, a benchmark suite's raw entries and the Python package's
//! `drive.import_raw` / `drive.import_bag` share, so that the three give the same dataset.
//!
//! ```no_run
//! use drive::import::{import_recording, ImportOptions, Recording};
//! let registries = drive::Registries::builtin();
//! let imported = import_recording(
//!     &registries,
//!     &Recording::Raw("raw_log.csv".as_ref()),
//!     "husky",
//!     &ImportOptions::default(),
//! )
//! .unwrap();
//! if let Some(why) = imported.failure(&[]) {
//!     eprintln!("{why}");
//! }
//! println!("{} windows", imported.dataset.windows.len());
//! ```

use crate::data::quality::{Finding, Severity};
use crate::data::{import_raw, raw_columns, read_bag, read_raw_log, BagTopics, DataError};
use crate::data::{ImportConfig, ImportReport};
use crate::samplers::{window_len, RobotError};
use crate::traits::{Dataset, PositionFrame, RobotDescription};
use crate::Registries;
use std::path::Path;
use std::sync::Arc;
use thiserror::Error;

/// What is imported.
#[derive(Debug, Clone, Copy)]
pub enum Recording<'a> {
    /// The DRIVE logger's raw CSV.
    Raw(&'a Path),
    /// A rosbag2 recording in MCAP storage (its directory or a `.mcap` file), with the
    /// topics that differ from the DRIVE logger's, each `KEY=/topic` (see
    /// [`BagTopics::set`]).
    Bag {
        /// The bag directory or `.mcap` file.
        path: &'a Path,
        /// `KEY=/topic` settings.
        topics: &'a [String],
    },
}

impl Recording<'_> {
    /// The file or directory read.
    pub fn path(&self) -> &Path {
        match self {
            Recording::Raw(p) => p,
            Recording::Bag { path, .. } => path,
        }
    }
}

/// How a recording is cut into windows (the defaults of `drive import`).
#[derive(Debug, Clone, PartialEq)]
pub struct ImportOptions {
    /// A time between two rows longer than this (s) cuts an interval.
    pub max_gap_s: f64,
    /// The longest time without a localization update inside an interval (s).
    pub localization_timeout_s: f64,
    /// The ground it was recorded on, free text (the sidecar's `terrain`).
    pub terrain: String,
    /// The dataset's name; the recording's file stem when `None`.
    pub name: Option<String>,
}

impl Default for ImportOptions {
    fn default() -> Self {
        let config = ImportConfig::default();
        ImportOptions {
            max_gap_s: config.max_gap_s,
            localization_timeout_s: config.localization_timeout_s,
            terrain: String::new(),
            name: None,
        }
    }
}

/// Why a recording could not be imported at all.
#[derive(Debug, Error)]
pub enum ImportError {
    /// The robot is not registered and is no robot file.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The robot's vehicle has inputs the logger's format does not hold.
    #[error("robot's vehicle: {0}")]
    Vehicle(String),
    /// A `KEY=/topic` setting is not understood.
    #[error("topic {0}")]
    Topic(String),
    /// The recording cannot be read, or holds nothing a window can be cut from.
    #[error(transparent)]
    Data(#[from] DataError),
}

/// An imported recording: its windows and the keep/drop report.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The windows (possibly none: see [`Imported::failure`]).
    pub dataset: Dataset,
    /// What was kept and dropped, and the data checks' findings.
    pub report: ImportReport,
}

impl Imported {
    /// Why this import must not be used: no usable window, or a fatal data check not in
    /// `allow` (check names, see [`crate::data::quality::CHECKS`]); `None` when it may be
    /// written.
    pub fn failure(&self, allow: &[String]) -> Option<String> {
        self.report.nothing_usable().or_else(|| {
            stopping(&self.report.checks, allow).map(|f| {
                format!(
                    "{}: check {}: {} (allow {} to import anyway)",
                    self.report.file, f.check, f.message, f.check
                )
            })
        })
    }
}

/// The first fatal finding not in `allow`.
pub fn stopping<'a>(findings: &'a [Finding], allow: &[String]) -> Option<&'a Finding> {
    findings
        .iter()
        .find(|f| f.severity == Severity::Fatal && !allow.iter().any(|a| a == f.check.key()))
}

/// Imports `recording` for `robot` (a registered robot or a robot TOML file): reads it, cuts
/// it into the protocol's windows and runs the data checks. The windows' poses are in the
/// frame of each window's first sample.
pub fn import_recording(
    registries: &Registries,
    recording: &Recording<'_>,
    robot: &str,
    options: &ImportOptions,
) -> Result<Imported, ImportError> {
    let spec = registries.robot(robot)?;
    crate::data::check_raw_vehicle(spec.vehicle.as_ref())
        .map_err(|e| ImportError::Vehicle(e.to_string()))?;
    let log = match recording {
        Recording::Bag { path, topics } => {
            let mut t = BagTopics::drive_logger(spec.vehicle.as_ref());
            for a in topics.iter() {
                t.set(a).map_err(|e| ImportError::Topic(e.to_string()))?;
            }
            read_bag(path, &t)?
        }
        Recording::Raw(path) => read_raw_log(path, &raw_columns(spec.vehicle.as_ref()))?,
    };
    let name = options.name.clone().unwrap_or_else(|| {
        recording
            .path()
            .file_stem()
            .map_or("raw".into(), |s| s.to_string_lossy().into_owned())
    });
    let description = RobotDescription {
        name,
        robot: spec.name.clone(),
        rate_hz: spec.rate_hz,
        window_len: window_len(&spec),
        vehicle: Arc::clone(&spec.vehicle),
        // Poses are re-based on the first sample of each window (position and yaw).
        position_frame: PositionFrame::FirstSample,
        terrain: options.terrain.trim().to_string(),
        registered_robot: String::new(),
    }
    .with_registered_robot(&spec.name);
    let config = ImportConfig {
        max_gap_s: options.max_gap_s,
        localization_timeout_s: options.localization_timeout_s,
        input_limits: Some(spec.input_space()),
    };
    let (dataset, report) = import_raw(&log, &description, &config)?;
    Ok(Imported { dataset, report })
}
