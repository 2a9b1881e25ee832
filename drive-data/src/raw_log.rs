//! The DRIVE logger's raw CSV: one row per command tick, as the paper's ROS 2 logger node
//! exports it (format: docs/data-format.md).

use crate::error::{parse_measurement, parse_number};
use crate::{DataError, DataErrorKind, Location};
use drive_traits::InvalidPart;
use drive_traits::{CommandModel, Input};
use std::fmt::Write as _;

/// The columns every raw log has.
pub const RAW_COLUMNS: [&str; 19] = [
    "ros_time",
    "joy_switch",
    "icp_index",
    "calib_state",
    "calib_step",
    "meas_left_vel",
    "meas_right_vel",
    "cmd_vel_x",
    "cmd_vel_omega",
    "icp_pos_x",
    "icp_pos_y",
    "icp_pos_z",
    "icp_quat_x",
    "icp_quat_y",
    "icp_quat_z",
    "icp_quat_w",
    "imu_x",
    "imu_y",
    "imu_z",
];

/// The columns of a raw log of `vehicle`: [`RAW_COLUMNS`] with the measured inputs named
/// by the vehicle ([`CommandModel::logger_measured_columns`]: `meas_left_vel,
/// meas_right_vel` for a differential drive, `meas_speed, meas_steering` for a car).
///
/// ```
/// use drive_data::{raw_columns, RAW_COLUMNS};
/// let car = drive_traits::vehicles::Ackermann::new(0.57, 0.37);
/// assert_eq!(&raw_columns(&car)[5..7], ["meas_speed", "meas_steering"]);
/// let husky = drive_traits::vehicles::DifferentialDrive::new(0.165, 0.55);
/// assert_eq!(raw_columns(&husky), RAW_COLUMNS);
/// ```
///
/// The logger records two measured inputs and a twist command (`cmd_vel_x`,
/// `cmd_vel_omega`): a vehicle of more input axes has no raw log (its first two measured
/// columns are named here; [`check_raw_vehicle`] says so before import or export).
pub fn raw_columns(vehicle: &dyn CommandModel) -> [&'static str; 19] {
    let mut c = RAW_COLUMNS;
    for (slot, name) in [5, 6].into_iter().zip(vehicle.logger_measured_columns()) {
        c[slot] = name;
    }
    c
}

/// `Ok` when the DRIVE logger's raw format can hold `vehicle`'s inputs (two axes, a twist
/// command); else an error that says why.
///
/// ```
/// let husky = drive_traits::vehicles::DifferentialDrive::new(0.165, 0.55);
/// assert!(drive_data::check_raw_vehicle(&husky).is_ok());
/// ```
pub fn check_raw_vehicle(vehicle: &dyn CommandModel) -> Result<(), InvalidPart> {
    let dim = vehicle.input_dim();
    if dim == 2 {
        return Ok(());
    }
    Err(InvalidPart::from(format!(
        "the DRIVE logger's recordings (its raw CSV and its bag topics) hold two measured inputs and a twist command (cmd_vel_x, cmd_vel_omega); this vehicle has {dim} input axes: write its windows as a window CSV with one command and one measured column per axis (the format drive simulate --out writes; see docs/data-format.md)"
    )))
}

/// The protocol's state as the logger writes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibState {
    /// Blank: the protocol has not started.
    Unset,
    /// `idle`: not driving an interval.
    Idle,
    /// `calib`: driving DRIVE interval `calib_step`.
    Calib,
    /// Any other word (kept, never treated as driving).
    Other,
}

impl CalibState {
    /// The state the logger's text names (`""`, `idle`, `calib`, anything else).
    ///
    /// ```
    /// use drive_data::CalibState;
    /// assert_eq!(CalibState::from_logger("calib"), CalibState::Calib);
    /// assert_eq!(CalibState::from_logger("paused"), CalibState::Other);
    /// ```
    pub fn from_logger(text: &str) -> Self {
        match text {
            "" => CalibState::Unset,
            "idle" => CalibState::Idle,
            "calib" => CalibState::Calib,
            _ => CalibState::Other,
        }
    }

    fn as_str(self) -> &'static str {
        match self {
            CalibState::Unset => "",
            CalibState::Idle => "idle",
            CalibState::Calib => "calib",
            CalibState::Other => "other",
        }
    }
}

/// One row of a raw log.
#[derive(Debug, Clone, PartialEq)]
pub struct RawRow {
    /// 1-based line in the file.
    pub line: usize,
    /// `ros_time` (ns).
    pub time_ns: i64,
    /// `joy_switch`: an operator's joystick has taken over, the protocol is suspended.
    pub joy_switch: bool,
    /// `icp_index`: counts localization updates.
    pub icp_index: u64,
    /// `calib_state`.
    pub calib_state: CalibState,
    /// `calib_step`: the DRIVE interval.
    pub calib_step: u64,
    /// The measured inputs: `meas_left_vel`, `meas_right_vel`, encoder wheel velocities
    /// (rad/s) of a differential drive; the vehicle's columns otherwise ([`raw_columns`]).
    pub measured: Input,
    /// `cmd_vel_x` (m/s), `cmd_vel_omega` (rad/s): the body command.
    pub body_command: [f64; 2],
    /// `icp_pos_x/y/z` (m).
    pub position: [f64; 3],
    /// `icp_quat_x/y/z/w`.
    pub quaternion: [f64; 4],
    /// `imu_x/y/z`: angular rates (rad/s).
    pub imu_rate: [f64; 3],
    /// The values of the other columns ([`RawLog::extra_columns`]), `None` where blank or
    /// not a number.
    pub extra: Vec<Option<f64>>,
}

