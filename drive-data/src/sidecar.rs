//! The sidecar JSON: the vehicle (with its geometry) and rates of a window dataset.

use crate::{DataError, DataErrorKind, Location};
use drive_traits::limits::{self, Short};
use drive_traits::vehicles::DifferentialDrive;
use drive_traits::{CommandModel, PositionFrame, RobotDescription};
use serde_json::{Map, Value};
use std::sync::Arc;

/// What a sidecar announces about its window CSV, to check the pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Announced {
    /// The number of windows (`windows`).
    pub windows: Option<usize>,
    /// The CSV the sidecar was written with (`csv`: its rows and checksum).
    pub csv: Option<CsvDigest>,
}

/// A window CSV's data rows and FNV-1a 64-bit checksum of its bytes: written into the
/// sidecar by [`sidecar_json`], so that a CSV beside another run's sidecar (or edited after
/// it) is refused instead of read with the wrong vehicle or rates.
///
/// ```
/// let d = drive_data::CsvDigest::of("window,k\n0,0\n0,1\n");
/// assert_eq!(d.rows, 2);
/// assert_ne!(d, drive_data::CsvDigest::of("window,k\n0,0\n0,2\n"));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CsvDigest {
    /// Data rows (lines after the header).
    pub rows: usize,
    /// FNV-1a (64 bit) of the file's bytes.
    pub fnv1a64: u64,
}

/// A [`CsvDigest`] computed line by line (each line with its ending).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DigestBuilder {
    hash: u64,
    lines: usize,
}

impl Default for DigestBuilder {
    fn default() -> Self {
        DigestBuilder {
            hash: 0xcbf2_9ce4_8422_2325,
            lines: 0,
        }
    }
}

impl DigestBuilder {
    /// Adds one line (its bytes, line ending included).
    pub(crate) fn update(&mut self, line: &[u8]) {
        for b in line {
            self.hash ^= u64::from(*b);
            self.hash = self.hash.wrapping_mul(0x0100_0000_01b3);
        }
        self.lines += 1;
    }

    /// The digest: rows are the lines after the header.
    pub(crate) fn finish(self) -> CsvDigest {
        CsvDigest {
            rows: self.lines.saturating_sub(1),
            fnv1a64: self.hash,
        }
    }
}

impl CsvDigest {
    /// The digest of a CSV text.
    pub fn of(text: &str) -> CsvDigest {
        let mut d = DigestBuilder::default();
        for line in text.split_inclusive('\n') {
            d.update(line.as_bytes());
        }
        d.finish()
    }

    fn to_json(self) -> Value {
        serde_json::json!({"rows": self.rows, "fnv1a64": format!("{:016x}", self.fnv1a64)})
    }
}

