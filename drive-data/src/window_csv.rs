//! The long-format window CSV: one row per sample.

use crate::{DataError, DataErrorKind, Location};
use drive_traits::{assign_intervals, Input, Phase, Pose, RobotDescription, Window};
use std::fmt::Write as _;

/// The required columns of a dataset of `robot`, in the order the writer uses: `window,
/// phase, k, t`, the commanded then the measured value of each of the vehicle's input axes
/// (`cmd_left, cmd_right, enc_left, enc_right` for a differential drive), then `x, y, yaw,
/// imu_yaw_rate`.
///
/// ```
/// use drive_traits::RobotDescription;
/// let robot = RobotDescription::new("r", "", 20.0, 40, drive_traits::vehicles::DifferentialDrive::new(0.1, 0.5));
/// assert_eq!(drive_data::columns(&robot)[4..8], ["cmd_left", "cmd_right", "enc_left", "enc_right"]);
/// assert_eq!(drive_data::columns(&robot).len(), 12);
/// ```
pub fn columns(robot: &RobotDescription) -> Vec<&'static str> {
    let axes = robot.vehicle.axes();
    let mut columns = vec!["window", "phase", "k", "t"];
    columns.extend(axes.iter().map(|a| a.command_column));
    columns.extend(axes.iter().map(|a| a.measured_column));
    columns.extend(["x", "y", "yaw", "imu_yaw_rate"]);
    columns
}

/// Columns that may be present and are ignored (`calib_step` is the logger's interval
/// counter, not reliable: intervals are found from `phase`).
pub const OPTIONAL_COLUMNS: [&str; 1] = ["calib_step"];

const WINDOW: usize = 0;
const PHASE: usize = 1;
const K: usize = 2;
const T: usize = 3;

struct Pending {
    index: usize,
    phase: Phase,
    command: Vec<Input>,
    measured: Vec<Input>,
    pose: Vec<Pose>,
    imu: Vec<f64>,
}

impl Pending {
    fn new(index: usize, phase: Phase, len: usize) -> Self {
        Pending {
            index,
            phase,
            command: Vec::with_capacity(len),
            measured: Vec::with_capacity(len),
            pose: Vec::with_capacity(len),
            imu: Vec::with_capacity(len),
        }
    }
}

/// Parses the window CSV text of `file` for the given robot description (its vehicle names
/// the input columns; its `window_len` and `rate_hz` are checked against the data).
pub fn parse_windows(
    file: &str,
    text: &str,
    robot: &RobotDescription,
) -> Result<Vec<Window>, DataError> {
    parse_lines(
        file,
        text.lines().enumerate().map(|(i, l)| Ok((i + 1, l))),
        robot,
    )
}

/// Reads the window CSV at `path` line by line (the text is never held whole), with the
/// digest of its bytes (a byte-order mark left out) for the sidecar's check.
pub(crate) fn read_windows(
    file: &str,
    opened: std::fs::File,
    robot: &RobotDescription,
) -> Result<(Vec<Window>, crate::CsvDigest), DataError> {
    use std::io::{BufRead as _, Read as _};
    // A line of a window CSV is a hundred characters or so: a longer one is no such file.
    const MAX_LINE_BYTES: u64 = 1 << 16;
    let mut reader = std::io::BufReader::new(opened);
    let mut digest = crate::sidecar::DigestBuilder::default();
    let mut number = 0;
    let mut failed = false;
    let lines = std::iter::from_fn(|| {
        if failed {
            return None;
        }
        let mut line = String::new();
        match (&mut reader).take(MAX_LINE_BYTES + 1).read_line(&mut line) {
            Ok(0) => None,
            Ok(n) if n as u64 > MAX_LINE_BYTES => {
                failed = true;
                Some(Err(DataError::new(
                    Location::line(file, number + 1),
                    DataErrorKind::Implausible(format!(
                        "a line longer than {MAX_LINE_BYTES} bytes: not a window CSV"
                    )),
                )))
            }
            Ok(_) => {
                number += 1;
                if number == 1 {
                    if let Some(rest) = line.strip_prefix('\u{feff}') {
                        line = rest.to_string();
                    }
                }
                digest.update(line.as_bytes());
                if line.ends_with('\n') {
                    line.pop();
                }
                Some(Ok((number, line)))
            }
            Err(e) => {
                let kind = if e.kind() == std::io::ErrorKind::InvalidData {
                    DataErrorKind::Io(format!("not UTF-8 text (line {})", number + 1))
                } else {
                    DataErrorKind::Io(e.to_string())
                };
                Some(Err(DataError::new(Location::file(file), kind)))
            }
        }
    });
    let windows = parse_lines(file, lines, robot)?;
    Ok((windows, digest.finish()))
}