impl RawRow {
    /// Yaw of the ICP orientation (rad), `None` when the quaternion is not a rotation
    /// (norm far from 1, as an all-zero quaternion).
    ///
    /// ```
    /// # let mut row = drive_data::RawRow::at_rest(1, 0);
    /// let half = 0.3_f64 / 2.0;
    /// row.quaternion = [0.0, 0.0, half.sin(), half.cos()];
    /// assert!((row.yaw().unwrap() - 0.3).abs() < 1e-12);
    /// row.quaternion = [0.0; 4];
    /// assert_eq!(row.yaw(), None);
    /// ```
    pub fn yaw(&self) -> Option<f64> {
        let [x, y, z, w] = self.quaternion;
        let n2 = x * x + y * y + z * z + w * w;
        if !(0.8..=1.2).contains(&n2) {
            return None;
        }
        Some((2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z)))
    }

    /// A row of a robot at rest at the origin, localized, not driving: a starting point
    /// for writing logs and for examples.
    pub fn at_rest(line: usize, time_ns: i64) -> Self {
        RawRow {
            line,
            time_ns,
            joy_switch: false,
            icp_index: 0,
            calib_state: CalibState::Idle,
            calib_step: 0,
            measured: Input::zeros(),
            body_command: [0.0; 2],
            position: [0.0; 3],
            quaternion: [0.0, 0.0, 0.0, 1.0],
            imu_rate: [0.0; 3],
            extra: Vec::new(),
        }
    }
}

/// A parsed raw log.
#[derive(Debug, Clone, PartialEq)]
pub struct RawLog {
    /// File name, for messages.
    pub file: String,
    /// The rows, in time order (placeholder rows left out).
    pub rows: Vec<RawRow>,
    /// Names of the columns beyond [`RAW_COLUMNS`] (IMU accelerations, the Warthog's wheel
    /// voltages and currents, ...): kept with every row, not used by the models.
    pub extra_columns: Vec<String>,
    /// All-zero rows left out (the logger writes one before the first message arrives).
    pub placeholder_rows: usize,
}

fn parse_count(raw: &str, at: impl Fn() -> Location) -> Result<u64, DataError> {
    // Integers may be written as `0.0`.
    let v = parse_number(raw, &at)?;
    if v < 0.0 || v.fract() != 0.0 || v > 2f64.powi(53) {
        return Err(DataError::new(
            at(),
            DataErrorKind::NotAnInteger(raw.to_string()),
        ));
    }
    Ok(v as u64)
}

fn parse_bool(raw: &str, at: impl Fn() -> Location) -> Result<bool, DataError> {
    match raw {
        "True" | "true" | "TRUE" | "1" | "1.0" => Ok(true),
        "False" | "false" | "FALSE" | "0" | "0.0" => Ok(false),
        other => Err(DataError::new(
            at(),
            DataErrorKind::NotABoolean(other.to_string()),
        )),
    }
}

fn parse_time(raw: &str, at: impl Fn() -> Location) -> Result<i64, DataError> {
    if let Ok(ns) = raw.parse::<i64>() {
        return Ok(ns);
    }
    let v = parse_number(raw, &at)?;
    if v.abs() > 9.0e18 {
        return Err(DataError::new(
            at(),
            DataErrorKind::NotAnInteger(raw.to_string()),
        ));
    }
    Ok(v.round() as i64)
}

