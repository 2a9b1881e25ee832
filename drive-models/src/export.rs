//! Fitted models written in the layouts other software loads: norlab_controllers'
//! slip-BLR (`.npy` arrays and a YAML of parameters), so that a model fitted here drives
//! norlab's own MPC controllers.
//!
//! The norlab layout, as `norlab-ulaval/norlab_controllers` reads it:
//! `norlabcontrollib/models/blr_slip.py` (`FullBodySlipBayesianLinearRegression.load_params`:
//! `weights_{x,y,yaw}.npy` (k x 1), `covariance_{x,y,yaw}.npy` (the posterior's K, k x k),
//! `a_param_n_{x,y,yaw}.npy` and `b_param_n_{x,y,yaw}.npy`, the slip inputs `[f_x]`,
//! `[f_x f_w]`, `[f_x f_w, f_x, f_w]` of the paper's eq. 5) and
//! `norlabcontrollib/controllers/slip_blr_pwrtrn_diff_drive_mpc.py` (the YAML keys
//! `wheel_radius`, `baseline`, `rate`, `slip_blr_param_path`, `pwrtrn_param_path`; the
//! powertrain's `powertrain_training_{left,right}.npy`, `[time constant, dead time]`).

use crate::model_file::FitSettings;
use drive_traits::{MotionModel, RobotDescription};
use serde_json::Value;
use std::path::PathBuf;
use thiserror::Error;

/// Why a model cannot be exported in a layout.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ExportError {
    /// The layout cannot hold the model (another slip model, powertrain or vehicle).
    #[error("the norlab layout holds slip-BLR on a FOPDT powertrain of a differential drive (norlab_controllers' SlipBLRPwrtrnDiffDriveMPC); this model {why}")]
    Unsupported {
        /// what of the model the layout lacks
        why: String,
    },
    /// The model does not serialize (a plug-in's part).
    #[error("the model does not serialize: {0}")]
    Serialize(String),
}

/// The files of an export, relative to its directory, and what the layout leaves out.
#[derive(Debug, Clone, PartialEq)]
pub struct Export {
    /// Each file's path in the export directory and its bytes.
    pub files: Vec<(PathBuf, Vec<u8>)>,
    /// What the layout does not carry, to say to the user (a calibration's scales).
    pub notes: Vec<String>,
}

