//! A saved model scored on a dataset it was not fitted on (transfer: another run, another
//! terrain, another calibration of the robot): eq. 8 on every window (`drive score`,
//! Python's `Model.score`).

use drive_eval::{evaluate_model_from, Summary, UncertaintyReport, WindowErrors};
use drive_traits::{CommandModel, Dataset, MotionModel, Phase, StartInfo};
use serde::Serialize;
use serde_json::Value;
use thiserror::Error;

/// Why a model cannot be scored on a dataset.
#[derive(Debug, Error)]
pub enum ScoreError {
    /// The model's vehicle type is not the dataset's: its inputs are other axes.
    #[error(
        "the model is of a {model} vehicle and the dataset's is {data}: its inputs are other axes"
    )]
    VehicleType {
        /// The model's vehicle type.
        model: String,
        /// The dataset's.
        data: String,
    },
    /// The same vehicle type with another geometry, not allowed.
    #[error("the model was fitted for the vehicle {model} and the dataset's is {data} ({difference}): another robot's inputs command other body velocities (fit a model on that robot's data, or score across calibrations of one robot with {allow})")]
    Geometry {
        /// The model's vehicle, as JSON.
        model: String,
        /// The dataset's.
        data: String,
        /// What differs ([`geometry_difference`]).
        difference: String,
        /// How the caller allows it (`--allow-other-geometry`, `allow_other_geometry=True`).
        allow: &'static str,
    },
    /// The model steps at another rate than the dataset is sampled at.
    #[error(
        "the model predicts in steps of {model_dt} s and the dataset is sampled every {data_dt} s"
    )]
    Rate {
        /// The model's step (s).
        model_dt: f64,
        /// The dataset's sample period (s).
        data_dt: f64,
    },
    /// A vehicle could not be written as JSON to be compared.
    #[error("the vehicle cannot be compared: {0}")]
    Vehicle(String),
}

/// Median and quartiles of one error kind over some windows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorQuartiles {
    /// Windows counted.
    pub windows: usize,
    /// Median.
    pub median: f64,
    /// First and third quartiles.
    pub iqr: [f64; 2],
}

impl From<Summary> for ErrorQuartiles {
    fn from(s: Summary) -> Self {
        ErrorQuartiles {
            windows: s.count,
            median: s.median,
            iqr: [s.q1, s.q3],
        }
    }
}

/// One error kind over all windows and over each phase's (`None` where there are none).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ByPhase {
    /// Every window.
    pub all: Option<ErrorQuartiles>,
    /// The transient windows.
    pub transient: Option<ErrorQuartiles>,
    /// The steady windows.
    pub steady: Option<ErrorQuartiles>,
}

/// A saved model's eq. 8 errors on every window of a dataset.
#[derive(Debug, Clone, Serialize)]
pub struct Score {
    /// The model's name.
    pub model: String,
    /// The dataset's name.
    pub dataset: String,
    /// What each prediction started from.
    pub start: &'static str,
    /// Windows scored.
    pub windows: usize,
    /// Translational MRMSE (m).
    pub translational_m: ByPhase,
    /// Rotational MRMSE (rad).
    pub rotational_rad: ByPhase,
    /// Every window's errors.
    pub per_window: Vec<WindowErrors>,
    /// The 95% regions' calibration, for a model with a pose covariance.
    pub uncertainty: Option<UncertaintyReport>,
    /// What the caller should know (a geometry scored across).
    pub notes: Vec<String>,
}

