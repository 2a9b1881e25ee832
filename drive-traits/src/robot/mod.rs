//! Robot descriptions for the protocol: the vehicle with its geometry, limits, rates and
//! acceleration limits, from a TOML file (`file.rs`) or a registered preset (`presets.rs`:
//! the paper's platforms). This file: the description, its builder and its checks.

use crate::limits::{self, Short};
use crate::vehicles::DifferentialDrive;
use crate::vehicles::{Ackermann, Omnidirectional};
use crate::{
    vehicle_tag, CommandModel, Input, InputSpace, Registry, RegistryError, RegistryItem, Steering,
    Tagged,
};
use serde::Deserialize;
use std::sync::Arc;
use thiserror::Error;

mod body_limits;
mod commands;
mod file;
mod presets;
pub use body_limits::BodyLimits;
pub use commands::{limit_acceleration, next_command, SentCommand};
pub use presets::{autorally, builtin_robots, ridgeback};

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

/// Lowest top speed a robot may have (m/s): below a millimetre per second is another unit,
/// and the wheel speeds of its input space fall towards the denormal numbers.
pub const MIN_SPEED_MPS: f64 = 1e-3;

/// A robot description for the DRIVE protocol.
///
/// In TOML: `name`, `mass_kg`, `max_speed` (the manufacturer's top speed, m/s),
/// `max_linear_acceleration`, `max_angular_acceleration`; optional `rate_hz` (20),
/// `controller_max_linear`, `controller_max_angular`, `tracked`, `body_length` and
/// `body_width` (the body's footprint in m, both or neither: its moment of inertia for the
/// terrain's unpredictability); the vehicle as a
/// `[vehicle]` table (`type = "differential"`, `wheel_radius`, `baseline`; `type =
/// "ackermann"`, `wheelbase`, `max_steering`; any registered vehicle type with its
/// geometry), or `wheel_radius` and `baseline` for a differential drive; the input space as
/// `input_limits = [[min, max], [min, max]]` per axis, or `wheel_limits = [min, max]` for
/// both wheels of a differential drive, or, when neither is given, the vehicle's nominal
/// space at `max_speed`.
///
/// The commands sent are limited in body acceleration (`max_linear_acceleration`,
/// `max_angular_acceleration`), or, with `input_rate_limits = [a, b]`, per input axis (a
/// car's speed in m/s^2 and steering in rad/s; the body accelerations may then be omitted).
/// A vehicle with steered wheels needs `input_rate_limits`.
///
/// ```
/// use drive_traits::robot::{builtin_robots, RobotSpec};
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
#[non_exhaustive]
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
    /// The protocol's lateral acceleration limit `|v w|` (m/s^2), when it has one: what
    /// keeps a fast car from spinning out (samples beyond it are redrawn, the schedule
    /// steers within it).
    pub max_lateral_acceleration: Option<f64>,
    /// Command rate (Hz).
    pub rate_hz: f64,
    /// Acceleration limit applied to the sent commands, linear (m/s^2); infinite when
    /// `input_rate_limits` apply instead.
    pub max_linear_acceleration: f64,
    /// Acceleration limit applied to the sent commands, angular (rad/s^2); infinite when
    /// `input_rate_limits` apply instead.
    pub max_angular_acceleration: f64,
    /// Rate limits applied to the sent commands per input axis (input units per second),
    /// instead of the body acceleration limits: what a car needs (speed and steering).
    pub input_rate_limits: Option<Input>,
    /// Input limits per axis, user-given or from the characterization step; the vehicle's
    /// nominal space at `max_speed` when absent.
    pub input_limits: Option<InputSpace>,
    /// The vehicle's nominal input space at `max_speed` (the manufacturer's J).
    pub nominal_input_space: InputSpace,
    /// Tracks rather than wheels.
    pub tracked: bool,
    /// The body's footprint, when known: what its moment of inertia about the vertical axis
    /// is computed from (a uniform box, [`BodySize::inertia_per_mass`]).
    pub body: Option<BodySize>,
}

