//! The datasets of a benchmark: a suite file's entries (window CSVs, raw logs and bags
//! imported on the fly, bundled datasets) or every bundled dataset, loaded with their robot
//! and terrain for [`drive_studies::run_bench`].
//!
//! ```
//! let registries = drive::Registries::builtin();
//! let inputs = drive::suite::bundled(&registries).unwrap();
//! assert_eq!(inputs.len(), drive::bundled::BUNDLED.len());
//! assert_eq!(inputs[1].robot, "warthog");
//! assert!(inputs[1].body.is_some());
//! ```

use crate::data::suite::{SuiteEntry, SuiteError, SuiteSource};
use crate::data::{read_dataset, DataError};
use crate::import::{import_recording, ImportError, ImportOptions, Imported, Recording};
use crate::samplers::{BodySize, RobotError, RobotSpec};
use crate::studies::BenchInput;
use crate::traits::Dataset;
use crate::Registries;
use rayon::prelude::*;
use thiserror::Error;

/// Why a dataset of a suite could not be loaded.
#[derive(Debug, Error)]
pub enum SuiteLoadError {
    /// The suite file is refused.
    #[error(transparent)]
    Suite(#[from] SuiteError),
    /// A dataset could not be read or imported.
    #[error("dataset '{name}': {reason}")]
    Data {
        /// The dataset's name in the suite.
        name: String,
        /// Why.
        reason: DataError,
    },
    /// Its robot could not be loaded.
    #[error("dataset '{name}': {reason}")]
    Robot {
        /// The dataset's name in the suite.
        name: String,
        /// Why.
        reason: RobotOfError,
    },
    /// The import kept nothing, or a data check found the recording useless.
    #[error("dataset '{name}': {message}")]
    Import {
        /// The dataset's name in the suite.
        name: String,
        /// Why.
        message: String,
    },
    /// The data's vehicle is not a registered vehicle.
    #[error("dataset '{name}': the data's vehicle: {reason}")]
    Vehicle {
        /// The dataset's name in the suite.
        name: String,
        /// Why.
        reason: crate::traits::RegistryError,
    },
    /// No dataset of the suite could be read (each named with why).
    #[error("no dataset of the suite could be read: {0}")]
    NoneRead(String),
}

/// Why a dataset's robot could not be taken.
#[derive(Debug, Error)]
pub enum RobotOfError {
    /// No such registered robot or robot file, or the file is refused.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The robot given has another vehicle type than the data's.
    #[error("the robot {robot}'s vehicle is {theirs} and the data's is {ours}: it is not this data's robot")]
    Vehicle {
        /// The robot.
        robot: String,
        /// The robot's vehicle type.
        theirs: String,
        /// The data's vehicle type.
        ours: String,
    },
}

/// The robot a dataset is of: its identity (a registered robot's name when one is given or
/// recognised), its body and where that body comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotOf {
    /// The identity.
    pub name: String,
    /// The body's footprint, when known.
    pub body: Option<BodySize>,
    /// Where the identity and the body come from (one line).
    pub source: String,
}

/// The registered robot whose name is a word of the sidecar's robot text ("Clearpath
/// Husky" is `husky`; a name with hyphens or underscores, `cmd-vel-robot`, is one word of
/// the text split at the other characters: "simulated cmd-vel-robot on snow"), when exactly
/// one is, or one name holds every other found (`warthog-1080` over `warthog` in
/// "warthog-1080 run").
///
/// ```
/// let mut registries = drive::Registries::builtin();
/// assert_eq!(drive::suite::recognised_robot(&registries, "Clearpath Warthog (wheels)").as_deref(), Some("warthog"));
/// assert_eq!(drive::suite::recognised_robot(&registries, "my rover"), None);
/// let mut rover = registries.robot("husky").unwrap();
/// rover.name = "my-rover".into();
/// registries.robots.register("my-rover", "a rover", std::sync::Arc::new(rover)).unwrap();
/// assert_eq!(drive::suite::recognised_robot(&registries, "simulated my-rover on snow").as_deref(), Some("my-rover"));
/// ```
pub fn recognised_robot(registries: &Registries, text: &str) -> Option<String> {
    let split = |keep: fn(char) -> bool| -> Vec<String> {
        text.split(|c: char| !keep(c))
            .filter(|w| !w.is_empty())
            .map(str::to_lowercase)
            .collect()
    };
    let mut words = split(char::is_alphanumeric);
    words.extend(split(|c| c.is_alphanumeric() || c == '-' || c == '_'));
    let found: Vec<&str> = registries
        .robots
        .names()
        .into_iter()
        .filter(|n| words.iter().any(|w| w == &n.to_lowercase()))
        .collect();
    // The longest name found, when it holds every other (a hyphenated name's parts).
    let longest = found.iter().max_by_key(|n| n.len())?;
    found
        .iter()
        .all(|n| longest.to_lowercase().contains(&n.to_lowercase()))
        .then(|| longest.to_string())
}

