//! A robot file: the TOML a user writes ([`RobotSpec::from_toml`]), and a robot named by
//! a preset's name or a file's path ([`RobotSpec::load`]).

use super::*;

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
    #[serde(default)]
    max_lateral_acceleration: Option<f64>,
    #[serde(default = "default_rate")]
    rate_hz: f64,
    #[serde(default)]
    max_linear_acceleration: Option<f64>,
    #[serde(default)]
    max_angular_acceleration: Option<f64>,
    #[serde(default, deserialize_with = "crate::exact::option_axes")]
    input_rate_limits: Option<Vec<f64>>,
    #[serde(default, deserialize_with = "crate::exact::option_array")]
    wheel_limits: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "crate::exact::option_min_max_pairs")]
    input_limits: Option<Vec<[f64; 2]>>,
    #[serde(default)]
    tracked: bool,
    #[serde(default)]
    body_length: Option<f64>,
    #[serde(default)]
    body_width: Option<f64>,
}

fn default_rate() -> f64 {
    20.0
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
        let f: RobotFile = toml::from_str(text).map_err(|e| {
            parse(crate::exact::parse_message(
                text,
                e.message(),
                e.span().map(|s| s.start),
            ))
        })?;
        let vehicle: Arc<dyn CommandModel> = match (&f.vehicle, f.wheel_radius, f.baseline) {
            (Some(v), None, None) => {
                if let Some((key, x)) = non_finite(v, "vehicle") {
                    return Err(invalid(
                        "vehicle",
                        format!("{key} = {} is not a finite number", Short(x)),
                    ));
                }
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
        vehicle
            .check()
            .map_err(|e| invalid("vehicle", e.to_string()))?;
        let axis_limits = match (f.wheel_limits, f.input_limits) {
            (Some(_), Some(_)) => {
                return Err(invalid(
                    "wheel_limits",
                    "give wheel_limits or input_limits, not both".into(),
                ))
            }
            (Some(_), None)
                if vehicle_tag(vehicle.as_ref()).as_deref() != Some(DifferentialDrive::TAG) =>
            {
                let axes: Vec<String> = vehicle
                    .axes()
                    .iter()
                    .map(|a| format!("{} [{}]", a.name, a.unit))
                    .collect();
                return Err(invalid(
                    "wheel_limits",
                    format!(
                        "wheel_limits gives both wheels of a differential drive one range; this vehicle's axes are {}: give input_limits = [{}]",
                        axes.join(", "),
                        vec!["[min, max]"; axes.len()].join(", ")
                    ),
                ));
            }
            (Some([lo, hi]), None) => Some(("wheel_limits", vec![[lo, hi], [lo, hi]])),
            (None, Some(l)) => Some(("input_limits", l)),
            (None, None) => None,
        };
        let dim = vehicle.input_dim();
        let mut input_limits = None;
        if let Some((field, pairs)) = axis_limits {
            let shown = pairs
                .iter()
                .map(|[a, b]| format!("[{}, {}]", Short(*a), Short(*b)))
                .collect::<Vec<_>>()
                .join(", ");
            if pairs.len() != dim {
                return Err(invalid(
                    field,
                    format!(
                        "expected one [min, max] pair per input axis of the vehicle ({dim}), found {}: [{shown}]",
                        pairs.len()
                    ),
                ));
            }
            let finite = pairs.iter().flatten().all(|v| v.is_finite());
            if finite && !pairs.iter().all(|[a, b]| (b - a).is_finite()) {
                return Err(invalid(
                    field,
                    format!("a range wider than the largest number: [{shown}]"),
                ));
            }
            let ok = finite && pairs.iter().all(|[a, b]| a < b);
            if !ok {
                let [a0s, a1s] = pairs[0].map(Short);
                return Err(invalid(
                    field,
                    if field == "wheel_limits" {
                        format!("expected [omega_min, omega_max] with omega_min < omega_max, found [{a0s}, {a1s}]")
                    } else {
                        format!("expected [min, max] with min < max on each axis, found [{shown}]")
                    },
                ));
            }
            let (mut lo, mut hi) = (Input::zeros(), Input::zeros());
            for (i, [a, b]) in pairs.iter().enumerate() {
                lo[i] = *a;
                hi[i] = *b;
            }
            input_limits = InputSpace::new(lo, hi);
            if let Some(space) = &input_limits {
                vehicle
                    .check_input_space(space)
                    .map_err(|e| invalid(field, e.to_string()))?;
            }
        }
        if !(f.max_speed.is_finite() && f.max_speed > 0.0) {
            return Err(invalid(
                "max_speed",
                format!("expected a positive number, found {}", Short(f.max_speed)),
            ));
        }
        if f.max_speed < super::MIN_SPEED_MPS {
            return Err(invalid(
                "max_speed",
                format!(
                    "{} m/s is below {} m/s: a speed in another unit (km/s?)",
                    Short(f.max_speed),
                    super::MIN_SPEED_MPS
                ),
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
                        Short(f.max_speed)
                    ),
                ))
            }
            (None, None) => {
                return Err(invalid(
                    "input_limits",
                    format!(
                        "this vehicle has no nominal input space: give input_limits = [{}]",
                        vec!["[min, max]"; dim].join(", ")
                    ),
                ))
            }
        };
        let input_rate_limits = match f.input_rate_limits {
            Some(rates) => {
                if !(rates.len() == dim && rates.iter().all(|v| v.is_finite() && *v > 0.0)) {
                    return Err(invalid(
                        "input_rate_limits",
                        format!(
                            "expected one positive rate per input axis of the vehicle ({dim}), found {rates:?}"
                        ),
                    ));
                }
                let mut limits = Input::zeros();
                for (i, r) in rates.iter().enumerate() {
                    limits[i] = *r;
                }
                Some(limits)
            }
            None if vehicle.steering() == Steering::Wheels => {
                return Err(invalid(
                    "input_rate_limits",
                    "missing: a vehicle with steered wheels needs input_rate_limits = [speed rate, steering rate] (m/s^2, rad/s); body acceleration limits would move its steering in jumps".into(),
                ))
            }
            None => None,
        };
        let body_limit = |field: &'static str, v: Option<f64>| match (v, input_rate_limits) {
            (Some(v), _) => Ok(v),
            (None, Some(_)) => Ok(f64::INFINITY),
            (None, None) => Err(invalid(
                field,
                format!("missing field `{field}` (or give input_rate_limits)"),
            )),
        };
        let body = match (f.body_length, f.body_width) {
            (Some(length_m), Some(width_m)) => Some(BodySize { length_m, width_m }),
            (None, None) => None,
            (Some(_), None) => {
                return Err(invalid(
                    "body_width",
                    "missing field `body_width` (give body_length and body_width together)".into(),
                ))
            }
            (None, Some(_)) => {
                return Err(invalid(
                    "body_length",
                    "missing field `body_length` (give body_length and body_width together)".into(),
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
            max_lateral_acceleration: f.max_lateral_acceleration,
            rate_hz: f.rate_hz,
            max_linear_acceleration: body_limit(
                "max_linear_acceleration",
                f.max_linear_acceleration,
            )?,
            max_angular_acceleration: body_limit(
                "max_angular_acceleration",
                f.max_angular_acceleration,
            )?,
            input_rate_limits,
            input_limits,
            nominal_input_space: nominal,
            tracked: f.tracked,
            body,
        };
        spec.validate(file)?;
        Ok(spec)
    }

    /// A registered robot by name, or a TOML file by path.
    pub fn load(robots: &Registry<RobotSpec>, name_or_path: &str) -> Result<RobotSpec, RobotError> {
        if Self::file_of(name_or_path).is_some() {
            // A robot file is a few lines of TOML.
            let text = crate::files::read_text(std::path::Path::new(name_or_path), 1 << 20)
                .map_err(|e| RobotError::Parse {
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

    /// The robot file `name_or_path` names, if it names a file rather than a registered
    /// robot (what [`RobotSpec::load`] reads): a `.toml` path, or any existing file (a folder
    /// named like a robot does not hide it).
    ///
    /// ```
    /// use drive_traits::robot::RobotSpec;
    /// assert!(RobotSpec::file_of("husky").is_none());
    /// assert!(RobotSpec::file_of("robots/mine.toml").is_some());
    /// ```
    pub fn file_of(name_or_path: &str) -> Option<&std::path::Path> {
        let path = std::path::Path::new(name_or_path);
        (name_or_path.ends_with(".toml") || path.is_file()).then_some(path)
    }
}

/// The first float of `value` (a TOML table, by dotted key under `path`) that is not
/// finite: JSON, through which a vehicle is read, has no such numbers.
fn non_finite(value: &toml::Value, path: &str) -> Option<(String, f64)> {
    match value {
        toml::Value::Float(x) if !x.is_finite() => Some((path.to_string(), *x)),
        toml::Value::Table(t) => t
            .iter()
            .find_map(|(k, v)| non_finite(v, &format!("{path}.{k}"))),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| non_finite(v, &format!("{path}[{i}]"))),
        _ => None,
    }
}