/// A robot body's footprint (m): length along its x axis (forward), width along y.
///
/// ```
/// let husky = drive_traits::robot::BodySize { length_m: 0.8382, width_m: 0.6604 };
/// // A uniform box: I / m = (l^2 + w^2) / 12.
/// assert!((husky.inertia_per_mass() - 0.0949).abs() < 1e-4);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BodySize {
    /// Length along the robot's x axis (m).
    pub length_m: f64,
    /// Width along the robot's y axis (m).
    pub width_m: f64,
}

impl BodySize {
    /// The moment of inertia about the vertical axis per unit mass (m^2) of a uniform box of
    /// this footprint: `(l^2 + w^2) / 12`.
    pub fn inertia_per_mass(&self) -> f64 {
        (self.length_m * self.length_m + self.width_m * self.width_m) / 12.0
    }
}

impl RegistryItem for RobotSpec {}

impl RobotSpec {
    /// A robot of `name` with `vehicle`, `mass_kg`, the manufacturer's top speed
    /// `max_speed` (m/s) and the acceleration limits applied to the sent commands
    /// (`max_linear_acceleration` m/s^2, `max_angular_acceleration` rad/s^2): the fields a
    /// robot file requires, with its defaults for the rest (the DRIVE command rate, 20 Hz;
    /// no controller limits; wheels; no body size; the vehicle's nominal input space at
    /// that speed as its input space), changed with the `with_*` methods. `Err` names a
    /// value out of range, or a vehicle that gives no nominal input space.
    ///
    /// ```
    /// use drive_traits::robot::RobotSpec;
    /// use std::sync::Arc;
    /// let wheels = || Arc::new(drive_traits::vehicles::DifferentialDrive::new(0.1, 0.4));
    /// let robot = RobotSpec::new("mine", wheels(), 30.0, 1.5, 1.0, 3.0)
    ///     .unwrap()
    ///     .with_rate(10.0)
    ///     .unwrap();
    /// assert_eq!(robot.input_space().max.x, 15.0); // 1.5 m/s on 0.1 m wheels
    /// assert_eq!((robot.rate_hz, robot.max_angular_acceleration), (10.0, 3.0));
    /// let e = RobotSpec::new("bad", wheels(), 30.0, -1.0, 1.0, 3.0).unwrap_err();
    /// assert!(e.to_string().contains("max_speed"));
    /// ```
    pub fn new(
        name: impl Into<String>,
        vehicle: Arc<dyn CommandModel>,
        mass_kg: f64,
        max_speed: f64,
        max_linear_acceleration: f64,
        max_angular_acceleration: f64,
    ) -> Result<RobotSpec, RobotError> {
        let name = name.into();
        let invalid = |field: &'static str, message: String| RobotError::Invalid {
            file: name.clone(),
            field,
            message,
        };
        positive(mass_kg).map_err(|m| invalid("mass_kg", m))?;
        positive(max_speed).map_err(|m| invalid("max_speed", m))?;
        vehicle
            .check()
            .map_err(|m| invalid("vehicle", m.to_string()))?;
        let nominal_input_space = vehicle.nominal_input_space(max_speed).ok_or_else(|| {
            invalid(
                "vehicle",
                "the vehicle gives no nominal input space: describe the robot in a TOML file with its input limits".into(),
            )
        })?;
        RobotSpec {
            name: name.clone(),
            mass_kg,
            vehicle,
            max_speed,
            controller_max_linear: None,
            controller_max_angular: None,
            max_lateral_acceleration: None,
            rate_hz: 20.0,
            max_linear_acceleration: 1.0,
            max_angular_acceleration: 1.0,
            input_rate_limits: None,
            input_limits: None,
            nominal_input_space,
            tracked: false,
            body: None,
        }
        .with_accelerations(max_linear_acceleration, max_angular_acceleration)
    }

    /// The same robot with the acceleration limits applied to the sent commands:
    /// `linear` (m/s^2) and `angular` (rad/s^2), both positive.
    pub fn with_accelerations(mut self, linear: f64, angular: f64) -> Result<Self, RobotError> {
        for (field, v) in [
            ("max_linear_acceleration", linear),
            ("max_angular_acceleration", angular),
        ] {
            positive(v).map_err(|message| RobotError::Invalid {
                file: self.name.clone(),
                field,
                message,
            })?;
        }
        self.max_linear_acceleration = linear;
        self.max_angular_acceleration = angular;
        Ok(self)
    }

    /// The same robot commanded at `rate_hz` (Hz, positive).
    pub fn with_rate(mut self, rate_hz: f64) -> Result<Self, RobotError> {
        positive(rate_hz).map_err(|message| RobotError::Invalid {
            file: self.name.clone(),
            field: "rate_hz",
            message,
        })?;
        self.rate_hz = rate_hz;
        Ok(self)
    }

    /// The same robot with its true input limits (from a characterization, or given).
    pub fn with_input_limits(mut self, limits: InputSpace) -> Self {
        self.input_limits = Some(limits);
        self
    }

    /// The same robot with its body's footprint (for its moment of inertia).
    pub fn with_body(mut self, body: BodySize) -> Self {
        self.body = Some(body);
        self
    }

    /// The same robot on tracks rather than wheels.
    pub fn tracked(mut self) -> Self {
        self.tracked = true;
        self
    }

    /// The same robot behind a low-level controller that caps the body velocity at
    /// `linear` (m/s) and `angular` (rad/s), each positive when given.
    pub fn with_controller_limits(
        mut self,
        linear: Option<f64>,
        angular: Option<f64>,
    ) -> Result<Self, RobotError> {
        for (field, v) in [
            ("controller_max_linear", linear),
            ("controller_max_angular", angular),
        ] {
            if let Some(v) = v {
                positive(v).map_err(|message| RobotError::Invalid {
                    file: self.name.clone(),
                    field,
                    message,
                })?;
            }
        }
        self.controller_max_linear = linear;
        self.controller_max_angular = angular;
        Ok(self)
    }

    /// The same robot with the protocol's lateral acceleration limit `|v w|` (m/s^2,
    /// positive): what keeps a fast car from spinning out.
    pub fn with_lateral_acceleration(mut self, limit: f64) -> Result<Self, RobotError> {
        positive(limit).map_err(|message| RobotError::Invalid {
            file: self.name.clone(),
            field: "max_lateral_acceleration",
            message,
        })?;
        self.max_lateral_acceleration = Some(limit);
        Ok(self)
    }

    /// The same robot with rate limits on its sent commands per input axis (input units per
    /// second, each positive) instead of body acceleration limits, which no longer apply
    /// (they become infinite): what a car needs for its speed and steering.
    ///
    /// ```
    /// use drive_traits::robot::RobotSpec;
    /// use drive_traits::Input;
    /// use std::sync::Arc;
    /// let car = Arc::new(drive_traits::vehicles::Ackermann::new(0.33, 0.42));
    /// let robot = RobotSpec::new("small", car, 3.5, 3.0, 3.0, 6.0).unwrap()
    ///     .with_input_rate_limits(Input::new(3.0, 6.0, 0.0)).unwrap()
    ///     .with_lateral_acceleration(2.5).unwrap();
    /// assert_eq!(robot.input_rate_limits, Some(Input::new(3.0, 6.0, 0.0)));
    /// assert!(robot.max_linear_acceleration.is_infinite());
    /// ```
    pub fn with_input_rate_limits(mut self, rates: Input) -> Result<Self, RobotError> {
        let dim = self.vehicle.input_dim();
        if !(rates.iter().take(dim).all(|v| v.is_finite() && *v > 0.0)
            && rates.iter().skip(dim).all(|v| *v == 0.0))
        {
            return Err(RobotError::Invalid {
                file: self.name.clone(),
                field: "input_rate_limits",
                message: format!(
                    "expected positive rates on each of the vehicle's {dim} input axes, found {:?}",
                    rates.as_slice()
                ),
            });
        }
        self.input_rate_limits = Some(rates);
        self.max_linear_acceleration = f64::INFINITY;
        self.max_angular_acceleration = f64::INFINITY;
        Ok(self)
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
        // The name is written into sidecars and printed: no control character (an escape
        // sequence would reach the terminal raw, and the sidecar's reader refuses it).
        if crate::limits::breaks_text(&self.name) {
            return invalid("name", "holds a control character");
        }
        let positive: [(&'static str, f64); 3] = [
            ("mass_kg", self.mass_kg),
            ("max_speed", self.max_speed),
            ("rate_hz", self.rate_hz),
        ];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return invalid(
                    field,
                    &format!("expected a positive number, found {}", Short(v)),
                );
            }
        }
        if self.max_speed < MIN_SPEED_MPS {
            return invalid(
                "max_speed",
                &format!(
                    "{} m/s is below {MIN_SPEED_MPS} m/s: a speed in another unit (km/s?)",
                    Short(self.max_speed)
                ),
            );
        }
        // The body limits are infinite only where per-axis rate limits replace them.
        for (field, v) in [
            ("max_linear_acceleration", self.max_linear_acceleration),
            ("max_angular_acceleration", self.max_angular_acceleration),
        ] {
            let ok = v > 0.0 && (v.is_finite() || self.input_rate_limits.is_some());
            if !ok {
                return invalid(
                    field,
                    &format!("expected a positive number, found {}", Short(v)),
                );
            }
        }
        if let Some(r) = self.input_rate_limits {
            let dim = self.vehicle.input_dim();
            if !(r.iter().take(dim).all(|v| v.is_finite() && *v > 0.0)
                && r.iter().skip(dim).all(|v| *v == 0.0))
            {
                let shown: Vec<String> =
                    r.iter().take(dim).map(|v| Short(*v).to_string()).collect();
                return invalid(
                    "input_rate_limits",
                    &format!(
                        "expected one positive rate per input axis ({dim}), found [{}]",
                        shown.join(", ")
                    ),
                );
            }
        }
        if self.rate_hz > limits::MAX_RATE_HZ {
            return invalid(
                "rate_hz",
                &format!(
                    "{} Hz is more than the limit of {} Hz",
                    Short(self.rate_hz),
                    limits::MAX_RATE_HZ
                ),
            );
        }
        if self.rate_hz * crate::WINDOW_S < 2.0 {
            return invalid(
                "rate_hz",
                &format!(
                    "{} Hz gives fewer than 2 samples per {} s window; expected at least {} Hz",
                    Short(self.rate_hz),
                    crate::WINDOW_S,
                    2.0 / crate::WINDOW_S
                ),
            );
        }
        for (field, v) in [
            ("controller_max_linear", self.controller_max_linear),
            ("controller_max_angular", self.controller_max_angular),
            ("max_lateral_acceleration", self.max_lateral_acceleration),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return invalid(
                        field,
                        &format!("expected a positive number, found {}", Short(v)),
                    );
                }
            }
        }
        if let Some(b) = self.body {
            for (field, v) in [("body_length", b.length_m), ("body_width", b.width_m)] {
                if !(v.is_finite() && v > 0.0 && v <= 100.0) {
                    return invalid(
                        field,
                        &format!("expected a length in m in (0, 100], found {}", Short(v)),
                    );
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

    /// The controller's body limits (speeds, lateral acceleration), when it has some.
    pub fn body_limits(&self) -> Option<BodyLimits> {
        let limits = [
            self.controller_max_linear,
            self.controller_max_angular,
            self.max_lateral_acceleration,
        ];
        limits.iter().any(Option::is_some).then(|| BodyLimits {
            vehicle: Arc::clone(&self.vehicle),
            max_linear: limits[0].unwrap_or(f64::INFINITY),
            max_angular: limits[1].unwrap_or(f64::INFINITY),
            max_lateral_acceleration: limits[2].unwrap_or(f64::INFINITY),
        })
    }

    /// The input space J used by the protocol: the given input limits, or the vehicle's
    /// nominal (manufacturer's) space at `max_speed`.
    pub fn input_space(&self) -> InputSpace {
        self.input_limits.unwrap_or(self.nominal_input_space)
    }
}

/// `Err` unless `v` is a finite positive number.
fn positive(v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{v} is not a positive number"))
    }
}