/// The robot of `data`: `explicit` (a registered robot or a robot file) when given (an
/// error when its vehicle type is not the data's), else the robot the sidecar names
/// exactly (`registered_robot`, registered or not), else the robot recognised in the
/// sidecar's robot text ([`recognised_robot`], when its vehicle type is the data's), else
/// the sidecar's text itself without a body.
pub fn robot_of(
    registries: &Registries,
    data: &Dataset,
    explicit: Option<&str>,
) -> Result<RobotOf, RobotOfError> {
    let ours = crate::traits::vehicle_tag(data.robot.vehicle.as_ref()).unwrap_or_default();
    let theirs =
        |spec: &RobotSpec| crate::traits::vehicle_tag(spec.vehicle.as_ref()).unwrap_or_default();
    if let Some(r) = explicit {
        let spec = registries.robot(r)?;
        if theirs(&spec) != ours {
            return Err(RobotOfError::Vehicle {
                robot: spec.name.clone(),
                theirs: theirs(&spec),
                ours,
            });
        }
        let from = match RobotSpec::file_of(r) {
            Some(_) => format!("robot file {r}"),
            None => format!("robot {r}"),
        };
        return Ok(of_spec(&spec, from));
    }
    // The robot the sidecar names exactly (written by `simulate` and `import`): its
    // identity whether or not it is registered here.
    let named = data.robot.registered_robot.as_str();
    if !named.is_empty() {
        if let Some(spec) = registries
            .robots
            .find(named)
            .map(|e| e.part().as_ref().clone())
            .filter(|spec| theirs(spec) == ours)
        {
            // A robot file that took a registered robot's name: not that robot's body.
            let geometry = |v: &dyn crate::traits::CommandModel| serde_json::to_value(v).ok();
            if geometry(spec.vehicle.as_ref()) != geometry(data.robot.vehicle.as_ref()) {
                return Ok(RobotOf {
                    name: named.to_string(),
                    body: None,
                    source: format!(
                        "the sidecar's registered_robot {named}, whose vehicle geometry is not the registered {named}'s (a robot file of that name?): no body size; --robot names the robot"
                    ),
                });
            }
            return Ok(of_spec(
                &spec,
                format!("robot {named}, named in the sidecar's registered_robot"),
            ));
        }
        return Ok(RobotOf {
            name: named.to_string(),
            body: None,
            source: format!(
                "the sidecar's registered_robot {named}, not registered here with this vehicle type: no body size"
            ),
        });
    }
    if let Some(name) = recognised_robot(registries, &data.robot.robot) {
        let spec = registries.robot(&name)?;
        if theirs(&spec) == ours {
            return Ok(of_spec(
                &spec,
                format!(
                    "robot {name}, recognised in the sidecar's robot \"{}\"",
                    data.robot.robot
                ),
            ));
        }
    }
    let text = data.robot.robot.trim();
    Ok(RobotOf {
        name: if text.is_empty() {
            data.robot.name.clone()
        } else {
            text.to_string()
        },
        body: None,
        source: "the sidecar's robot, not a registered one: no body size".into(),
    })
}

