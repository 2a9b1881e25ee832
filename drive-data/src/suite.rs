//! The suite file of a benchmark (`drive bench --suite suite.toml`): the datasets to compare,
//! each a window CSV, a raw logger CSV or a rosbag2 recording (imported on the fly), or a
//! bundled dataset, with optional labels.
//!
//! ```toml
//! [[dataset]]
//! path = "runs/a.csv"          # a window CSV with its sidecar beside it (or sidecar = "...")
//! terrain = "asphalt"          # optional labels; default from the sidecar
//! [[dataset]]
//! raw = "logs/b.csv"           # a raw logger CSV, imported on the fly
//! robot = "husky2024.toml"     # a registered robot or a robot file
//! [[dataset]]
//! bag = "bags/c"               # a rosbag2 / MCAP recording
//! robot = "husky"
//! topic = ["odometry=/icp_odom"]
//! [[dataset]]
//! path = "bundled:warthog_grass_2024-08-08"
//! name = "grass"               # its name in the results (default: the file's stem)
//! ```
//!
//! Paths are relative to the suite file. Reading the datasets (and importing raw logs and
//! bags with their robot) is the caller's: this module parses and checks the file.

use drive_traits::exact::parse_message;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The most datasets a suite may name.
pub const MAX_SUITE_DATASETS: usize = 500;

/// Why a suite file is refused.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{file}: {message}")]
pub struct SuiteError {
    /// The suite file.
    pub file: String,
    /// What is wrong (the line, the dataset).
    pub message: String,
}

/// Where a dataset of a suite comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum SuiteSource {
    /// A window CSV (or `bundled:NAME`) and its sidecar, when not beside it.
    Windows {
        /// The CSV (resolved against the suite's folder), or `bundled:NAME`.
        csv: PathBuf,
        /// Its sidecar, when given.
        sidecar: Option<PathBuf>,
    },
    /// A raw DRIVE logger CSV.
    Raw(PathBuf),
    /// A rosbag2 recording (a folder or a .mcap file) and its topics other than the
    /// logger's (`KEY=/topic`, as `drive import --topic`).
    Bag {
        /// The recording.
        path: PathBuf,
        /// Topic assignments.
        topics: Vec<String>,
    },
}

/// One dataset of a suite.
#[derive(Debug, Clone, PartialEq)]
pub struct SuiteEntry {
    /// Where it comes from.
    pub source: SuiteSource,
    /// Its name in the results (default: the file's stem).
    pub name: Option<String>,
    /// A registered robot's name or a robot file (resolved against the suite's folder when
    /// it names a file): needed to import a raw log or a bag; otherwise it names the robot
    /// (its body, and the datasets compared in transfer).
    pub robot: Option<String>,
    /// The ground (default: the sidecar's `terrain`).
    pub terrain: Option<String>,
    /// Positions of a dataset in the paper parser's frame: `as-published` (default) or
    /// `corrected` (as `drive eval --frame`).
    pub corrected_frame: bool,
}

impl SuiteEntry {
    /// The default name: the stem of the file (a bundled dataset's name).
    pub fn default_name(&self) -> String {
        let path = match &self.source {
            SuiteSource::Windows { csv, .. } => {
                if let Some(b) = crate::bundled::name_in(csv) {
                    return crate::bundled::find(b).map_or(b, |d| d.name).to_string();
                }
                csv
            }
            SuiteSource::Raw(p) => p,
            SuiteSource::Bag { path, .. } => path,
        };
        let name = path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let name = name.strip_suffix(".gz").unwrap_or(&name);
        let name = name
            .strip_suffix(".csv")
            .or_else(|| name.strip_suffix(".mcap"))
            .unwrap_or(name);
        name.to_string()
    }