/// Scores `model`, fitted for the robot `fitted_for` (its vehicle and windows), on every
/// window of `data`, each prediction starting from what `start` allows. Refused: a vehicle
/// of another type, a model stepping at another rate, and a vehicle of the same type with
/// another geometry (two robots, or two calibrations of one robot) unless
/// `allow_other_geometry`, where the difference is in `notes`; `allow` names how a caller
/// allows it, for the error. Windows of another length than the model's are scored with a
/// note (eq. 8 is then over their length, not the one the model was fitted on).
///
/// ```
/// use drive_studies::{score_model, ScoreError};
/// use drive_models::{powertrain::Commanded, slip::NoSlip, Composed};
/// use drive_traits::{Learner, StartInfo};
/// let data = drive_data::bundled::load("husky_drive").unwrap();
/// let naive = Learner::fit(&Composed::new(Commanded, NoSlip), &data.all()).unwrap();
/// let s = score_model(&naive, &data.robot, &data, StartInfo::default(), false, "").unwrap();
/// assert_eq!(s.windows, data.windows.len());
/// assert!(s.translational_m.all.unwrap().median > 0.0);
/// // The Warthog's baseline is not the Husky's.
/// let warthog = drive_data::bundled::load("warthog_drive").unwrap();
/// let across = score_model(&naive, &data.robot, &warthog, StartInfo::default(), false, "--allow-other-geometry");
/// assert!(matches!(across, Err(ScoreError::Geometry { .. })));
/// ```
pub fn score_model(
    model: &dyn MotionModel,
    fitted_for: &drive_traits::RobotDescription,
    data: &Dataset,
    start: StartInfo,
    allow_other_geometry: bool,
    allow: &'static str,
) -> Result<Score, ScoreError> {
    let robot = fitted_for;
    let fitted_for = robot.vehicle.as_ref();
    let (ours, theirs) = (
        drive_traits::vehicle_tag(fitted_for).unwrap_or_default(),
        drive_traits::vehicle_tag(data.robot.vehicle.as_ref()).unwrap_or_default(),
    );
    if ours != theirs {
        return Err(ScoreError::VehicleType {
            model: ours,
            data: theirs,
        });
    }
    let json = |v: &dyn CommandModel| {
        serde_json::to_value(v).map_err(|e| ScoreError::Vehicle(e.to_string()))
    };
    let (a, b) = (json(fitted_for)?, json(data.robot.vehicle.as_ref())?);
    let mut notes = Vec::new();
    if !same_geometry(&a, &b) {
        let difference = geometry_difference(&a, &b);
        if !allow_other_geometry {
            return Err(ScoreError::Geometry {
                model: a.to_string(),
                data: b.to_string(),
                difference,
                allow,
            });
        }
        notes.push(format!(
            "{}: scored across geometries, the model's against the dataset's: {difference}; the model's inputs command the body velocities of the geometry it was fitted for",
            data.robot.name
        ));
    }
    if (model.dt() - data.robot.dt()).abs() > 1e-9 * data.robot.dt() {
        return Err(ScoreError::Rate {
            model_dt: model.dt(),
            data_dt: data.robot.dt(),
        });
    }
    let window_s = |r: &drive_traits::RobotDescription| r.window_len as f64 / r.rate_hz;
    let (fitted_s, scored_s) = (window_s(robot), window_s(&data.robot));
    if (fitted_s - scored_s).abs() > 1e-9 * fitted_s.abs().max(scored_s.abs()) {
        notes.push(format!(
            "{}: windows of {} s, the model was fitted on windows of {} s: its errors (eq. 8) and the 95% regions' coverage are over {} s",
            data.robot.name,
            drive_traits::limits::Short(scored_s),
            drive_traits::limits::Short(fitted_s),
            drive_traits::limits::Short(scored_s)
        ));
    }
    let report = evaluate_model_from(model, &data.all(), start);
    let by_phase = |f: &dyn Fn(Option<Phase>) -> Option<Summary>| ByPhase {
        all: f(None).map(Into::into),
        transient: f(Some(Phase::Transient)).map(Into::into),
        steady: f(Some(Phase::Steady)).map(Into::into),
    };
    Ok(Score {
        model: report.name.clone(),
        dataset: data.robot.name.clone(),
        start: start.as_str(),
        windows: report.windows.len(),
        translational_m: by_phase(&|p| report.translational(p)),
        rotational_rad: by_phase(&|p| report.rotational(p)),
        per_window: report.windows,
        uncertainty: report.uncertainty,
        notes,
    })
}

/// Whether two vehicles' JSON are one geometry: equal but for numbers within a millionth of
/// each other (a sidecar written in 32-bit floats, 0.16500000655651093 for 0.165).
///
/// ```
/// use serde_json::json;
/// let a = json!({"type": "differential", "baseline": 0.55, "wheel_radius": 0.165});
/// let b = json!({"type": "differential", "baseline": 0.55, "wheel_radius": 0.16500000655651093});
/// assert!(drive_studies::same_geometry(&a, &b));
/// let c = json!({"type": "differential", "baseline": 0.55, "wheel_radius": 0.159});
/// assert!(!drive_studies::same_geometry(&a, &c));
/// ```
pub fn same_geometry(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => match (x.as_f64(), y.as_f64()) {
            (Some(p), Some(q)) => (p - q).abs() <= 1e-6 * p.abs().max(q.abs()),
            _ => x == y,
        },
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len()
                && x.iter()
                    .all(|(k, v)| y.get(k).is_some_and(|w| same_geometry(v, w)))
        }
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(v, w)| same_geometry(v, w))
        }
        _ => a == b,
    }
}

/// What differs between two vehicles of one type, field by field of their JSON, e.g. two
/// calibrations of one robot.
///
/// ```
/// use serde_json::json;
/// let a = json!({"baseline": 1.1652, "wheel_radius": 0.3});
/// let b = json!({"baseline": 1.08, "wheel_radius": 0.3});
/// assert_eq!(drive_studies::geometry_difference(&a, &b), "baseline 1.1652 -> 1.08 (-7.3%)");
/// let c = json!({"baseline": 1.1652, "wheel_radius": 0.3000015});
/// assert_eq!(drive_studies::geometry_difference(&a, &c), "wheel_radius 0.3 -> 0.3000015 (+5.0e-4%)");
/// ```
pub fn geometry_difference(ours: &Value, theirs: &Value) -> String {
    let (Some(a), Some(b)) = (ours.as_object(), theirs.as_object()) else {
        return format!("{ours} -> {theirs}");
    };
    let mut parts = Vec::new();
    for (key, x) in a {
        let y = b.get(key).unwrap_or(&Value::Null);
        if same_geometry(x, y) {
            continue;
        }
        match (x.as_f64(), y.as_f64()) {
            (Some(x), Some(y)) if x != 0.0 => {
                // A difference under a tenth of a percent keeps its digits (not "+0.0%").
                let percent = 100.0 * (y - x) / x;
                let shown = if percent.abs() >= 0.05 {
                    format!("{percent:+.1}")
                } else {
                    format!("{percent:+.1e}")
                };
                parts.push(format!("{key} {x} -> {y} ({shown}%)"))
            }
            _ => parts.push(format!("{key} {x} -> {y}")),
        }
    }
    for (key, y) in b {
        if !a.contains_key(key) {
            parts.push(format!("{key} none -> {y}"));
        }
    }
    parts.join(", ")
}
