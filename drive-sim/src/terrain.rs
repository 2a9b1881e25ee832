//! Terrain presets: the parameters of the traction, skid and rolling-resistance models.
//!
//! Values are typical figures from the terramechanics literature (Wong, *Theory of Ground
//! Vehicles*, 4th ed., 2008, tables of traction and rolling-resistance coefficients;
//! Janosi and Hanamoto 1961 for the shear-deformation modulus), chosen once, per terrain,
//! not tuned to make any protocol or model win.

use crate::{ControllerParams, PowertrainParams, Sensors, TurnStall, TwinProtocol};
use drive_traits::{Registry, RegistryError, RegistryItem};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use thiserror::Error;

/// The shortest contact spread a terrain may give (a share of the baseline,
/// [`Terrain::contact_spread`]).
pub const MIN_CONTACT_SPREAD: f64 = 0.1;
/// The longest contact spread a terrain may give (a share of the baseline).
pub const MAX_CONTACT_SPREAD: f64 = 3.0;

/// The ground's parameters, and, for a fitted twin of a real robot (`drive sim-fit`), the
/// robot's powertrain, controller, sensors and the protocol its real run followed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Terrain {
    /// Name.
    pub name: String,
    /// Peak longitudinal traction coefficient mu_x (traction / normal load): the friction
    /// ellipse's semi-axis along the wheel.
    pub traction: f64,
    /// Slip at which 63% of the peak friction is reached (shear-deformation modulus over
    /// contact length, as a slip ratio): small on firm ground, large on loose or soft ground.
    pub slip_modulus: f64,
    /// The same across the wheel, when it differs (a tyre's cornering stiffness is not its
    /// longitudinal stiffness); `slip_modulus` when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lateral_slip_modulus: Option<f64>,
    /// Lateral friction coefficient mu_y: the friction ellipse's semi-axis across the
    /// wheel (what turning a skid-steer scrubs against).
    pub lateral: f64,
    /// Rolling-resistance coefficient.
    pub rolling: f64,
    /// How far apart along each side the ground holds the wheels or the track: the contacts'
    /// spread as a share of the baseline (the lever arm of the turning resistance a
    /// skid-steer scrubs against); the vehicle's own when absent (0.9 for wheels, 1.1 for
    /// tracks: [`VehicleParams::from_spec`](crate::VehicleParams::from_spec)). A fitted
    /// twin has one when its check chose it (`drive_studies::fit_twin`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_spread: Option<f64>,
    /// The motors of a fitted twin (the robot's defaults when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub powertrain: Option<PowertrainParams>,
    /// The low-level controller of a fitted twin (the identity when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller: Option<ControllerParams>,
    /// The sensors of a fitted twin ([`Sensors::default`] when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensors: Option<Sensors>,
    /// How the grip varies in time around the coefficients above (none when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variability: Option<Variability>,
    /// How the ground holds a turn at its start (none when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_stall: Option<TurnStall>,
    /// How a fitted twin's real run commanded the robot: the input space it sampled and how
    /// its commands changed (the characterization is skipped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub protocol: Option<TwinProtocol>,
    /// The vehicle a twin of another type than the differential drive was fitted for
    /// (`drive sim-fit`'s ground fit): a robot of another type or geometry is refused it,
    /// as a skid-steer twin's protocol refuses another geometry.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fitted_for: Option<FittedVehicle>,
}

/// The vehicle a twin was fitted for: its type and its geometry as the vehicle writes them.
///
/// ```
/// use drive_sim::FittedVehicle;
/// let base = drive_traits::robot::ridgeback();
/// let fitted = FittedVehicle::of(base.vehicle.as_ref());
/// assert_eq!(fitted.vehicle, "omnidirectional");
/// assert!(fitted.refuses(base.vehicle.as_ref()).is_none());
/// let husky = drive_traits::vehicles::DifferentialDrive::new(0.165, 0.55);
/// assert!(fitted.refuses(&husky).unwrap().contains("'differential'"));
/// // A record no fit writes drives nothing.
/// let broken = FittedVehicle { geometry: "notjson".into(), ..fitted };
/// assert!(broken.refuses(base.vehicle.as_ref()).is_some());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedVehicle {
    /// The vehicle's type (`omnidirectional`, `ackermann`, a plug-in's).
    pub vehicle: String,
    /// Its geometry, as the vehicle serializes itself (JSON text).
    pub geometry: String,
}