    /// The name in the results.
    pub fn name(&self) -> String {
        self.name.clone().unwrap_or_else(|| self.default_name())
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteFileToml {
    #[serde(default)]
    dataset: Vec<EntryToml>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EntryToml {
    #[serde(default)]
    path: Option<String>,
    #[serde(default)]
    sidecar: Option<String>,
    #[serde(default)]
    bundled: Option<String>,
    #[serde(default)]
    raw: Option<String>,
    #[serde(default)]
    bag: Option<String>,
    #[serde(default)]
    topic: Vec<String>,
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    robot: Option<String>,
    #[serde(default)]
    terrain: Option<String>,
    #[serde(default)]
    frame: Option<String>,
}

/// Parses a suite file's text; `file` names it in errors and its folder resolves the
/// relative paths.
///
/// ```
/// use drive_data::suite::{parse_suite, SuiteSource};
/// let text = "[[dataset]]\npath = \"runs/a.csv\"\nterrain = \"asphalt\"\n\
///             [[dataset]]\nraw = \"logs/b.csv\"\nrobot = \"husky\"\n\
///             [[dataset]]\npath = \"bundled:warthog_asphalt_a\"\n";
/// let suite = parse_suite("bench/suite.toml", text).unwrap();
/// assert_eq!(suite.len(), 3);
/// assert_eq!(suite[0].source, SuiteSource::Windows { csv: "bench/runs/a.csv".into(), sidecar: None });
/// assert_eq!(suite[1].robot.as_deref(), Some("husky"));
/// assert_eq!(suite[2].name(), "warthog_asphalt_a");
/// assert!(parse_suite("s.toml", "[[dataset]]\nraw = \"b.csv\"\n").unwrap_err().to_string().contains("robot"));
/// ```
pub fn parse_suite(file: &str, text: &str) -> Result<Vec<SuiteEntry>, SuiteError> {
    let err = |message: String| SuiteError {
        file: file.to_string(),
        message,
    };
    let base = Path::new(file).parent().unwrap_or(Path::new(""));
    let parsed: SuiteFileToml = toml::from_str(text)
        .map_err(|e| err(parse_message(text, e.message(), e.span().map(|s| s.start))))?;
    if parsed.dataset.is_empty() {
        return Err(err(
            "no dataset: give one [[dataset]] table per dataset (path, raw or bag)".into(),
        ));
    }
    if parsed.dataset.len() > MAX_SUITE_DATASETS {
        return Err(err(format!(
            "{} datasets; at most {MAX_SUITE_DATASETS}",
            parsed.dataset.len()
        )));
    }
    let resolve = |p: &str| -> PathBuf {
        if crate::bundled::name_in(Path::new(p)).is_some() {
            PathBuf::from(p)
        } else {
            base.join(p)
        }
    };
    let mut out = Vec::with_capacity(parsed.dataset.len());
    for (i, e) in parsed.dataset.into_iter().enumerate() {
        let which = format!("dataset {}", i + 1);
        let given = [
            e.path.is_some(),
            e.bundled.is_some(),
            e.raw.is_some(),
            e.bag.is_some(),
        ];
        if given.iter().filter(|g| **g).count() != 1 {
            return Err(err(format!(
                "{which}: give exactly one of path = \"window.csv\", bundled = \"NAME\", raw = \"log.csv\" and bag = \"recording\""
            )));
        }
        if e.sidecar.is_some() && e.path.is_none() {
            return Err(err(format!(
                "{which}: sidecar goes with path = \"window.csv\" only"
            )));
        }
        if !e.topic.is_empty() && e.bag.is_none() {
            return Err(err(format!("{which}: topic goes with bag = \"...\" only")));
        }
        for (field, v) in [
            ("name", &e.name),
            ("terrain", &e.terrain),
            ("robot", &e.robot),
            ("path", &e.path),
            ("sidecar", &e.sidecar),
            ("bundled", &e.bundled),
            ("raw", &e.raw),
            ("bag", &e.bag),
        ] {
            if let Some(v) = v {
                let most = if matches!(field, "name" | "terrain") {
                    200
                } else {
                    4096
                };
                if v.trim().is_empty() || v.chars().count() > most {
                    return Err(err(format!(
                        "{which}: {field} must be non-empty text of at most {most} characters"
                    )));
                }
                if drive_traits::limits::breaks_text(v) {
                    return Err(err(format!("{which}: {field} holds a control character")));
                }
            }
        }
        let source = if let Some(p) = &e.path {
            SuiteSource::Windows {
                csv: resolve(p),
                sidecar: e.sidecar.as_deref().map(resolve),
            }
        } else if let Some(b) = &e.bundled {
            SuiteSource::Windows {
                csv: PathBuf::from(format!("{}{b}", crate::bundled::PREFIX)),
                sidecar: None,
            }
        } else if let Some(r) = &e.raw {
            SuiteSource::Raw(resolve(r))
        } else {
            // One of the four is given (checked above).
            SuiteSource::Bag {
                path: resolve(e.bag.as_deref().unwrap_or_default()),
                topics: e.topic.clone(),
            }
        };
        if matches!(source, SuiteSource::Raw(_) | SuiteSource::Bag { .. }) && e.robot.is_none() {
            return Err(err(format!(
                "{which}: a raw log or a bag needs robot = \"NAME or robot.toml\" (its vehicle, geometry and rate)"
            )));
        }
        let corrected_frame = match e.frame.as_deref() {
            None | Some("as-published") => false,
            Some("corrected") => true,
            Some(other) => {
                return Err(err(format!(
                    "{which}: frame = {other:?}; expected \"as-published\" or \"corrected\""
                )))
            }
        };
        // A robot file is relative to the suite; a registered name stays a name.
        let robot = e.robot.map(|r| {
            let joined = base.join(&r);
            if r.ends_with(".toml") || joined.is_file() {
                joined.display().to_string()
            } else {
                r
            }
        });
        out.push(SuiteEntry {
            source,
            name: e.name.map(|n| n.trim().to_string()),
            robot,
            terrain: e.terrain.map(|t| t.trim().to_string()),
            corrected_frame,
        });
    }
    Ok(out)
}

/// Reads and parses a suite file.
pub fn read_suite(path: &Path) -> Result<Vec<SuiteEntry>, SuiteError> {
    let file = path.display().to_string();
    let cannot = |e: std::io::Error| SuiteError {
        file: file.clone(),
        message: format!("cannot read: {e}"),
    };
    // A suite is a short list: at most 1 MiB of a regular file.
    let text = drive_traits::files::read_text(path, 1 << 20).map_err(cannot)?;
    parse_suite(&file, &text)
}