/// The window CSV parser over numbered lines (1-based, without their line ending).
fn parse_lines<S: AsRef<str>>(
    file: &str,
    lines: impl Iterator<Item = Result<(usize, S), DataError>>,
    robot: &RobotDescription,
) -> Result<Vec<Window>, DataError> {
    let columns = columns(robot);
    let dim = robot.vehicle.input_dim();
    if !(2..=drive_traits::MAX_INPUTS).contains(&dim) || columns.len() != 8 + 2 * dim {
        return Err(DataError::new(
            Location::file(file),
            DataErrorKind::Implausible(format!(
                "the vehicle has {dim} input axes (and {} columns); a vehicle has 2 or 3",
                columns.len()
            )),
        ));
    }
    // The slots of the command, measured, pose and IMU values.
    let (command, measured, pose) = (4, 4 + dim, 4 + 2 * dim);
    let imu = pose + 3;
    let mut lines = lines;
    let header = loop {
        match lines.next() {
            None => return Err(DataError::new(Location::file(file), DataErrorKind::Empty)),
            Some(Err(e)) => return Err(e),
            Some(Ok((_, l))) if l.as_ref().trim().is_empty() => continue,
            Some(Ok((n, l))) => break (n, l),
        }
    };
    let (header_line, header_owned) = header;
    let header_text = header_owned.as_ref();
    let header_text = header_text.strip_suffix('\r').unwrap_or(header_text);
    // Position in the row of each required column; None for ignored optional columns.
    let mut slot_of_field: Vec<Option<usize>> = Vec::new();
    let mut position_of = vec![usize::MAX; columns.len()];
    let mut seen = std::collections::HashSet::new();
    for (pos, raw) in header_text.split(',').enumerate() {
        let name = unquoted(raw.trim());
        if !seen.insert(name.to_string()) {
            return Err(DataError::new(
                Location::cell(file, header_line, name),
                DataErrorKind::DuplicateColumn,
            ));
        }
        if let Some(slot) = columns.iter().position(|c| *c == name) {
            position_of[slot] = pos;
            slot_of_field.push(Some(slot));
        } else if OPTIONAL_COLUMNS.contains(&name) {
            slot_of_field.push(None);
        } else {
            let known = columns
                .iter()
                .chain(OPTIONAL_COLUMNS.iter())
                .copied()
                .collect::<Vec<_>>()
                .join(", ");
            return Err(DataError::new(
                Location::cell(file, header_line, name),
                DataErrorKind::UnknownColumn(known),
            ));
        }
    }
    if let Some(slot) = position_of.iter().position(|p| *p == usize::MAX) {
        return Err(DataError::new(
            Location::cell(file, header_line, columns[slot]),
            DataErrorKind::MissingColumn(columns.join(", ")),
        ));
    }
    let n_fields = slot_of_field.len();
    let dt = robot.dt();
    let len = robot.window_len;

    let mut windows: Vec<Window> = Vec::new();
    let mut phases: Vec<Phase> = Vec::new();
    let mut pending: Option<Pending> = None;
    let mut last_line = header_line;
    let mut values = vec![0.0f64; columns.len()];

    let finish = |p: Pending,
                  line: usize,
                  windows: &mut Vec<Window>,
                  phases: &mut Vec<Phase>|
     -> Result<(), DataError> {
        if p.pose.len() != len {
            return Err(DataError::new(
                Location::line(file, line),
                DataErrorKind::WrongWindowLength {
                    window: p.index,
                    expected: len,
                    found: p.pose.len(),
                },
            ));
        }
        phases.push(p.phase);
        windows.push(Window::new(
            p.index, 0, p.phase, p.command, p.measured, p.pose, p.imu,
        ));
        Ok(())
    };

    for line in lines {
        let (line_no, owned) = line?;
        let line = owned.as_ref();
        let line = line.strip_suffix('\r').unwrap_or(line);
        if line.trim().is_empty() {
            continue;
        }
        let found = line.bytes().filter(|b| *b == b',').count() + 1;
        if found != n_fields {
            return Err(DataError::new(
                Location::line(file, line_no),
                DataErrorKind::FieldCount {
                    expected: n_fields,
                    found,
                },
            ));
        }
        let mut phase = Phase::Steady;
        for (field, slot) in line.split(',').zip(&slot_of_field) {
            let Some(slot) = *slot else { continue };
            let raw = unquoted(field.trim());
            let at = || Location::cell(file, line_no, columns[slot]);
            if slot == PHASE {
                phase = match raw {
                    "transient" => Phase::Transient,
                    "steady" => Phase::Steady,
                    other => {
                        return Err(DataError::new(
                            at(),
                            DataErrorKind::BadPhase(other.to_string()),
                        ))
                    }
                };
                continue;
            }
            let v = if slot == WINDOW || slot == K {
                crate::error::parse_number(raw, at)?
            } else {
                crate::error::parse_measurement(raw, at)?
            };
            if (slot == WINDOW || slot == K) && (v < 0.0 || v.fract() != 0.0 || v > u32::MAX as f64)
            {
                return Err(DataError::new(
                    at(),
                    DataErrorKind::NotAnInteger(raw.to_string()),
                ));
            }
            values[slot] = v;
        }
        let window = values[WINDOW] as usize;
        let k = values[K] as usize;

        let same_window = pending.as_ref().is_some_and(|p| p.index == window);
        if !same_window {
            if let Some(p) = pending.take() {
                if window < p.index {
                    return Err(DataError::new(
                        Location::cell(file, line_no, "window"),
                        DataErrorKind::WindowOutOfOrder {
                            previous: p.index,
                            found: window,
                        },
                    ));
                }
                finish(p, last_line, &mut windows, &mut phases)?;
            }
            if let Some(prev) = windows.last() {
                if window <= prev.index {
                    return Err(DataError::new(
                        Location::cell(file, line_no, "window"),
                        DataErrorKind::WindowOutOfOrder {
                            previous: prev.index,
                            found: window,
                        },
                    ));
                }
            }
            pending = Some(Pending::new(window, phase, len));
        }
        // `pending` was set just above when it was empty or belonged to another window.
        let p = pending.as_mut().expect("a pending window exists here");
        let expected_k = p.pose.len();
        if k != expected_k {
            let kind = if expected_k >= len {
                DataErrorKind::WrongWindowLength {
                    window,
                    expected: len,
                    found: expected_k + 1,
                }
            } else {
                DataErrorKind::SampleOutOfOrder {
                    window,
                    expected: expected_k,
                    found: k,
                }
            };
            return Err(DataError::new(Location::cell(file, line_no, "k"), kind));
        }
        if k >= len {
            return Err(DataError::new(
                Location::cell(file, line_no, "k"),
                DataErrorKind::WrongWindowLength {
                    window,
                    expected: len,
                    found: k + 1,
                },
            ));
        }
        if phase != p.phase {
            return Err(DataError::new(
                Location::cell(file, line_no, "phase"),
                DataErrorKind::PhaseChangesInWindow(window),
            ));
        }
        let t_expected = k as f64 * dt;
        if (values[T] - t_expected).abs() > 0.5 * dt {
            return Err(DataError::new(
                Location::cell(file, line_no, "t"),
                DataErrorKind::TimeMismatch {
                    expected: t_expected,
                    found: values[T],
                },
            ));
        }
        let (mut c, mut m) = (Input::zeros(), Input::zeros());
        for i in 0..dim {
            c[i] = values[command + i];
            m[i] = values[measured + i];
        }
        p.command.push(c);
        p.measured.push(m);
        p.pose
            .push(Pose::new(values[pose], values[pose + 1], values[pose + 2]));
        p.imu.push(values[imu]);
        last_line = line_no;
    }
    match pending {
        Some(p) => finish(p, last_line, &mut windows, &mut phases)?,
        None => return Err(DataError::new(Location::file(file), DataErrorKind::Empty)),
    }
    let mut intervals = vec![0; windows.len()];
    assign_intervals(&phases, &mut intervals);
    for (w, i) in windows.iter_mut().zip(intervals) {
        w.interval = i;
    }
    Ok(windows)
}

