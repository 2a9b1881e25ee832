//! The sidecar JSON: the vehicle (with its geometry) and rates of a window dataset.

use crate::{DataError, DataErrorKind, Location};
use drive_models::DifferentialDrive;
use drive_traits::{CommandModel, RobotDescription};
use serde_json::{Map, Value};
use std::sync::Arc;

/// Parses and validates a sidecar. Returns the robot description and, when the sidecar
/// announces it, the number of windows.
///
/// Required fields: `name` (string), `rate_hz` (a positive number), `window_len` (an
/// integer of at least 2) and the vehicle: `vehicle`, an object naming its type and geometry
/// (`{"type": "differential", "wheel_radius": 0.165, "baseline": 0.55}`), or, as the DRIVE
/// datasets have it, `wheel_radius` and `baseline` (positive numbers) for a differential
/// drive. Optional: `robot` (string), `windows` (integer). Other fields are ignored.
///
/// ```
/// let side = r#"{"name": "run", "rate_hz": 20, "window_len": 40,
///                "vehicle": {"type": "differential", "wheel_radius": 0.3, "baseline": 1.2}}"#;
/// let (robot, windows) = drive_data::parse_sidecar("run.json", side).unwrap();
/// assert_eq!(robot.vehicle.axes()[1].measured_column, "enc_right");
/// assert_eq!(windows, None);
/// let legacy = r#"{"name": "run", "rate_hz": 20, "window_len": 40, "wheel_radius": 0.3, "baseline": 1.2}"#;
/// assert_eq!(drive_data::parse_sidecar("run.json", legacy).unwrap().0, robot);
/// ```
pub fn parse_sidecar(
    file: &str,
    text: &str,
) -> Result<(RobotDescription, Option<usize>), DataError> {
    let bad = |field: &str, msg: String| {
        DataError::new(Location::field(file, field), DataErrorKind::BadSidecar(msg))
    };
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
            Err(bad(field, format!("expected a positive number, found {x}")))
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
    let window_len = integer("window_len", 2)?.ok_or_else(|| {
        bad(
            "window_len",
            "missing field (samples per window, an integer >= 2)".into(),
        )
    })?;
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
    let windows = integer("windows", 0)?;
    Ok((
        RobotDescription {
            name,
            robot,
            rate_hz,
            window_len,
            vehicle,
        },
        windows,
    ))
}

fn required<'a>(obj: &'a Map<String, Value>, field: &str) -> Option<&'a Value> {
    obj.get(field).filter(|v| !v.is_null())
}

/// The sidecar JSON text for a robot description and a window count; an error when the
/// vehicle does not serialize (a plug-in vehicle with, say, a map keyed by numbers).
pub fn sidecar_json(robot: &RobotDescription, windows: usize) -> Result<String, String> {
    let vehicle = serde_json::to_value(robot.vehicle.as_ref())
        .map_err(|e| format!("the vehicle cannot be saved: {e}"))?;
    let value = serde_json::json!({
        "name": robot.name,
        "robot": robot.robot,
        "rate_hz": robot.rate_hz,
        "window_len": robot.window_len,
        "vehicle": vehicle,
        "windows": windows,
    });
    serde_json::to_string_pretty(&value)
        .map(|t| t + "\n")
        .map_err(|e| format!("the sidecar cannot be written: {e}"))
}