/// Parses and validates a sidecar. Returns the robot description and what it announces
/// about its CSV (the number of windows, the CSV's rows and checksum).
///
/// Required fields: `name` (string), `rate_hz` (a positive number), `window_len` (an
/// integer of at least 2) and the vehicle: `vehicle`, an object naming its type and geometry
/// (`{"type": "differential", "wheel_radius": 0.165, "baseline": 0.55}`), or, as the DRIVE
/// datasets have it, `wheel_radius` and `baseline` (positive numbers) for a differential
/// drive. Optional: `robot` (string), `windows` (integer), `csv` (`{"rows": integer,
/// "fnv1a64": "16 hex digits"}`, see [`CsvDigest`]), `position_frame` (`"first-sample"`,
/// the default, or `"paper-mean5"`: see [`PositionFrame`]), `terrain` (free text, at most
/// 200 characters: the ground the data was recorded on). Other fields are ignored.
///
/// ```
/// let side = r#"{"name": "run", "rate_hz": 20, "window_len": 40,
///                "vehicle": {"type": "differential", "wheel_radius": 0.3, "baseline": 1.2}}"#;
/// let (robot, windows) = drive_data::parse_sidecar("run.json", side).unwrap();
/// assert_eq!(robot.vehicle.axes()[1].measured_column, "enc_right");
/// assert_eq!(windows, drive_data::Announced::default());
/// assert_eq!(robot.terrain, "");
/// let on_grass = side.replace("\"run\",", "\"run\", \"terrain\": \" wet grass \",");
/// assert_eq!(drive_data::parse_sidecar("run.json", &on_grass).unwrap().0.terrain, "wet grass");
/// let legacy = r#"{"name": "run", "rate_hz": 20, "window_len": 40, "wheel_radius": 0.3, "baseline": 1.2}"#;
/// assert_eq!(drive_data::parse_sidecar("run.json", legacy).unwrap().0, robot);
/// ```
pub fn parse_sidecar(file: &str, text: &str) -> Result<(RobotDescription, Announced), DataError> {
    let bad = |field: &str, msg: String| {
        DataError::new(Location::field(file, field), DataErrorKind::BadSidecar(msg))
    };
    // A byte-order mark (an editor's) is not part of the JSON.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if text.trim().is_empty() {
        return Err(DataError::new(Location::file(file), DataErrorKind::Empty));
    }
    let value: Value = serde_json::from_str(text).map_err(|e| {
        DataError::new(
            Location::line(file, e.line()),
            DataErrorKind::BadSidecar(format!("not valid JSON: {e}")),
        )
    })?;
    let obj = value.as_object().ok_or_else(|| {
        DataError::new(
            Location::file(file),
            DataErrorKind::BadSidecar("expected a JSON object".into()),
        )
    })?;
    let positive = |field: &str| -> Result<f64, DataError> {
        let v = required(obj, field)
            .ok_or_else(|| bad(field, "missing field (a positive number)".into()))?;
        let x = v
            .as_f64()
            .ok_or_else(|| bad(field, format!("expected a positive number, found {v}")))?;
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(bad(
                field,
                format!("expected a positive number, found {}", Short(x)),
            ))
        }
    };
    let integer = |field: &str, min: u64| -> Result<Option<usize>, DataError> {
        match required(obj, field) {
            None => Ok(None),
            Some(v) => match v.as_u64() {
                Some(n) if n >= min => Ok(Some(n as usize)),
                _ => Err(bad(
                    field,
                    format!("expected an integer >= {min}, found {v}"),
                )),
            },
        }
    };
    let name = match required(obj, "name") {
        Some(Value::String(s)) if !s.trim().is_empty() => s.clone(),
        Some(v) => {
            return Err(bad(
                "name",
                format!("expected a non-empty string, found {v}"),
            ))
        }
        None => return Err(bad("name", "missing field (the dataset's name)".into())),
    };
    let robot = match required(obj, "robot") {
        Some(Value::String(s)) => s.clone(),
        Some(v) => return Err(bad("robot", format!("expected a string, found {v}"))),
        None => String::new(),
    };
    let rate_hz = positive("rate_hz")?;
    if !(limits::MIN_RATE_HZ..=limits::MAX_RATE_HZ).contains(&rate_hz) {
        return Err(bad(
            "rate_hz",
            format!(
                "{} Hz is outside the supported {} to {} Hz",
                Short(rate_hz),
                limits::MIN_RATE_HZ,
                limits::MAX_RATE_HZ
            ),
        ));
    }
    let window_len = integer("window_len", 2)?.ok_or_else(|| {
        bad(
            "window_len",
            "missing field (samples per window, an integer >= 2)".into(),
        )
    })?;
    limits::at_most(
        "window_len",
        window_len as f64,
        limits::MAX_WINDOW_LEN as f64,
        "",
    )
    .map_err(|e| bad("window_len", e.to_string()))?;
    let vehicle: Arc<dyn CommandModel> = match required(obj, "vehicle") {
        Some(v) => {
            for field in ["wheel_radius", "baseline"] {
                if required(obj, field).is_some() {
                    return Err(bad(
                        field,
                        "give the geometry inside 'vehicle' only (the top-level field is the older form of a differential drive's)".into(),
                    ));
                }
            }
            let vehicle: Box<dyn CommandModel> = serde_json::from_value(v.clone())
                .map_err(|e| bad("vehicle", format!("not a known vehicle: {e}")))?;
            vehicle.check().map_err(|e| bad("vehicle", e.to_string()))?;
            Arc::from(vehicle)
        }
        None => Arc::new(DifferentialDrive::new(
            positive("wheel_radius")?,
            positive("baseline")?,
        )),
    };
    let position_frame = match required(obj, "position_frame") {
        None => PositionFrame::default(),
        Some(Value::String(name)) => {
            PositionFrame::parse(name).map_err(|e| bad("position_frame", e.to_string()))?
        }
        Some(v) => {
            return Err(bad(
                "position_frame",
                format!(
                    "expected one of {}, found {v}",
                    PositionFrame::NAMES.join(", ")
                ),
            ))
        }
    };
    for (field, text) in [("name", &name), ("robot", &robot)] {
        if limits::breaks_text(text) {
            return Err(bad(
                field,
                "holds a control character or a line separator".into(),
            ));
        }
    }
    let terrain = match required(obj, "terrain") {
        None => String::new(),
        Some(Value::String(s)) => s.trim().to_string(),
        Some(v) => return Err(bad("terrain", format!("expected a string, found {v}"))),
    };
    // Free text for labels and tables, not a document.
    limits::at_most(
        "terrain (characters)",
        terrain.chars().count() as f64,
        200.0,
        "",
    )
    .map_err(|e| bad("terrain", e.to_string()))?;
    if limits::breaks_text(&terrain) {
        return Err(bad(
            "terrain",
            "holds a control character or a line separator".into(),
        ));
    }
    let registered_robot = match required(obj, "registered_robot") {
        None => String::new(),
        Some(Value::String(s)) if drive_traits::is_part_name(s) && s.len() <= 200 => s.clone(),
        Some(v) => {
            return Err(bad(
                "registered_robot",
                format!("expected a registered robot's name (1 to 200 ASCII letters, digits, '-' and '_'), found {v}"),
            ))
        }
    };
    let windows = integer("windows", 0)?;
    let csv = match required(obj, "csv") {
        None => None,
        Some(v) => {
            let rows = v.get("rows").and_then(Value::as_u64);
            let hash = v
                .get("fnv1a64")
                .and_then(Value::as_str)
                .filter(|h| h.len() == 16)
                .and_then(|h| u64::from_str_radix(h, 16).ok());
            match (rows, hash) {
                (Some(rows), Some(fnv1a64)) => Some(CsvDigest {
                    rows: rows as usize,
                    fnv1a64,
                }),
                _ => {
                    return Err(bad(
                        "csv",
                        format!(
                        "expected {{\"rows\": an integer, \"fnv1a64\": 16 hex digits}}, found {v}"
                    ),
                    ))
                }
            }
        }
    };
    Ok((
        RobotDescription {
            name,
            robot,
            rate_hz,
            window_len,
            vehicle,
            position_frame,
            terrain,
            registered_robot,
        },
        Announced { windows, csv },
    ))
}

