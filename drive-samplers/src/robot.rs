//! Robot descriptions for the protocol: geometry, limits, rates and acceleration limits,
//! from a TOML file or a built-in preset of the paper's platforms.

use drive_traits::{Input, InputSpace};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a robot description is refused.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RobotError {
    /// Not valid TOML, or a field has the wrong type, is missing or is unknown.
    #[error("{file}: {message}")]
    Parse {
        /// file name
        file: String,
        /// parser message (names the field and line)
        message: String,
    },
    /// A value is out of its physical range.
    #[error("{file}, field '{field}': {message}")]
    Invalid {
        /// file name
        file: String,
        /// field
        field: &'static str,
        /// what is expected
        message: String,
    },
    /// No preset of that name.
    #[error("unknown robot '{0}' (presets: husky, hd2, warthog; or a path to a .toml file)")]
    UnknownPreset(String),
}

/// A robot description for the DRIVE protocol.
///
/// ```
/// let husky = drive_samplers::RobotSpec::preset("husky").unwrap();
/// assert_eq!(husky.wheel_radius, 0.165);
/// let toml = "name = 'mine'\nmass_kg = 30\nwheel_radius = 0.1\nbaseline = 0.4\nmax_speed = 1.5\n\
///             max_linear_acceleration = 1.0\nmax_angular_acceleration = 3.0\n";
/// let mine = drive_samplers::RobotSpec::from_toml("mine.toml", toml).unwrap();
/// assert_eq!(mine.rate_hz, 20.0); // the DRIVE command rate by default
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// Robot name.
    pub name: String,
    /// Mass (kg).
    pub mass_kg: f64,
    /// Wheel or track sprocket radius r (m).
    pub wheel_radius: f64,
    /// Vehicle width b (m).
    pub baseline: f64,
    /// Manufacturer's top speed (m/s): gives the naive input space.
    pub max_speed: f64,
    /// The low-level controller's linear speed limit (m/s), when it has one.
    #[serde(default)]
    pub controller_max_linear: Option<f64>,
    /// The low-level controller's angular speed limit (rad/s), when it has one.
    #[serde(default)]
    pub controller_max_angular: Option<f64>,
    /// Command rate (Hz).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Acceleration limit applied to the sent commands, linear (m/s^2).
    pub max_linear_acceleration: f64,
    /// Acceleration limit applied to the sent commands, angular (rad/s^2).
    pub max_angular_acceleration: f64,
    /// Wheel velocity limits `[omega_min, omega_max]` (rad/s), user-given or from the
    /// characterization step; the naive limits `+-max_speed / r` when absent.
    #[serde(default)]
    pub wheel_limits: Option<[f64; 2]>,
    /// Tracks rather than wheels.
    #[serde(default)]
    pub tracked: bool,
}

fn default_rate() -> f64 {
    20.0
}

impl RobotSpec {
    /// A built-in preset of the paper's platforms: `husky` (75 kg, 1 m/s), `hd2` (tracked,
    /// 80 kg, 1.2 m/s) or `warthog` (470 kg, 5 m/s). Acceleration limits are this project's
    /// defaults (about one top speed per second), not the manufacturers'.
    pub fn preset(name: &str) -> Result<RobotSpec, RobotError> {
        let (mass_kg, max_speed, wheel_radius, baseline, tracked) = match name {
            "husky" => (75.0, 1.0, 0.165, 0.55, false),
            "hd2" => (80.0, 1.2, 0.116, 0.5927, true),
            "warthog" => (470.0, 5.0, 0.3, 1.1652, false),
            other => return Err(RobotError::UnknownPreset(other.to_string())),
        };
        Ok(RobotSpec {
            name: name.to_string(),
            mass_kg,
            wheel_radius,
            baseline,
            max_speed,
            controller_max_linear: None,
            controller_max_angular: None,
            rate_hz: 20.0,
            max_linear_acceleration: max_speed,
            max_angular_acceleration: 2.0 * max_speed / baseline,
            wheel_limits: None,
            tracked,
        })
    }

    /// Parses and validates a TOML description (`file` names it in errors).
    pub fn from_toml(file: &str, text: &str) -> Result<RobotSpec, RobotError> {
        let spec: RobotSpec = toml::from_str(text).map_err(|e| RobotError::Parse {
            file: file.into(),
            message: e.to_string().trim().replace('\n', " "),
        })?;
        spec.validate(file)?;
        Ok(spec)
    }

    /// A preset by name, or a TOML file by path.
    pub fn load(name_or_path: &str) -> Result<RobotSpec, RobotError> {
        if name_or_path.ends_with(".toml") || std::path::Path::new(name_or_path).exists() {
            let text = std::fs::read_to_string(name_or_path).map_err(|e| RobotError::Parse {
                file: name_or_path.into(),
                message: e.to_string(),
            })?;
            return Self::from_toml(name_or_path, &text);
        }
        Self::preset(name_or_path)
    }

    /// Checks physical ranges: positive geometry, rates and limits (no fixed speed caps:
    /// robots differ by orders of magnitude).
    pub fn validate(&self, file: &str) -> Result<(), RobotError> {
        let invalid = |field, message: &str| {
            Err(RobotError::Invalid {
                file: file.into(),
                field,
                message: message.into(),
            })
        };
        let positive: [(&'static str, f64); 7] = [
            ("mass_kg", self.mass_kg),
            ("wheel_radius", self.wheel_radius),
            ("baseline", self.baseline),
            ("max_speed", self.max_speed),
            ("rate_hz", self.rate_hz),
            ("max_linear_acceleration", self.max_linear_acceleration),
            ("max_angular_acceleration", self.max_angular_acceleration),
        ];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return invalid(field, &format!("expected a positive number, found {v}"));
            }
        }
        if self.rate_hz * crate::WINDOW_S < 2.0 {
            return invalid(
                "rate_hz",
                &format!(
                    "{} Hz gives fewer than 2 samples per {} s window; expected at least {} Hz",
                    self.rate_hz,
                    crate::WINDOW_S,
                    2.0 / crate::WINDOW_S
                ),
            );
        }
        for (field, v) in [
            ("controller_max_linear", self.controller_max_linear),
            ("controller_max_angular", self.controller_max_angular),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return invalid(field, &format!("expected a positive number, found {v}"));
                }
            }
        }
        if let Some([lo, hi]) = self.wheel_limits {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return invalid("wheel_limits", &format!("expected [omega_min, omega_max] with omega_min < omega_max, found [{lo}, {hi}]"));
            }
        }
        Ok(())
    }

    /// The input space J used by the protocol: the wheel limits on both sides, or the naive
    /// (manufacturer's) `+-max_speed / r`.
    pub fn input_space(&self) -> InputSpace {
        let [lo, hi] = self.wheel_limits.unwrap_or([
            -self.max_speed / self.wheel_radius,
            self.max_speed / self.wheel_radius,
        ]);
        // Validated: lo < hi, finite.
        InputSpace::new(Input::new(lo, lo), Input::new(hi, hi)).expect("validated wheel limits")
    }
}
