//! Robot descriptions for the protocol: the vehicle with its geometry, limits, rates and
//! acceleration limits, from a TOML file or a registered preset (the paper's platforms).

use drive_models::DifferentialDrive;
use drive_traits::{CommandModel, Input, InputSpace, Registry, RegistryError, RegistryItem};
use serde::Deserialize;
use std::sync::Arc;
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
    /// No registered robot of that name, and no such file.
    #[error(transparent)]
    Registry(#[from] RegistryError),
}

/// A robot description for the DRIVE protocol.
///
/// In TOML: `name`, `mass_kg`, `max_speed` (the manufacturer's top speed, m/s),
/// `max_linear_acceleration`, `max_angular_acceleration`; optional `rate_hz` (20),
/// `controller_max_linear`, `controller_max_angular`, `tracked`; the vehicle as a
/// `[vehicle]` table (`type = "differential"`, `wheel_radius`, `baseline`; any registered
/// vehicle type with its geometry), or `wheel_radius` and `baseline` for a differential
/// drive; the input space as `input_limits = [[min, max], [min, max]]` per axis, or
/// `wheel_limits = [min, max]` for both wheels of a differential drive, or, when neither is
/// given, the vehicle's nominal space at `max_speed`.
///
/// ```
/// use drive_samplers::{builtin_robots, RobotSpec};
/// let husky = builtin_robots().get("husky").unwrap().part().as_ref().clone();
/// assert_eq!(husky.vehicle.geometry()[0], ("wheel_radius", 0.165));
/// let toml = "name = 'mine'\nmass_kg = 30\nmax_speed = 1.5\nmax_linear_acceleration = 1.0\n\
///             max_angular_acceleration = 3.0\n[vehicle]\ntype = 'differential'\n\
///             wheel_radius = 0.1\nbaseline = 0.4\n";
/// let mine = RobotSpec::from_toml("mine.toml", toml).unwrap();
/// assert_eq!(mine.rate_hz, 20.0); // the DRIVE command rate by default
/// assert_eq!(mine.input_space().max.x, 15.0); // 1.5 m/s on 0.1 m wheels
/// ```
#[derive(Debug, Clone)]
pub struct RobotSpec {
    /// Robot name.
    pub name: String,
    /// Mass (kg).
    pub mass_kg: f64,
    /// The vehicle and its geometry.
    pub vehicle: Arc<dyn CommandModel>,
    /// Manufacturer's top speed (m/s): gives the naive input space.
    pub max_speed: f64,
    /// The low-level controller's linear speed limit (m/s), when it has one.
    pub controller_max_linear: Option<f64>,
    /// The low-level controller's angular speed limit (rad/s), when it has one.
    pub controller_max_angular: Option<f64>,
    /// Command rate (Hz).
    pub rate_hz: f64,
    /// Acceleration limit applied to the sent commands, linear (m/s^2).
    pub max_linear_acceleration: f64,
    /// Acceleration limit applied to the sent commands, angular (rad/s^2).
    pub max_angular_acceleration: f64,
    /// Input limits per axis, user-given or from the characterization step; the vehicle's
    /// nominal space at `max_speed` when absent.
    pub input_limits: Option<InputSpace>,
    /// The vehicle's nominal input space at `max_speed` (the manufacturer's J).
    pub nominal_input_space: InputSpace,
    /// Tracks rather than wheels.
    pub tracked: bool,
}

impl RegistryItem for RobotSpec {}

/// A robot file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotFile {
    name: String,
    mass_kg: f64,
    max_speed: f64,
    #[serde(default)]
    vehicle: Option<toml::Value>,
    #[serde(default)]
    wheel_radius: Option<f64>,
    #[serde(default)]
    baseline: Option<f64>,
    #[serde(default)]
    controller_max_linear: Option<f64>,
    #[serde(default)]
    controller_max_angular: Option<f64>,
    #[serde(default = "default_rate")]
    rate_hz: f64,
    max_linear_acceleration: f64,
    max_angular_acceleration: f64,
    #[serde(default)]
    wheel_limits: Option<[f64; 2]>,
    #[serde(default)]
    input_limits: Option<[[f64; 2]; 2]>,
    #[serde(default)]
    tracked: bool,
}

fn default_rate() -> f64 {
    20.0
}