/// A numpy `.npy` file (format 1.0) of little-endian doubles of `shape` (row-major, `()` a
/// scalar).
///
/// ```
/// let bytes = drive_models::export::npy(&[1.5, 2.5], &[2, 1]);
/// assert_eq!(&bytes[..6], b"\x93NUMPY");
/// // The header pads to a multiple of 64 bytes, ending with a newline; two doubles follow.
/// let header = bytes.len() - 16;
/// assert_eq!((header % 64, bytes[header - 1]), (0, b'\n'));
/// assert!(String::from_utf8_lossy(&bytes[10..header]).contains("'shape': (2, 1)"));
/// assert_eq!(&bytes[header..header + 8], &1.5f64.to_le_bytes());
/// ```
pub fn npy(values: &[f64], shape: &[usize]) -> Vec<u8> {
    let shape = match shape {
        [] => "()".to_string(),
        [n] => format!("({n},)"),
        dims => format!(
            "({})",
            dims.iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6), version (2), header length (2), the header padded with spaces to a
    // multiple of 64 bytes, ending with a newline.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + 8 * values.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// The numbers of `v` (an array of numbers).
fn numbers(v: &Value, what: &str) -> Result<Vec<f64>, ExportError> {
    v.as_array()
        .and_then(|a| a.iter().map(Value::as_f64).collect::<Option<Vec<_>>>())
        .ok_or_else(|| ExportError::Unsupported {
            why: format!("has no numbers for {what}"),
        })
}

fn number(v: &Value, what: &str) -> Result<f64, ExportError> {
    v.as_f64().ok_or_else(|| ExportError::Unsupported {
        why: format!("has no number for {what}"),
    })
}

/// A YAML string (single-quoted).
fn quoted(s: &str) -> String {
    format!("'{}'", s.replace('\'', "''").replace(['\n', '\r'], " "))
}

/// `model` (for `robot`) in norlab_controllers' layout: `slip_blr/` (the twelve arrays of
/// `load_params`), `powertrain/` (`powertrain_training_left.npy` and `_right.npy`) and
/// `norlab_controller.yaml` (the model's keys of `SlipBLRPwrtrnDiffDriveMPC`; its tuning,
/// such as the horizon and the costs, is the user's to add). A calibrated model is written
/// without its calibration (norlab propagates eq. 7's variance; a note says so); a model of
/// another slip learner, powertrain or vehicle is refused.
pub fn norlab(
    model: &dyn MotionModel,
    robot: &RobotDescription,
    fitted_with: Option<&FitSettings>,
) -> Result<Export, ExportError> {
    let mut notes = Vec::new();
    let mut value =
        serde_json::to_value(model).map_err(|e| ExportError::Serialize(e.to_string()))?;
    if value["type"] == "calibrated" {
        notes.push("the model's calibration (its per-step scales of the covariance) is not written: norlab_controllers propagates the slip's eq. 7 variance as published".into());
        value = value["model"].take();
    }
    let unsupported = |why: String| ExportError::Unsupported { why };
    if value["type"] != "composed" {
        return Err(unsupported(format!(
            "is {} (a whole-model baseline)",
            model.name()
        )));
    }
    let slip = &value["slip"];
    if slip["type"] != "slip-blr" {
        return Err(unsupported(format!("has the slip model {}", slip["type"])));
    }
    if slip["basis"] != "skid-steer" {
        return Err(unsupported(format!(
            "uses slip-BLR's {} basis, not the skid-steer basis of eq. 5",
            slip["basis"]
        )));
    }
    let powertrain = &value["powertrain"];
    if powertrain["type"] != "fopdt" {
        return Err(unsupported(format!(
            "has the powertrain {}",
            powertrain["type"]
        )));
    }
    let vehicle = &value["vehicle"];
    if vehicle["type"] != "differential" {
        return Err(unsupported(format!("is of a {} vehicle", vehicle["type"])));
    }
    let mut files = Vec::new();
    for (dim, key) in [("x", "slip_x"), ("y", "slip_y"), ("yaw", "slip_yaw")] {
        let p = &slip[key];
        let mean = numbers(&p["mean"], key)?;
        let k = mean.len();
        let cov = numbers(&p["covariance"], key)?;
        if cov.len() != k * k {
            return Err(unsupported(format!(
                "has a {key} covariance of {} numbers for {k} weights",
                cov.len()
            )));
        }
        let dir = PathBuf::from("slip_blr");
        files.push((dir.join(format!("weights_{dim}.npy")), npy(&mean, &[k, 1])));
        files.push((
            dir.join(format!("covariance_{dim}.npy")),
            npy(&cov, &[k, k]),
        ));
        files.push((
            dir.join(format!("a_param_n_{dim}.npy")),
            npy(&[number(&p["a"], key)?], &[]),
        ));
        files.push((
            dir.join(format!("b_param_n_{dim}.npy")),
            npy(&[number(&p["b"], key)?], &[1, 1]),
        ));
    }
    let axes = powertrain["axes"]
        .as_array()
        .map(Vec::as_slice)
        .unwrap_or_default();
    let [left, right] = axes else {
        return Err(unsupported(format!(
            "has a powertrain of {} axes",
            axes.len()
        )));
    };
    for (side, axis) in [("left", left), ("right", right)] {
        let values = [
            number(&axis["time_constant"], "the time constant")?,
            number(&axis["delay"], "the dead time")?,
        ];
        files.push((
            PathBuf::from("powertrain").join(format!("powertrain_training_{side}.npy")),
            npy(&values, &[2]),
        ));
    }
    let fitted = fitted_with.map_or(String::new(), |f| {
        format!(
            "# fitted as {} ({}) from {}, uncertainty {}, on {} training windows\n",
            f.model,
            f.canonical,
            f.start.as_str(),
            f.uncertainty.as_str(),
            f.training_windows
        )
    });
    let yaml = format!(
        "# A DRIVE model for norlab_controllers' SlipBLRPwrtrnDiffDriveMPC\n\
         # (norlabcontrollib/controllers/slip_blr_pwrtrn_diff_drive_mpc.py), written by\n\
         # `drive export --format norlab`. The controller's tuning (horizon_length, the costs,\n\
         # the velocity limits, ...) is yours to add; the paths are relative to this file's\n\
         # directory, as the controller resolves them from its package's share directory.\n\
         # robot: {robot}\n{fitted}\
         controller_name: 'SlipBLRPwrtrnDiffDriveMPC'\n\
         rate: {rate:?}\n\
         wheel_radius: {r:?}\n\
         baseline: {b:?}\n\
         slip_blr_param_path: 'slip_blr/'\n\
         pwrtrn_param_path: 'powertrain/'\n",
        robot = quoted(&robot.name),
        rate = robot.rate_hz,
        r = number(&vehicle["wheel_radius"], "the wheel radius")?,
        b = number(&vehicle["baseline"], "the baseline")?,
    );
    files.push((PathBuf::from("norlab_controller.yaml"), yaml.into_bytes()));
    Ok(Export { files, notes })
}