impl FittedVehicle {
    /// The record of `vehicle`.
    pub fn of(vehicle: &dyn drive_traits::CommandModel) -> Self {
        FittedVehicle {
            vehicle: drive_traits::vehicle_tag(vehicle).unwrap_or_default(),
            geometry: serde_json::to_string(vehicle).unwrap_or_default(),
        }
    }

    /// Why a twin fitted for this vehicle cannot drive `vehicle`: another type, or a
    /// geometry more than 1% away in any of its numbers; `None` when it can.
    pub fn refuses(&self, vehicle: &dyn drive_traits::CommandModel) -> Option<String> {
        let theirs = drive_traits::vehicle_tag(vehicle).unwrap_or_default();
        if theirs != self.vehicle {
            return Some(format!(
                "it is a twin of a vehicle of type '{}'; this robot's is of type '{theirs}'",
                self.vehicle
            ));
        }
        let ours: serde_json::Value = match serde_json::from_str::<serde_json::Value>(&self.geometry) {
            Ok(v) if v.get("type").and_then(|t| t.as_str()) == Some(self.vehicle.as_str()) => v,
            // A record no fit writes cannot say which robots the twin drives: none.
            _ => {
                return Some(format!(
                    "its fitted_for.geometry is not the JSON of a '{}' vehicle (what drive sim-fit writes)",
                    self.vehicle
                ))
            }
        };
        let theirs = serde_json::to_value(vehicle).ok()?;
        (!close(&ours, &theirs)).then(|| {
            format!(
                "it is a twin of the vehicle {ours}; this robot's is {theirs} (more than 1% apart)"
            )
        })
    }
}

/// Whether two vehicles' JSON agree: the same keys and strings, numbers within 1%.
fn close(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    use serde_json::Value;
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            (x - y).abs() <= 0.01 * x.abs().max(y.abs())
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| close(v, w)))
        }
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(v, w)| close(v, w))
        }
        _ => a == b,
    }
}

/// How the ground varies in time: the traction and lateral friction coefficients and the
/// rolling resistance are multiplied by `exp(x - s^2 / 2)`, each `x` a first-order
/// Gauss-Markov (Ornstein-Uhlenbeck) process of standard deviation `s` (`traction`,
/// `lateral` or `rolling`, 0 when absent) and correlation time `correlation_time`,
/// independent of each other, advanced once per command tick. The factors' mean is one: the
/// terrain's coefficients are the means.
///
/// Real runs need it: on the bundled Husky data the steady yaw rate scatters by 0.14 rad/s
/// around any smooth function of the measured wheel speeds (the IMU agrees, so it is motion,
/// not localization noise), growing with the turn rate, uncorrelated with position,
/// heading or time, and correlated within an interval (0.65 between its two steady
/// windows): the turning resistance changes from one moment to the next. `drive sim-fit`
/// fits the three numbers so that a twin's scatter is the real run's.
///
/// ```
/// let t = drive_sim::Terrain::from_toml("patchy.toml",
///     "name = 'patchy'\ntraction = 0.4\nslip_modulus = 0.1\nlateral = 0.3\nrolling = 0.03\n\
///      [variability]\ntraction = 0.1\nlateral = 0.3\ncorrelation_time = 4.0\n").unwrap();
/// assert_eq!(t.variability.unwrap().correlation_time, 4.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variability {
    /// Standard deviation of the log of the traction coefficient.
    #[serde(default)]
    pub traction: f64,
    /// Standard deviation of the log of the lateral friction coefficient.
    #[serde(default)]
    pub lateral: f64,
    /// Standard deviation of the log of the rolling resistance.
    #[serde(default)]
    pub rolling: f64,
    /// Correlation time of the three (s).
    pub correlation_time: f64,
}

impl Variability {
    /// The three standard deviations: traction, lateral, rolling.
    pub fn deviations(&self) -> [f64; 3] {
        [self.traction, self.lateral, self.rolling]
    }
}