/// The paper's platforms: `husky` (75 kg, 1 m/s), `hd2` (tracked, 80 kg, 1.2 m/s),
/// `warthog` (470 kg, 5 m/s), differential drives. Acceleration limits are this project's
/// defaults (about one top speed per second), not the manufacturers'.
pub fn builtin_robots() -> Registry<RobotSpec> {
    let mut r: Registry<RobotSpec> = Registry::new("robot");
    for (name, description, mass_kg, max_speed, wheel_radius, baseline, tracked) in [
        (
            "husky",
            "Clearpath Husky: wheeled skid-steer, 75 kg, 1 m/s",
            75.0,
            1.0,
            0.165,
            0.55,
            false,
        ),
        (
            "hd2",
            "Superdroid HD2: tracked skid-steer, 80 kg, 1.2 m/s",
            80.0,
            1.2,
            0.116,
            0.5927,
            true,
        ),
        (
            "warthog",
            "Clearpath Warthog on wheels: skid-steer, 470 kg, 5 m/s",
            470.0,
            5.0,
            0.3,
            1.1652,
            false,
        ),
    ] {
        let vehicle = DifferentialDrive::new(wheel_radius, baseline);
        let spec = RobotSpec {
            name: name.to_string(),
            mass_kg,
            max_speed,
            controller_max_linear: None,
            controller_max_angular: None,
            rate_hz: 20.0,
            max_linear_acceleration: max_speed,
            max_angular_acceleration: 2.0 * max_speed / baseline,
            input_limits: None,
            nominal_input_space: InputSpace::new(
                Input::repeat(-max_speed / wheel_radius),
                Input::repeat(max_speed / wheel_radius),
            )
            .expect("positive presets"),
            vehicle: Arc::new(vehicle),
            tracked,
        };
        // Three distinct names.
        r.register_trusted(name, description, Arc::new(spec))
            .expect("distinct presets");
    }
    r
}

impl RobotSpec {
    /// Parses and validates a TOML description (`file` names it in errors).
    pub fn from_toml(file: &str, text: &str) -> Result<RobotSpec, RobotError> {
        let parse = |message: String| RobotError::Parse {
            file: file.into(),
            message: message.trim().replace('\n', " "),
        };
        let invalid = |field, message: String| RobotError::Invalid {
            file: file.into(),
            field,
            message,
        };
        let f: RobotFile = toml::from_str(text).map_err(|e| parse(e.to_string()))?;
        let vehicle: Arc<dyn CommandModel> = match (&f.vehicle, f.wheel_radius, f.baseline) {
            (Some(v), None, None) => {
                let json = serde_json::to_value(v).map_err(|e| parse(e.to_string()))?;
                let v: Box<dyn CommandModel> = serde_json::from_value(json)
                    .map_err(|e| invalid("vehicle", format!("not a known vehicle: {e}")))?;
                Arc::from(v)
            }
            (None, Some(r), Some(b)) => Arc::new(DifferentialDrive::new(r, b)),
            (Some(_), _, _) => {
                return Err(invalid(
                    "vehicle",
                    "give the geometry inside [vehicle] only (wheel_radius and baseline at the top are the older form of a differential drive's)".into(),
                ))
            }
            (None, Some(_), None) => {
                return Err(invalid(
                    "baseline",
                    "missing field `baseline` (a differential drive needs wheel_radius and baseline; or give a [vehicle] table)".into(),
                ))
            }
            (None, None, Some(_)) => {
                return Err(invalid(
                    "wheel_radius",
                    "missing field `wheel_radius` (a differential drive needs wheel_radius and baseline; or give a [vehicle] table)".into(),
                ))
            }
            (None, None, None) => {
                return Err(invalid(
                    "vehicle",
                    "missing: a [vehicle] table (type = \"differential\", wheel_radius, baseline, ...), or wheel_radius and baseline".into(),
                ))
            }
        };
        vehicle.check().map_err(|e| invalid("vehicle", e))?;
        let axis_limits = match (f.wheel_limits, f.input_limits) {
            (Some(_), Some(_)) => {
                return Err(invalid(
                    "wheel_limits",
                    "give wheel_limits or input_limits, not both".into(),
                ))
            }
            (Some([lo, hi]), None) => Some(("wheel_limits", [[lo, hi], [lo, hi]])),
            (None, Some(l)) => Some(("input_limits", l)),
            (None, None) => None,
        };
        let mut input_limits = None;
        if let Some((field, [[a0, a1], [b0, b1]])) = axis_limits {
            let ok = [a0, a1, b0, b1].iter().all(|v| v.is_finite()) && a0 < a1 && b0 < b1;
            if !ok {
                return Err(invalid(
                    field,
                    if field == "wheel_limits" {
                        format!("expected [omega_min, omega_max] with omega_min < omega_max, found [{a0}, {a1}]")
                    } else {
                        format!("expected [min, max] with min < max on each axis, found [[{a0}, {a1}], [{b0}, {b1}]]")
                    },
                ));
            }
            input_limits = InputSpace::new(Input::new(a0, b0), Input::new(a1, b1));
        }
        if !(f.max_speed.is_finite() && f.max_speed > 0.0) {
            return Err(invalid(
                "max_speed",
                format!("expected a positive number, found {}", f.max_speed),
            ));
        }
        let nominal = match (vehicle.nominal_input_space(f.max_speed), input_limits) {
            (Some(j), _) => j,
            (None, Some(limits)) => limits,
            // The vehicle gives a nominal space at ordinary speeds: the top speed is too large.
            (None, None) if vehicle.nominal_input_space(1.0).is_some() => {
                return Err(invalid(
                    "max_speed",
                    format!(
                        "the nominal input space at {} m/s is not finite; expected a realistic top speed",
                        f.max_speed
                    ),
                ))
            }
            (None, None) => {
                return Err(invalid(
                    "input_limits",
                    "this vehicle has no nominal input space: give input_limits = [[min, max], [min, max]]".into(),
                ))
            }
        };
        let spec = RobotSpec {
            name: f.name,
            mass_kg: f.mass_kg,
            vehicle,
            max_speed: f.max_speed,
            controller_max_linear: f.controller_max_linear,
            controller_max_angular: f.controller_max_angular,
            rate_hz: f.rate_hz,
            max_linear_acceleration: f.max_linear_acceleration,
            max_angular_acceleration: f.max_angular_acceleration,
            input_limits,
            nominal_input_space: nominal,
            tracked: f.tracked,
        };
        spec.validate(file)?;
        Ok(spec)
    }

