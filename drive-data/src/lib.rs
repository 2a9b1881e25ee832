//! Reading and writing DRIVE window datasets: the long-format window CSV (one row per
//! sample, input columns named by the vehicle) and its sidecar JSON (the vehicle with its
//! geometry, and rates); and the DRIVE logger's raw CSV ([`parse_raw_log`]) cut into
//! windows by [`import_raw`], with a keep/drop report.
//!
//! Every problem in the input is reported as a [`DataError`] that names the file, the line
//! and the column (or the sidecar field), and what was expected. Nothing here panics on
//! user data.
//!
//! ```
//! let csv = "window,phase,k,t,cmd_left,cmd_right,enc_left,enc_right,x,y,yaw,imu_yaw_rate\n\
//!            0,transient,0,0,1,1,0,0,0,0,0,0\n\
//!            0,transient,1,0.5,1,1,0.5,0.5,0.1,0,0,0\n";
//! let sidecar = r#"{"name": "tiny", "rate_hz": 2, "window_len": 2, "wheel_radius": 0.1, "baseline": 0.5}"#;
//! let data = drive_data::parse_dataset("tiny.csv", csv, "tiny.json", sidecar).unwrap();
//! assert_eq!(data.windows.len(), 1);
//! assert_eq!(data.robot.rate_hz, 2.0);
//! ```

#![warn(missing_docs)]

mod bag;
pub mod bundled;
mod chunk_codecs;
mod command_csv;
mod error;
mod import;
pub mod output;
pub mod output_names;
pub mod quality;
mod raw_log;
mod sidecar;
pub mod suite;
mod window_csv;

pub use bag::{
    bag_files, read_bag, read_bag_bytes, BagTopics, TopicAssignmentError, MAX_BAG_BYTES,
    MAX_BAG_MESSAGES, MAX_BAG_RECORD_BYTES,
};
pub use command_csv::{
    read_commands, CommandFile, CommandFileError, GRID_TOLERANCE, MAX_COMMANDS,
    MAX_COMMAND_LINE_BYTES,
};
pub use error::{DataError, DataErrorKind, Location};
pub use import::{import_raw, DropReason, ImportConfig, ImportReport, StepOutcome};
pub use raw_log::{
    check_raw_vehicle, parse_raw_log, raw_columns, write_raw_log, CalibState, RawLog, RawRow,
    RAW_COLUMNS,
};
pub use sidecar::{parse_sidecar, sidecar_json, Announced, CsvDigest, SidecarError};
pub use window_csv::{columns, parse_windows, write_windows_csv, OPTIONAL_COLUMNS};

use drive_traits::Dataset;
use std::path::{Path, PathBuf};

/// Parses a dataset from the window CSV text and the sidecar JSON text; the names are used
/// in error messages only.
pub fn parse_dataset(
    csv_name: &str,
    csv_text: &str,
    sidecar_name: &str,
    sidecar_text: &str,
) -> Result<Dataset, DataError> {
    let (robot, announced) = parse_sidecar(sidecar_name, sidecar_text)?;
    // A problem in the CSV is reported where it is; a well-formed CSV that is not the
    // sidecar's (another run's, or edited) is refused after.
    let windows = parse_windows(csv_name, csv_text, &robot)?;
    check_pair(csv_name, sidecar_name, &announced, windows.len(), || {
        CsvDigest::of(csv_text)
    })?;
    let mut data = Dataset { robot, windows };
    data.link_start_velocities();
    Ok(data)
}

/// Checks a CSV against what its sidecar announces: the number of windows, then the digest.
fn check_pair(
    csv_name: &str,
    sidecar_name: &str,
    announced: &Announced,
    windows: usize,
    digest: impl FnOnce() -> CsvDigest,
) -> Result<(), DataError> {
    if let Some(n) = announced.windows {
        if n != windows {
            return Err(DataError::new(
                Location::field(sidecar_name, "windows"),
                DataErrorKind::Inconsistent(format!(
                    "the sidecar announces {n} windows but {csv_name} holds {windows}"
                )),
            ));
        }
    }
    if let Some(expected) = announced.csv {
        let found = digest();
        if found != expected {
            return Err(DataError::new(
                Location::field(sidecar_name, "csv"),
                DataErrorKind::Inconsistent(format!(
                    "{csv_name} is not the CSV this sidecar was written with ({} rows, checksum {:016x}; the file has {} rows, checksum {:016x}): the pair comes from two runs, or the CSV was edited (if on purpose, delete the sidecar's 'csv' field)",
                    expected.rows, expected.fnv1a64, found.rows, found.fnv1a64
                )),
            ));
        }
    }
    Ok(())
}