/// Why a terrain file is refused.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TerrainError {
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
    /// No registered terrain of that name, and no such file.
    #[error(transparent)]
    Registry(#[from] RegistryError),
}

impl Terrain {
    /// `tile`, `gravel`, `snow` or `ice`.
    ///
    /// ```
    /// let ice = drive_sim::Terrain::preset("ice").unwrap();
    /// assert!(ice.traction < drive_sim::Terrain::preset("tile").unwrap().traction / 5.0);
    /// ```
    pub fn preset(name: &str) -> Option<Terrain> {
        Some(match name {
            // Dry indoor tile / concrete: firm, high friction, low rolling resistance.
            "tile" => Terrain {
                name: "tile".into(),
                traction: 0.8,
                slip_modulus: 0.04,
                lateral: 0.6,
                rolling: 0.015,
                ..Terrain::plain()
            },
            // Loose gravel: medium friction, soft shear response, higher rolling resistance.
            "gravel" => Terrain {
                name: "gravel".into(),
                traction: 0.55,
                slip_modulus: 0.12,
                lateral: 0.5,
                rolling: 0.05,
                ..Terrain::plain()
            },
            // Packed snow: low friction, soft, high rolling resistance (compaction).
            "snow" => Terrain {
                name: "snow".into(),
                traction: 0.3,
                slip_modulus: 0.2,
                lateral: 0.25,
                rolling: 0.08,
                ..Terrain::plain()
            },
            // Resurfaced ice rink: extreme slip.
            "ice" => Terrain {
                name: "ice".into(),
                traction: 0.08,
                slip_modulus: 0.06,
                lateral: 0.05,
                rolling: 0.01,
                ..Terrain::plain()
            },
            _ => return None,
        })
    }

    /// The preset names.
    pub const NAMES: [&'static str; 4] = ["tile", "gravel", "snow", "ice"];

    /// A ground with no twin parts (the fields the presets leave out).
    fn plain() -> Terrain {
        Terrain {
            name: String::new(),
            traction: 0.5,
            slip_modulus: 0.1,
            lateral_slip_modulus: None,
            lateral: 0.5,
            rolling: 0.02,
            contact_spread: None,
            powertrain: None,
            controller: None,
            sensors: None,
            variability: None,
            turn_stall: None,
            protocol: None,
            fitted_for: None,
        }
    }

    /// A terrain from a TOML file's text (what `drive sim-fit` writes): the ground's
    /// `name`, `traction`, `slip_modulus`, `lateral`, `rolling`, optionally
    /// `lateral_slip_modulus` and `contact_spread`, and optionally the tables
    /// `[powertrain]`, `[controller]`, `[sensors]`, `[variability]`, `[turn_stall]` and
    /// `[protocol]`.
    ///
    /// ```
    /// let t = drive_sim::Terrain::from_toml("wet.toml",
    ///     "name = 'wet grass'\ntraction = 0.4\nslip_modulus = 0.15\nlateral = 0.35\nrolling = 0.06\n").unwrap();
    /// assert_eq!(t.name, "wet grass");
    /// assert!(drive_sim::Terrain::from_toml("bad.toml", "name = 'x'\ntraction = -1\nslip_modulus = 0.1\nlateral = 0.3\nrolling = 0.0\n").is_err());
    /// ```
    pub fn from_toml(file: &str, text: &str) -> Result<Terrain, TerrainError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let t: Terrain = toml::from_str(text).map_err(|e| TerrainError::Parse {
            file: file.to_string(),
            message: drive_traits::exact::parse_message(
                text,
                e.message(),
                e.span().map(|s| s.start),
            ),
        })?;
        t.validate(file)?;
        // A fitted robot's parts ([powertrain], [controller]: a twin's) without the record
        // of the robot they were fitted for ([protocol], [fitted_for]) would drive any robot
        // with another's motors: the geometry check lives in that record.
        if (t.powertrain.is_some() || t.controller.is_some())
            && t.protocol.is_none()
            && t.fitted_for.is_none()
        {
            return Err(TerrainError::Invalid {
                file: file.to_string(),
                field: "protocol",
                message: "a terrain with a [powertrain] or [controller] section (a twin's, fitted to one robot) needs the [protocol] section that records the robot it was fitted for (its wheel radius and baseline), as drive sim-fit writes it".into(),
            });
        }
        Ok(t)
    }