/// Parses the text of a raw log with the standard `columns` (for a vehicle: [`raw_columns`];
/// [`RAW_COLUMNS`] for the DRIVE logger's differential drive); other columns are kept as
/// extra columns.
///
/// ```
/// let text = "ros_time,joy_switch,icp_index,calib_state,calib_step,meas_left_vel,meas_right_vel,\
/// cmd_vel_x,cmd_vel_omega,icp_pos_x,icp_pos_y,icp_pos_z,icp_quat_x,icp_quat_y,icp_quat_z,\
/// icp_quat_w,imu_x,imu_y,imu_z,left_wheel_current\n\
/// 0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0\n\
/// 1000000000,False,3.0,calib,0,1.5,1.5,0.5,0.0,2.0,0.0,0.0,0.0,0.0,0.0,1.0,0.0,0.0,0.0,4.5\n";
/// let log = drive_data::parse_raw_log("bench.csv", text, &drive_data::RAW_COLUMNS).unwrap();
/// assert_eq!(log.placeholder_rows, 1);
/// assert_eq!(log.rows[0].icp_index, 3);
/// assert_eq!(log.extra_columns, ["left_wheel_current"]);
/// assert_eq!(log.rows[0].extra, [Some(4.5)]);
/// ```
pub fn parse_raw_log(
    file: &str,
    text: &str,
    columns: &[&'static str; 19],
) -> Result<RawLog, DataError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((header_line, header)) = lines.next() else {
        return Err(DataError::new(Location::file(file), DataErrorKind::Empty));
    };
    // A writer that quotes its fields (`"ros_time"`, `"False"`) writes the same log.
    let names: Vec<&str> = header
        .split(',')
        .map(|f| crate::window_csv::unquoted(f.trim()))
        .collect();
    let mut seen = std::collections::HashSet::new();
    for name in &names {
        if !seen.insert(*name) {
            return Err(DataError::new(
                Location::cell(file, header_line, name),
                DataErrorKind::DuplicateColumn,
            ));
        }
    }
    let mut position = [0usize; RAW_COLUMNS.len()];
    for (slot, column) in columns.iter().enumerate() {
        position[slot] = names.iter().position(|n| n == column).ok_or_else(|| {
            DataError::new(
                Location::cell(file, header_line, column),
                DataErrorKind::MissingColumn(columns.join(", ")),
            )
        })?;
    }
    let extra_positions: Vec<usize> = (0..names.len()).filter(|p| !position.contains(p)).collect();
    let mut log = RawLog {
        file: file.to_string(),
        rows: Vec::new(),
        extra_columns: extra_positions
            .iter()
            .map(|&p| names[p].to_string())
            .collect(),
        placeholder_rows: 0,
    };
    let mut fields: Vec<&str> = Vec::with_capacity(names.len());
    for (line, text) in lines {
        fields.clear();
        fields.extend(
            text.split(',')
                .map(|f| crate::window_csv::unquoted(f.trim())),
        );
        if fields.len() != names.len() {
            return Err(DataError::new(
                Location::line(file, line),
                DataErrorKind::FieldCount {
                    expected: names.len(),
                    found: fields.len(),
                },
            ));
        }
        if fields
            .iter()
            .all(|f| f.parse::<f64>().is_ok_and(|v| v == 0.0))
        {
            log.placeholder_rows += 1;
            continue;
        }
        let field = |slot: usize| fields[position[slot]];
        let at = |slot: usize| move || Location::cell(file, line, columns[slot]);
        let num = |slot: usize| parse_measurement(field(slot), at(slot));
        let time_ns = parse_time(field(0), at(0))?;
        if time_ns <= 0 {
            return Err(DataError::new(
                at(0)(),
                DataErrorKind::Inconsistent(format!(
                    "ros_time {} is not a positive time in nanoseconds",
                    field(0)
                )),
            ));
        }
        if let Some(prev) = log.rows.last() {
            if time_ns < prev.time_ns {
                return Err(DataError::new(
                    at(0)(),
                    DataErrorKind::Inconsistent(format!(
                        "ros_time goes back by {:.3} s from line {}",
                        (prev.time_ns - time_ns) as f64 * 1e-9,
                        prev.line
                    )),
                ));
            }
        }
        let calib_state = CalibState::from_logger(field(3));
        log.rows.push(RawRow {
            line,
            time_ns,
            joy_switch: parse_bool(field(1), at(1))?,
            icp_index: parse_count(field(2), at(2))?,
            calib_state,
            calib_step: parse_count(field(4), at(4))?,
            measured: Input::new(num(5)?, num(6)?, 0.0),
            body_command: [num(7)?, num(8)?],
            position: [num(9)?, num(10)?, num(11)?],
            quaternion: [num(12)?, num(13)?, num(14)?, num(15)?],
            imu_rate: [num(16)?, num(17)?, num(18)?],
            extra: extra_positions
                .iter()
                .map(|&p| fields[p].parse::<f64>().ok().filter(|v| v.is_finite()))
                .collect(),
        });
    }
    if log.rows.is_empty() {
        return Err(DataError::new(Location::file(file), DataErrorKind::Empty));
    }
    Ok(log)
}

/// Writes rows in the logger's format with the standard `columns` ([`raw_columns`]):
/// booleans as `True`/`False`, the extra columns after the standard ones, blank where
/// `None`.
pub fn write_raw_log(
    rows: &[RawRow],
    columns: &[&'static str; 19],
    extra_columns: &[String],
    out: &mut String,
) {
    out.push_str(&columns.join(","));
    for c in extra_columns {
        out.push(',');
        out.push_str(c);
    }
    out.push('\n');
    for r in rows {
        let _ = write!(
            out,
            "{},{},{},{},{},{},{},{},{}",
            r.time_ns,
            if r.joy_switch { "True" } else { "False" },
            r.icp_index,
            r.calib_state.as_str(),
            r.calib_step,
            r.measured.x,
            r.measured.y,
            r.body_command[0],
            r.body_command[1]
        );
        for v in r.position.iter().chain(&r.quaternion).chain(&r.imu_rate) {
            let _ = write!(out, ",{v}");
        }
        for i in 0..extra_columns.len() {
            match r.extra.get(i).copied().flatten() {
                Some(v) => {
                    let _ = write!(out, ",{v}");
                }
                None => out.push(','),
            }
        }
        out.push('\n');
    }
}