fn of_spec(spec: &RobotSpec, from: String) -> RobotOf {
    RobotOf {
        name: spec.name.clone(),
        body: spec.body,
        source: match spec.body {
            Some(_) => from,
            None => format!("{from}, which has no body size"),
        },
    }
}

/// Every bundled dataset, with the robot it was recorded with.
pub fn bundled(registries: &Registries) -> Result<Vec<BenchInput>, SuiteLoadError> {
    let entries: Vec<SuiteEntry> = crate::bundled::BUNDLED
        .iter()
        .map(|b| SuiteEntry {
            source: SuiteSource::Windows {
                csv: format!("{}{}", crate::bundled::PREFIX, b.name).into(),
                sidecar: None,
            },
            name: None,
            robot: Some(b.robot.to_string()),
            terrain: None,
            corrected_frame: false,
        })
        .collect();
    load(registries, &entries)
}

/// Loads every entry of a suite (in parallel): reads the window CSVs, imports the raw logs
/// and bags with their robot (as `drive import` does, refusing a recording a data check
/// finds useless), and labels each with its robot and terrain.
pub fn load(
    registries: &Registries,
    entries: &[SuiteEntry],
) -> Result<Vec<BenchInput>, SuiteLoadError> {
    entries
        .par_iter()
        .map(|e| load_entry(registries, e))
        .collect()
}

/// [`load`], each entry on its own: a benchmark goes on without a dataset that cannot be
/// read or imported (a NaN cell, a recording whose every interval is dropped) and names it
/// as skipped, while a suite that names a robot that does not exist is still refused (see
/// [`SuiteLoadError::skippable`]).
pub fn load_each(
    registries: &Registries,
    entries: &[SuiteEntry],
) -> Vec<(String, Result<BenchInput, SuiteLoadError>)> {
    entries
        .par_iter()
        .map(|e| (e.name(), load_entry(registries, e)))
        .collect()
}

/// [`load_each`] for a benchmark: the datasets read, and those that could not be (their own
/// file unreadable, corrupted or with nothing usable: [`SuiteLoadError::skippable`]) named
/// with why, for the benchmark's `skipped`; `Err` for an error of the suite's (a robot that
/// does not exist) or when no dataset could be read, naming each.
///
/// ```
/// let registries = drive::Registries::builtin();
/// let entries = drive::data::suite::parse_suite(
///     "suite.toml",
///     "[[dataset]]\npath = \"no-such-run.csv\"\n[[dataset]]\npath = \"bundled:husky_drive\"\n",
/// )
/// .unwrap();
/// let (read, skipped) = drive::suite::load_skipping(&registries, &entries).unwrap();
/// assert_eq!((read.len(), skipped.len()), (1, 1));
/// assert_eq!(skipped[0].dataset, "no-such-run");
/// ```
pub fn load_skipping(
    registries: &Registries,
    entries: &[SuiteEntry],
) -> Result<(Vec<BenchInput>, Vec<crate::studies::SkippedDataset>), SuiteLoadError> {
    let mut read = Vec::new();
    let mut skipped = Vec::new();
    for (name, outcome) in load_each(registries, entries) {
        match outcome {
            Ok(d) => read.push(d),
            Err(err) if err.skippable() => skipped.push(crate::studies::SkippedDataset {
                dataset: name,
                reason: err.reason(),
            }),
            Err(err) => return Err(err),
        }
    }
    if read.is_empty() {
        return Err(SuiteLoadError::NoneRead(
            crate::studies::SkippedDataset::listed(&skipped),
        ));
    }
    Ok((read, skipped))
}

impl SuiteLoadError {
    /// Whether the error is the dataset's own (its file unreadable, corrupted or with
    /// nothing usable), so that a benchmark goes on without it; the others (the suite file,
    /// a robot or vehicle that does not exist) are the suite's configuration.
    pub fn skippable(&self) -> bool {
        matches!(self, Self::Data { .. } | Self::Import { .. })
    }