    /// The terrain as the TOML text [`Terrain::from_toml`] reads.
    pub fn to_toml(&self) -> String {
        // A terrain is plain numbers and strings: it always serializes.
        toml::to_string(self).unwrap_or_default()
    }

    /// A registered terrain, or a terrain TOML file (a path, or a name ending in `.toml`).
    pub fn load(terrains: &Registry<Terrain>, name_or_path: &str) -> Result<Terrain, TerrainError> {
        if let Some(t) = terrains.find(name_or_path) {
            return Ok(t.part().as_ref().clone());
        }
        let path = std::path::Path::new(name_or_path);
        if name_or_path.ends_with(".toml") || path.exists() {
            // A terrain file is a few tables of TOML.
            let text =
                drive_traits::files::read_text(path, 1 << 20).map_err(|e| TerrainError::Parse {
                    file: name_or_path.to_string(),
                    message: format!("cannot read: {e}"),
                })?;
            return Terrain::from_toml(name_or_path, &text);
        }
        // A path (a folder or an extension in it) names a file, not a terrain: a missing
        // dataset given for a twin was called an unknown terrain.
        if path.extension().is_some() || name_or_path.contains(['/', '\\']) {
            return Err(TerrainError::Parse {
                file: name_or_path.to_string(),
                message: format!(
                    "no such file (a terrain is a terrain TOML file, as drive sim-fit writes, or a registered terrain: {})",
                    terrains.names().join(", ")
                ),
            });
        }
        Err(terrains.get(name_or_path).err().map_or_else(
            || TerrainError::Parse {
                file: name_or_path.to_string(),
                message: "no such terrain".into(),
            },
            TerrainError::from,
        ))
    }

    /// Whether `name` can name a terrain: 1 to 200 characters (not all blank), without
    /// control characters (it is in every output line and in a simulated run's sidecar).
    ///
    /// ```
    /// assert!(drive_sim::Terrain::is_valid_name("gravel twin"));
    /// assert!(!drive_sim::Terrain::is_valid_name(" ") && !drive_sim::Terrain::is_valid_name("a\nb"));
    /// assert!(!drive_sim::Terrain::is_valid_name("a\u{2028}b")); // a line separator
    /// ```
    pub fn is_valid_name(name: &str) -> bool {
        !name.trim().is_empty()
            && name.chars().count() <= 200
            // Nor a line or paragraph separator (U+2028, U+2029): a name is one line.
            && !drive_traits::limits::breaks_text(name)
    }

