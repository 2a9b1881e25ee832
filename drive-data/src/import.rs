//! Raw logs into DRIVE windows: each 6 s interval (`calib_step` while `calib_state` is
//! `calib`) is cut into one transient and two steady 2 s windows on the command-rate grid,
//! and every interval that cannot be used is dropped with its reason.

use crate::quality::Finding;
use crate::{CalibState, DataError, DataErrorKind, Location, RawLog, RawRow};
use drive_traits::{
    relative_pose, Dataset, Phase, Pose, RobotDescription, Window, WINDOWS_PER_INTERVAL,
};
use std::fmt;

/// What makes an interval unusable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImportConfig {
    /// A time between two rows longer than this (s) cuts the interval; never less than
    /// two command periods of the robot (a slow logger's regular rows are no gap).
    pub max_gap_s: f64,
    /// The longest time without a localization update inside an interval (s).
    pub localization_timeout_s: f64,
    /// The robot description's input limits, for the `outside-limits` data check.
    pub input_limits: Option<drive_traits::InputSpace>,
}

impl Default for ImportConfig {
    fn default() -> Self {
        ImportConfig {
            max_gap_s: 0.25,
            localization_timeout_s: 0.5,
            input_limits: None,
        }
    }
}

/// Why an interval was dropped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DropReason {
    /// The operator's joystick took over (`joy_switch` True) and no full interval was
    /// driven after it.
    OperatorTakeover {
        /// line of the first takeover row
        line: usize,
    },
    /// Rows are missing: a gap longer than the limit.
    TimeGap {
        /// the gap (s)
        gap_s: f64,
        /// line after the gap
        line: usize,
    },
    /// The interval lasted less than its three windows.
    TooShort {
        /// how long it lasted (s)
        lasted_s: f64,
    },
    /// The localization is all zeros (no localization, as on a bench).
    LocalizationMissing,
    /// The localization orientation is not a rotation (quaternion of norm far from 1).
    BadQuaternion {
        /// line
        line: usize,
    },
    /// The localization did not update for longer than the limit.
    LocalizationFrozen {
        /// how long (s)
        for_s: f64,
        /// line where it froze
        line: usize,
    },
    /// A body command the vehicle cannot be given as inputs (a yaw rate at zero speed for
    /// a car, say).
    CommandNotAnInput {
        /// line
        line: usize,
        /// The command's forward speed (m/s).
        linear: f64,
        /// The command's yaw rate (rad/s).
        angular: f64,
    },
}

impl DropReason {
    /// A short key per kind of reason, for counts and JSON.
    pub fn key(&self) -> &'static str {
        match self {
            DropReason::OperatorTakeover { .. } => "operator_takeover",
            DropReason::TimeGap { .. } => "time_gap",
            DropReason::TooShort { .. } => "too_short",
            DropReason::LocalizationMissing => "localization_missing",
            DropReason::BadQuaternion { .. } => "bad_quaternion",
            DropReason::LocalizationFrozen { .. } => "localization_frozen",
            DropReason::CommandNotAnInput { .. } => "command_not_an_input",
        }
    }
}

impl fmt::Display for DropReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DropReason::OperatorTakeover { line } => write!(
                f,
                "operator takeover (joy_switch True from line {line}) and no full interval after it"
            ),
            DropReason::TimeGap { gap_s, line } => {
                write!(f, "a {gap_s:.3} s gap in the log before line {line}")
            }
            DropReason::TooShort { lasted_s } => write!(f, "lasted {lasted_s:.2} s"),
            DropReason::LocalizationMissing => {
                write!(f, "localization all zeros (no localization)")
            }
            DropReason::BadQuaternion { line } => {
                write!(f, "the ICP quaternion on line {line} is not a rotation")
            }
            DropReason::LocalizationFrozen { for_s, line } => {
                write!(f, "localization frozen for {for_s:.2} s from line {line}")
            }
            DropReason::CommandNotAnInput {
                line,
                linear,
                angular,
            } => write!(
                f,
                "the body command on line {line} ({linear} m/s forward, {angular} rad/s yaw rate) has no input of the vehicle (CommandModel::input_for_twist)"
            ),
        }
    }
}

