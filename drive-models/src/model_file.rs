//! Fitted models saved as JSON and loaded back as trait objects (typetag), with a format
//! version so that a file from a newer or unknown format is refused, never misread.

use drive_traits::{MotionModel, RobotDescription};
use serde::Serialize;
use serde_json::Value;
use thiserror::Error;

/// The format version this build writes and reads.
pub const MODEL_FORMAT_VERSION: u64 = 1;

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
    /// The format version is not one this build reads.
    #[error("{file}, field 'format_version': version {found} is not supported (this build reads version {supported}; a newer file needs a newer drive)")]
    UnsupportedVersion {
        /// file name
        file: String,
        /// version found
        found: String,
        /// version supported
        supported: u64,
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
    robot: &'a RobotDescription,
    model: &'a dyn MotionModel,
}

/// The JSON text of a fitted model file.
pub fn model_to_json(model: &dyn MotionModel, robot: &RobotDescription) -> String {
    let file = ModelFileOut {
        format: FORMAT_NAME,
        format_version: MODEL_FORMAT_VERSION,
        robot,
        model,
    };
    // The fitted models hold plain numbers and strings: serialization cannot fail.
    serde_json::to_string_pretty(&file).expect("fitted models always serialize") + "\n"
}

/// Loads a model file's text (`file` names it in errors): the model and the robot it was
/// fitted for.
pub fn model_from_json(
    file: &str,
    text: &str,
) -> Result<(Box<dyn MotionModel>, RobotDescription), ModelFileError> {
    let mut value: Value = serde_json::from_str(text).map_err(|e| ModelFileError::Parse {
        file: file.into(),
        line: e.line(),
        message: e.to_string(),
    })?;
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
    if version.as_u64() != Some(MODEL_FORMAT_VERSION) {
        return Err(ModelFileError::UnsupportedVersion {
            file: file.into(),
            found: version.to_string(),
            supported: MODEL_FORMAT_VERSION,
        });
    }
    let robot = obj.remove("robot").ok_or(ModelFileError::MissingField {
        file: file.into(),
        field: "robot",
    })?;
    let robot: RobotDescription =
        serde_json::from_value(robot).map_err(|e| ModelFileError::Model {
            file: file.into(),
            message: format!("robot: {e}"),
        })?;
    let model = obj.remove("model").ok_or(ModelFileError::MissingField {
        file: file.into(),
        field: "model",
    })?;
    let model: Box<dyn MotionModel> =
        serde_json::from_value(model).map_err(|e| ModelFileError::Model {
            file: file.into(),
            message: e.to_string(),
        })?;
    model.check().map_err(|message| ModelFileError::Model {
        file: file.into(),
        message,
    })?;
    Ok((model, robot))
}