/// Appends the window CSV text (header and rows, see [`columns`]) of `windows` to `out`.
pub fn write_windows_csv(windows: &[Window], robot: &RobotDescription, out: &mut String) {
    out.push_str(&columns(robot).join(","));
    out.push('\n');
    let dim = robot.vehicle.input_dim().min(drive_traits::MAX_INPUTS);
    for w in windows {
        for k in 0..w.len() {
            let (c, e, p) = (w.command[k], w.measured[k], w.pose[k]);
            // Writing into a String cannot fail.
            let _ = write!(
                out,
                "{},{},{},{}",
                w.index,
                w.phase.as_str(),
                k,
                k as f64 / robot.rate_hz
            );
            for u in [c, e] {
                for i in 0..dim {
                    let _ = write!(out, ",{}", u[i]);
                }
            }
            let _ = writeln!(out, ",{},{},{},{}", p.x, p.y, p.z, w.imu_yaw_rate[k]);
        }
    }
}

/// `field` without one pair of double quotes around it: a CSV writer that quotes its text
/// (pandas with `quoting=csv.QUOTE_NONNUMERIC`, a spreadsheet) writes `"transient"`, the
/// same field (a quote inside a field is not one a window CSV holds).
pub(crate) fn unquoted(field: &str) -> &str {
    field
        .strip_prefix('"')
        .and_then(|f| f.strip_suffix('"'))
        .filter(|f| !f.contains('"'))
        .unwrap_or(field)
}
