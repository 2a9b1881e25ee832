//! Fitted models saved as JSON and loaded back as trait objects (typetag), with a format
//! version so that a file from a newer or unknown format is refused, never misread.
//!
//! Version 2 saves the model as its parts (`{"type": "composed", "vehicle": {...},
//! "powertrain": {...}, "slip": {...}}`, or a baseline's own fields); files of version 1
//! (the paper's four models, written before the parts) are converted when read.

use crate::calibration::Uncertainty;
use drive_traits::{MotionModel, RobotDescription, StartInfo, StartState};
use serde::{Deserialize, Serialize};
use serde_json::{json, Map, Value};
use thiserror::Error;

/// The format version this build writes.
pub const MODEL_FORMAT_VERSION: u64 = 2;

/// Largest model file read (bytes): a slip-ipem model is about 100 kB; a plug-in model that
/// stores its training data (a kNN) some megabytes. Readers cap the file at this before
/// parsing ([`drive_traits::files::read_text`]).
pub const MAX_MODEL_FILE_BYTES: u64 = 64 << 20;

/// Largest calibration scale a file may hold (a calibrated covariance over the model's
/// own, whose variances are at least 1e-12; errors beyond 1e9 m are refused on reading).
const MAX_CALIBRATION_SCALE: f64 = 1e30;

const FORMAT_NAME: &str = "drive-motion-model";

/// Why a model file could not be loaded.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ModelFileError {
    /// Not JSON, or not the expected structure.
    #[error("{file}, line {line}: not a valid model file: {message}")]
    Parse {
        /// file name
        file: String,
        /// line of the problem
        line: usize,
        /// parser message
        message: String,
    },
    /// A required field is absent.
    #[error("{file}, field '{field}': missing (is this a file written by `drive train`?)")]
    MissingField {
        /// file name
        file: String,
        /// field name
        field: &'static str,
    },
    /// A top-level field `train` never writes.
    #[error("{file}, field '{field}': not a field of a model file (one holds format, format_version, fitted_with, robot and model)")]
    UnknownField {
        /// file name
        file: String,
        /// the field found
        field: String,
    },
    /// The format version is not one this build reads.
    #[error("{file}, field 'format_version': version {found} is not supported (this build reads versions 1 to {supported}; a newer file needs a newer drive)")]
    UnsupportedVersion {
        /// file name
        file: String,
        /// version found
        found: String,
        /// version supported
        supported: u64,
    },
    /// The file says it is another format (`train` writes `"format": "drive-motion-model"`).
    #[error(
        "{file}, field 'format': {found} is not a DRIVE motion model file (\"drive-motion-model\")"
    )]
    Format {
        /// file name
        file: String,
        /// the format found, as JSON
        found: String,
    },
    /// The model itself does not parse.
    #[error("{file}, field 'model': {message}")]
    Model {
        /// file name
        file: String,
        /// parser message
        message: String,
    },
}

#[derive(Serialize)]
struct ModelFileOut<'a> {
    format: &'static str,
    format_version: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    fitted_with: Option<&'a FitSettings>,
    robot: &'a RobotDescription,
    model: &'a dyn MotionModel,
}

/// The settings a model was fitted with, kept in its model file (`fitted_with`) so that a
/// loaded model predicts and scores as the fitted one did.
///
/// ```
/// use drive_models::calibration::Uncertainty;
/// use drive_models::model_file::FitSettings;
/// use drive_traits::StartInfo;
/// let s = FitSettings::new("slip-blr", "slip-blr+fopdt", StartInfo::EncodersImuLocalization, Uncertainty::Calibrated);
/// let json = serde_json::to_value(&s).unwrap();
/// assert_eq!(json["start"], "encoders+imu+localization");
/// assert_eq!(serde_json::from_value::<FitSettings>(json).unwrap(), s);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSettings {
    /// The model name asked for (`slip-blr`, `naive`, `slip-blr+rate-limited`).
    pub model: String,
    /// Its parts (`slip-blr+fopdt`).
    pub canonical: String,
    /// What its predictions start from (`drive train --start`, `fit(start=)`): what the
    /// fit kept of the IMU and the localization, and what a score predicts from.
    #[serde(with = "start_name")]
    pub start: StartInfo,
    /// How its pose covariance was made (`--uncertainty`).
    #[serde(with = "uncertainty_name")]
    pub uncertainty: Uncertainty,
    /// The share of the dataset's intervals it was fitted on (`--split`); `None`: all of
    /// them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split: Option<f64>,
    /// The training windows.
    #[serde(default)]
    pub training_windows: usize,
    /// The commands the training windows held, per input axis (`None` in a file written
    /// before it was kept): a prediction for commands beyond them is noted, not trusted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub commanded: Option<CommandRange>,
}

/// The least and largest command of each input axis over a model's training windows.
///
/// ```
/// use drive_models::model_file::CommandRange;
/// let range = CommandRange { min: vec![-1.0, -2.0], max: vec![1.0, 2.0] };
/// assert_eq!(range.beyond(&[0.5, 2.05]), None); // within 5% of the span
/// assert_eq!(range.beyond(&[0.5, 3.0]), Some((1, 3.0)));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandRange {
    /// Per axis, the least command.
    pub min: Vec<f64>,
    /// Per axis, the largest command.
    pub max: Vec<f64>,
}

impl CommandRange {
    /// The range of the commands of `windows`; `None` without a command or with one that
    /// is not finite.
    pub fn of(windows: &drive_traits::WindowSet<'_>) -> Option<Self> {
        let axes = windows.robot.vehicle.input_dim();
        let mut range = CommandRange {
            min: vec![f64::INFINITY; axes],
            max: vec![f64::NEG_INFINITY; axes],
        };
        for u in windows.windows.iter().flat_map(|w| &w.command) {
            for i in 0..axes {
                range.min[i] = range.min[i].min(u[i]);
                range.max[i] = range.max[i].max(u[i]);
            }
        }
        range
            .min
            .iter()
            .chain(&range.max)
            .all(|v| v.is_finite())
            .then_some(range)
    }

