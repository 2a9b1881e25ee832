use drive_traits::limits::Short;
use std::fmt;
use thiserror::Error;

/// Where in the input a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// File name (or `bundled:...` for the bundled dataset).
    pub file: String,
    /// 1-based line, when the problem is on one line.
    pub line: Option<usize>,
    /// CSV column or JSON field, when known.
    pub field: Option<String>,
}

impl Location {
    /// The whole file.
    pub fn file(file: &str) -> Self {
        Location {
            file: file.to_string(),
            line: None,
            field: None,
        }
    }
    /// A line of a file.
    pub fn line(file: &str, line: usize) -> Self {
        Location {
            file: file.to_string(),
            line: Some(line),
            field: None,
        }
    }
    /// A column on a line of a file.
    pub fn cell(file: &str, line: usize, column: &str) -> Self {
        Location {
            file: file.to_string(),
            line: Some(line),
            field: Some(column.to_string()),
        }
    }
    /// A field of a JSON file.
    pub fn field(file: &str, field: &str) -> Self {
        Location {
            file: file.to_string(),
            line: None,
            field: Some(field.to_string()),
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(line) = self.line {
            write!(f, ", line {line}")?;
        }
        match (&self.field, self.line) {
            (Some(c), Some(_)) => write!(f, ", column '{c}'"),
            (Some(c), None) => write!(f, ", field '{c}'"),
            _ => Ok(()),
        }
    }
}

/// What is wrong.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DataErrorKind {
    /// The file could not be read.
    #[error("cannot read: {0}")]
    Io(String),
    /// The file could not be written (nothing was replaced).
    #[error("cannot write: {0}")]
    Write(String),
    /// A number far outside anything physical.
    #[error("{0}")]
    Implausible(String),
    /// The file holds no data.
    #[error("the file is empty")]
    Empty,
    /// A required CSV column is absent.
    #[error("missing column (required: {0})")]
    MissingColumn(String),
    /// A CSV column is not one of the format's.
    #[error("unknown column (the columns are: {0})")]
    UnknownColumn(String),
    /// A CSV column appears twice.
    #[error("duplicate column")]
    DuplicateColumn,
    /// A row has the wrong number of fields.
    #[error("{found} fields where the header has {expected}")]
    FieldCount {
        /// fields in the header
        expected: usize,
        /// fields on this row
        found: usize,
    },
    /// A value is not a number.
    #[error("'{0}' is not a number")]
    NotANumber(String),
    /// A value is NaN or infinite.
    #[error("'{0}' is not a finite number")]
    NotFinite(String),
    /// A value should be a non-negative integer.
    #[error("'{0}' is not a non-negative integer")]
    NotAnInteger(String),
    /// A value should be a boolean (`True`/`False`, `true`/`false`, `1`/`0`).
    #[error("'{0}' is not a boolean (expected True or False)")]
    NotABoolean(String),
    /// The phase is neither `transient` nor `steady`.
    #[error("'{0}' is not a phase (expected 'transient' or 'steady')")]
    BadPhase(String),
    /// Samples of a window are not in order `k = 0, 1, ...`.
    #[error("sample out of order in window {window}: expected k = {expected}, found k = {found}")]
    SampleOutOfOrder {
        /// window index
        window: usize,
        /// expected sample index
        expected: usize,
        /// found sample index
        found: usize,
    },
    /// Windows are not in increasing order, or a window's rows are not contiguous.
    #[error("window {found} after window {previous}: windows must be in increasing order, each in one block of rows")]
    WindowOutOfOrder {
        /// previous window index
        previous: usize,
        /// found window index
        found: usize,
    },
    /// A window has the wrong number of samples.
    #[error("window {window} has {found} samples, the sidecar's window_len is {expected}")]
    WrongWindowLength {
        /// window index
        window: usize,
        /// window_len from the sidecar
        expected: usize,
        /// samples found
        found: usize,
    },
    /// The phase changes inside a window.
    #[error("the phase changes inside window {0}")]
    PhaseChangesInWindow(usize),
    /// The time column disagrees with k / rate_hz.
    #[error("t = {} but k / rate_hz = {} (is the sidecar's rate_hz right?)", Short(*.found), Short(*.expected))]
    TimeMismatch {
        /// k / rate_hz
        expected: f64,
        /// value found
        found: f64,
    },
    /// The sidecar is missing.
    #[error("{0}")]
    MissingSidecar(String),
    /// The sidecar is not valid JSON, or a field is missing or invalid.
    #[error("{0}")]
    BadSidecar(String),
    /// The CSV and the sidecar disagree.
    #[error("{0}")]
    Inconsistent(String),
    /// No bundled dataset of that name (`bundled:NAME`).
    #[error("{0}")]
    NotBundled(String),
}

/// An error in a dataset, with where it is.
///
/// ```
/// use drive_data::{DataErrorKind, parse_dataset};
/// let side = r#"{"name": "t", "rate_hz": 20, "window_len": 40, "wheel_radius": 0.1, "baseline": 0.5}"#;
/// let err = parse_dataset("d.csv", "window,phase,k\n", "d.json", side).unwrap_err();
/// assert!(matches!(err.kind, DataErrorKind::MissingColumn(_)));
/// assert!(err.to_string().starts_with("d.csv, line 1"));
/// ```
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{location}: {kind}")]
pub struct DataError {
    /// Where.
    pub location: Location,
    /// What.
    pub kind: DataErrorKind,
}

impl DataError {
    /// Builds an error.
    pub fn new(location: Location, kind: DataErrorKind) -> Self {
        DataError { location, kind }
    }
}

/// Parses a measured or commanded value: a finite number within
/// `drive_traits::limits::MAX_ABS_MEASUREMENT`.
pub(crate) fn parse_measurement(raw: &str, at: impl Fn() -> Location) -> Result<f64, DataError> {
    let v = parse_number(raw, &at)?;
    let limit = drive_traits::limits::MAX_ABS_MEASUREMENT;
    if v.abs() > limit {
        return Err(DataError::new(
            at(),
            DataErrorKind::Implausible(format!(
                "{} is beyond +-{} (not a physical value; a corrupted number?)",
                Short(v),
                Short(limit)
            )),
        ));
    }
    Ok(v)
}

/// Parses a finite number; `at` locates the value for the error.
pub(crate) fn parse_number(raw: &str, at: impl Fn() -> Location) -> Result<f64, DataError> {
    let v: f64 = raw
        .parse()
        .map_err(|_| DataError::new(at(), DataErrorKind::NotANumber(raw.to_string())))?;
    if !v.is_finite() {
        return Err(DataError::new(
            at(),
            DataErrorKind::NotFinite(raw.to_string()),
        ));
    }
    Ok(v)
}