    /// A registered robot by name, or a TOML file by path.
    pub fn load(robots: &Registry<RobotSpec>, name_or_path: &str) -> Result<RobotSpec, RobotError> {
        if name_or_path.ends_with(".toml") || std::path::Path::new(name_or_path).exists() {
            let text = std::fs::read_to_string(name_or_path).map_err(|e| RobotError::Parse {
                file: name_or_path.into(),
                message: e.to_string(),
            })?;
            return Self::from_toml(name_or_path, &text);
        }
        robots
            .find(name_or_path)
            .map(|e| e.part().as_ref().clone())
            .ok_or_else(|| {
                RobotError::Registry(RegistryError::Unknown {
                    kind: "robot",
                    name: name_or_path.to_string(),
                    known: format!("{}; or a path to a .toml file", robots.names().join(", ")),
                })
            })
    }

    /// Checks physical ranges: positive rates, limits and mass, a finite nominal input
    /// space (no fixed speed caps: robots differ by orders of magnitude).
    pub fn validate(&self, file: &str) -> Result<(), RobotError> {
        let invalid = |field, message: &str| {
            Err(RobotError::Invalid {
                file: file.into(),
                field,
                message: message.into(),
            })
        };
        let positive: [(&'static str, f64); 5] = [
            ("mass_kg", self.mass_kg),
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
        let j = self.nominal_input_space;
        if !(j.min.iter().chain(j.max.iter()).all(|v| v.is_finite())
            && j.min.x < j.max.x
            && j.min.y < j.max.y)
        {
            return invalid(
                "max_speed",
                &format!(
                    "the nominal input space at {} m/s is not a finite box: [{}, {}] x [{}, {}]",
                    self.max_speed, j.min.x, j.max.x, j.min.y, j.max.y
                ),
            );
        }
        Ok(())
    }

    /// The input space J used by the protocol: the given input limits, or the vehicle's
    /// nominal (manufacturer's) space at `max_speed`.
    pub fn input_space(&self) -> InputSpace {
        self.input_limits.unwrap_or(self.nominal_input_space)
    }
}