/// What became of one `calib_step` of the log.
#[derive(Debug, Clone, PartialEq)]
pub struct StepOutcome {
    /// The logger's interval counter.
    pub calib_step: u64,
    /// First line of the step.
    pub first_line: usize,
    /// Time from its first to its last row, plus one row (s).
    pub lasted_s: f64,
    /// The interval index in the imported dataset, or why it was dropped.
    pub outcome: Result<usize, DropReason>,
}

/// The keep/drop report of an import.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportReport {
    /// Log file.
    pub file: String,
    /// Rows read (placeholders excluded).
    pub rows: usize,
    /// All-zero placeholder rows skipped.
    pub placeholder_rows: usize,
    /// One entry per `calib_step` driven, in log order.
    pub steps: Vec<StepOutcome>,
    /// Columns kept with the rows but not used by the models.
    pub extra_columns: Vec<String>,
    /// Other things worth knowing (steps longer than an interval, ...).
    pub notes: Vec<String>,
    /// What the data-quality checks found on the kept windows (see [`crate::quality`]).
    pub checks: Vec<Finding>,
}

impl ImportReport {
    /// Windows written.
    pub fn windows_kept(&self) -> usize {
        WINDOWS_PER_INTERVAL * self.steps.iter().filter(|s| s.outcome.is_ok()).count()
    }

    /// Windows dropped.
    pub fn windows_dropped(&self) -> usize {
        WINDOWS_PER_INTERVAL * self.steps.iter().filter(|s| s.outcome.is_err()).count()
    }