fn required<'a>(obj: &'a Map<String, Value>, field: &str) -> Option<&'a Value> {
    obj.get(field).filter(|v| !v.is_null())
}

/// The sidecar JSON text for a robot description, a window count and (when given) the
/// digest of the CSV it goes with; an error when the vehicle does not serialize (a plug-in
/// vehicle with, say, a map keyed by numbers).
pub fn sidecar_json(
    robot: &RobotDescription,
    windows: usize,
    csv: Option<CsvDigest>,
) -> Result<String, SidecarError> {
    let vehicle = serde_json::to_value(robot.vehicle.as_ref())
        .map_err(|e| SidecarError(format!("the vehicle cannot be saved: {e}")))?;
    let mut value = serde_json::json!({
        "name": robot.name,
        "robot": robot.robot,
        "rate_hz": robot.rate_hz,
        "window_len": robot.window_len,
        "vehicle": vehicle,
        "position_frame": robot.position_frame.as_str(),
        "windows": windows,
    });
    if !robot.terrain.is_empty() {
        value["terrain"] = robot.terrain.clone().into();
    }
    if !robot.registered_robot.is_empty() {
        value["registered_robot"] = robot.registered_robot.clone().into();
    }
    if let Some(d) = csv {
        value["csv"] = d.to_json();
    }
    serde_json::to_string_pretty(&value)
        .map(|t| t + "\n")
        .map_err(|e| SidecarError(format!("the sidecar cannot be written: {e}")))
}

/// A sidecar that cannot be written (a plug-in vehicle that does not serialize to JSON),
/// with why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SidecarError(pub String);