    fn validate(&self, file: &str) -> Result<(), TerrainError> {
        let bad = |field: &'static str, message: String| TerrainError::Invalid {
            file: file.to_string(),
            field,
            message,
        };
        // The name is in every output line and in the sidecar of every run simulated on it
        // (whose reader holds it to the same rule).
        if !Terrain::is_valid_name(&self.name) {
            return Err(bad(
                "name",
                "must be 1 to 200 characters without control characters".into(),
            ));
        }
        // Within `lo` (excluded, or included when `closed`) and `hi` (included).
        let within = |field: &'static str, v: f64, lo: f64, hi: f64, closed: bool| {
            if v.is_finite() && (v > lo || (closed && v == lo)) && v <= hi {
                Ok(())
            } else {
                let open = if closed { '[' } else { '(' };
                Err(bad(
                    field,
                    format!(
                        "must be in {open}{lo}, {hi}], got {}",
                        drive_traits::limits::Short(v)
                    ),
                ))
            }
        };
        let range = |field, v, lo, hi| within(field, v, lo, hi, false);
        let closed = |field, v, lo, hi| within(field, v, lo, hi, true);
        range("traction", self.traction, 0.0, 5.0)?;
        range("lateral", self.lateral, 0.0, 5.0)?;
        range("slip_modulus", self.slip_modulus, 0.0, 10.0)?;
        if let Some(k) = self.lateral_slip_modulus {
            range("lateral_slip_modulus", k, 0.0, 10.0)?;
        }
        if let Some(s) = self.contact_spread {
            closed("contact_spread", s, MIN_CONTACT_SPREAD, MAX_CONTACT_SPREAD)?;
        }
        if !(self.rolling.is_finite() && (0.0..1.0).contains(&self.rolling)) {
            return Err(bad(
                "rolling",
                format!(
                    "must be in [0, 1), got {}",
                    drive_traits::limits::Short(self.rolling)
                ),
            ));
        }
        if let Some(p) = &self.powertrain {
            for (field, v, hi) in [
                ("powertrain.time_constant", p.time_constant[0], 100.0),
                ("powertrain.time_constant", p.time_constant[1], 100.0),
                ("powertrain.right_lag", p.right_lag, 10.0),
                ("powertrain.right_gain", p.right_gain, 10.0),
                ("powertrain.wheel_limit", p.wheel_limit, 1e4),
                ("powertrain.acceleration_limit", p.acceleration_limit, 1e6),
                ("powertrain.torque_limit", p.torque_limit, 1e6),
                ("powertrain.inertia", p.inertia, 1e4),
            ] {
                range(field, v, 0.0, hi)?;
            }
            if !(p.dead_time.is_finite() && (0.0..=10.0).contains(&p.dead_time)) {
                return Err(bad(
                    "powertrain.dead_time",
                    format!(
                        "must be in [0, 10] s, got {}",
                        drive_traits::limits::Short(p.dead_time)
                    ),
                ));
            }
        }
        if let Some(c) = &self.controller {
            range("controller.linear_gain", c.linear_gain, 0.0, 100.0)?;
            range("controller.angular_gain", c.angular_gain, 0.0, 100.0)?;
            if let Some(m) = c.max_linear {
                range("controller.max_linear", m, 0.0, 1e4)?;
            }
            if let Some(m) = c.max_angular {
                range("controller.max_angular", m, 0.0, 1e4)?;
            }
            if let Some(a) = c.max_linear_acceleration {
                range("controller.max_linear_acceleration", a, 0.0, 1e6)?;
            }
            if let Some(a) = c.max_angular_acceleration {
                range("controller.max_angular_acceleration", a, 0.0, 1e6)?;
            }
        }
        if let Some(s) = &self.sensors {
            range("sensors.icp_rate_hz", s.icp_rate_hz, 0.0, 1000.0)?;
            for (field, v) in [
                ("sensors.encoder_noise", s.encoder_noise),
                ("sensors.icp_noise", s.icp_noise[0]),
                ("sensors.icp_noise", s.icp_noise[1]),
                ("sensors.icp_latency", s.icp_latency),
                ("sensors.icp_jitter", s.icp_jitter),
                ("sensors.imu_noise", s.imu_noise),
            ] {
                closed(field, v, 0.0, 100.0)?;
            }
            if !s
                .icp_mount
                .iter()
                .all(|v| v.is_finite() && v.abs() <= 100.0)
            {
                return Err(bad(
                    "sensors.icp_mount",
                    format!(
                        "each of forward (m), left (m) and yaw (rad) must be within +-100, got [{}, {}, {}]",
                        drive_traits::limits::Short(s.icp_mount[0]),
                        drive_traits::limits::Short(s.icp_mount[1]),
                        drive_traits::limits::Short(s.icp_mount[2])
                    ),
                ));
            }
            if !s
                .icp_gaps
                .iter()
                .all(|g| g.is_finite() && (0.0..=1.0).contains(g))
            {
                return Err(bad(
                    "sensors.icp_gaps",
                    format!(
                        "each share must be in [0, 1] ({} bins of {} s), got {:?}",
                        crate::ICP_GAP_BINS,
                        crate::ICP_GAP_STEP_S,
                        s.icp_gaps
                    ),
                ));
            }
            if !(s.imu_bias.is_finite() && s.imu_bias.abs() <= 100.0) {
                return Err(bad(
                    "sensors.imu_bias",
                    format!(
                        "must be within +-100 rad/s, got {}",
                        drive_traits::limits::Short(s.imu_bias)
                    ),
                ));
            }
        }
        if let Some(v) = &self.variability {
            for (field, value) in [
                ("variability.traction", v.traction),
                ("variability.lateral", v.lateral),
                ("variability.rolling", v.rolling),
            ] {
                closed(field, value, 0.0, 3.0)?;
            }
            range("variability.correlation_time", v.correlation_time, 0.0, 1e4)?;
        }
        if let Some(s) = &self.turn_stall {
            for (field, value) in [
                ("turn_stall.probability", s.probability),
                ("turn_stall.share", s.share),
            ] {
                closed(field, value, 0.0, 1.0)?;
            }
        }
        if let Some(p) = &self.protocol {
            range(
                "protocol.robot_wheel_radius",
                p.robot_wheel_radius,
                0.0,
                1e3,
            )?;
            range("protocol.robot_baseline", p.robot_baseline, 0.0, 1e3)?;
            // Within a factor of 100 of the robot's: beyond, the recorded commands would be
            // far outside anything the robot could be sent.
            range(
                "protocol.baseline",
                p.baseline,
                p.robot_baseline / 100.0,
                100.0 * p.robot_baseline,
            )?;
            let axes = p.input_limits.map(|a| ("protocol.input_limits", a));
            let body = p
                .body_limits
                .map(|b| b.map(|a| ("protocol.body_limits", a)));
            for (field, axis) in axes.into_iter().chain(body.into_iter().flatten()) {
                if !(axis[0].is_finite()
                    && axis[1].is_finite()
                    && axis[0] < axis[1]
                    && axis[0].abs().max(axis[1].abs()) <= 1e6)
                {
                    return Err(bad(
                        field,
                        format!(
                            "each axis must be [min, max] with min < max, finite, got {axis:?}"
                        ),
                    ));
                }
            }
            // The rectangle must hold body velocities the box reaches (in the robot's
            // geometry: the box's mean wheel speed gives the forward speed, its difference
            // over the protocol's baseline the yaw rate); a draw outside both would be moved
            // into the rectangle, outside the box.
            if let Some([v, w]) = p.body_limits {
                let [l, r] = p.input_limits;
                let radius = p.robot_wheel_radius;
                let speeds = [radius * (l[0] + r[0]) / 2.0, radius * (l[1] + r[1]) / 2.0];
                let rates = [
                    radius * (r[0] - l[1]) / p.baseline,
                    radius * (r[1] - l[0]) / p.baseline,
                ];
                if v[1] < speeds[0] || v[0] > speeds[1] || w[1] < rates[0] || w[0] > rates[1] {
                    return Err(bad(
                        "protocol.body_limits",
                        format!(
                            "holds no body velocity input_limits reach (forward speeds [{:.3}, {:.3}] m/s, yaw rates [{:.3}, {:.3}] rad/s)",
                            speeds[0], speeds[1], rates[0], rates[1]
                        ),
                    ));
                }
            }
            for (field, v) in [
                (
                    "protocol.max_linear_acceleration",
                    p.max_linear_acceleration,
                ),
                (
                    "protocol.max_angular_acceleration",
                    p.max_angular_acceleration,
                ),
            ] {
                if let Some(v) = v {
                    range(field, v, 0.0, 1e6)?;
                }
            }
        }
        Ok(())
    }
}

impl RegistryItem for Terrain {}

/// The terrain presets by name: `tile`, `gravel`, `snow`, `ice` (see [`Terrain::preset`]).
///
/// ```
/// let terrains = drive_sim::builtin_terrains();
/// assert_eq!(terrains.names(), ["tile", "gravel", "snow", "ice"]);
/// ```
pub fn builtin_terrains() -> Registry<Terrain> {
    let mut r: Registry<Terrain> = Registry::new("terrain");
    for (name, description) in [
        ("tile", "dry indoor tile or concrete: firm, high friction"),
        (
            "gravel",
            "loose gravel: medium friction, soft shear response",
        ),
        (
            "snow",
            "packed snow: low friction, soft, high rolling resistance",
        ),
        ("ice", "resurfaced ice rink: extreme slip"),
    ] {
        // The four presets exist under distinct names.
        let t = Terrain::preset(name).expect("a preset");
        r.register_trusted(name, description, Arc::new(t))
            .expect("distinct presets");
    }
    r
}