    /// Dropped windows per reason key, in first-seen order.
    pub fn dropped_by_reason(&self) -> Vec<(&'static str, usize)> {
        let mut counts: Vec<(&'static str, usize)> = Vec::new();
        for s in &self.steps {
            if let Err(r) = &s.outcome {
                match counts.iter_mut().find(|(k, _)| *k == r.key()) {
                    Some((_, n)) => *n += WINDOWS_PER_INTERVAL,
                    None => counts.push((r.key(), WINDOWS_PER_INTERVAL)),
                }
            }
        }
        counts
    }

    /// Why nothing could be imported, in one line (`None` when windows were kept).
    pub fn nothing_usable(&self) -> Option<String> {
        if self.windows_kept() > 0 {
            return None;
        }
        if self.steps.is_empty() {
            return Some(format!(
                "no usable window in {}: no DRIVE interval in the log (no row has calib_state 'calib')",
                self.file
            ));
        }
        let reasons: Vec<String> = self
            .dropped_by_reason()
            .iter()
            .map(|(k, n)| format!("{n} windows: {}", k.replace('_', " ")))
            .collect();
        let all_missing = self
            .steps
            .iter()
            .all(|s| s.outcome == Err(DropReason::LocalizationMissing));
        // Every interval lasting under a second, where each is 6 s: ros_time in seconds
        // (the logger writes nanoseconds) makes each last billionths of one.
        let all_brief = self
            .steps
            .iter()
            .all(|s| matches!(s.outcome, Err(DropReason::TooShort { .. })) && s.lasted_s < 1.0);
        Some(format!(
            "no usable window in {}: all {} intervals dropped ({}){}",
            self.file,
            self.steps.len(),
            reasons.join(", "),
            if all_missing {
                "; the localization is all zeros throughout (a bench run without localization?)"
            } else if all_brief {
                "; every interval lasted under a second where DRIVE holds each command 6 s: ros_time in seconds or milliseconds (the logger writes nanoseconds)?"
            } else {
                ""
            }
        ))
    }

    /// The report as text, one line per dropped interval.
    pub fn to_text(&self) -> String {
        let mut out = format!(
            "{}: {} rows ({} placeholder rows skipped), {} DRIVE intervals: {} windows kept, {} dropped\n",
            self.file,
            self.rows,
            self.placeholder_rows,
            self.steps.len(),
            self.windows_kept(),
            self.windows_dropped()
        );
        for (key, n) in self.dropped_by_reason() {
            out.push_str(&format!(
                "  dropped {n} windows: {}\n",
                key.replace('_', " ")
            ));
        }
        for s in &self.steps {
            if let Err(r) = &s.outcome {
                out.push_str(&format!(
                    "  calib_step {} (line {}, {:.2} s): dropped, {r}\n",
                    s.calib_step, s.first_line, s.lasted_s
                ));
            }
        }
        out.push_str(&crate::quality::to_text(&self.checks));
        for note in &self.notes {
            out.push_str(&format!("  note: {note}\n"));
        }
        if !self.extra_columns.is_empty() {
            out.push_str(&format!(
                "  kept, not used by the models: {}\n",
                self.extra_columns.join(", ")
            ));
        }
        out
    }

    /// The report as a JSON value.
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let steps: Vec<serde_json::Value> = self
            .steps
            .iter()
            .map(|s| {
                let (kept, interval, reason, detail) = match &s.outcome {
                    Ok(i) => (true, Some(*i), None, None),
                    Err(r) => (false, None, Some(r.key()), Some(r.to_string())),
                };
                json!({
                    "calib_step": s.calib_step,
                    "first_line": s.first_line,
                    "lasted_s": s.lasted_s,
                    "kept": kept,
                    "interval": interval,
                    "reason": reason,
                    "detail": detail,
                })
            })
            .collect();
        let by_reason: serde_json::Map<String, serde_json::Value> = self
            .dropped_by_reason()
            .into_iter()
            .map(|(k, n)| (k.to_string(), json!(n)))
            .collect();
        json!({
            "file": self.file,
            "rows": self.rows,
            "placeholder_rows": self.placeholder_rows,
            "intervals": self.steps.len(),
            "windows_kept": self.windows_kept(),
            "windows_dropped": self.windows_dropped(),
            "dropped_by_reason": by_reason,
            "steps": steps,
            "extra_columns": self.extra_columns,
            "notes": self.notes,
            "checks": self.checks,
        })
    }
}

fn seconds(ns: i64) -> f64 {
    ns as f64 * 1e-9
}