/// The sidecar path a window CSV's description is written to: the same path with a
/// `.meta.json` extension, a name no one redirects a command's JSON output to (`drive eval
/// --data run.csv --json > run.json` leaves `run.meta.json` alone).
///
/// ```
/// use std::path::Path;
/// assert_eq!(drive_data::sidecar_path(Path::new("runs/husky.csv")), Path::new("runs/husky.meta.json"));
/// ```
pub fn sidecar_path(csv: &Path) -> PathBuf {
    csv.with_extension("meta.json")
}

/// The sidecar name of earlier releases: the CSV's path with a `.json` extension. It is still
/// read when the [`sidecar_path`] does not exist (see [`sidecar_to_read`]).
///
/// ```
/// use std::path::Path;
/// assert_eq!(drive_data::legacy_sidecar_path(Path::new("runs/husky.csv")), Path::new("runs/husky.json"));
/// ```
pub fn legacy_sidecar_path(csv: &Path) -> PathBuf {
    csv.with_extension("json")
}

/// The sidecar read with a window CSV when none is given: [`sidecar_path`] (`run.meta.json`),
/// or the earlier releases' `run.json` ([`legacy_sidecar_path`]) when only that one exists.
///
/// ```
/// use std::path::Path;
/// // Neither exists: the current name, which the "not found" error then names.
/// assert_eq!(
///     drive_data::sidecar_to_read(Path::new("/nonexistent/run.csv")),
///     Path::new("/nonexistent/run.meta.json")
/// );
/// ```
pub fn sidecar_to_read(csv: &Path) -> PathBuf {
    let current = sidecar_path(csv);
    let legacy = legacy_sidecar_path(csv);
    // symlink_metadata: a dangling link at the current name is still the current sidecar.
    if current.symlink_metadata().is_err() && legacy != csv && legacy.is_file() {
        legacy
    } else {
        current
    }
}

/// The largest raw logger CSV read (bytes), 256 MiB: its text is held whole, then its rows
/// (about 1.7 times the text at the peak), so that an import stays well under 1 GB of
/// memory. A DRIVE logger writes about 15 MB an hour at 20 Hz: 17 hours fit.
pub const MAX_RAW_LOG_BYTES: u64 = 1 << 28;

/// Reads a dataset from a window CSV file and its sidecar (by default beside the CSV, see
/// [`sidecar_to_read`]); `bundled:NAME` is the bundled dataset of that name (see [`bundled`]),
/// which carries its own sidecar.
pub fn read_dataset(csv: &Path, sidecar: Option<&Path>) -> Result<Dataset, DataError> {
    if let Some(name) = bundled::name_in(csv) {
        if let Some(s) = sidecar {
            return Err(DataError::new(
                Location::file(&s.display().to_string()),
                DataErrorKind::BadSidecar(format!(
                    "{} is a bundled dataset, which carries its own sidecar (give no sidecar)",
                    csv.display()
                )),
            ));
        }
        return bundled::load(name);
    }
    let sidecar = sidecar
        .map(Path::to_path_buf)
        .unwrap_or_else(|| sidecar_to_read(csv));
    let csv_name = csv.display().to_string();
    let sidecar_name = sidecar.display().to_string();
    let opened = drive_traits::files::regular(csv)
        .and_then(|()| std::fs::File::open(csv))
        .map_err(|e| DataError::new(Location::file(&csv_name), DataErrorKind::Io(e.to_string())))?;
    // A sidecar is a short JSON object.
    let sidecar_text = drive_traits::files::read_text(&sidecar, 1 << 20).map_err(|e| {
        let kind = if e.kind() == std::io::ErrorKind::NotFound {
            DataErrorKind::MissingSidecar(format!(
                "the sidecar JSON of {csv_name} was not found (expected at {sidecar_name}; give it with --sidecar)"
            ))
        } else {
            DataErrorKind::Io(e.to_string())
        };
        DataError::new(Location::file(&sidecar_name), kind)
    })?;
    let (robot, announced) = parse_sidecar(&sidecar_name, &sidecar_text)?;
    // Line by line: the CSV's text is never held whole.
    let (windows, digest) = window_csv::read_windows(&csv_name, opened, &robot)?;
    check_pair(&csv_name, &sidecar_name, &announced, windows.len(), || {
        digest
    })?;
    let mut data = Dataset { robot, windows };
    data.link_start_velocities();
    Ok(data)
}