    /// The first axis and value of `command` beyond the range by more than 5% of the axis's
    /// span (and 1e-9), if any.
    pub fn beyond(&self, command: &[f64]) -> Option<(usize, f64)> {
        command
            .iter()
            .zip(self.min.iter().zip(&self.max))
            .enumerate()
            .find(|(_, (v, (lo, hi)))| {
                let slack = 0.05 * (*hi - *lo) + 1e-9;
                **v < *lo - slack || **v > *hi + slack
            })
            .map(|(i, (v, _))| (i, *v))
    }

    /// `Err` unless one finite `min <= max` per axis of `axes`.
    fn check(&self, axes: usize) -> Result<(), String> {
        if self.min.len() != axes || self.max.len() != axes {
            return Err(format!(
                "fitted_with.commanded has {} and {} values for a vehicle of {axes} input axes",
                self.min.len(),
                self.max.len()
            ));
        }
        if !self
            .min
            .iter()
            .zip(&self.max)
            .all(|(lo, hi)| lo.is_finite() && hi.is_finite() && lo <= hi)
        {
            return Err(
                "fitted_with.commanded is not a range (finite, min <= max) per axis".into(),
            );
        }
        Ok(())
    }
}

impl FitSettings {
    /// The settings of a model fitted as `model` (parts `canonical`) for `start`, with
    /// `uncertainty`, on all of a dataset (no split) of unknown size.
    pub fn new(model: &str, canonical: &str, start: StartInfo, uncertainty: Uncertainty) -> Self {
        FitSettings {
            model: model.into(),
            canonical: canonical.into(),
            start,
            uncertainty,
            split: None,
            training_windows: 0,
            commanded: None,
        }
    }

    /// The settings of `spec`.
    pub fn of(spec: &crate::ModelSpec) -> Self {
        FitSettings::new(&spec.name, &spec.canonical(), spec.start, spec.uncertainty)
    }
}

