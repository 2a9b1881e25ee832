//! The sidecar JSON: robot geometry and rates of a window dataset.

use crate::{DataError, DataErrorKind, Location};
use drive_traits::RobotDescription;
use serde_json::{Map, Value};

/// Parses and validates a sidecar. Returns the robot description and, when the sidecar
/// announces it, the number of windows.
///
/// Required fields: `name` (string), `rate_hz`, `wheel_radius`, `baseline` (positive
/// numbers) and `window_len` (integer >= 2). Optional: `robot` (string), `windows`
/// (integer). Other fields are kept by the writer's caller, ignored here.
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
    let wheel_radius = positive("wheel_radius")?;
    let baseline = positive("baseline")?;
    let windows = integer("windows", 0)?;
    Ok((
        RobotDescription {
            name,
            robot,
            rate_hz,
            window_len,
            wheel_radius,
            baseline,
        },
        windows,
    ))
}

fn required<'a>(obj: &'a Map<String, Value>, field: &str) -> Option<&'a Value> {
    obj.get(field).filter(|v| !v.is_null())
}

/// The sidecar JSON text for a robot description and a window count.
pub fn sidecar_json(robot: &RobotDescription, windows: usize) -> String {
    let value = serde_json::json!({
        "name": robot.name,
        "robot": robot.robot,
        "rate_hz": robot.rate_hz,
        "window_len": robot.window_len,
        "wheel_radius": robot.wheel_radius,
        "baseline": robot.baseline,
        "windows": windows,
    });
    // Serializing a `Value` built from plain fields cannot fail.
    serde_json::to_string_pretty(&value).expect("a JSON value always serializes") + "\n"
}