/// Writes a dataset as a window CSV at `csv` and its sidecar beside it, both or neither
/// (see [`output::Outputs`]); the sidecar records the CSV's digest ([`CsvDigest`]).
pub fn write_dataset(dataset: &Dataset, csv: &Path) -> Result<(), DataError> {
    let mut outputs = output::Outputs::new(&[]);
    stage_dataset(&mut outputs, dataset, csv)?;
    outputs.publish().map_err(|e| write_error(csv, e))?;
    Ok(())
}

/// Stages a dataset's window CSV at `csv` and its sidecar beside it into `outputs` (which
/// the caller publishes with its other files).
pub fn stage_dataset(
    outputs: &mut output::Outputs,
    dataset: &Dataset,
    csv: &Path,
) -> Result<(), DataError> {
    let side = sidecar_path(csv);
    if output::is_special(csv) || output::is_special(&side) {
        return Err(DataError::new(
            Location::file(&csv.display().to_string()),
            DataErrorKind::Write(
                "not a regular file: a dataset is a CSV with its sidecar JSON beside it".into(),
            ),
        ));
    }
    // No NaN or infinity is written: the reader would refuse the file.
    let bad = dataset.windows.iter().find(|w| {
        let inputs = w.command.iter().chain(&w.measured).flat_map(|u| u.iter());
        let poses = w.pose.iter().flat_map(|p| p.iter());
        !inputs
            .chain(poses)
            .chain(&w.imu_yaw_rate)
            .all(|v| v.is_finite())
    });
    if let Some(w) = bad {
        return Err(DataError::new(
            Location::file(&csv.display().to_string()),
            DataErrorKind::Write(format!(
                "window {} holds a value that is not a finite number",
                w.index
            )),
        ));
    }
    let mut text = String::new();
    write_windows_csv(&dataset.windows, &dataset.robot, &mut text);
    let sidecar = sidecar_json(
        &dataset.robot,
        dataset.windows.len(),
        Some(CsvDigest::of(&text)),
    )
    .map_err(|e| {
        DataError::new(
            Location::file(&side.display().to_string()),
            DataErrorKind::Io(e.to_string()),
        )
    })?;
    // What is written can be read back: a text field the reader refuses (a terrain with a
    // tab or of 300 characters, a name with a control character) is refused here, before
    // anything is written, with the reader's words.
    if let Err(e) = parse_sidecar(&side.display().to_string(), &sidecar) {
        return Err(DataError::new(
            Location::file(&side.display().to_string()),
            DataErrorKind::Write(format!(
                "it would not be read back ({}{}): nothing written",
                e.location
                    .field
                    .map_or(String::new(), |f| format!("field '{f}': ")),
                e.kind
            )),
        ));
    }
    outputs.write(csv, text).map_err(|e| write_error(csv, e))?;
    outputs
        .write(&side, sidecar)
        .map_err(|e| write_error(&side, e))
}

fn write_error(path: &Path, e: output::OutputError) -> DataError {
    let reason = match e {
        output::OutputError::Write { reason, .. } => reason,
        e => e.to_string(),
    };
    DataError::new(
        Location::file(&path.display().to_string()),
        DataErrorKind::Write(reason),
    )
}

/// Reads a raw log file with the standard `columns` (see [`parse_raw_log`]).
pub fn read_raw_log(path: &Path, columns: &[&'static str; 19]) -> Result<RawLog, DataError> {
    parse_raw_log(&path.display().to_string(), &read_text(path)?, columns)
}

fn read_text(path: &Path) -> Result<String, DataError> {
    let name = path.display().to_string();
    let io =
        |e: std::io::Error| DataError::new(Location::file(&name), DataErrorKind::Io(e.to_string()));
    drive_traits::files::regular(path).map_err(io)?;
    let size = std::fs::metadata(path).map_err(io)?.len();
    if size > MAX_RAW_LOG_BYTES {
        return Err(DataError::new(
            Location::file(&name),
            DataErrorKind::Implausible(format!(
                "{size} bytes, more than the {MAX_RAW_LOG_BYTES} a raw log is read to (about 17 hours at 20 Hz; cut it into runs)"
            )),
        ));
    }
    let bytes = std::fs::read(path).map_err(io)?;
    // A byte-order mark (spreadsheet exports) is not part of the text.
    let bytes = match bytes.strip_prefix(b"\xef\xbb\xbf") {
        Some(rest) => rest.to_vec(),
        None => bytes,
    };
    String::from_utf8(bytes).map_err(|e| {
        DataError::new(
            Location::file(&name),
            DataErrorKind::Io(format!(
                "not UTF-8 text (byte {})",
                e.utf8_error().valid_up_to()
            )),
        )
    })
}