/// Cuts a raw log into DRIVE windows for `robot` (its geometry converts the body commands
/// to wheel commands; its rate and window length give the grid).
///
/// Each `calib_step` is split into uninterrupted stretches: rows in a row of the log, all
/// `calib`, no operator takeover, no gap beyond [`ImportConfig::max_gap_s`]. The first
/// three windows of the last stretch long enough to hold them are the interval (a step
/// suspended and resumed restarts its interval; a step held longer than 6 s keeps its
/// first 6 s). Each grid instant takes the row nearest in time, so values the logger held
/// between updates (ICP poses at 10 Hz) stay held. Poses are re-based to each window's
/// first pose, in the body frame there; yaw comes from the quaternion.
///
/// ```
/// use drive_data::{import_raw, ImportConfig, RawRow, CalibState, RawLog};
/// use drive_traits::RobotDescription;
/// let robot = RobotDescription::new("toy", "", 2.0, 4, drive_traits::vehicles::DifferentialDrive::new(0.5, 1.0));
/// // 6.5 s of driving straight at 1 m/s, localized at every tick.
/// let rows: Vec<RawRow> = (0..14).map(|i| {
///     let mut r = RawRow::at_rest(i + 2, 1_000_000_000 + i as i64 * 500_000_000);
///     r.calib_state = CalibState::Calib;
///     r.body_command = [1.0, 0.0];
///     r.icp_index = i as u64;
///     r.position = [0.5 * i as f64, 0.0, 0.0];
///     r
/// }).collect();
/// let log = RawLog { file: "toy.csv".into(), rows, extra_columns: vec![], placeholder_rows: 0 };
/// let (data, report) = import_raw(&log, &robot, &ImportConfig::default()).unwrap();
/// assert_eq!(report.windows_kept(), 3);
/// assert_eq!(data.windows[1].command[0].x, 2.0); // 1 m/s on 0.5 m wheels
/// assert_eq!(data.windows[1].pose[3].x, 1.5);    // re-based to the window's start
/// ```
pub fn import_raw(
    log: &RawLog,
    robot: &RobotDescription,
    config: &ImportConfig,
) -> Result<(Dataset, ImportReport), DataError> {
    for (name, v) in [
        ("max_gap_s", config.max_gap_s),
        ("localization_timeout_s", config.localization_timeout_s),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(DataError::new(
                Location::field("import configuration", name),
                DataErrorKind::Inconsistent(format!(
                    "{} is not a positive number of seconds",
                    drive_traits::limits::Short(v)
                )),
            ));
        }
    }
    if !(robot.rate_hz.is_finite() && robot.rate_hz > 0.0) || robot.window_len < 2 {
        return Err(DataError::new(
            Location::field("robot description", "rate_hz"),
            DataErrorKind::Inconsistent(format!(
                "a command rate of {} Hz gives {} samples per 2 s window; at least 2 are needed",
                robot.rate_hz, robot.window_len
            )),
        ));
    }
    let rows = &log.rows;
    let period_ns = 1e9 / robot.rate_hz;
    let samples = WINDOWS_PER_INTERVAL * robot.window_len;
    // The last grid instant, less half a period of tolerance for jitter.
    let needed_ns = ((samples - 1) as f64 - 0.5) * period_ns;
    let max_gap_ns = (config.max_gap_s * 1e9).max(2.0 * period_ns);

    // Steps in order of first appearance, with their rows (indices into `rows`).
    // (A map from step to its place keeps this linear in the steps.)
    let mut steps: Vec<(u64, Vec<usize>)> = Vec::new();
    let mut place: std::collections::HashMap<u64, usize> = std::collections::HashMap::new();
    for (i, r) in rows.iter().enumerate() {
        if r.calib_state != CalibState::Calib {
            continue;
        }
        let at = *place.entry(r.calib_step).or_insert_with(|| {
            steps.push((r.calib_step, Vec::new()));
            steps.len() - 1
        });
        steps[at].1.push(i);
    }

    let mut report = ImportReport {
        file: log.file.clone(),
        rows: rows.len(),
        placeholder_rows: log.placeholder_rows,
        steps: Vec::new(),
        extra_columns: log.extra_columns.clone(),
        notes: Vec::new(),
        checks: Vec::new(),
    };
    let mut windows: Vec<Window> = Vec::new();
    for (step, idx) in &steps {
        let (first, last) = (&rows[idx[0]], &rows[idx[idx.len() - 1]]);
        let lasted_s = seconds(last.time_ns - first.time_ns) + 1.0 / robot.rate_hz;
        // Uninterrupted stretches, and what interrupted them.
        let mut stretches: Vec<(usize, usize)> = Vec::new(); // [start, end] in `idx`
        let mut takeover: Option<usize> = None;
        let mut widest_gap: Option<(f64, usize)> = None;
        let mut open: Option<usize> = None;
        for (j, &i) in idx.iter().enumerate() {
            let r = &rows[i];
            if r.joy_switch {
                takeover.get_or_insert(r.line);
                if let Some(s) = open.take() {
                    stretches.push((s, j - 1));
                }
                continue;
            }
            if let Some(s) = open {
                let prev = idx[j - 1];
                let gap = (r.time_ns - rows[prev].time_ns) as f64;
                if prev + 1 != i || gap > max_gap_ns {
                    if gap > max_gap_ns && widest_gap.is_none_or(|(g, _)| gap * 1e-9 > g) {
                        widest_gap = Some((gap * 1e-9, r.line));
                    }
                    stretches.push((s, j - 1));
                    open = Some(j);
                }
            } else {
                open = Some(j);
            }
        }
        if let Some(s) = open {
            stretches.push((s, idx.len() - 1));
        }
        let usable = stretches
            .iter()
            .rev()
            .find(|(s, e)| (rows[idx[*e]].time_ns - rows[idx[*s]].time_ns) as f64 >= needed_ns);
        let outcome = match usable {
            None => Err(match (takeover, widest_gap) {
                (Some(line), _) => DropReason::OperatorTakeover { line },
                (None, Some((gap_s, line))) => DropReason::TimeGap { gap_s, line },
                (None, None) => DropReason::TooShort { lasted_s },
            }),
            Some(&(s, e)) => {
                let stretch: Vec<&RawRow> = idx[s..=e].iter().map(|&i| &rows[i]).collect();
                cut_interval(&stretch, robot, period_ns, samples, config).map(|mut w| {
                    let interval = windows.len() / WINDOWS_PER_INTERVAL;
                    for (k, win) in w.iter_mut().enumerate() {
                        win.index = windows.len() + k;
                        win.interval = interval;
                    }
                    windows.extend(w);
                    interval
                })
            }
        };
        if lasted_s > (samples as f64 + 1.5) / robot.rate_hz {
            report.notes.push(format!(
                "calib_step {step} lasts {lasted_s:.2} s, longer than one {:.0} s interval{}",
                samples as f64 / robot.rate_hz,
                match (&outcome, stretches.len()) {
                    (Ok(_), 1) => ": its first interval's worth was used",
                    (Ok(_), _) => ": the interval was taken from its last uninterrupted stretch",
                    (Err(_), _) => "",
                }
            ));
        }
        report.steps.push(StepOutcome {
            calib_step: *step,
            first_line: first.line,
            lasted_s,
            outcome,
        });
    }
    let mut data = Dataset {
        robot: robot.clone(),
        windows,
    };
    report.checks = crate::quality::check(&data, config.input_limits.as_ref());
    // The orientation's order, from the log's rows: the cause, said first.
    let quaternions: Vec<[f64; 4]> = rows.iter().map(|r| r.quaternion).collect();
    if let Some(f) = crate::quality::orientation_tilt(&quaternions) {
        report.checks.insert(0, f);
    }
    // The positions in the log's own world frame: each window is turned into its start
    // frame, which leaves a world grid off the axes and moves a fixed world axis (both
    // unseen by the windows' checks).
    let world = [rows
        .iter()
        .map(|r| [r.position[0], r.position[1]])
        .collect::<Vec<[f64; 2]>>()];
    if !report
        .checks
        .iter()
        .any(|f| f.check == crate::quality::Check::PositionSteps)
    {
        report.checks.extend(crate::quality::position_grid(&world));
    }
    if !report.checks.iter().any(|f| {
        f.check == crate::quality::Check::LocalizationFrame
            && f.severity == crate::quality::Severity::Fatal
    }) {
        report
            .checks
            .extend(crate::quality::fixed_position_axis(&world));
    }
    if report
        .checks
        .iter()
        .any(|f| f.check == crate::quality::Check::ImuConstant)
    {
        let dt = robot.dt();
        let vehicle = robot.vehicle.as_ref();
        // From each sample and the ones before it only (see yaw_rate_from_localization).
        let rates: Vec<Vec<f64>> = (0..data.windows.len())
            .map(|i| {
                let w = &data.windows[i];
                let before = i
                    .checked_sub(1)
                    .map(|p| &data.windows[p])
                    .filter(|b| b.continued_by(w));
                crate::quality::yaw_rate_from_localization(w, before, vehicle, dt)
            })
            .collect();
        for (w, r) in data.windows.iter_mut().zip(rates) {
            w.imu_yaw_rate = r;
        }
        report.notes.push(
            "the imu_yaw_rate column holds the yaw rate from localization (backward differences of its yaw, from each sample and the ones before it), as the IMU was not recorded".into(),
        );
    }
    data.link_start_velocities();
    Ok((data, report))
}