    /// The reason alone, without the dataset's name.
    pub fn reason(&self) -> String {
        match self {
            Self::Data { reason, .. } => reason.to_string(),
            Self::Import { message, .. } => message.clone(),
            e => e.to_string(),
        }
    }
}

fn load_entry(registries: &Registries, entry: &SuiteEntry) -> Result<BenchInput, SuiteLoadError> {
    let name = entry.name();
    let data_error = |reason| SuiteLoadError::Data {
        name: name.clone(),
        reason,
    };
    let robot_error = |reason| SuiteLoadError::Robot {
        name: name.clone(),
        reason,
    };
    let mut notes = Vec::new();
    let (mut data, source) = match &entry.source {
        SuiteSource::Windows { csv, sidecar } => {
            let data = read_dataset(csv, sidecar.as_deref()).map_err(data_error)?;
            registries
                .check_vehicle(data.robot.vehicle.as_ref())
                .map_err(|reason| SuiteLoadError::Vehicle {
                    name: name.clone(),
                    reason,
                })?;
            (data, csv.display().to_string())
        }
        SuiteSource::Raw(path) | SuiteSource::Bag { path, .. } => {
            // The suite's parser requires a robot for a raw log or a bag.
            let robot = entry.robot.as_deref().unwrap_or_default();
            let recording = match &entry.source {
                SuiteSource::Bag { topics, .. } => Recording::Bag { path, topics },
                _ => Recording::Raw(path),
            };
            let options = ImportOptions {
                name: Some(name.clone()),
                terrain: entry.terrain.clone().unwrap_or_default(),
                ..ImportOptions::default()
            };
            let Imported {
                dataset: data,
                report,
            } = import_recording(registries, &recording, robot, &options).map_err(|e| match e {
                ImportError::Robot(e) => robot_error(e.into()),
                ImportError::Topic(message) | ImportError::Vehicle(message) => {
                    SuiteLoadError::Import {
                        name: name.clone(),
                        message,
                    }
                }
                ImportError::Data(e) => data_error(e),
            })?;
            notes.extend(
                report
                    .checks
                    .iter()
                    .filter(|f| f.severity == crate::data::quality::Severity::Warning)
                    .map(|f| format!("check {}: {}", f.check, f.message)),
            );
            if let Some(why) = report.nothing_usable() {
                return Err(SuiteLoadError::Import {
                    name: name.clone(),
                    message: why,
                });
            }
            // A fatal finding is the benchmark's to judge, as a window CSV's is: the dataset
            // is skipped with it (ranked with --allow-useless).
            (data, path.display().to_string())
        }
    };
    if entry.corrected_frame {
        data.to_first_sample_frame();
    }
    let bundled_robot = match &entry.source {
        SuiteSource::Windows { csv, .. } => crate::data::bundled::name_in(csv)
            .and_then(crate::bundled::find)
            .map(|b| b.robot.to_string()),
        _ => None,
    };
    let explicit = entry.robot.clone().or(bundled_robot);
    let mut robot = robot_of(registries, &data, explicit.as_deref()).map_err(robot_error)?;
    // A robot named for data of another geometry (`robot = "husky"` on a Warthog run): said,
    // as `check --robot` says it, and its body not taken for the data's.
    if let Some(spec) = explicit.as_deref().and_then(|r| registries.robot(r).ok()) {
        if let Some(f) = crate::data::quality::vehicle_mismatch(
            data.robot.vehicle.as_ref(),
            spec.vehicle.as_ref(),
            &spec.name,
        ) {
            notes.push(format!("check {}: {}", f.check, f.message));
            if robot.body.take().is_some() {
                robot.source =
                    format!("{}, not of the data's geometry: no body size", robot.source);
            }
        }
    }
    let terrain = entry
        .terrain
        .clone()
        .unwrap_or_else(|| data.robot.terrain.clone());
    data.robot.terrain = terrain.clone();
    Ok(BenchInput {
        name,
        source,
        robot: robot.name,
        terrain,
        body: robot.body,
        body_source: robot.source,
        data,
        notes,
    })
}