/// A start's name in a file (`encoders+imu`), as `--start` spells it.
mod start_name {
    use drive_traits::StartInfo;
    use serde::{Deserialize, Deserializer, Serializer};
    pub fn serialize<S: Serializer>(v: &StartInfo, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(v.as_str())
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<StartInfo, D::Error> {
        let name = String::deserialize(d)?;
        StartInfo::parse(&name).map_err(serde::de::Error::custom)
    }
}

/// An uncertainty's name in a file (`calibrated`), as `--uncertainty` spells it.
mod uncertainty_name {
    use crate::calibration::Uncertainty;
    use serde::{Deserialize, Deserializer, Serializer};
    pub fn serialize<S: Serializer>(v: &Uncertainty, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(v.as_str())
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Uncertainty, D::Error> {
        let name = String::deserialize(d)?;
        Uncertainty::parse(&name).map_err(serde::de::Error::custom)
    }
}

/// A model file read: the model, the robot it was fitted for and the settings it was
/// fitted with (`None` in a file written before they were kept, or by a program that did
/// not give them).
#[derive(Debug)]
pub struct ModelFile {
    /// The fitted model.
    pub model: Box<dyn MotionModel>,
    /// The robot (rate, vehicle) it was fitted for.
    pub robot: RobotDescription,
    /// The settings it was fitted with.
    pub fitted_with: Option<FitSettings>,
}

/// The JSON text of a fitted model file; an error when a part does not serialize (a
/// plug-in's part with, say, a map keyed by numbers).
pub fn model_to_json(
    model: &dyn MotionModel,
    robot: &RobotDescription,
) -> Result<String, serde_json::Error> {
    model_file_to_json(model, robot, None)
}

/// The JSON text of a fitted model file that keeps the settings the model was fitted with
/// (`fitted_with`, read back by [`read_model_file`]).
pub fn model_file_to_json(
    model: &dyn MotionModel,
    robot: &RobotDescription,
    fitted_with: Option<&FitSettings>,
) -> Result<String, serde_json::Error> {
    // A model that carries an uncertainty and could not be calibrated (too few training
    // intervals to hold out) has the model's own covariance, the paper's: its file says so.
    let mut settings = fitted_with.cloned();
    if let Some(f) = settings.as_mut() {
        if f.uncertainty != crate::calibration::Uncertainty::Paper
            && carries_uncertainty(model)
            && calibration_layers(&serde_json::to_value(model)?) == 0
        {
            f.uncertainty = crate::calibration::Uncertainty::Paper;
        }
    }
    let file = ModelFileOut {
        format: FORMAT_NAME,
        format_version: MODEL_FORMAT_VERSION,
        fitted_with: settings.as_ref(),
        robot,
        model,
    };
    Ok(serde_json::to_string_pretty(&file)? + "\n")
}

/// Whether `model` predicts a pose covariance (the naive and powertrain models do not).
fn carries_uncertainty(model: &dyn MotionModel) -> bool {
    let start = drive_traits::StartState::at_rest(drive_traits::Pose::zeros());
    let (mut poses, mut covariances) = (Vec::new(), Vec::new());
    model
        .predict_with_covariance_into(
            &start,
            &[drive_traits::Input::zeros(); 2],
            &mut poses,
            &mut covariances,
        )
        .is_ok()
}

/// How many calibration layers a saved model holds, one inside another: the most on any path
/// from the file's model to a model it holds (a wrapper's `model`, a blend's `models`).
fn calibration_layers(model: &Value) -> usize {
    let calibrated = usize::from(model.get("type").and_then(Value::as_str) == Some("calibrated"));
    let inner = model.get("model").map_or(0, calibration_layers);
    let members = model
        .get("models")
        .and_then(Value::as_array)
        .map_or(0, |ms| ms.iter().map(calibration_layers).max().unwrap_or(0));
    calibrated + inner.max(members)
}

/// A parse error inside the file's `root` field (whose JSON is `value`), with the path to
/// the value it concerns (`model.model.powertrain.dt: invalid type: ...`). Inside a plug-in
/// part (typetag's internally tagged objects, read through a buffer) serde loses the path:
/// the value the error names (a string, number, boolean or null) is then looked up in `value`,
/// and its path given when exactly one leaf holds it.
fn at_path(root: &str, value: &Value, e: &serde_path_to_error::Error<serde_json::Error>) -> String {
    let path = e.path().to_string();
    let message = e.inner().to_string();
    let path = if path == "." {
        located(value, &message).unwrap_or_default()
    } else {
        path
    };
    if path.is_empty() || path == "." {
        format!("{root}: {message}")
    } else {
        format!("{root}.{path}: {message}")
    }
}

/// The path inside `value` of the one leaf equal to the value a serde `message` names
/// (`invalid type: string "fast", expected f64`), if exactly one leaf is.
fn located(value: &Value, message: &str) -> Option<String> {
    let between = |start: &str, end: &str| {
        let rest = message.split_once(start)?.1;
        Some(rest.split_once(end)?.0.to_string())
    };
    let target = if let Some(text) = between("string \"", "\"") {
        Value::String(text)
    } else if let Some(number) =
        between("integer `", "`").or_else(|| between("floating point `", "`"))
    {
        serde_json::from_str::<Value>(&number).ok()?
    } else if let Some(flag) = between("boolean `", "`") {
        Value::Bool(flag == "true")
    } else if message.contains("invalid type: null") || message.contains("invalid type: unit value")
    {
        Value::Null
    } else {
        return None;
    };
    fn walk(v: &Value, path: String, target: &Value, found: &mut Vec<String>) {
        match v {
            Value::Object(map) => {
                for (k, x) in map {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    walk(x, p, target, found);
                }
            }
            Value::Array(items) => {
                for (i, x) in items.iter().enumerate() {
                    walk(x, format!("{path}[{i}]"), target, found);
                }
            }
            // Numbers compared as numbers (1 and 1.0 alike).
            Value::Number(a) => {
                if let Value::Number(b) = target {
                    if a.as_f64() == b.as_f64() {
                        found.push(path);
                    }
                }
            }
            leaf => {
                if leaf == target {
                    found.push(path);
                }
            }
        }
    }
    let mut found = Vec::new();
    walk(value, String::new(), &target, &mut found);
    (found.len() == 1).then(|| found.remove(0))
}

/// Loads a model file's text (`file` names it in errors): the model and the robot it was
/// fitted for (see [`read_model_file`] for the settings too).
pub fn model_from_json(
    file: &str,
    text: &str,
) -> Result<(Box<dyn MotionModel>, RobotDescription), ModelFileError> {
    read_model_file(file, text).map(|m| (m.model, m.robot))
}

/// Loads a model file's text (`file` names it in errors): the model, the robot it was
/// fitted for and the settings it was fitted with.
pub fn read_model_file(file: &str, text: &str) -> Result<ModelFile, ModelFileError> {
    // A byte-order mark (an editor's) is not part of the JSON.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let parse_error = |e: serde_json::Error| ModelFileError::Parse {
        file: file.into(),
        line: e.line(),
        message: e.to_string(),
    };
    // A key given twice would be read as its last value, silently: refused.
    serde_json::from_str::<NoDuplicateKeys>(text).map_err(parse_error)?;
    let mut value: Value = serde_json::from_str(text).map_err(parse_error)?;
    let obj = value.as_object_mut().ok_or_else(|| ModelFileError::Parse {
        file: file.into(),
        line: 1,
        message: "expected a JSON object".into(),
    })?;
    let version = obj
        .get("format_version")
        .ok_or(ModelFileError::MissingField {
            file: file.into(),
            field: "format_version",
        })?;
    let version = match version.as_u64() {
        Some(v @ (1 | MODEL_FORMAT_VERSION)) => v,
        _ => {
            return Err(ModelFileError::UnsupportedVersion {
                file: file.into(),
                found: version.to_string(),
                supported: MODEL_FORMAT_VERSION,
            })
        }
    };
    // What `train` writes names its format; a version 1 file may predate the field.
    match obj.get("format") {
        Some(Value::String(f)) if f == FORMAT_NAME => {}
        None if version == 1 => {}
        Some(found) => {
            return Err(ModelFileError::Format {
                file: file.into(),
                found: found.to_string(),
            })
        }
        None => {
            return Err(ModelFileError::MissingField {
                file: file.into(),
                field: "format",
            })
        }
    }
    if version == 1 {
        upgrade_v1(obj).map_err(|message| ModelFileError::Model {
            file: file.into(),
            message: format!("a version 1 file that cannot be read: {message}"),
        })?;
    }
    let fitted_with = match obj.remove("fitted_with") {
        Some(v) => Some(
            serde_path_to_error::deserialize::<_, FitSettings>(&v).map_err(|e| {
                ModelFileError::Model {
                    file: file.into(),
                    message: at_path("fitted_with", &v, &e),
                }
            })?,
        ),
        None => None,
    };
    if let Some(split) = fitted_with.as_ref().and_then(|f| f.split) {
        if !(split > 0.0 && split <= 1.0) {
            return Err(ModelFileError::Model {
                file: file.into(),
                message: format!(
                    "fitted_with.split = {} is not a share of the intervals in (0, 1]",
                    drive_traits::limits::Short(split)
                ),
            });
        }
    }
    let robot = obj.remove("robot").ok_or(ModelFileError::MissingField {
        file: file.into(),
        field: "robot",
    })?;
    let robot: RobotDescription =
        serde_path_to_error::deserialize(&robot).map_err(|e| ModelFileError::Model {
            file: file.into(),
            message: at_path("robot", &robot, &e),
        })?;
    // The rate's range is the sidecar's (a rate of 0 made the command period infinite,
    // which no step compared unequal to).
    let (lo, hi) = (
        drive_traits::limits::MIN_RATE_HZ,
        drive_traits::limits::MAX_RATE_HZ,
    );
    if !(lo..=hi).contains(&robot.rate_hz) {
        return Err(ModelFileError::Model {
            file: file.into(),
            message: format!(
                "robot.rate_hz = {} Hz is outside the supported {lo} to {hi} Hz",
                drive_traits::limits::Short(robot.rate_hz)
            ),
        });
    }
    // The robot's text as its sidecar holds it (train copies it from one): no control
    // character, a registered robot by its part name.
    if robot.name.trim().is_empty() {
        return Err(ModelFileError::Model {
            file: file.into(),
            message: "robot.name is empty (a sidecar names its dataset)".into(),
        });
    }
    for (field, text) in [
        ("robot.name", &robot.name),
        ("robot.robot", &robot.robot),
        ("robot.terrain", &robot.terrain),
    ] {
        if drive_traits::limits::breaks_text(text) {
            return Err(ModelFileError::Model {
                file: file.into(),
                message: format!(
                    "{field} holds a control character or a line separator (a sidecar cannot)"
                ),
            });
        }
    }
    let registered = &robot.registered_robot;
    let named =
        registered.is_empty() || drive_traits::is_part_name(registered) && registered.len() <= 200;
    if !named {
        return Err(ModelFileError::Model {
            file: file.into(),
            message: "robot.registered_robot is not a registered robot's name (1 to 200 ASCII letters, digits, '-' and '_')".into(),
        });
    }
    // A built-in robot's name for a robot of another vehicle type (a Husky named on a
    // mecanum base's model): a fit writes the name of the robot the data was recorded with.
    if let Some(entry) = drive_traits::robot::builtin_robots().find(registered) {
        let (theirs, ours) = (
            drive_traits::vehicle_tag(entry.part().vehicle.as_ref()),
            drive_traits::vehicle_tag(robot.vehicle.as_ref()),
        );
        if theirs != ours {
            return Err(ModelFileError::Model {
                file: file.into(),
                message: format!(
                    "robot.registered_robot is '{registered}', a robot of vehicle type '{}', and the model's vehicle is of type '{}'",
                    theirs.unwrap_or_default(),
                    ours.unwrap_or_default()
                ),
            });
        }
    }
    let model = obj.remove("model").ok_or(ModelFileError::MissingField {
        file: file.into(),
        field: "model",
    })?;
    // What train writes and nothing else: a key it never writes is a file of something else
    // (or an edit that means something to its author and nothing to this reader).
    if let Some(key) = obj
        .keys()
        .find(|k| !matches!(k.as_str(), "format" | "format_version"))
    {
        return Err(ModelFileError::UnknownField {
            file: file.into(),
            field: key.clone(),
        });
    }
    // A model that carries its vehicle must carry the robot's: the command columns come
    // from the one, the physics from the other. A wrapper (the calibrated model) holds the
    // model it wraps under "model".
    let mut inner = &model;
    while inner.get("vehicle").is_none() {
        match inner.get("model") {
            Some(m) => inner = m,
            None => break,
        }
    }
    // A fit writes at most one calibration layer: one inside another would scale the
    // covariance twice.
    let layers = calibration_layers(&model);
    if layers > 1 {
        return Err(ModelFileError::Model {
            file: file.into(),
            message: format!(
                "{layers} calibration layers, one inside another: a fit writes at most one (the covariance would be scaled {layers} times)"
            ),
        });
    }
    if layers == 1
        && fitted_with
            .as_ref()
            .is_some_and(|f| f.uncertainty == crate::calibration::Uncertainty::Paper)
    {
        return Err(ModelFileError::Model {
            file: file.into(),
            message: "fitted_with.uncertainty is \"paper\" (no calibration) but the model is calibrated: a fit writes the one with the other".into(),
        });
    }
    if let Some(calibration) = model.get("calibration") {
        let trained = fitted_with.as_ref().map_or(0, |f| f.training_windows);
        check_calibration(calibration, robot.window_len, trained).map_err(|message| {
            ModelFileError::Model {
                file: file.into(),
                message,
            }
        })?;
    }
    if let Some(vehicle) = inner.get("vehicle") {
        // Both as written by the vehicle's own type (so that 1 and 1.0 are the same).
        let saved = |v: &dyn drive_traits::CommandModel| serde_json::to_value(v).ok();
        let theirs = serde_json::from_value::<Box<dyn drive_traits::CommandModel>>(vehicle.clone())
            .ok()
            .and_then(|v| saved(v.as_ref()));
        let robots = saved(robot.vehicle.as_ref());
        if theirs.is_some() && theirs != robots {
            return Err(ModelFileError::Model {
                file: file.into(),
                message: format!(
                    "the model's vehicle {vehicle} is not the robot's {}",
                    robots.unwrap_or_default()
                ),
            });
        }
    }
    // What the model is built of (its learner's and powertrain's types), for its names.
    let tag = |v: Option<&Value>| {
        v.and_then(|v| v.get("type"))
            .and_then(Value::as_str)
            .map(String::from)
    };
    let structure = Structure {
        kind: tag(Some(inner)),
        slip: tag(inner.get("slip")),
        slip_within: inner.get("slip").map(types_within).unwrap_or_default(),
        powertrain: tag(inner.get("powertrain")),
    };
    let model: Box<dyn MotionModel> =
        serde_path_to_error::deserialize(&model).map_err(|e| ModelFileError::Model {
            file: file.into(),
            message: at_path("model", &model, &e),
        })?;
    // A model that carries an uncertainty is calibrated unless fitted with the paper's: a
    // file whose calibration layer was taken away would give covariances a fit never gave.
    if layers == 0
        && fitted_with
            .as_ref()
            .is_some_and(|f| f.uncertainty != crate::calibration::Uncertainty::Paper)
        && carries_uncertainty(model.as_ref())
    {
        return Err(ModelFileError::Model {
            file: file.into(),
            message: format!(
                "fitted_with.uncertainty is \"{}\" but the model has no calibration layer: a fit calibrates every model that carries an uncertainty (and writes \"paper\" where it could not)",
                fitted_with.as_ref().map_or("", |f| f.uncertainty.as_str())
            ),
        });
    }
    check_names(&model.name(), &structure, fitted_with.as_ref()).map_err(|message| {
        ModelFileError::Model {
            file: file.into(),
            message,
        }
    })?;
    model.check().map_err(|e| ModelFileError::Model {
        file: file.into(),
        message: e.to_string(),
    })?;
    let (dt, period) = (model.dt(), 1.0 / robot.rate_hz);
    if !(robot.rate_hz.is_finite() && (dt - period).abs() <= 1e-9 * dt.max(period)) {
        return Err(ModelFileError::Model {
            file: file.into(),
            message: format!(
                "the model's step {} s is not the robot's command period 1 / {} Hz",
                drive_traits::limits::Short(dt),
                drive_traits::limits::Short(robot.rate_hz)
            ),
        });
    }
    if let Some(range) = fitted_with.as_ref().and_then(|f| f.commanded.as_ref()) {
        range
            .check(robot.vehicle.input_dim())
            .map_err(|message| ModelFileError::Model {
                file: file.into(),
                message,
            })?;
        let invalid = |message| ModelFileError::Model {
            file: file.into(),
            message,
        };
        if let Some(powertrain) = model.powertrain() {
            reaches_its_commands(powertrain, range).map_err(invalid)?;
        }
        moves_with_its_commands(model.as_ref(), &robot, range).map_err(invalid)?;
    }
    Ok(ModelFile {
        model,
        robot,
        fitted_with,
    })
}

/// The least share of the commands a model was fitted on (`fitted_with.commanded`) that its
/// powertrain must reach, held, on some axis: a fit's powertrain follows the wheels it was
/// fitted on, which reach most of what they were commanded (a Warthog on gravel 0.6 of its
/// forward command); one that reaches a twentieth of it on every axis is not one a fit
/// writes (limits of 1e-9 rad/s against commands of 16 rad/s: a robot that never moves).
const MIN_REACHED_SHARE: f64 = 0.05;

/// `Err` naming what `powertrain` reaches when, held for 5 s at either end of `range` from
/// rest, it reaches less than [`MIN_REACHED_SHARE`] of the command on an axis commanded (a
/// fit's limits are the wheels' extremes: one wheel held to a twentieth of its commands is
/// a side that never turns, which the data checks refuse in the data).
fn reaches_its_commands(
    powertrain: &dyn drive_traits::Powertrain,
    range: &CommandRange,
) -> Result<(), String> {
    let steps = powertrain
        .step()
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(100, |s| ((5.0 / s).ceil() as usize).clamp(1, 10_000));
    for end in [&range.max, &range.min] {
        let mut command = drive_traits::Input::zeros();
        for (i, v) in end.iter().enumerate().take(drive_traits::MAX_INPUTS) {
            command[i] = *v;
        }
        let reached = powertrain.predict(&drive_traits::Input::zeros(), &vec![command; steps]);
        let Some(last) = reached.last() else {
            continue;
        };
        // The first axis commanded whose share is under the least.
        let short = end
            .iter()
            .enumerate()
            .filter(|(_, c)| c.abs() > 0.0)
            .map(|(i, c)| (i, last[i] / c))
            .find(|(_, s)| s.is_nan() || s.abs() < MIN_REACHED_SHARE);
        if let Some((axis, _)) = short {
            let show = |v: &[f64]| {
                v.iter()
                    .map(|x| drive_traits::limits::Short(*x).to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(format!(
                "its powertrain, held at the commands it was fitted on ([{}], fitted_with.commanded) for 5 s, reaches [{}]: less than {} of them on axis {axis} (its limits or gains are not what a fit writes)",
                show(end),
                show(&last.iter().take(end.len()).copied().collect::<Vec<_>>()),
                MIN_REACHED_SHARE
            ));
        }
    }
    Ok(())
}

/// The least share of what a corner of the commands it was fitted on asks (eq. 4, over a
/// window from rest) that a model must travel (or turn, for a corner that mostly asks a
/// turn) at some corner: a simulated Warthog on ice, its powertrain starting from rest,
/// travels 0.044 of it (its slip-ipem fit); a slip edited to 0.999 travels a thousandth.
const MIN_MOVED_SHARE: f64 = 0.01;

/// How many times what the commands ask (eq. 4) a model may travel or turn, from rest over a
/// window at a corner of the commands it was fitted on, before its file is refused: no
/// ground drives a robot five times faster than its wheels (a fit's slip keeps a share of
/// the commanded motion; a slip edited to 1000 slid a Husky 20 m sideways in 4 s).
const MAX_MOTION_FACTOR: f64 = 5.0;

/// `Err` when `model`, from rest, held for one of `robot`'s windows at a corner of `range`
/// (the commands it was fitted on: every combination of each axis's least and largest)
/// that asks of the vehicle (eq. 4, `robot`'s command model) at least a centimetre or a
/// hundredth of a radian:
/// - travels (or turns, for a command that mostly asks a turn, a radian against a metre;
///   both summed step by step) less than [`MIN_MOVED_SHARE`] of what it asks at every
///   corner judged so: a model whose slip takes every motion (slip-BLR's forward slip edited to 1, acc-BLR's
///   accelerations to 0, a yaw slip of 1 that never turns) predicts a robot that never
///   moves, which no fit writes (a Warthog on gravel keeps about half of its commanded
///   speed, a simulated car on ice a seventh);
/// - travels or turns more than [`MAX_MOTION_FACTOR`] times the most any corner asks;
/// - ends on the other side of its start from where a nearly straight command (under a
///   radian of turn asked) takes the vehicle, where it moves at all, or, for a command that mostly asks a turn
///   (half a radian or more, more radians than metres), turns under [`MIN_TURN_SHARE`] of
///   it the way asked: a forward slip of 2 drove a Husky backwards, a yaw slip of 1 never
///   turned it (an arc's turn is not judged: a fit's powertrains may answer its two sides
///   unevenly from rest).
fn moves_with_its_commands(
    model: &dyn MotionModel,
    robot: &RobotDescription,
    range: &CommandRange,
) -> Result<(), String> {
    let steps = robot.window_len.clamp(2, 10_000);
    let seconds = (steps - 1) as f64 * model.dt();
    let axes = range
        .min
        .len()
        .min(range.max.len())
        .min(drive_traits::MAX_INPUTS);
    let corners: Vec<drive_traits::Input> = (0..1usize << axes)
        .map(|corner| {
            let mut command = drive_traits::Input::zeros();
            for i in 0..axes {
                command[i] = if corner >> i & 1 == 1 {
                    range.max[i]
                } else {
                    range.min[i]
                };
            }
            command
        })
        .collect();
    // What each corner asks over the window (eq. 4 from rest, the ideal unicycle): its
    // path, its turn and where it ends.
    let ideal: Vec<(f64, f64, [f64; 2])> = corners
        .iter()
        .map(|c| {
            let v = robot.vehicle.body_velocity(c);
            let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
            let dt = model.dt();
            for _ in 1..steps {
                x += (v.x * yaw.cos() - v.y * yaw.sin()) * dt;
                y += (v.x * yaw.sin() + v.y * yaw.cos()) * dt;
                yaw += v.z * dt;
            }
            (v.x.hypot(v.y) * seconds, v.z * seconds, [x, y])
        })
        .collect();
    let most_move = ideal.iter().map(|i| i.0).fold(0.0, f64::max);
    let most_turn = ideal.iter().map(|i| i.1.abs()).fold(0.0, f64::max);
    let show = |v: &drive_traits::Input| {
        (0..axes)
            .map(|i| drive_traits::limits::Short(v[i]).to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    // Of the corners judged by their travel, and of those judged by their turn: whether
    // some follows what it asks, and the first that does not.
    let mut follows_somewhere = [false; 2];
    let mut hardly: [Option<String>; 2] = [None, None];
    for (command, &(asked_move, asked_turn, asked_end)) in corners.iter().zip(&ideal) {
        if !(asked_move >= 0.01 || asked_turn.abs() >= 0.01) {
            // Nothing asked at this corner: it tells nothing.
            continue;
        }
        let start = StartState::at_rest(drive_traits::Pose::zeros());
        let poses = model.predict(&start, &vec![*command; steps]);
        // The path travelled and the turn, summed step by step (a model that spins in
        // place still travels: a yaw edited to 1e6 is no robot that stands still).
        let (moved, turned) = poses.windows(2).fold((0.0, 0.0), |(m, t), p| {
            (
                m + (p[1].x - p[0].x).hypot(p[1].y - p[0].y),
                t + (p[1].z - p[0].z).abs(),
            )
        });
        let (Some(first), Some(last)) = (poses.first(), poses.last()) else {
            continue;
        };
        let net_turn = drive_traits::net_turn(&poses);
        // A prediction that is not finite is refused where it is made (predict, score).
        let by_turn = usize::from(asked_turn.abs() > asked_move);
        if !(moved.is_finite() && turned.is_finite() && net_turn.is_finite()) {
            follows_somewhere[by_turn] = true;
            continue;
        }
        let end = [last.x - first.x, last.y - first.y];
        let said = |fault: &str| {
            format!(
                "the model, from rest at the commands it was fitted on (fitted_with.commanded), {fault}: at [{}] it travels {} m, ends at ({}, {}) m and turns {} rad in {} s, where the commands ask {} m, to ({}, {}) m, and {} rad (its parameters are not what a fit writes)",
                show(command),
                drive_traits::limits::Short(moved),
                drive_traits::limits::Short(end[0]),
                drive_traits::limits::Short(end[1]),
                drive_traits::limits::Short(net_turn),
                drive_traits::limits::Short(seconds),
                drive_traits::limits::Short(asked_move),
                drive_traits::limits::Short(asked_end[0]),
                drive_traits::limits::Short(asked_end[1]),
                drive_traits::limits::Short(asked_turn)
            )
        };
        let follows = if by_turn == 0 {
            moved >= MIN_MOVED_SHARE * asked_move
        } else {
            turned >= MIN_MOVED_SHARE * asked_turn.abs()
        };
        follows_somewhere[by_turn] |= follows;
        if !follows && hardly[by_turn].is_none() {
            hardly[by_turn] = Some(said(&format!(
                "predicts a robot that hardly moves: less than {MIN_MOVED_SHARE} of what the commands ask at every corner of them that mostly asks {}",
                if by_turn == 0 { "travel" } else { "a turn" }
            )));
        }
        let fault = if moved > MAX_MOTION_FACTOR * most_move.max(0.01)
            || turned > MAX_MOTION_FACTOR * most_turn.max(0.01)
        {
            Some(format!(
                "moves more than {MAX_MOTION_FACTOR} times the most the commands ask"
            ))
        } else if follows
            && asked_turn.abs() < 1.0
            && asked_move >= 0.01
            && end[0] * asked_end[0] + end[1] * asked_end[1] < 0.0
        {
            Some("ends on the other side of its start from where the commands take it".into())
        } else if asked_turn.abs() >= 0.5_f64.max(asked_move)
            && net_turn * asked_turn.signum() < MIN_TURN_SHARE * asked_turn.abs()
        {
            Some(format!(
                "hardly turns (under {MIN_TURN_SHARE} of the turn asked), or turns the other way"
            ))
        } else {
            None
        };
        if let Some(fault) = fault {
            return Err(said(&fault));
        }
    }
    for (hardly, follows) in hardly.into_iter().zip(follows_somewhere) {
        if let Some(hardly) = hardly.filter(|_| !follows) {
            return Err(hardly);
        }
    }
    Ok(())
}

/// The least share of the turn a corner of the commands mostly asks (half a radian or more
/// over a window, from rest) that a model must turn, the way asked: a skid-steer spinning in place
/// from rest turns little of what its wheels ask (a Husky's slip-BLR 0.049 of 17 rad), a
/// yaw slip edited to 1 none.
const MIN_TURN_SHARE: f64 = 0.01;

/// What a model file's model is built of: its type (`composed`, `acc-blr`, ...) and its
/// slip model's and powertrain's types.
struct Structure {
    kind: Option<String>,
    slip: Option<String>,
    /// Every type inside the slip model: a wrapper's (an adapted model's `corrected-slip`)
    /// and the model it wraps.
    slip_within: Vec<String>,
    powertrain: Option<String>,
}

/// Every `type` tag in `v` and the objects inside it.
fn types_within(v: &Value) -> Vec<String> {
    let mut out = Vec::new();
    let mut pending = vec![v];
    while let Some(v) = pending.pop() {
        match v {
            Value::Object(o) => {
                if let Some(t) = o.get("type").and_then(Value::as_str) {
                    out.push(t.to_string());
                }
                pending.extend(o.values());
            }
            Value::Array(a) => pending.extend(a),
            _ => {}
        }
    }
    out
}

/// A model file's names against what its model is built of: the model's label is
/// `fitted_with.canonical` (when the file has one); `fitted_with.model`, where it is a
/// built-in name, stands for that canonical name (`slip-blr` for `slip-blr+fopdt`); a label
/// that is a built-in model's name is a model of that model's parts (a slip-BLR fit
/// relabelled `acc-blr+commanded` is refused). Names of a researcher's parts are checked
/// against `fitted_with` only: the loader does not know what they are built of.
fn check_names(
    label: &str,
    structure: &Structure,
    fitted_with: Option<&FitSettings>,
) -> Result<(), String> {
    let (p, s, b, a) = (
        crate::registry::builtin_powertrains(),
        crate::registry::builtin_slip_learners(),
        crate::registry::builtin_baselines(),
        crate::registry::builtin_aliases(),
    );
    let models = crate::registry::Models {
        powertrains: &p,
        slip_learners: &s,
        baselines: &b,
        aliases: &a,
    };
    if let Some(f) = fitted_with {
        // A model's name as `drive train --model` takes it: registered part names joined
        // by '+' (a researcher's included); nothing else (control characters, spaces).
        for (field, name) in [("model", &f.model), ("canonical", &f.canonical)] {
            if !name.split('+').all(drive_traits::is_part_name) || name.len() > 400 {
                return Err(format!(
                    "fitted_with.{field} {name:?} is not a model name (registered part names joined by '+')"
                ));
            }
        }
        if f.canonical != label {
            return Err(format!(
                "the model is labelled '{label}' and fitted_with.canonical says '{}': a fit writes the one it is",
                f.canonical
            ));
        }
        if let Ok(spec) = models.resolve(&f.model) {
            if spec.canonical() != f.canonical {
                return Err(format!(
                    "fitted_with.model '{}' is the model '{}', not '{}' (fitted_with.canonical)",
                    f.model,
                    spec.canonical(),
                    f.canonical
                ));
            }
        }
    }
    let Ok(spec) = models.resolve(label) else {
        return Ok(());
    };
    if spec.canonical() != label {
        // A built-in alias as a label: no fit writes one (labels are canonical names).
        return Err(format!(
            "the model is labelled '{label}', a name of '{}': a fit labels a model by its canonical name",
            spec.canonical()
        ));
    }
    let composed = spec.kind == crate::registry::LearnerKind::Slip;
    let built = if composed {
        // An adapted model keeps its prior's label, its slip model wrapped.
        structure.kind.as_deref() == Some("composed")
            && structure.slip_within.contains(&spec.learner)
            && structure.powertrain.as_deref() == spec.powertrain.as_deref()
    } else {
        structure.kind.as_deref() == Some(spec.learner.as_str())
            && structure.powertrain.as_deref() == spec.powertrain.as_deref()
    };
    if built {
        Ok(())
    } else {
        let part = |v: &Option<String>| v.clone().unwrap_or_else(|| "none".into());
        Err(format!(
            "the model is labelled '{label}' but is built of a {} model (slip {}, powertrain {}): the label is another model's",
            part(&structure.kind),
            part(&structure.slip),
            part(&structure.powertrain)
        ))
    }
}

/// The calibration of a calibrated model file against its robot and fit: as many per-step
/// scales as the robot's window has samples (what a fit writes), each within
/// [1 / MAX_CALIBRATION_SCALE, MAX_CALIBRATION_SCALE], from as many windows as the fit's
/// training windows (when the file says).
fn check_calibration(
    calibration: &Value,
    window_len: usize,
    training_windows: usize,
) -> Result<(), String> {
    // The windows its scales come from: every training window is held out once
    // (cross-conformal), so a fit writes as many as it was trained on.
    if let Some(windows) = calibration.get("windows").and_then(Value::as_u64) {
        if windows == 0 {
            return Err(
                "calibration windows is 0: a calibration's scales come from held-out windows"
                    .into(),
            );
        }
        if training_windows > 0 && windows != training_windows as u64 {
            return Err(format!(
                "calibration windows is {windows} but fitted_with.training_windows {training_windows}: a fit calibrates on the windows it was trained on"
            ));
        }
    }
    for key in ["position_scale", "yaw_scale"] {
        let Some(scales) = calibration.get(key).and_then(Value::as_array) else {
            continue;
        };
        if scales.len() != window_len {
            return Err(format!(
                "calibration {key}: {} scales for a robot whose windows have {window_len} samples",
                scales.len()
            ));
        }
        if let Some(v) = scales.iter().find(|v| {
            !v.as_f64()
                .is_some_and(|v| (1.0 / MAX_CALIBRATION_SCALE..=MAX_CALIBRATION_SCALE).contains(&v))
        }) {
            return Err(format!(
                "calibration {key}: the scale {v} is not a number in [1e-30, 1e30]"
            ));
        }
    }
    Ok(())
}

/// Any JSON value, refused where an object names a key twice (`serde_json::Value` keeps
/// the last silently).
struct NoDuplicateKeys;

impl<'de> serde::Deserialize<'de> for NoDuplicateKeys {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NoDuplicateKeysVisitor)
    }
}

struct NoDuplicateKeysVisitor;

impl<'de> serde::de::Visitor<'de> for NoDuplicateKeysVisitor {
    type Value = NoDuplicateKeys;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<Self::Value, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_i64<E>(self, _: i64) -> Result<Self::Value, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_u64<E>(self, _: u64) -> Result<Self::Value, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_f64<E>(self, _: f64) -> Result<Self::Value, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_str<E>(self, _: &str) -> Result<Self::Value, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_unit<E>(self) -> Result<Self::Value, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        while seq.next_element::<NoDuplicateKeys>()?.is_some() {}
        Ok(NoDuplicateKeys)
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut seen = std::collections::HashSet::new();
        while let Some(key) = map.next_key::<String>()? {
            if seen.contains(&key) {
                return Err(serde::de::Error::custom(format!(
                    "the key \"{key}\" appears twice in one object"
                )));
            }
            map.next_value::<NoDuplicateKeys>()?;
            seen.insert(key);
        }
        Ok(NoDuplicateKeys)
    }
}

/// Rewrites a version 1 file (in place) as version 2: the robot's wheel radius and baseline
/// become a differential-drive vehicle, and the four models of version 1 become their
/// parts (`naive` is `no-slip+commanded`, `powertrain` is `no-slip` on its powertrain,
/// `slip-blr` is the slip model on its powertrain, `acc-blr` keeps its regressions).
fn upgrade_v1(file: &mut Map<String, Value>) -> Result<(), String> {
    let vehicle = |v: &Value| -> Result<Value, String> {
        let r = v.get("wheel_radius").cloned().ok_or("no wheel_radius")?;
        let b = v.get("baseline").cloned().ok_or("no baseline")?;
        Ok(json!({"type": "differential", "wheel_radius": r, "baseline": b}))
    };
    if let Some(Value::Object(robot)) = file.get_mut("robot") {
        let v = vehicle(&Value::Object(robot.clone()))?;
        robot.remove("wheel_radius");
        robot.remove("baseline");
        robot.insert("vehicle".into(), v);
    }
    let Some(Value::Object(model)) = file.get_mut("model") else {
        return Err("no model".into());
    };
    let kind = model
        .get("model")
        .and_then(Value::as_str)
        .ok_or("no model name")?
        .to_string();
    let vehicle = vehicle(model.get("vehicle").ok_or("no vehicle")?)?;
    let powertrain = match model.get("powertrain") {
        None => json!({"type": "commanded"}),
        Some(p) => match p.get("powertrain").and_then(Value::as_str) {
            Some("ideal") => json!({"type": "commanded"}),
            Some("fopdt") => json!({
                "type": "fopdt",
                "axes": [p.get("left").ok_or("no left side")?, p.get("right").ok_or("no right side")?],
                "limits": p.get("limits").ok_or("no limits")?,
                "dt": p.get("dt").ok_or("no powertrain dt")?,
            }),
            other => return Err(format!("unknown powertrain {other:?}")),
        },
    };
    let dt = model.get("dt").cloned().ok_or("no dt")?;
    let pt_name = powertrain["type"].as_str().unwrap_or_default().to_string();
    let upgraded = match kind.as_str() {
        "naive" | "powertrain" => json!({
            "type": "composed",
            "label": format!("no-slip+{pt_name}"),
            "vehicle": vehicle,
            "powertrain": if kind == "naive" { json!({"type": "commanded"}) } else { powertrain },
            "slip": {"type": "no-slip"},
            "dt": dt,
        }),
        "slip-blr" => json!({
            "type": "composed",
            "label": format!("slip-blr+{pt_name}"),
            "vehicle": vehicle,
            "powertrain": powertrain,
            "slip": {
                "type": "slip-blr",
                "slip_x": model.get("slip_x").ok_or("no slip_x")?,
                "slip_y": model.get("slip_y").ok_or("no slip_y")?,
                "slip_yaw": model.get("slip_yaw").ok_or("no slip_yaw")?,
            },
            "dt": dt,
        }),
        "acc-blr" => json!({
            "type": "acc-blr",
            "label": format!("acc-blr+{pt_name}"),
            "vehicle": vehicle,
            "powertrain": powertrain,
            "accel_x": model.get("accel_x").ok_or("no accel_x")?,
            "accel_yaw": model.get("accel_yaw").ok_or("no accel_yaw")?,
            "dt": dt,
        }),
        other => return Err(format!("unknown model '{other}'")),
    };
    file.insert("model".into(), upgraded);
    Ok(())
}