/// The three windows of an interval from an uninterrupted stretch of rows, or why the
/// localization makes it unusable.
fn cut_interval(
    stretch: &[&RawRow],
    robot: &RobotDescription,
    period_ns: f64,
    samples: usize,
    config: &ImportConfig,
) -> Result<Vec<Window>, DropReason> {
    let t0 = stretch[0].time_ns;
    // Nearest row to each grid instant (rows are in time order).
    let mut picked: Vec<&RawRow> = Vec::with_capacity(samples);
    let mut j = 0;
    for k in 0..samples {
        let t = t0 + (k as f64 * period_ns).round() as i64;
        while j + 1 < stretch.len()
            && (stretch[j + 1].time_ns - t).abs() <= (stretch[j].time_ns - t).abs()
        {
            j += 1;
        }
        picked.push(stretch[j]);
    }
    let t_end = picked[samples - 1].time_ns;
    let used: Vec<&RawRow> = stretch
        .iter()
        .copied()
        .take_while(|r| r.time_ns <= t_end)
        .collect();
    if used
        .iter()
        .all(|r| r.position == [0.0; 3] && r.yaw().is_none_or(|y| y == 0.0))
    {
        return Err(DropReason::LocalizationMissing);
    }
    if let Some(r) = used.iter().find(|r| r.yaw().is_none()) {
        return Err(DropReason::BadQuaternion { line: r.line });
    }
    // Localization updates: a new icp_index or a new pose.
    let mut last_update = (t0, used[0].line);
    let mut frozen: Option<(f64, usize)> = None;
    let mut check = |since: (i64, usize), now: i64| {
        let dt = seconds(now - since.0);
        if dt > config.localization_timeout_s && frozen.is_none_or(|(f, _)| dt > f) {
            frozen = Some((dt, since.1));
        }
    };
    for w in used.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b.icp_index != a.icp_index || b.position != a.position || b.quaternion != a.quaternion {
            check(last_update, b.time_ns);
            last_update = (b.time_ns, b.line);
        }
    }
    check(last_update, t_end);
    if let Some((for_s, line)) = frozen {
        return Err(DropReason::LocalizationFrozen { for_s, line });
    }
    // Body commands into the vehicle's inputs (wheel velocities for a differential drive).
    let mut commands = Vec::with_capacity(picked.len());
    for row in &picked {
        let [v, w] = row.body_command;
        match robot.vehicle.input_for_twist(v, w) {
            Some(u) => commands.push(u),
            None => {
                return Err(DropReason::CommandNotAnInput {
                    line: row.line,
                    linear: v,
                    angular: w,
                })
            }
        }
    }
    let len = robot.window_len;
    Ok(picked
        .chunks(len)
        .zip(commands.chunks(len))
        .enumerate()
        .map(|(i, (chunk, command))| {
            // Checked above: every used row's quaternion is a rotation.
            let pose = |row: &RawRow| {
                Pose::new(row.position[0], row.position[1], row.yaw().unwrap_or(0.0))
            };
            let p0 = pose(chunk[0]);
            Window::new(
                0,
                0,
                if i == 0 {
                    Phase::Transient
                } else {
                    Phase::Steady
                },
                command.to_vec(),
                chunk.iter().map(|row| row.measured).collect(),
                chunk
                    .iter()
                    .map(|row| relative_pose(&p0, &pose(row)))
                    .collect(),
                chunk.iter().map(|row| row.imu_rate[2]).collect(),
            )
        })
        .collect())
}
