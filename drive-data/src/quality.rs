//! Data-quality checks on a window dataset: problems real logs carry that no parser sees
//! (the robot on a stand, an IMU not recorded, encoders not recorded, the wrong robot
//! file). `drive import` runs them on what it imports, `drive check` on a window CSV.
//!
//! ```
//! use drive_data::quality::{check, Check, Severity};
//! # let csv = "window,phase,k,t,cmd_left,cmd_right,enc_left,enc_right,x,y,yaw,imu_yaw_rate\n\
//! #            0,transient,0,0,4,4,4,4,0,0,0,0\n0,transient,1,0.5,4,4,4,4,0,0,0,0\n";
//! # let side = r#"{"name": "t", "rate_hz": 2, "window_len": 2, "wheel_radius": 0.5, "baseline": 1}"#;
//! // Wheels turning at 4 rad/s (2 m/s) for a window, localization still: wheels in the air?
//! let data = drive_data::parse_dataset("d.csv", csv, "d.json", side).unwrap();
//! let findings = check(&data, None);
//! let stand = findings.iter().find(|f| f.check == Check::NotMoving).unwrap();
//! assert_eq!(stand.severity, Severity::Fatal);
//! ```

use drive_traits::limits::Short;
use drive_traits::{Dataset, InputSpace, Phase, Pose, Window};
use serde::Serialize;

/// `encoder-command`: the least-squares gain of a measured input on its command above which
/// the encoders are in another unit than the commands (the real runs: 0.42-0.84, a powertrain
/// saturating below its commands; a powertrain answers a command, it does not keep turning
/// twice as fast: a wheel's commands in m/s against its encoders in rad/s scale the gain by
/// 1 / radius, 2.6 on a real Warthog run).
const MAX_ENCODER_GAIN: f64 = 2.0;

/// `encoder-command`: the band of least-squares gains (a measured input on its command) that
/// real DRIVE runs fall in, with a margin: the bundled and norlab runs 0.42-0.84 (the Husky
/// commanded far beyond its limits, the lowest), the simulated robots 0.77-1.0. Outside it
/// (commands scaled by 2.5-3 answer 0.25-0.28, by 0.3 answer 1.4) a warning: commands
/// scaled or in another unit would fit a powertrain of that gain and a model answering
/// other commands than the robot's.
const TYPICAL_ENCODER_GAIN: std::ops::RangeInclusive<f64> = 0.3..=1.25;

mod copies;
mod localization;
mod parts;
mod scattered;
mod steps;
pub use localization::{fixed_position_axis, position_grid};

/// How bad a finding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Worth knowing; the data is used.
    Warning,
    /// The dataset is useless as it is: import writes nothing unless allowed.
    Fatal,
}

impl Severity {
    /// [`Severity::Fatal`] when `fatal`, else [`Severity::Warning`].
    fn fatal_if(fatal: bool) -> Severity {
        if fatal {
            Severity::Fatal
        } else {
            Severity::Warning
        }
    }
}

/// The data checks, one function each; a check's key (`not-moving`, ...) is the name
/// `--allow` takes and the JSON's `check`.
///
/// ```
/// use drive_data::quality::Check;
/// assert_eq!(Check::NotMoving.key(), "not-moving");
/// assert_eq!(Check::from_key("encoder-units"), Some(Check::EncoderUnits));
/// assert_eq!(serde_json::to_string(&Check::ImuConstant).unwrap(), "\"imu-constant\"");
/// assert_eq!(Check::ALL.len(), drive_data::quality::CHECKS.len());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Check {
    /// Localization still while the encoders turn, or nothing moving under the commands.
    NotMoving,
    /// An IMU yaw rate that never changes.
    ImuConstant,
    /// Encoders at zero under commands.
    EncodersZero,
    /// Encoders stuck at their noise under commands.
    EncodersStuck,
    /// Encoders in another unit than localization (distance or yaw).
    EncoderUnits,
    /// A measured input that does not follow its command.
    EncoderCommand,
    /// Commands or encoders far beyond the robot description's limits, or another vehicle.
    OutsideLimits,
    /// Localization turning or moving the other way from the encoders (a mirrored frame,
    /// swapped or sign-flipped encoder columns).
    Direction,
    /// One command throughout (the data shows the robot's answer to nothing else).
    CommandsConstant,
    /// Localization's positions moving at an angle from its own heading, or turning against
    /// its own yaw (a heading from another frame, x and y swapped, one axis negated).
    LocalizationFrame,
    /// Localization not following the encoders at all, or following another window's
    /// (another run's localization, timestamps shifted).
    LocalizationSync,
    /// Positions on a coarse grid (world coordinates stored as 32-bit floats).
    PositionSteps,
    /// Windows written twice in one dataset (a model would be scored on its own windows).
    DuplicateWindows,
    /// An IMU yaw rate against localization's turn: sign flipped, or in another unit.
    ImuYawRate,
    /// The transient and steady labels against what the wheels do (swapped labels).
    Phases,
    /// Windows out of the order they were recorded in (steady windows holding another
    /// command than their interval's transient one).
    WindowOrder,
}

impl Check {
    /// Every check, in [`CHECKS`]' order.
    pub const ALL: [Check; 16] = [
        Check::NotMoving,
        Check::ImuConstant,
        Check::EncodersZero,
        Check::EncodersStuck,
        Check::EncoderUnits,
        Check::EncoderCommand,
        Check::OutsideLimits,
        Check::Direction,
        Check::CommandsConstant,
        Check::LocalizationFrame,
        Check::LocalizationSync,
        Check::PositionSteps,
        Check::DuplicateWindows,
        Check::ImuYawRate,
        Check::Phases,
        Check::WindowOrder,
    ];

    /// The check's key, the name `--allow` takes (its entry in [`CHECKS`]).
    pub fn key(self) -> &'static str {
        CHECKS[self as usize].0
    }

    /// What the check looks for, in one line.
    pub fn describe(self) -> &'static str {
        CHECKS[self as usize].1
    }

    /// The check of a key; `None` for no check of that name.
    pub fn from_key(key: &str) -> Option<Check> {
        Check::ALL.into_iter().find(|c| c.key() == key)
    }
}

impl std::fmt::Display for Check {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.key())
    }
}

/// One thing a check found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    /// The check (its key in the JSON, the name `--allow` takes).
    pub check: Check,
    /// How bad.
    pub severity: Severity,
    /// What was found, in one line.
    pub message: String,
}

/// The checks' keys and what they look for, in [`Check`]'s order.
pub const CHECKS: [(&str, &str); 16] = [
    (
        "not-moving",
        "localization still while the encoders turn (wheels off the ground, localization frozen)",
    ),
    (
        "imu-constant",
        "an IMU yaw rate that never changes (not recorded); start states then use localization",
    ),
    (
        "encoders-zero",
        "encoders at zero under commands (encoders not recorded)",
    ),
    (
        "encoders-stuck",
        "encoders under a millionth of the largest command throughout commanded windows (stuck at their noise, not recorded)",
    ),
    (
        "encoder-units",
        "the distance the encoders imply a fixed factor (over 2.5 or under 0.6) away from the one localization saw (encoders in another unit, or the wrong wheel radius), or localization's yaw turning over five times faster than the encoders' (yaw in degrees), or turning over 2.5 times what they imply (a baseline too wide), or an angle input beyond pi (in degrees), or the encoders driving one way where the commands drive no travel (an offset on them), or turning one way in the steady windows where the commands turn little, beyond what they turn (an offset on one side, or on a yaw-rate input)",
    ),
    (
        "encoder-command",
        "a measured input that does not follow its command: near zero while commanded (one encoder dead), against its commands (sign flipped, sides swapped), or a fixed factor away (over 2 or under 0.1: commands or encoders in another unit; a warning outside 0.3-1.25, where real runs answer 0.42-0.84: commands scaled), its command copied (delayed, scaled or with noise, within 0.5%), answering 1.2 s late or more (fatal from 1.5 s); on a skid-steer, driving straight, one side's measurement over its command 1.25 times the other's or more (fatal from 1.5: one side scaled); the measured inputs holding one value through four in five steady windows while the commands vary (fatal: the columns exchanged); on a skid-steer, the two commands equal to the bit where the wheels turn the robot (fatal: one command written for both sides), or the commanded forward speed following the yaw rate the encoders imply and the commanded yaw rate their forward speed while localization does not follow the commands' own axes (fatal: a log's cmd_vel linear and angular columns read for each other; where localization follows them, one encoder negated, named as such)",
    ),
    (
        "outside-limits",
        "commands or encoder speeds beyond three times the robot description's limits (wrong robot file?)",
    ),
    (
        "direction",
        "localization turning the other way from the encoders in most windows where both turn (a mirrored frame, the encoder columns swapped), or moving backwards where they drive forwards (encoders sign-flipped); the same of the commands in the steady windows (command columns swapped or sign-flipped); interval by interval, one of the commands, the encoders and localization turning or driving against two others that agree in a tenth of the intervals (a column corrupted in intervals scattered over the run)",
    ),
    (
        "commands-constant",
        "one command throughout (the data shows how the robot answers nothing else)",
    ),
    (
        "localization-frame",
        "localization's positions moving at 20 degrees or more from its own heading where the encoders drive along it (a heading from another frame than the positions), at 45 degrees or more either way (x and y swapped, a yaw in degrees), or the path they draw turning against its yaw (y negated alone)",
    ),
    (
        "localization-sync",
        "localization's travel and turn per window not following the encoders' (correlation under 0.3: another run's localization), or following the window before's or after's better (timestamps shifted by a window); sample by sample, localization equal to the encoders' dead reckoning (wheel odometry: no slip to learn), jumping at one sample of every window (3 times the mean step; fatal from 5), or moving from sample to sample twice what the encoders imply and 0.5 m/s more (noise on every position; fatal from 4 times and 2 m/s), or moving where the encoders imply no path (drifting)",
    ),
    (
        "position-steps",
        "positions on a grid of 2 cm or coarser (world coordinates stored as 32-bit floats, or written to few digits): fatal from 10 cm, where the grid is a large part of every error",
    ),
    (
        "duplicate-windows",
        "windows written twice in one dataset, bit for bit or within a thousandth of the data's range in every sample (the run listed twice, or its windows or intervals repeated, perhaps rounded or with noise added), or a fifth of them agreeing in their mean inputs with the window a constant number of places later (the run written again, re-cut a few samples later): a split would score a model on the windows it was fitted on",
    ),
    (
        "imu-yaw-rate",
        "the IMU's yaw rate, integrated over each window, against localization's turn: over twice it (scaled, deg/s), under half of it (lagging, another signal) or against it and scaled; a warning outside 0.75-1.33 times it, and for an IMU read backwards alone (-1.33 to -0.75: the models' start from the IMU turns the wrong way), and for one equal to the yaw rate the encoders imply (computed from them, not measured)",
    ),
    (
        "phases",
        "the measured inputs changing more over the steady windows than over the transient ones (the phase labels swapped: a split and the per-phase errors would be of the wrong windows), or steps to a new command opening windows labelled steady (transient labels lost), or no transient window among ten or more (the phase column lost: no interval to split by, no step for the powertrain's fit)",
    ),
    (
        "window-order",
        "windows out of the order they were recorded in: over half of the steady windows holding another command than the transient window that opens their interval, where the windows hold their commands (windows sorted, reversed or shuffled: the split, the start states and the transient fit would take windows from other moments)",
    ),
];

/// A window's motion as the encoders imply it (dead reckoning of the measured inputs
/// through the vehicle) and as localization saw it: (implied distance m, implied yaw rad,
/// localized distance m, localized yaw rad (signed)), net over the window.
fn motion(data: &Dataset, w: &Window) -> (f64, f64, f64, f64) {
    let (distance, yaw) = dead_reckoned(data, &w.measured, w.len());
    let (first, last) = (w.pose[0], w.pose[w.len() - 1]);
    let moved = ((last.x - first.x).powi(2) + (last.y - first.y).powi(2)).sqrt();
    // Unwrapped: a fast spin passes +-pi within a window.
    let turned = drive_traits::net_turn(&w.pose);
    (distance, yaw, moved, turned)
}

/// The net distance and the absolute net yaw change that the first `len - 1` of `inputs`
/// imply through the vehicle (eq. 4, dead-reckoned over the window).
fn dead_reckoned(data: &Dataset, inputs: &[drive_traits::Input], len: usize) -> (f64, f64) {
    let dt = data.robot.dt();
    let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
    for u in inputs.iter().take(len.saturating_sub(1)) {
        let v = data.robot.vehicle.body_velocity(u);
        x += (v.x * yaw.cos() - v.y * yaw.sin()) * dt;
        y += (v.x * yaw.sin() + v.y * yaw.cos()) * dt;
        yaw += v.z * dt;
    }
    ((x * x + y * y).sqrt(), yaw.abs())
}

/// The windows the checks read (two samples or more) and each one's motion ([`motion`]),
/// computed once for every check.
struct Windows<'a> {
    data: &'a Dataset,
    windows: Vec<&'a Window>,
    motions: Vec<(f64, f64, f64, f64)>,
    /// Each window's travel in the body frame, seen and implied, and the implied turn
    /// ([`localization::body_travel`]), computed once for the localization checks.
    travels: Vec<([f64; 2], [f64; 2], f64)>,
}

/// Runs every check on `data`; `limits` is the robot description's input space when known
/// (for `outside-limits`). The findings in order: `not-moving`, `imu-constant`,
/// `encoders-zero`, `encoders-stuck`, `encoder-command`, `encoder-units`, `outside-limits`,
/// `direction`, `localization-frame`, `localization-sync`, `position-steps`,
/// `duplicate-windows`, `imu-yaw-rate`, `commands-constant`.
pub fn check(data: &Dataset, limits: Option<&InputSpace>) -> Vec<Finding> {
    let windows: Vec<&Window> = data.windows.iter().filter(|w| w.len() >= 2).collect();
    if windows.is_empty() {
        return Vec::new();
    }
    let motions = windows.iter().map(|w| motion(data, w)).collect();
    let travels = windows
        .iter()
        .map(|w| localization::body_travel(data, w))
        .collect();
    let w = Windows {
        data,
        windows,
        motions,
        travels,
    };
    let mut out = not_moving(&w);
    out.extend(imu_constant(&w));
    out.extend(encoders_silent(&w, Check::EncodersZero));
    out.extend(encoders_silent(&w, Check::EncodersStuck));
    out.extend(encoder_command(data, &w.windows));
    out.extend(encoder_units(&w));
    if let Some(space) = limits {
        out.extend(outside_limits(&w, space));
    }
    out.extend(direction(&w));
    out.extend(localization::frame(&w));
    out.extend(localization::sync(&w));
    out.extend(localization::positions(&w));
    out.extend(steps::written_from_encoders(&w));
    out.extend(steps::jumps_and_noise(&w));
    out.extend(steps::drifting(&w));
    out.extend(steps::slow_updates(&w));
    out.extend(steps::encoder_offset(&w));
    out.extend(duplicate_windows(&w));
    out.extend(imu_yaw_rate(&w));
    out.extend(steps::imu_from_encoders(&w));
    out.extend(phases(&w));
    out.extend(window_order(&w.windows));
    out.extend(exchanged(&w.windows));
    out.extend(commands_constant(&w));
    let in_parts = parts::parts(&w, &out);
    out.extend(in_parts);
    // A measured column at odds with its commands (another unit, a sign flipped in part of
    // the run) makes the robot look still under its commands, or localization look
    // drifting where the encoders imply no path, or moving at an angle from its heading
    // where they drive backwards: the column is the cause, said first.
    if let Some(first) = out.iter().position(|f| {
        f.severity == Severity::Fatal
            && matches!(
                f.check,
                Check::NotMoving | Check::LocalizationSync | Check::LocalizationFrame
            )
    }) {
        let (mut cause, rest): (Vec<Finding>, Vec<Finding>) = out[first..]
            .iter()
            .cloned()
            .partition(|f| f.severity == Severity::Fatal && f.check == Check::EncoderCommand);
        out.truncate(first);
        out.append(&mut cause);
        out.extend(rest);
    }
    match parts::turn_faults(&w) {
        // The IMU agrees with the encoders: what `imu-yaw-rate` said of it against
        // localization is localization's doing.
        Some(parts::TurnFault::Localization(f)) => {
            out.retain(|g| g.check != Check::ImuYawRate);
            if !out
                .iter()
                .any(|g| g.severity == Severity::Fatal && localization_blamed(g))
            {
                out.push(f);
            }
        }
        // One part's IMU read backwards: what the whole run's gain said (a mix of the two
        // signs reads little of the turn) is that.
        Some(parts::TurnFault::ImuFlipped(f) | parts::TurnFault::ImuScaled(f)) => {
            out.retain(|g| {
                g.check != Check::ImuYawRate
                    || !(g.message.contains("integrates to") || g.message.contains(" alone"))
            });
            out.push(f);
        }
        None => {}
    }
    scattered::add_scattered(&w, &mut out);
    out
}

/// Whether a finding already blames localization (a part's localization mirrored, frozen or
/// scaled), so that [`parts::turn_faults`]' finding would repeat it.
fn localization_blamed(f: &Finding) -> bool {
    matches!(
        f.check,
        Check::Direction | Check::LocalizationSync | Check::LocalizationFrame | Check::EncoderUnits
    ) && f.message.contains("localization")
}

/// `encoder-command`: the command and measured columns exchanged. A steady window holds its
/// command and the wheels answer it with their noise: the real runs' commands hold one value
/// through 95-100% of their steady windows and their encoders through 0-1%; exchanged, the
/// other way round (1% and 95%). Fatal where the measured inputs hold one value (bit for
/// bit, every axis) through four in five steady windows or more (ten at least) and the
/// commands vary in four in five.
fn exchanged(windows: &[&Window]) -> Option<Finding> {
    let steady: Vec<&&Window> = windows
        .iter()
        .filter(|w| w.phase != Phase::Transient && w.len() >= 2)
        .collect();
    if steady.len() < 10 {
        return None;
    }
    let held = |inputs: &[drive_traits::Input]| inputs.iter().all(|u| *u == inputs[0]);
    let measured = steady.iter().filter(|w| held(&w.measured)).count();
    let commands = steady.iter().filter(|w| !held(&w.command)).count();
    let most = |k: usize| k * 5 >= steady.len() * 4;
    (most(measured) && most(commands)).then(|| Finding {
        check: Check::EncoderCommand,
        severity: Severity::Fatal,
        message: format!(
            "the measured inputs hold one value through {measured} of {} steady windows while the commands vary in {commands}: a steady window holds its command and the wheels answer it with their noise; the command and measured columns exchanged?",
            steady.len()
        ),
    })
}

/// `window-order`: a DRIVE interval's transient window ramps to one command (within the
/// robot's acceleration) that its steady windows hold (the intervals are found from the
/// phases: each transient window opens one). Where the steady windows hold their commands
/// (within 1% of the axis's range in nine of ten), fatal when over half of them (ten at
/// least) hold another command than the one their interval's transient window ends on:
/// windows sorted, reversed or shuffled (the real runs: 0-5%; a run's windows reversed or
/// shuffled: 95-99%). A split by interval, the start states (a window's preceding one) and
/// the transient fit would take windows from other moments of the run.
fn window_order(windows: &[&Window]) -> Option<Finding> {
    // Every input axis (a two-input vehicle's third is 0 throughout).
    let axes = 3;
    // Each axis's command range over the run (the tolerance's scale).
    let mut range = [0.0f64; 3];
    for a in 0..axes {
        let (lo, hi) = windows
            .iter()
            .flat_map(|w| w.command.iter().map(move |u| u[a]))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        range[a] = (hi - lo).max(0.0);
    }
    let tolerance = |a: usize| 0.01 * range[a] + 1e-12;
    let mean = |w: &Window, a: usize| w.command.iter().map(|u| u[a]).sum::<f64>() / w.len() as f64;
    let steadies: Vec<&&Window> = windows
        .iter()
        .filter(|w| w.phase != Phase::Transient)
        .collect();
    let held = steadies
        .iter()
        .filter(|w| {
            (0..axes).all(|a| {
                let m = mean(w, a);
                w.command.iter().all(|u| (u[a] - m).abs() <= tolerance(a))
            })
        })
        .count();
    if held * 10 < steadies.len() * 9 {
        return None;
    }
    let mut opening: Option<(usize, &Window)> = None;
    let (mut steady, mut other) = (0usize, 0usize);
    for w in windows {
        if w.phase == Phase::Transient {
            opening = Some((w.interval, w));
            continue;
        }
        let Some((interval, transient)) = opening else {
            continue;
        };
        if interval != w.interval {
            continue;
        }
        steady += 1;
        // The command the transient window ramps to (within the robot's acceleration).
        let Some(target) = transient.command.last() else {
            continue;
        };
        if (0..axes).any(|a| (mean(w, a) - target[a]).abs() > tolerance(a)) {
            other += 1;
        }
    }
    if steady < 10 || other * 2 <= steady {
        return None;
    }
    Some(Finding {
        check: Check::WindowOrder,
        severity: Severity::Fatal,
        message: format!(
            "{other} of {steady} steady windows hold another command than the transient window that opens their interval: the windows are not in the order they were recorded in (sorted, reversed or shuffled?)"
        ),
    })
}

/// `phases`: the steps to a new command (a window's first five commands' mean off the last
/// five's of the window before it by a twentieth of the commands' range or more) that open a window
/// labelled steady. A DRIVE interval opens with its transient window, so a step opening a
/// steady window is a transient label lost (none on 227 real and simulated runs). Fatal from
/// a tenth of the steps, five at least: the intervals (cut at the transient windows) would
/// run into one another, and the powertrain's fit would miss their steps.
fn steps_on_steady_windows(windows: &[&Window]) -> Option<Finding> {
    let (low, high) = windows
        .iter()
        .flat_map(|w| w.command.iter())
        .flat_map(|u| u.iter().copied())
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let step = 0.05 * (high - low);
    if !(step.is_finite() && step > 0.0) {
        return None;
    }
    let (mut steps, mut on_steady) = (0usize, 0usize);
    for pair in windows.windows(2) {
        let (before, window) = (pair[0], pair[1]);
        // The means of the five samples each side of the boundary (a command column with
        // noise on every sample steps by none).
        let (n, m) = (before.command.len(), window.command.len());
        if n < 5 || m < 5 {
            continue;
        }
        let mean = |s: &[drive_traits::Input]| s.iter().sum::<drive_traits::Input>() / 5.0;
        let (last, first) = (mean(&before.command[n - 5..]), mean(&window.command[..5]));
        if window.index != before.index + 1 || !(first - last).abs().iter().any(|d| *d >= step) {
            continue;
        }
        steps += 1;
        on_steady += usize::from(window.phase == drive_traits::Phase::Steady);
    }
    (on_steady >= 5 && on_steady * 10 >= steps).then(|| Finding {
        check: Check::Phases,
        severity: Severity::Fatal,
        message: format!(
            "{on_steady} of the {steps} steps to a new command open a window labelled steady, where a DRIVE interval opens with its transient window: transient labels lost (the intervals would run into one another and the powertrain's fit would miss their steps)?"
        ),
    })
}

/// `phases`: the median change of the measured inputs over a window (the mean of its last
/// five samples against its first five, summed over the input axes), in the steady windows
/// against the transient ones, ten of each at least. A transient window holds the step to a
/// new command, a steady one holds it: the bundled runs' steady windows change 0.02-0.07
/// times as much, the simulator's 0.003-0.1 (the linear-focused sampler's 0.1). Steady
/// windows changing half as much as transient ones or more ([`PHASES_MAX_RATIO`]) are
/// labels swapped or drawn at random (0.8-0.9): fatal (the intervals are cut at the
/// transient windows, and the errors reported per phase would be the other phase's). So
/// are intervals of a single window (a tenth of the transient windows followed by another
/// transient one), and no transient window at all among ten or more.
fn phases(w: &Windows<'_>) -> Option<Finding> {
    let mut change: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    for win in &w.windows {
        let n = win.measured.len();
        if n < 10 {
            continue;
        }
        let mean = |s: &[drive_traits::Input]| s.iter().sum::<drive_traits::Input>() / 5.0;
        let d = (mean(&win.measured[n - 5..]) - mean(&win.measured[..5]))
            .abs()
            .sum();
        if d.is_finite() {
            change[usize::from(win.phase == drive_traits::Phase::Steady)].push(d);
        }
    }
    // Not one transient window among many: the intervals (each opened by a transient
    // window) and the powertrain's fit (on the transient windows) have nothing to go by.
    let transients = w
        .windows
        .iter()
        .filter(|win| win.phase == drive_traits::Phase::Transient)
        .count();
    if transients == 0 && w.windows.len() >= 10 {
        return Some(Finding {
            check: Check::Phases,
            severity: Severity::Fatal,
            message: format!(
                "none of the {} windows is a transient one: a DRIVE interval opens with its transient window (the step to a new command), so the data has no interval to split by and no step for the powertrain's fit; the phase column lost or overwritten?",
                w.windows.len()
            ),
        });
    }
    let [mut transient, mut steady] = change;
    if transient.len() >= 10 && steady.len() >= 10 {
        let (t, st) = (
            drive_traits::median(&mut transient),
            drive_traits::median(&mut steady),
        );
        if st > 0.0 && st >= PHASES_MAX_RATIO * t {
            return Some(Finding {
                check: Check::Phases,
                severity: Severity::Fatal,
                message: format!(
                    "the measured inputs change {} over a steady window and {} over a transient one (medians over {} and {} windows; a transient window holds the step to a new command, and a steady window of a DRIVE run changes under a tenth as much): the phase labels swapped, drawn at random, or the measurements late by a window?",
                    Short(three_digits(st)),
                    Short(three_digits(t)),
                    steady.len(),
                    transient.len()
                ),
            });
        }
    }
    if let Some(f) = steps_on_steady_windows(&w.windows) {
        return Some(f);
    }
    // Transient windows followed by another transient window: intervals of one window. A
    // DRIVE interval is its transient window and then its steady ones (none such on 227 real
    // and simulated runs); labels drawn at random give a quarter or more, the first steady
    // window of every interval relabelled transient a half.
    let single = w
        .windows
        .windows(2)
        .filter(|p| {
            p[0].phase == drive_traits::Phase::Transient
                && p[1].phase == drive_traits::Phase::Transient
        })
        .count();
    (transients >= 10 && single * 10 >= transients && single >= 5).then(|| Finding {
        check: Check::Phases,
        severity: Severity::Fatal,
        message: format!(
            "{single} of the {transients} transient windows are followed by another transient window: intervals of a single window, where a DRIVE interval is its transient window and then its steady ones; the phase labels shifted, relabelled or drawn at random?"
        ),
    })
}

/// The steady windows' median change over the transient windows' from which the phase
/// labels are wrong (`phases`): five times the largest of 8 real and 213 simulated runs.
const PHASES_MAX_RATIO: f64 = 0.5;

/// The motion (m, rad) under which a window's commands, encoders and localization are at
/// rest (`not-moving`'s warning on runs of such windows).
const REST_MOTION: f64 = 0.02;

/// Fewest windows where both the encoders and localization turn (or move) clearly, for
/// `direction` to judge their agreement.
const DIRECTION_MIN_WINDOWS: usize = 10;
/// Most share of those windows that may agree for `direction` to call the two opposed.
const DIRECTION_MAX_AGREEING: f64 = 0.2;

/// `direction`: in the windows where the encoders imply a clear turn (0.2 rad or more) and
/// localization saw one (0.1 rad or more), the two turn the same way in under a fifth of
/// them (a mirrored localization frame, or the encoder columns swapped); or, where the
/// encoders imply 0.3 m or more of forward or backward travel and localization saw 0.15 m,
/// localization moved the other way along the robot's heading in over four fifths (encoders
/// sign-flipped). The same of the commands, in the steady windows (where the robot has
/// answered them): localization turning or driving against them in over four fifths (the
/// command columns swapped or sign-flipped while the encoders' are not). Fatal: a model
/// fitted on it learns the robot backwards.
fn direction(w: &Windows<'_>) -> Vec<Finding> {
    let signals = direction_signals(w);
    direction_of(signals.iter())
}

/// A window's signals for [`direction`]: the signed net turn and forward travel (body
/// frame, eq. 4 summed) its encoders imply and, in a steady window, its commands ask for;
/// the turn localization saw and its travel along the heading it started the window with.
#[derive(Debug, Clone, Copy)]
struct DirectionSignals {
    inputs: [Option<(f64, f64)>; 2],
    turned: f64,
    along: f64,
}

/// Each window's [`DirectionSignals`], in order.
fn direction_signals(w: &Windows<'_>) -> Vec<DirectionSignals> {
    let data = w.data;
    let dt = data.robot.dt();
    w.windows
        .iter()
        .zip(&w.motions)
        .map(|(win, m)| {
            let n = win.len().saturating_sub(1);
            let (first, last) = (win.pose[0], win.pose[n]);
            let along = (last.x - first.x) * first.z.cos() + (last.y - first.y) * first.z.sin();
            let steady = win.phase == drive_traits::Phase::Steady;
            let sums = |inputs: &[drive_traits::Input]| {
                let (mut yaw, mut forward) = (0.0, 0.0);
                for u in inputs.iter().take(n) {
                    let v = data.robot.vehicle.body_velocity(u);
                    yaw += v.z * dt;
                    forward += v.x * dt;
                }
                (yaw, forward)
            };
            DirectionSignals {
                inputs: [
                    Some(sums(&win.measured)),
                    steady.then(|| sums(&win.command)),
                ],
                turned: m.3,
                along,
            }
        })
        .collect()
}

/// [`direction`] on the windows' signals.
fn direction_of<'a>(signals: impl Iterator<Item = &'a DirectionSignals>) -> Vec<Finding> {
    // [encoders, commands]: windows that turn (drive) clearly, and those that agree.
    let (mut turns, mut turns_agree, mut drives, mut drives_agree) =
        ([0usize; 2], [0usize; 2], [0usize; 2], [0usize; 2]);
    for sig in signals {
        for (i, sums) in sig.inputs.iter().enumerate() {
            let Some((yaw, forward)) = *sums else {
                continue;
            };
            if yaw.abs() >= 0.2 && sig.turned.abs() >= 0.1 {
                turns[i] += 1;
                turns_agree[i] += usize::from(yaw.signum() == sig.turned.signum());
            }
            if forward.abs() >= 0.3 && sig.along.abs() >= 0.15 {
                drives[i] += 1;
                drives_agree[i] += usize::from(forward.signum() == sig.along.signum());
            }
        }
    }
    let (turns_by_command, turns_by_command_agree) = (turns[1], turns_agree[1]);
    let (drives_by_command, drives_by_command_agree) = (drives[1], drives_agree[1]);
    let (turns, turns_agree, drives, drives_agree) =
        (turns[0], turns_agree[0], drives[0], drives_agree[0]);
    let mut out = Vec::new();
    let opposed = |n: usize, agree: usize| {
        n >= DIRECTION_MIN_WINDOWS && (agree as f64) < DIRECTION_MAX_AGREEING * n as f64
    };
    // Where the encoders and localization disagree, the commands (steady windows) side with
    // one of them: the other is the odd one (four in five of their windows agreeing).
    let with_localization = |n: usize, agree: usize| {
        n >= DIRECTION_MIN_WINDOWS && agree as f64 >= (1.0 - DIRECTION_MAX_AGREEING) * n as f64
    };
    let with_encoders = |n: usize, agree: usize| with_localization(n, n - agree);
    if opposed(turns, turns_agree) {
        let cause = if with_localization(turns_by_command, turns_by_command_agree) {
            "the commands turn with localization: are the measured columns swapped, or one of them sign-flipped?"
        } else if with_encoders(turns_by_command, turns_by_command_agree) {
            "the commands turn with the encoders: is the localization mirrored (y and yaw negated)?"
        } else {
            "is the localization mirrored (y and yaw negated), or are the encoder columns swapped?"
        };
        out.push(Finding {
            check: Check::Direction,
            severity: Severity::Fatal,
            message: format!(
                "localization turns the other way from the encoders in {} of {turns} windows where both turn: {cause}",
                turns - turns_agree
            ),
        });
    }
    if opposed(drives, drives_agree) {
        let cause = if with_localization(drives_by_command, drives_by_command_agree) {
            "the commands drive with localization: are the encoders sign-flipped?"
        } else if with_encoders(drives_by_command, drives_by_command_agree) {
            "the commands drive with the encoders: is the localization's heading turned half a turn?"
        } else {
            "are the encoders sign-flipped, or the localization's heading turned half a turn?"
        };
        out.push(Finding {
            check: Check::Direction,
            severity: Severity::Fatal,
            message: format!(
                "localization moves backwards along the robot's heading where the encoders drive forwards (and the other way) in {} of {drives} windows: {cause}",
                drives - drives_agree
            ),
        });
    }
    // The commands, when the encoders agree with localization (else the finding above
    // already names the cause).
    if out.is_empty()
        && opposed(turns_by_command, turns_by_command_agree)
        && opposed(drives_by_command, drives_by_command_agree)
    {
        out.push(Finding {
            check: Check::Direction,
            severity: Severity::Fatal,
            message: format!(
                "the robot turned the other way from its commands in {} of {turns_by_command} steady windows where both turn, and drove backwards where they drive forwards (and the other way) in {} of {drives_by_command}, while its encoders did as it did: are the commands sign-flipped?",
                turns_by_command - turns_by_command_agree,
                drives_by_command - drives_by_command_agree
            ),
        });
    }
    if out.is_empty() && opposed(turns_by_command, turns_by_command_agree) {
        out.push(Finding {
            check: Check::Direction,
            severity: Severity::Fatal,
            message: format!(
                "the robot turned the other way from its commands in {} of {turns_by_command} steady windows where both turn, while its encoders turned with it: are the command columns swapped?",
                turns_by_command - turns_by_command_agree
            ),
        });
    }
    if out.is_empty() && opposed(drives_by_command, drives_by_command_agree) {
        out.push(Finding {
            check: Check::Direction,
            severity: Severity::Fatal,
            message: format!(
                "the robot drove backwards where it was commanded forwards (and the other way) in {} of {drives_by_command} steady windows, while its encoders drove with it: are the commands sign-flipped?",
                drives_by_command - drives_by_command_agree
            ),
        });
    }
    out
}

/// `duplicate-windows`: windows equal bit for bit (commands, measurements, poses, IMU) to
/// another of the dataset, among those where anything moves, or else within a thousandth
/// of the data's range of another ([`near_duplicates`]). Fatal: no two windows of a run
/// are the same to the bit, and a split by interval would put one copy in training and the
/// other in evaluation.
fn duplicate_windows(w: &Windows<'_>) -> Option<Finding> {
    use std::collections::HashMap;
    let mut seen: HashMap<u64, Vec<usize>> = HashMap::new();
    let mut repeated = 0usize;
    for (i, win) in w.windows.iter().enumerate() {
        let still = win
            .command
            .iter()
            .chain(&win.measured)
            .all(|u| u.iter().all(|v| *v == 0.0))
            && win.pose.iter().all(|p| *p == win.pose[0]);
        if still {
            continue;
        }
        // A multiplicative fold of the values' bits (a few instructions a value: what
        // `drive train` runs before every fit); equal windows are then compared whole.
        let mut h = 0u64;
        let mut fold =
            |v: f64| h = (h.rotate_left(5) ^ v.to_bits()).wrapping_mul(0x517c_c1b7_2722_0a95);
        for u in win.command.iter().chain(&win.measured) {
            u.iter().for_each(|v| fold(*v));
        }
        for p in &win.pose {
            p.iter().for_each(|v| fold(*v));
        }
        win.imu_yaw_rate.iter().for_each(|v| fold(*v));
        let same = seen.entry(h).or_default();
        let equal = |j: &usize| {
            let o = w.windows[*j];
            o.command == win.command
                && o.measured == win.measured
                && o.pose == win.pose
                && o.imu_yaw_rate == win.imu_yaw_rate
        };
        if same.iter().any(equal) {
            repeated += 1;
        }
        same.push(i);
    }
    if repeated > 0 {
        return Some(Finding {
            check: Check::DuplicateWindows,
            severity: Severity::Fatal,
            message: format!(
                "{repeated} of the {} windows repeat another bit for bit: the run listed twice, or its windows or intervals written twice? A split would score the models on windows they were fitted on",
                w.windows.len()
            ),
        });
    }
    let (near, below_noise) = near_duplicates(&w.windows);
    if near > 0 {
        return Some(Finding {
            check: Check::DuplicateWindows,
            severity: Severity::Fatal,
            message: format!(
                "{near} of the {} windows repeat another to within a thousandth of the data's range in every sample (commands, measurements, poses, IMU): the run or its windows written twice, with noise or rounding added? No two windows a robot drives agree that closely; a split would score the models on windows they were fitted on",
                w.windows.len()
            ),
        });
    }
    if below_noise < MIN_COPIES_BELOW_NOISE.max(w.windows.len() / 100) {
        return copies::shifted_copies(&w.windows);
    }
    Some(Finding {
        check: Check::DuplicateWindows,
        severity: Severity::Fatal,
        message: format!(
            "{below_noise} of the {} windows repeat another closer than their sensors' own noise allows: their encoders' and IMU's differences from it are under {} of the noise those signals show within a window (two recordings differ by about 1.4 times it), within a hundredth of the data's range elsewhere: the run or its windows written twice, with noise added? A split would score the models on windows they were fitted on",
            w.windows.len(),
            Short(BELOW_NOISE)
        ),
    })
}

/// How far under the sensors' own noise a window's difference from another must be to be
/// a copy (see [`near_duplicates`]): two recordings of one motion differ by about 1.4
/// times the noise; the closest two windows of ten real runs, 0.61 of it.
const BELOW_NOISE: f64 = 0.4;

/// Copies below the noise that make a run's windows written twice (a coincidence of a
/// pair or two is not).
const MIN_COPIES_BELOW_NOISE: usize = 3;

/// The windows equal to another within a thousandth of the dataset's range in every value:
/// the commands and measurements against the largest command, the positions and headings
/// against the largest a window travels and turns, the IMU against its largest rate. A
/// copy with noise or rounding added to it stays within that; two windows a robot drove do
/// not (their encoders' and localization's noise alone is larger). Windows where neither
/// the commands, the measurements nor the pose change are left out (a robot at rest repeats
/// itself). Candidates are found by sorting on the windows' mean measurement, so the cost
/// is the sort and the few neighbours within tolerance.
///
/// The second count: the windows within a hundredth of the range of another in every value
/// whose re-measured signals (each encoder, the IMU) differ from it by less than
/// [`BELOW_NOISE`] times their own noise (RMS of the difference over the noise that signal
/// shows within a window: the median over the moving windows of the second differences'
/// RMS over the square root of 6, which is the standard deviation of white noise). A copy
/// with noise added differs by that noise alone; two recordings of one motion differ by
/// both recordings' noise, and the sensors' noise is measured on the data itself, so
/// noise added at any scale under the data's own is caught.
fn near_duplicates(windows: &[&Window]) -> (usize, usize) {
    let largest = |f: &dyn Fn(&Window) -> f64| {
        windows
            .iter()
            .map(|w| f(w))
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max)
    };
    let abs_max = |v: &[drive_traits::Input]| {
        v.iter()
            .flat_map(|u| u.iter())
            .fold(0.0f64, |m, x| m.max(x.abs()))
    };
    let tol_input = 1e-3 * largest(&|w| abs_max(&w.command).max(abs_max(&w.measured)));
    let tol_position = 1e-3
        * largest(&|w| {
            w.pose
                .iter()
                .map(|p| (p.x - w.pose[0].x).hypot(p.y - w.pose[0].y))
                .fold(0.0, f64::max)
        });
    let tol_yaw = 1e-3
        * largest(&|w| {
            w.pose
                .iter()
                .map(|p| (p.z - w.pose[0].z).abs())
                .fold(0.0, f64::max)
        });
    let tol_imu = 1e-3 * largest(&|w| w.imu_yaw_rate.iter().fold(0.0, |m, r| m.max(r.abs())));
    if tol_input.is_nan() || tol_input <= 0.0 {
        return (0, 0);
    }
    let moving = |w: &Window| {
        abs_max(&w.command) > tol_input
            || abs_max(&w.measured) > tol_input
            || w.pose
                .iter()
                .any(|p| (p.x - w.pose[0].x).hypot(p.y - w.pose[0].y) > tol_position.max(1e-6))
    };
    let key = |w: &Window| {
        w.measured.iter().map(|u| u[0] + u[1]).sum::<f64>() / w.measured.len().max(1) as f64
    };
    let mut order: Vec<(f64, usize)> = windows
        .iter()
        .enumerate()
        .filter(|(_, w)| !w.measured.is_empty() && moving(w))
        .map(|(i, w)| (key(w), i))
        .filter(|(k, _)| k.is_finite())
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol;
    let same = |a: &Window, b: &Window| {
        a.len() == b.len()
            && a.command
                .iter()
                .zip(&b.command)
                .all(|(x, y)| (0..x.len()).all(|i| close(x[i], y[i], tol_input)))
            && a.measured
                .iter()
                .zip(&b.measured)
                .all(|(x, y)| (0..x.len()).all(|i| close(x[i], y[i], tol_input)))
            && a.pose.iter().zip(&b.pose).all(|(p, q)| {
                (p.x - q.x).hypot(p.y - q.y) <= tol_position && close(p.z, q.z, tol_yaw)
            })
            && a.imu_yaw_rate
                .iter()
                .zip(&b.imu_yaw_rate)
                .all(|(x, y)| close(*x, *y, tol_imu) || (x.is_nan() && y.is_nan()))
    };
    // The re-measured signals' own noise: each encoder's and the IMU's.
    let signal = |w: &Window, c: usize| -> Vec<f64> {
        match c {
            0 | 1 => w.measured.iter().map(|u| u[c]).collect(),
            _ => w.imu_yaw_rate.clone(),
        }
    };
    let noise: Vec<f64> = (0..3)
        .map(|c| {
            let mut per_window: Vec<f64> = order
                .iter()
                .filter_map(|&(_, i)| {
                    let x = signal(windows[i], c);
                    let n = x.len().checked_sub(2).filter(|n| *n > 0)?;
                    let ss: f64 = x
                        .windows(3)
                        .map(|t| (t[2] - 2.0 * t[1] + t[0]).powi(2))
                        .sum();
                    Some((ss / n as f64 / 6.0).sqrt())
                })
                .filter(|v| v.is_finite())
                .collect();
            drive_traits::median(&mut per_window)
        })
        .collect();
    let loose = 10.0;
    let below_noise = |a: &Window, b: &Window| {
        let mut decisive = false;
        for (c, &sigma) in noise.iter().enumerate() {
            if !(sigma.is_finite() && sigma > 0.0) {
                continue;
            }
            let (x, y) = (signal(a, c), signal(b, c));
            let ss: f64 = x.iter().zip(&y).map(|(p, q)| (p - q) * (p - q)).sum();
            let rms = (ss / x.len().max(1) as f64).sqrt();
            if rms.is_nan() || rms >= BELOW_NOISE * sigma {
                return false;
            }
            decisive = true;
        }
        decisive
    };
    let loosely_same = |a: &Window, b: &Window| {
        let t = loose * tol_input;
        // Where the windows end first: two windows a robot drove part there.
        let ends = |p: Option<&Pose>, q: Option<&Pose>| match (p, q) {
            (Some(p), Some(q)) => {
                (p.x - q.x).hypot(p.y - q.y) <= loose * tol_position
                    && close(p.z, q.z, loose * tol_yaw)
            }
            _ => false,
        };
        a.len() == b.len()
            && ends(a.pose.last(), b.pose.last())
            && a.command
                .iter()
                .chain(&a.measured)
                .zip(b.command.iter().chain(&b.measured))
                .all(|(x, y)| (0..x.len()).all(|i| close(x[i], y[i], t)))
            && a.pose.iter().zip(&b.pose).all(|(p, q)| {
                (p.x - q.x).hypot(p.y - q.y) <= loose * tol_position
                    && close(p.z, q.z, loose * tol_yaw)
            })
    };
    // Driven: commanded or turning its wheels at a fiftieth of the largest or more. A robot
    // at rest repeats itself closer than its sensors' noise while driving allows (encoders
    // reading exactly zero, an IMU quieter without vibration): extra intervals at rest are
    // no copy.
    let driven = |w: &Window| {
        abs_max(&w.command) > 20.0 * tol_input || abs_max(&w.measured) > 20.0 * tol_input
    };
    let mut repeated = vec![false; windows.len()];
    let mut copied = vec![false; windows.len()];
    for (n, &(k, i)) in order.iter().enumerate() {
        // The mean of two measurements within t of each other is within 2 t.
        for &(kj, j) in order[n + 1..].iter() {
            if kj - k > 2.0 * loose * tol_input {
                break;
            }
            if repeated[j] {
                continue;
            }
            if kj - k <= 2.0 * tol_input && same(windows[i], windows[j]) {
                repeated[j] = true;
            } else if !copied[j]
                && driven(windows[j])
                && loosely_same(windows[i], windows[j])
                && below_noise(windows[i], windows[j])
            {
                copied[j] = true;
            }
        }
    }
    let count = |v: &[bool]| v.iter().filter(|r| **r).count();
    (count(&repeated), count(&copied))
}

/// `imu-yaw-rate`: over the windows where localization turned 0.2 rad or more (ten at
/// least), the least-squares gain of the turn the IMU's yaw rate integrates to on
/// localization's. Both measure the body's rotation: the bundled runs give 0.93-1.01, the
/// simulator 1.02-1.07. Over 2 an IMU scaled or in another unit (deg/s: 57), under 0.5 one
/// that reads little of the turn (lagging, another signal, or against it and scaled);
/// fatal (a model reading the IMU, slip-ipem or acc-BLR, starts from it scaled). Outside
/// 0.75-1.33, a warning; so is -1.33 to -0.75, an IMU read backwards and nothing else (a
/// real Warthog run on gravel gives -0.98): the data is sound, the models' start from the
/// IMU is not, and the warning says how to avoid it. An IMU that never changes
/// is `imu-constant`'s (the models then start from localization).
///
/// And an offset ([`imu_offset`]): the IMU reading a turn where localization saw none.
fn imu_yaw_rate(w: &Windows<'_>) -> Option<Finding> {
    // An IMU that never changes is `imu-constant`'s (a warning: the models then start from
    // localization instead).
    let mut imu = w.windows.iter().flat_map(|win| win.imu_yaw_rate.iter());
    let first = imu.next().copied().unwrap_or(0.0);
    if imu.all(|v| *v == first) {
        return None;
    }
    let offset = imu_offset(w);
    if let Some(f) = offset.as_ref().filter(|f| f.severity == Severity::Fatal) {
        return Some(f.clone());
    }
    if let Some(f) = imu_shift(w) {
        return Some(f);
    }
    imu_gain(w).or_else(|| imu_lag(w)).or(offset)
}

/// How late an IMU may follow localization before `imu-yaw-rate` says so: a quarter
/// second (s).
const IMU_LATE_S: f64 = 0.25;

/// How much better (in correlation) the IMU must follow localization at its lag than at
/// none to be called late.
const IMU_LATE_MARGIN: f64 = 0.01;

/// How much better (in correlation) the IMU must lead localization at its lag than at none
/// to be called early, or localization late: the released and norlab Warthog runs' IMU
/// leads their localization by 0.25-1.1 s, 0.009-0.041 better than at no lag (ICP's
/// latency); an IMU 0.5 s early on the Husky run, 0.07; localization 0.5 s late within the
/// windows, 0.14-0.16.
const IMU_EARLY_MARGIN: f64 = 0.06;

/// How much better the IMU (or localization) must follow the encoders' yaw rate at a lag of
/// a quarter second or more than at none for that one to be named the shifted signal: the
/// real runs' IMU 0.013 at most; a body lagging its wheels on gravel or ice moves both
/// alike (localization 0.065 behind the encoders on norlab's gravel run, and so is its
/// IMU).
const SHIFTED_MARGIN: f64 = 0.03;

/// `imu-yaw-rate`'s lag, within a window: the yaw rate localization saw (its turn over 0.4 s
/// around each sample) against the IMU's (its mean over the same 0.4 s) a lag later, every
/// sample of every window, lags up to 1.2 s (and half a window) either way. On the nine
/// released and norlab Warthog runs the correlation peaks with the IMU 0.25-1.1 s ahead of
/// localization, flat (0.009-0.041 above no lag); on the Husky run 0.15 s ahead; in the
/// simulator at no lag; every one of them 0.01 below its peak or less with the IMU later.
/// An IMU column made half a window (1 s) late peaks late on all of them (0.55-1 s late,
/// 0.011-0.099 above no lag): on the Husky run acc-BLR's rotational error rose from 0.092
/// to 0.122 rad, slip-ipem's from 0.078 to 0.086. An IMU that follows localization
/// [`IMU_LATE_S`] or more late, [`IMU_LATE_MARGIN`] better than at no lag, is a warning;
/// so is one that leads it by as much, [`IMU_EARLY_MARGIN`] better: an IMU early or a
/// localization late (0.5 s late within the windows: slip-ipem's rotational error +77% on
/// a Warthog run), told apart by which of the two is shifted against the encoders' yaw rate
/// ([`SHIFTED_MARGIN`]). The whole-window shift is [`imu_shift`]'s, fatal.
fn imu_lag(w: &Windows<'_>) -> Option<Finding> {
    let dt = w.data.robot.dt();
    if !(dt > 0.0 && dt.is_finite()) {
        return None;
    }
    // Half the span each rate is taken over, in samples.
    let half = ((0.2 / dt).round() as usize).max(1);
    let shortest = w.windows.iter().map(|win| win.len()).min().unwrap_or(0);
    let most = ((1.2 / dt).round() as usize).min(shortest / 2);
    let least = (IMU_LATE_S / dt).round() as usize;
    if shortest < 2 * half + 2 || least > most {
        return None;
    }
    let vehicle = w.data.robot.vehicle.as_ref();
    // Per window, each sample's yaw rates: localization's, the IMU's and the encoders'
    // (their means around it, from running sums: this runs on every sample of every fit).
    let span = (2 * half) as f64;
    let rates: Vec<Vec<[f64; 3]>> = w
        .windows
        .iter()
        .map(|win| {
            let n = win
                .len()
                .min(win.imu_yaw_rate.len())
                .min(win.measured.len());
            let sums = |values: &mut dyn Iterator<Item = f64>| {
                let mut out = Vec::with_capacity(n + 1);
                out.push(0.0);
                let mut total = 0.0;
                for v in values.take(n) {
                    total += v;
                    out.push(total);
                }
                out
            };
            let imu = sums(&mut win.imu_yaw_rate.iter().copied());
            let wheels = sums(&mut win.measured.iter().map(|u| vehicle.body_velocity(u).z));
            (half..n.saturating_sub(half))
                .map(|k| {
                    let turn = (win.pose[k + half].z - win.pose[k - half].z + std::f64::consts::PI)
                        .rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI;
                    [
                        turn / span / dt,
                        (imu[k + half] - imu[k - half]) / span,
                        (wheels[k + half] - wheels[k - half]) / span,
                    ]
                })
                .collect()
        })
        .collect();
    if rates.iter().flatten().flatten().any(|v| !v.is_finite()) {
        return None;
    }
    // The correlation (in size) of signal `a` with signal `b` a lag later.
    let at = |a: usize, b: usize, lag: isize| lag_correlation(&rates, a, b, lag);
    // Of the lags of `b` behind `a` from `from` to `to` samples, the best: (lag, its
    // correlation).
    // Every other lag, then the two beside the best of those (the correlation changes
    // slowly with the lag: rates averaged over 0.4 s).
    let best = |a: usize, b: usize, from: isize, to: isize| {
        let coarse = (from..=to)
            .step_by(2)
            .map(|lag| (lag, at(a, b, lag)))
            .max_by(|x, y| x.1.total_cmp(&y.1))?;
        [coarse.0 - 1, coarse.0 + 1]
            .into_iter()
            .filter(|lag| (from..=to).contains(lag))
            .map(|lag| (lag, at(a, b, lag)))
            .chain([coarse])
            .max_by(|x, y| x.1.total_cmp(&y.1))
    };
    let (most, least) = (most as isize, least as isize);
    let none = at(0, 1, 0);
    let (late_lag, late) = best(0, 1, 1, most)?;
    let (early_lag, early) = best(0, 1, -most, -1)?;
    let windows = rates.len();
    let shown = |v: f64| Short((v * 1000.0).round() / 1000.0);
    let starts = "The models that start from the IMU's yaw rate (slip-ipem, acc-BLR, --start encoders+imu) start from the rate";
    if late_lag >= least && late >= none + IMU_LATE_MARGIN && late > early {
        let s = three_digits(late_lag as f64 * dt);
        return Some(Finding {
            check: Check::ImuYawRate,
            severity: Severity::Warning,
            message: format!(
                "the IMU's yaw rate follows the rate localization saw {} s late (correlation {} at that lag against {} at none, every sample of {windows} windows): its timestamps late? {starts} of {} s before; shift the imu_yaw_rate column, or give --start encoders",
                Short(s),
                shown(late),
                shown(none),
                Short(s),
            ),
        });
    }
    if early_lag <= -least && early >= none + IMU_EARLY_MARGIN && early > late {
        let s = three_digits(-early_lag as f64 * dt);
        // Which one is shifted: the one that leads (the IMU) or lags (localization) the
        // encoders' yaw rate by a quarter second or more, clearly.
        let shifted = |b: usize, from: isize, to: isize| {
            best(2, b, from, to).is_some_and(|(_, c)| c >= at(2, b, 0) + SHIFTED_MARGIN)
        };
        let (imu_early, localization_late) = (shifted(1, -most, -least), shifted(0, least, most));
        let cause = match (imu_early, localization_late) {
            (true, false) => format!(
                "the IMU's timestamps early (it leads the encoders' yaw rate too)? {starts} {s} s ahead; shift the imu_yaw_rate column, or give --start encoders"
            ),
            (false, true) => "localization's timestamps late within the windows (it lags the encoders' yaw rate too, where the IMU does not)? Every model is fitted and scored on poses that lag the commands: shift the x, y and yaw columns".to_string(),
            _ => format!(
                "the IMU's timestamps early, or localization's late? Either way the models are fitted on poses {s} s out of step with the IMU"
            ),
        };
        return Some(Finding {
            // Localization's timing where it is the one shifted.
            check: if localization_late && !imu_early {
                Check::LocalizationSync
            } else {
                Check::ImuYawRate
            },
            severity: Severity::Warning,
            message: format!(
                "the IMU's yaw rate leads the rate localization saw by {} s (correlation {} at that lag against {} at none, every sample of {windows} windows): {cause}",
                Short(s),
                shown(early),
                shown(none),
            ),
        });
    }
    None
}

/// `imu-yaw-rate`'s shift: per window, the turn the IMU's yaw rate integrates to against
/// the turn localization saw (over windows where localization turned, twenty at least, in
/// their recorded order): on the ten released and norlab runs the IMU correlates with its
/// own window's turn at 0.95-0.995 (the gravel run's IMU, read backwards, at -0.98), with
/// the window before's or after's at 0.59-0.91, at least 0.06 less; one correlating with a
/// neighbour's better by [`localization::SHIFT_MARGIN`] or more, at 0.7 or more (in size:
/// an IMU also read backwards correlates negatively), is an IMU
/// whose timestamps shifted by a window (a Husky IMU column a window late: 0.99 against
/// 0.80; a Warthog asphalt run's: 0.96 against 0.90; it passed every check, and acc-BLR's
/// rotational error rose from 0.09 to 0.16 rad on the Husky). Fatal: the models that start
/// from the IMU's yaw rate start from another window's.
fn imu_shift(w: &Windows<'_>) -> Option<Finding> {
    let dt = w.data.robot.dt();
    // (localization's turn, the IMU's) per window.
    let turns: Vec<(f64, f64)> = w
        .windows
        .iter()
        .zip(&w.motions)
        .map(|(win, m)| {
            let len = win.len();
            let imu = win
                .imu_yaw_rate
                .iter()
                .take(len.saturating_sub(1))
                .sum::<f64>()
                * dt;
            (m.3, imu)
        })
        .collect();
    if turns.iter().filter(|(seen, _)| seen.abs() >= 0.05).count() < 20
        || !turns.iter().all(|(a, b)| a.is_finite() && b.is_finite())
    {
        return None;
    }
    let len = turns.len() as isize;
    let table = &turns;
    let at = |lag: isize| {
        localization::correlation(
            (0..len)
                .filter(move |i| (0..len).contains(&(i + lag)))
                .map(move |i| (table[i as usize].0, table[(i + lag) as usize].1)),
        )
    };
    // In size: an IMU read backwards (a sign the gain's warning names) correlates as well
    // with its own window, negatively.
    let own = at(0);
    // The IMU of window i + 1 reading window i's turn reads the window before's: late.
    for (lag, which) in [(1, "before"), (-1, "after")] {
        let r = at(lag);
        if r.abs() >= 0.7 && r.abs() >= own.abs() + localization::SHIFT_MARGIN {
            return Some(Finding {
                check: Check::ImuYawRate,
                severity: Severity::Fatal,
                message: format!(
                    "the IMU's yaw rate follows the turn localization saw in the window {which} better than in its own window (correlation {} against {}, over {} windows): its timestamps shifted by a window? The models that start from the IMU's yaw rate (slip-ipem, acc-BLR, --start encoders+imu) start from another window's",
                    Short((r * 100.0).round() / 100.0),
                    Short((own * 100.0).round() / 100.0),
                    turns.len()
                ),
            });
        }
    }
    None
}

/// The correlation (in size) of signal `a` of each window's samples with signal `b` `lag`
/// samples later in the same window ([`imu_lag`]), in one pass over the pairs (it runs for
/// every lag on every sample of a run: the data checks of every fit).
fn lag_correlation(rates: &[Vec<[f64; 3]>], a: usize, b: usize, lag: isize) -> f64 {
    let (mut n, mut sa, mut sb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let shift = lag.unsigned_abs();
    for r in rates {
        if r.len() <= shift {
            continue;
        }
        let (xs, ys) = if lag >= 0 {
            (&r[..r.len() - shift], &r[shift..])
        } else {
            (&r[shift..], &r[..r.len() - shift])
        };
        for (x, y) in xs.iter().zip(ys) {
            let (x, y) = (x[a], y[b]);
            n += 1.0;
            sa += x;
            sb += y;
            saa += x * x;
            sbb += y * y;
            sab += x * y;
        }
    }
    if n < 2.0 {
        return 0.0;
    }
    let (va, vb) = (saa - sa * sa / n, sbb - sb * sb / n);
    if va > 0.0 && vb > 0.0 {
        ((sab - sa * sb / n) / (va * vb).sqrt()).abs()
    } else {
        0.0
    }
}

/// Offsets of the IMU (its mean rate where localization saw no turn) against the RMS yaw
/// rate localization saw, from which they are a warning and fatal: the real runs give 0.03
/// at most.
const IMU_OFFSET_WARNING: f64 = 0.1;
const IMU_OFFSET_FATAL: f64 = 0.3;

/// `imu-yaw-rate`'s offset: a line through each window's mean IMU rate against the yaw
/// rate localization saw over it (every window with both, ten at least), its intercept
/// against the RMS of localization's rate (at least 0.1 rad/s: a run that hardly turns
/// leaves a real gyro's bias of a degree a second or so). The bundled runs and norlab's
/// sand and gravel runs: 0.03 at most. Over 0.1 a warning, over 0.3 fatal: the models that
/// start from the IMU (slip-ipem, acc-BLR, `--start encoders+imu`) start turning where the
/// robot does not (acc-BLR's rotational error 0.09 -> 0.50 rad on the Husky with 1 rad/s
/// added).
fn imu_offset(w: &Windows<'_>) -> Option<Finding> {
    let dt = w.data.robot.dt();
    let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0usize, 0.0, 0.0, 0.0, 0.0);
    for (win, m) in w.windows.iter().zip(&w.motions) {
        let len = win.len();
        if len < 2 {
            continue;
        }
        let x = m.3 / ((len - 1) as f64 * dt);
        let y = win.imu_yaw_rate.iter().take(len - 1).sum::<f64>() / (len - 1) as f64;
        if !(x.is_finite() && y.is_finite()) {
            continue;
        }
        n += 1;
        (sx, sy, sxx, sxy) = (sx + x, sy + y, sxx + x * x, sxy + x * y);
    }
    let nf = n as f64;
    let var = sxx / nf.max(1.0) - (sx / nf.max(1.0)).powi(2);
    if n < 10 || var.is_nan() || var <= 0.0 {
        return None;
    }
    let slope = (sxy / nf - sx * sy / (nf * nf)) / var;
    let offset = sy / nf - slope * sx / nf;
    let rms = (sxx / nf).sqrt().max(0.1);
    let ratio = offset.abs() / rms;
    (ratio >= IMU_OFFSET_WARNING).then(|| Finding {
        check: Check::ImuYawRate,
        severity: Severity::fatal_if(ratio >= IMU_OFFSET_FATAL),
        message: format!(
            "the IMU reads {} rad/s of yaw rate where localization saw no turn (the offset of a line through the windows' mean rates, {n} windows; {} of the RMS rate localization saw, {} rad/s): a gyro bias, or an offset added? The models that start from the IMU's yaw rate (slip-ipem, acc-BLR, --start encoders+imu) start turning where the robot does not; remove the offset from the imu_yaw_rate column, or give --start encoders",
            Short(three_digits(offset)),
            Short(three_digits(ratio)),
            Short(three_digits(rms))
        ),
    })
}

/// `imu-yaw-rate`'s gain (see [`imu_yaw_rate`]).
fn imu_gain(w: &Windows<'_>) -> Option<Finding> {
    let dt = w.data.robot.dt();
    let (mut ii, mut it, mut n) = (0.0, 0.0, 0usize);
    for (win, m) in w.windows.iter().zip(&w.motions) {
        if m.3.abs() < 0.2 {
            continue;
        }
        let imu: f64 = win.imu_yaw_rate.iter().take(win.len() - 1).sum::<f64>() * dt;
        ii += m.3 * m.3;
        it += m.3 * imu;
        n += 1;
    }
    if n < 10 || ii <= 0.0 {
        return None;
    }
    let gain = it / ii;
    if (0.75..=1.0 / 0.75).contains(&gain) {
        return None;
    }
    // An IMU read backwards, and only that (its negation within the band), is a warning: a
    // real recording (a Warthog on gravel, -0.98) was logged so, and only the models'
    // start reads the IMU.
    let flipped = (-1.0 / 0.75..=-0.75).contains(&gain);
    let fatal = !flipped && (gain <= 0.5 || gain > 2.0);
    Some(Finding {
        check: Check::ImuYawRate,
        severity: Severity::fatal_if(fatal),
        message: format!(
            "the IMU's yaw rate integrates to {} times the turn localization saw (least squares over {n} windows; both measure the body's rotation): {}",
            Short(three_digits(gain)),
            if flipped {
                "its sign flipped: the models that start from the IMU's yaw rate (slip-ipem, acc-BLR, --start encoders+imu) start turning the wrong way; negate the imu_yaw_rate column, or give --start encoders"
            } else if gain < 0.0 {
                "its sign flipped (or the localization mirrored)?"
            } else if gain > 5.0 {
                "in deg/s, or another unit?"
            } else if gain > 1.0 {
                "scaled, or another unit?"
            } else {
                "it reads little of the turn: scaled, lagging, or another signal?"
            }
        ),
    })
}

/// `commands-constant`: every command of every window the same (a warning: the data tells
/// how the robot answers that one command only).
fn commands_constant(w: &Windows<'_>) -> Option<Finding> {
    let mut commands = w.windows.iter().flat_map(|win| win.command.iter());
    let first = *commands.next()?;
    if w.windows.len() >= 2 && commands.all(|u| *u == first) {
        let dim = w.data.robot.vehicle.input_dim().min(first.len());
        let shown: Vec<String> = (0..dim).map(|i| Short(first[i]).to_string()).collect();
        return Some(Finding {
            check: Check::CommandsConstant,
            severity: Severity::Warning,
            message: format!(
                "every window commands the same input ({}): the data shows how the robot answers that command only, a model fitted on it predicts no other",
                shown.join(", ")
            ),
        });
    }
    None
}

/// `not-moving`: the encoders turn and localization does not follow, the commands ask for
/// motion that neither sees, or nothing is driven at all.
fn not_moving(w: &Windows<'_>) -> Vec<Finding> {
    let (data, windows, motions) = (w.data, &w.windows, w.motions.as_slice());
    let mut out = Vec::new();
    // not-moving: among windows where the encoders imply real motion (0.2 m or 0.2 rad),
    // those where localization saw less than a tenth of it.
    let (mut driven, mut still) = (0usize, 0usize);
    for (w, &(d, r, moved, turned)) in windows.iter().zip(motions) {
        let turned = turned.abs();
        let significant = [(d, moved, 0.2), (r, turned, 0.2)]
            .into_iter()
            .filter(|(implied, _, floor)| implied >= floor)
            .collect::<Vec<_>>();
        if significant.is_empty() {
            continue;
        }
        driven += 1;
        // Localization saw a tenth of none of the implied motion; or one of its parts did
        // not change at all (a position frozen under a live heading is frozen too: sliding
        // on ice moves a little, never exactly nothing).
        let (frozen_position, frozen_heading) = (
            w.pose
                .iter()
                .all(|p| p.x == w.pose[0].x && p.y == w.pose[0].y),
            w.pose.iter().all(|p| p.z == w.pose[0].z),
        );
        if significant
            .iter()
            .all(|(implied, seen, _)| *seen < 0.1 * implied)
            || (d >= 0.2 && frozen_position)
            || (r >= 0.2 && frozen_heading)
        {
            still += 1;
        }
    }
    // Windows where the commands (through the vehicle) ask for real motion but neither the
    // encoders nor localization saw a tenth of it: a robot that never moved (e-stop, motors
    // off) whose encoders and localization read only their noise.
    // Of those, the windows whose encoders and localization did move (0.2 m or 0.2 rad):
    // a robot driving at a small share of its commands (commands in another unit).
    let (mut asked, mut ignored, mut ignored_moving) = (0usize, 0usize, 0usize);
    for (w, &(d, r, moved, turned)) in windows.iter().zip(motions) {
        let (cd, cr) = dead_reckoned(data, &w.command, w.len());
        let significant: Vec<(f64, f64, f64)> = [(cd, d, moved), (cr, r, turned.abs())]
            .into_iter()
            .filter(|(c, _, _)| *c >= 0.2)
            .collect();
        if significant.is_empty() {
            continue;
        }
        asked += 1;
        if significant
            .iter()
            .all(|(c, enc, seen)| *enc < 0.1 * c && *seen < 0.1 * c)
        {
            ignored += 1;
            if (d >= 0.2 && moved >= 0.2) || (r >= 0.2 && turned.abs() >= 0.2) {
                ignored_moving += 1;
            }
        }
    }
    // Windows at rest: nothing commanded, nothing measured, nothing seen (under 2 cm and
    // 0.02 rad each). A run of them leaves the windows there nothing to predict: every
    // model's error over them is zero, and a split that takes its evaluation windows from
    // the run's end compares the models on them (every model 0.000, "+0.0%").
    let at_rest: Vec<bool> = windows
        .iter()
        .zip(motions)
        .map(|(w, &(d, r, moved, turned))| {
            let (cd, cr) = dead_reckoned(data, &w.command, w.len());
            [cd, cr, d, r, moved, turned.abs()]
                .iter()
                .all(|v| v.is_finite() && *v < REST_MOTION)
        })
        .collect();
    // A tenth of the windows, or a fifth of the last half (where a split by time takes its
    // evaluation windows: eval's default takes half): the bundled and norlab runs hold 0-3%
    // overall and none in their last half; an eleventh outside sweep's 40% of the last half
    // at rest, interleaved, collapsed every median 2.5-3 times without a word.
    let resting = at_rest.iter().filter(|r| **r).count();
    let tail = &at_rest[at_rest.len() - at_rest.len() / 2..];
    let resting_late = tail.iter().filter(|r| **r).count();
    if windows.len() >= 10 && (resting * 10 >= windows.len() || resting_late * 5 >= tail.len()) {
        out.push(Finding {
            check: Check::NotMoving,
            severity: Severity::Warning,
            message: format!(
                "{resting} of the {} windows ({resting_late} of the last {}, where a split by time takes its evaluation windows) command nothing and do not move (under 2 cm and 0.02 rad commanded, measured and seen): there is nothing to predict there, every model's error is zero on them and the models compared on them tie; the robot parked, or the run's end recorded at rest?",
                windows.len(),
                tail.len()
            ),
        });
    }
    if asked > 0 && ignored * 10 >= asked && still * 10 < driven.max(1) {
        let fatal = ignored * 2 > asked;
        out.push(Finding {
            check: Check::NotMoving,
            severity: Severity::fatal_if(fatal),
            message: format!(
                "in {ignored} of {asked} windows whose commands ask for at least 0.2 m or 0.2 rad of motion, neither the encoders nor localization saw a tenth of it: {}",
                if ignored_moving * 2 > ignored {
                    format!(
                        "yet in {ignored_moving} of them both moved 0.2 m or 0.2 rad: the robot drove at a small share of its commands, commands in another unit (rpm, deg/s)?"
                    )
                } else if fatal {
                    "the robot did not move (e-stop engaged, motors off?)".into()
                } else {
                    "stopped in those windows?".into()
                }
            ),
        });
    }
    // Nothing driven at all: no window's commands, encoders or localization reach the
    // motion the checks above look at (commands and limits in another unit, or zero).
    // Unless the robot moved as its commands asked, however slowly (a planetary rover at a
    // few centimetres a second): localization saw at least a tenth of the distance and the
    // turn the commands asked for over the run, something was asked, and localization moved
    // beyond its noise. Then the data holds a slow robot, which the checks above cannot
    // judge: a warning.
    if asked == 0 && driven == 0 && motions.iter().all(|m| m.2 < 0.2 && m.3.abs() < 0.2) {
        let (mut commanded, mut seen) = ([0.0f64; 2], [0.0f64; 2]);
        for (w, m) in windows.iter().zip(motions) {
            let (cd, cr) = dead_reckoned(data, &w.command, w.len());
            commanded[0] += cd;
            commanded[1] += cr;
            seen[0] += m.2;
            seen[1] += m.3.abs();
        }
        // Above localization's noise: 5 mm or 5 mrad a window on average (a limit in
        // another unit, 1e-300, moves nothing a sensor sees).
        let per_window = (seen[0] + seen[1]) / windows.len().max(1) as f64;
        let slow = commanded.iter().any(|c| *c > 0.0)
            && per_window >= 0.005
            && (0..2).all(|i| commanded[i] <= 0.0 || seen[i] >= 0.1 * commanded[i]);
        out.push(Finding {
            check: Check::NotMoving,
            severity: Severity::fatal_if(!slow),
            message: if slow {
                format!(
                    "in none of the {} windows do the commands, the encoders or localization reach 0.2 m or 0.2 rad of motion, though localization moved as the commands asked: a slow robot? (the checks that compare motions need 0.2 m or 0.2 rad to judge, so they looked at nothing)",
                    windows.len()
                )
            } else {
                format!(
                    "in none of the {} windows do the commands, the encoders or localization reach 0.2 m or 0.2 rad of motion: nothing was driven (commands in another unit, or all zero?)",
                    windows.len()
                )
            },
        });
    }
    if driven > 0 && still * 10 >= driven {
        let fatal = still * 2 > driven;
        out.push(Finding {
            check: Check::NotMoving,
            severity: Severity::fatal_if(fatal),
            message: format!(
                "in {still} of {driven} windows where the encoders imply at least 0.2 m or 0.2 rad of motion, localization saw less than a tenth of it: {}",
                if fatal {
                    "the robot did not move (wheels off the ground, or localization frozen?)"
                } else {
                    "stuck or localization lost in those windows?"
                }
            ),
        });
    }
    out
}

/// `imu-constant`: one IMU yaw rate throughout while localization turns.
fn imu_constant(w: &Windows<'_>) -> Option<Finding> {
    let (data, windows, motions) = (w.data, &w.windows, w.motions.as_slice());
    let imu: Vec<f64> = windows
        .iter()
        .flat_map(|w| w.imu_yaw_rate.iter().copied())
        .collect();
    if let Some(&first) = imu.first() {
        // How far localization's turning departs from what the constant rate implies.
        let departs = windows
            .iter()
            .zip(motions)
            .map(|(w, m)| (m.3 - first * (w.len() - 1) as f64 * data.robot.dt()).abs())
            .fold(0.0, f64::max);
        if imu.iter().all(|v| *v == first) && departs > 0.2 {
            return Some(Finding {
                check: Check::ImuConstant,
                severity: Severity::Warning,
                message: format!(
                    "the IMU yaw rate is {} rad/s throughout, while localization's turning departs from it by up to {} rad in a window: not recorded?",
                    Short(first),
                    Short((departs * 100.0).round() / 100.0)
                ),
            });
        }
    }
    None
}

/// `encoders-zero` (`which`: the encoders exactly zero) or `encoders-stuck` (not zero but
/// under a millionth of the largest command) throughout the windows commanded at a tenth of
/// the largest command or more; any other `which` finds nothing.
fn encoders_silent(w: &Windows<'_>, which: Check) -> Option<Finding> {
    let windows = &w.windows;
    let largest = windows
        .iter()
        .flat_map(|w| w.command.iter())
        .map(|u| u.x.abs().max(u.y.abs()))
        .fold(0.0, f64::max);
    if largest <= 0.0 {
        return None;
    }
    let commanded: Vec<&&Window> = windows
        .iter()
        .filter(|w| {
            w.command
                .iter()
                .any(|u| u.x.abs().max(u.y.abs()) >= 0.1 * largest)
        })
        .collect();
    let zero = |w: &Window| w.measured.iter().all(|u| u.x == 0.0 && u.y == 0.0);
    let tiny = |w: &Window| {
        !zero(w)
            && w.measured
                .iter()
                .all(|u| u.x.abs().max(u.y.abs()) <= 1e-6 * largest)
    };
    let (count, what, guess) = match which {
        Check::EncodersZero => (
            commanded.iter().filter(|w| zero(w)).count(),
            "read zero".to_string(),
            "not recorded?",
        ),
        Check::EncodersStuck => (
            commanded.iter().filter(|w| tiny(w)).count(),
            format!(
                "stay under {} (a millionth of the largest command, {})",
                Short(1e-6 * largest),
                Short(largest)
            ),
            "stuck, or not recorded?",
        ),
        _ => return None,
    };
    (count > 0 && count * 10 >= commanded.len()).then(|| Finding {
        check: which,
        severity: Severity::fatal_if(count == commanded.len()),
        message: format!(
            "the encoders {what} throughout {count} of {} commanded windows: {guess}",
            commanded.len(),
        ),
    })
}

/// Whether the body speeds the encoders imply are a ground vehicle's: the 95th percentile
/// under 40 m/s (encoders and commands both in cm/s reach hundreds).
fn plausible_speeds(data: &Dataset, windows: &[&Window]) -> bool {
    let mut speeds: Vec<f64> = windows
        .iter()
        .flat_map(|w| w.measured.iter())
        .map(|u| {
            let v = data.robot.vehicle.body_velocity(u);
            v.x.hypot(v.y)
        })
        .filter(|v| v.is_finite())
        .collect();
    if speeds.is_empty() {
        return true;
    }
    let k = speeds.len() * 95 / 100;
    *speeds.select_nth_unstable_by(k, f64::total_cmp).1 < 40.0
}

/// Whether every input axis's measurements follow its commands at a least-squares gain
/// within [0.5, 2] (over the samples commanded at a tenth of the axis's largest command or
/// more, a hundred at least): the encoders in the commands' unit.
fn encoders_follow_commands(data: &Dataset, windows: &[&Window]) -> bool {
    let axes = data
        .robot
        .vehicle
        .axes()
        .len()
        .min(drive_traits::MAX_INPUTS);
    (0..axes).all(|i| {
        let samples = || {
            windows
                .iter()
                .flat_map(|w| w.command.iter().zip(w.measured.iter()))
        };
        let largest = samples().map(|(c, _)| c[i].abs()).fold(0.0, f64::max);
        if largest <= 0.0 || !largest.is_finite() {
            return true;
        }
        let (mut n, mut cc, mut cm) = (0usize, 0.0, 0.0);
        for (c, m) in samples().filter(|(c, _)| c[i].abs() >= 0.1 * largest) {
            let (c, m) = (c[i] / largest, m[i] / largest);
            n += 1;
            cc += c * c;
            cm += c * m;
        }
        n < 100 || (0.5..=2.0).contains(&(cm / cc))
    })
}

/// `encoder-units`: the distance the encoders imply against localization's, and
/// localization's yaw rate against the encoders'.
fn encoder_units(w: &Windows<'_>) -> Vec<Finding> {
    encoder_units_in(w, true)
}

/// The median ratio of the turn localization saw to the one the encoders imply, over the
/// windows where either turned 0.3 rad (ten at least), where it is a vehicle's: 0.2-1.05 (a
/// vehicle turns at most as much as its wheels imply, a skid-steer less, 0.41-0.62 on the
/// bundled runs; encoders in another unit, a wheel radius too small, or a yaw in degrees,
/// are off by their factor). `None` otherwise.
pub(super) fn usual_turn(motions: &[(f64, f64, f64, f64)]) -> Option<f64> {
    let mut turns: Vec<f64> = motions
        .iter()
        .filter(|m| m.1 >= 0.05 && (m.1 >= 0.3 || m.3.abs() >= 0.3) && m.3.is_finite())
        .map(|m| m.3.abs() / m.1)
        .collect();
    if turns.len() < 10 {
        return None;
    }
    let median = drive_traits::median(&mut turns);
    (0.2..=1.05).contains(&median).then_some(median)
}

/// The least median ratio of the distance the encoders imply to the one localization saw
/// before `encoder-units` warns (the bundled runs' nearly straight windows: 1.01-1.08; a
/// short simulated Warthog log 0.73).
const MIN_DISTANCE_RATIO: f64 = 0.6;

/// [`encoder_units`] on the whole run (`whole`), or on a part of it ([`parts`]): there the
/// distance and the turn against localization's, not the speeds, the angles' units or
/// localization's yaw rate sample by sample, which read the whole run.
fn encoder_units_in(w: &Windows<'_>, whole: bool) -> Vec<Finding> {
    let (data, windows, motions) = (w.data, &w.windows, w.motions.as_slice());
    let mut out = Vec::new();
    // encoder-units: over the windows where localization saw at least 0.2 m, the median ratio
    // of the distance the encoders imply to the one localization saw (1.01-1.08 on the
    // bundled runs' nearly straight windows, slip included). Beyond a factor of 5 either way no slip explains it: a
    // model trained on such encoders is wrong by that factor, so the finding is fatal.
    // The nearly straight windows (localization turned under 0.3 rad) when there are ten (a
    // net distance through a turn does
    // not scale with the wheel speeds: three times the speed curls the path three times as
    // far), else every window.
    let ratio_of = |straight: bool| -> Vec<f64> {
        motions
            .iter()
            .filter(|m| m.2 >= 0.2 && (!straight || m.3.abs() < 0.3))
            .map(|m| m.0 / m.2)
            .collect()
    };
    let mut ratios = ratio_of(true);
    if ratios.len() < 10 {
        ratios = ratio_of(false);
    }
    // Too few windows where localization saw 0.2 m (positions shrunk to a tenth, in another
    // unit): the windows where the encoders imply 0.2 m instead, nearly straight by their
    // own turn when there are ten (a localization that saw nothing at all is not-moving's).
    if ratios.len() < 10 {
        let by_encoders = |straight: bool| -> Vec<f64> {
            motions
                .iter()
                .filter(|m| m.0 >= 0.2 && m.2 > 0.0 && (!straight || m.1 < 0.3))
                .map(|m| m.0 / m.2)
                .collect()
        };
        ratios = by_encoders(true);
        if ratios.len() < 10 {
            ratios = by_encoders(false);
        }
    }
    // Speeds no ground vehicle drives: encoders in cm/s, or another unit (the 95th
    // percentile of the body speed they imply over 40 m/s). Fatal.
    if whole && !plausible_speeds(data, windows) {
        out.push(Finding {
            check: Check::EncoderUnits,
            severity: Severity::Fatal,
            message: "the encoders imply body speeds over 40 m/s on a twentieth of the samples or more: encoders (and commands) in another unit?".into(),
        });
    }
    if ratios.len() >= 10 {
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        // A unit scales every window alike; wheels spinning on ice spin more in some
        // windows than others (a simulated car on ice: a median of 7, a quarter of the
        // windows under 2.5). Fatal when the quartile nearer 1 is beyond the warning's
        // bound too.
        let (low, high) = (ratios[ratios.len() / 4], ratios[ratios.len() * 3 / 4]);
        let consistent = if median > 1.0 { low > 2.5 } else { high < 0.4 };
        // Wheels spinning on ice follow their commands; encoders in another unit do not
        // (and positions in another unit scale every window alike, within 30%): under 20
        // times, with the windows' ratios spread and the encoders at their commands, the
        // wheels spun.
        let may_spin = median > 1.0
            && median < 20.0
            && encoders_follow_commands(data, windows)
            && plausible_speeds(data, windows);
        let spun = may_spin && high > 1.3 * low;
        let consistent = consistent && !spun;
        // Under 0.6: localization saw two thirds more than the wheels roll (a robot travels
        // about as far as its wheels turn, short of sliding downhill: the bundled runs
        // 1.01-1.08, a short simulated Warthog log 0.73): a wheel radius too small in the
        // geometry (half of it: 0.52), or a unit. Over 2.5:
        // beyond what the wheels' spinning on loose ground explains (a Warthog on gravel:
        // about 1.8).
        if !(MIN_DISTANCE_RATIO..=2.5).contains(&median) {
            out.push(Finding {
                check: Check::EncoderUnits,
                severity: Severity::fatal_if(!(0.2..=5.0).contains(&median) && consistent),
                // Wheels at their commands that travel further than the robot: they spun,
                // or the wheel radius (or both columns' unit) is wrong; the data cannot
                // tell which, the ground can (a simulated car on ice: 4.2x, every window
                // within 4.0-4.9x).
                message: if may_spin {
                    format!(
                        "the encoders imply {}x the distance localization saw (median over {} windows; a quarter of them under {}x, a quarter over {}x; the encoders at their commands): the wheels spinning (ice, snow, mud)? A model fitted on it learns that slip. If the ground held: the wrong wheel radius, or commands and encoders in another unit?",
                        Short((median * 1000.0).round() / 1000.0),
                        ratios.len(),
                        Short((low * 100.0).round() / 100.0),
                        Short((high * 100.0).round() / 100.0)
                    )
                } else if let Some(turn) = usual_turn(motions).filter(|_| !(0.5..=2.0).contains(&median)) {
                    // The encoders' turn agrees with localization's as a vehicle's does:
                    // their unit and the geometry hold, the positions' do not (a factor of
                    // two or more: a drift adds less).
                    format!(
                        "the encoders imply {}x the distance localization saw (median over {} windows), where localization turns {}x what they imply, as a vehicle does: localization's positions in another unit (cm, feet)? (Else encoders in another unit, or the wrong wheel radius)",
                        Short((median * 1000.0).round() / 1000.0),
                        ratios.len(),
                        Short((turn * 100.0).round() / 100.0)
                    )
                } else {
                    format!(
                        "the encoders imply {}x the distance localization saw (median over {} windows): encoders in another unit, or the wrong wheel radius?{}",
                        Short((median * 1000.0).round() / 1000.0),
                        ratios.len(),
                        if median < 1.0 {
                            " Or localization moving more than the robot (drifting)"
                        } else {
                            ""
                        }
                    )
                },
            });
        }
    }
    // encoder-units, the turn: over the windows where the encoders imply a turn of 0.3 rad
    // or more, the median ratio of the turn localization saw to it. A skid-steer turns
    // less than its encoders imply (0.41-0.62 on the bundled runs); over 2.5 times as much,
    // its geometry is off (a baseline too wide in the sidecar or robot file: eq. 4's yaw
    // rate is the wheel speed difference over it); over 5 times, as for the distance, no
    // geometry explains it (a yaw in degrees turns 57 times): fatal.
    let mut turns: Vec<f64> = motions
        .iter()
        .filter(|m| m.1 >= 0.05 && (m.1 >= 0.3 || m.3.abs() >= 0.3))
        .map(|m| m.3.abs() / m.1)
        .collect();
    // A skid-steer only: a car on ice or snow may spin out past what its wheels imply.
    let skid_steer =
        drive_traits::vehicle_tag(data.robot.vehicle.as_ref()).as_deref() == Some("differential");
    if !skid_steer && turns.len() >= 10 {
        // Another vehicle turns as its wheels or steering imply, or spins out past it on
        // ice in some windows: over ten times in the median, no geometry or ground explains
        // it (a yaw in degrees turns 57 times).
        turns.sort_by(f64::total_cmp);
        let median = turns[turns.len() / 2];
        if median > 10.0 {
            out.push(Finding {
                check: Check::EncoderUnits,
                severity: Severity::Fatal,
                message: format!(
                    "localization turns {}x what the encoders imply (median over {} windows): a yaw in degrees?",
                    Short((median * 100.0).round() / 100.0),
                    turns.len()
                ),
            });
        }
    }
    if skid_steer && turns.len() >= 10 {
        turns.sort_by(f64::total_cmp);
        let median = turns[turns.len() / 2];
        if median > 2.5 {
            out.push(Finding {
                check: Check::EncoderUnits,
                severity: Severity::fatal_if(median > 5.0),
                message: format!(
                    "localization turns {}x what the encoders imply (median over {} windows), where a vehicle turns at most as much: a baseline too wide (or a wheel radius too small) in the vehicle's geometry, or a yaw in degrees?",
                    Short((median * 100.0).round() / 100.0),
                    turns.len()
                ),
            });
        }
    }
    if !whole {
        return out;
    }
    // encoder-units, an angle: an input axis in radians (a steering or articulation
    // angle) beyond pi on a twentieth of its commanded or measured samples: no angle of a
    // wheel is, one in degrees is (a steering of 25 degrees).
    for (i, axis) in data.robot.vehicle.axes().iter().enumerate() {
        if axis.unit != "rad" || i >= drive_traits::MAX_INPUTS {
            continue;
        }
        for (what, column, pick) in [
            ("commanded", axis.command_column, 0usize),
            ("measured", axis.measured_column, 1),
        ] {
            let (mut n, mut beyond, mut largest) = (0usize, 0usize, 0.0f64);
            for w in windows {
                let values = if pick == 0 { &w.command } else { &w.measured };
                for u in values {
                    n += 1;
                    beyond += usize::from(u[i].abs() > std::f64::consts::PI);
                    largest = largest.max(u[i].abs());
                }
            }
            if n > 0 && beyond * 20 >= n {
                out.push(Finding {
                    check: Check::EncoderUnits,
                    severity: Severity::Fatal,
                    message: format!(
                        "the {what} '{column}' (an angle in rad) is beyond pi on {beyond} of {n} samples (up to {}): an angle in degrees?",
                        Short(three_digits(largest))
                    ),
                });
            }
        }
    }
    out.extend(yaw_units(data, windows));
    out
}

/// encoder-units, the yaw: the localization's yaw rate (median over the samples its yaw
/// changed at) against the encoders' (median over the samples they turn at). A skid-steer's
/// localization turns less than its encoders say; a yaw in degrees, or scaled, turns many
/// times more (its wrapped steps scattered up to pi). Run on the whole run and on its parts
/// ([`parts`]: a yaw in degrees in a fifth of a run was named a mirrored localization).
fn yaw_units(data: &Dataset, windows: &[&Window]) -> Option<Finding> {
    let dt = data.robot.dt();
    // Each change over the time since the previous one (a localization slower than the
    // command rate holds its yaw in between).
    let mut seen: Vec<f64> = Vec::new();
    for w in windows {
        let mut last = 0;
        for k in 1..w.len() {
            let d = w.pose[k].z - w.pose[last].z;
            if d != 0.0 {
                let wrapped = (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                seen.push(wrapped.abs() / ((k - last) as f64 * dt));
                last = k;
            }
        }
    }
    let mut implied: Vec<f64> = windows
        .iter()
        .flat_map(|w| w.measured.iter())
        .map(|u| data.robot.vehicle.body_velocity(u).z.abs())
        .filter(|r| *r > 1e-3)
        .collect();
    if seen.len() >= 100 && implied.len() >= 100 {
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let (seen, implied) = (median(&mut seen), median(&mut implied));
        if seen > 5.0 && seen > 5.0 * implied {
            // Fatal: the documented bound (no localization's yaw changes at a median of 5
            // rad/s and five times the wheels'; a Warthog's yaw in degrees: 7.35 and 8.4x).
            return Some(Finding {
                check: Check::EncoderUnits,
                severity: Severity::Fatal,
                message: format!(
                    "localization's yaw turns at a median {} rad/s where it changes, {}x the encoders' median yaw rate: yaw in degrees, or in another unit?",
                    Short((seen * 100.0).round() / 100.0),
                    Short((seen / implied * 10.0).round() / 10.0)
                ),
            });
        }
    }
    None
}

/// `outside-limits`: commands or measured inputs beyond three times the robot description's
/// limit `space` on an axis.
fn outside_limits(w: &Windows<'_>, space: &InputSpace) -> Vec<Finding> {
    let (data, windows) = (w.data, &w.windows);
    let mut out = Vec::new();
    // outside-limits: beyond three times the description's limit on an axis (real runs go
    // past a manufacturer's nominal speed: the bundled Husky data reaches 2.4 times it).
    let axes = data.robot.vehicle.axes();
    for (i, axis) in axes.iter().enumerate() {
        let limit = space.min[i].abs().max(space.max[i].abs());
        for (what, values) in [
            (
                "commands",
                windows
                    .iter()
                    .flat_map(|w| w.command.iter())
                    .collect::<Vec<_>>(),
            ),
            (
                "measured inputs",
                windows.iter().flat_map(|w| w.measured.iter()).collect(),
            ),
        ] {
            let peak = values.iter().map(|u| u[i].abs()).fold(0.0, f64::max);
            if limit > 0.0 && peak > 3.0 * limit {
                out.push(Finding {
                    check: Check::OutsideLimits,
                    severity: Severity::Warning,
                    message: format!(
                        "{what} reach {} {} on '{}', {}x the robot description's limit of {}: is it the right robot?",
                        Short(peak),
                        axis.unit,
                        axis.name,
                        Short((peak / limit * 10.0).round() / 10.0),
                        Short(limit)
                    ),
                });
                break;
            }
        }
    }
    out
}

/// The `encoder-command` findings: per input axis, over the samples commanded at a tenth of
/// that axis's largest command or more, a measured input near zero (under a thousandth of
/// the largest command on nine samples in ten: that encoder dead while the other turns),
/// against its commands (a negative least-squares gain through zero, or following the other
/// axis's commands better than its own: sign flipped, sides swapped), or a fixed factor
/// away (a gain over 4 or under 0.1; the bundled runs: 0.42-0.82, the Husky commanded far beyond its limits). At least 100 such samples per axis.
/// On a skid-steer, also the two sides against each other, driving straight and over every
/// command (one side's encoders or commands scaled: another unit, another wheel's radius);
/// and on every axis, the measurements answering their commands late ([`answered_late`]).
fn encoder_command(data: &Dataset, windows: &[&Window]) -> Vec<Finding> {
    encoder_command_in(data, windows, true)
}

/// [`encoder_command`] on the whole run (`whole`), or on a part of it ([`parts`]): there
/// only the per-axis rules a corruption of that part breaks (a measurement dead, stuck,
/// flipped, another's or in another unit), not the copies, the sides' comparison or the
/// delay, which read the whole run.
fn encoder_command_in(data: &Dataset, windows: &[&Window], whole: bool) -> Vec<Finding> {
    let axes = data.robot.vehicle.axes();
    let samples = || {
        windows
            .iter()
            .flat_map(|w| w.command.iter().zip(w.measured.iter()))
    };
    let mut out = Vec::new();
    let axes = &axes[..axes.len().min(drive_traits::MAX_INPUTS)];
    let skid_steer =
        drive_traits::vehicle_tag(data.robot.vehicle.as_ref()).as_deref() == Some("differential");
    // Correlations over fewer commands than this are chance (a run of one or two intervals:
    // a car's steering servo following its speed command at 0.9): a warning at most.
    let intervals = {
        let mut seen: Vec<usize> = windows.iter().map(|w| w.interval).collect();
        seen.sort_unstable();
        seen.dedup();
        seen.len()
    };
    if intervals >= 10 {
        if let Some(f) = body_axes_exchanged(data, windows) {
            // The wheels' findings below would be its consequences, each naming a wrong
            // cause.
            return vec![f];
        }
    }
    // Per axis, its gain and its correlation with its own command where neither is
    // suspect on its own (the sides' comparison below).
    let mut followed: Vec<Option<(f64, f64)>> = vec![None; axes.len()];
    for (i, axis) in axes.iter().enumerate() {
        let largest = samples().map(|(c, _)| c[i].abs()).fold(0.0, f64::max);
        if largest <= 0.0 || !largest.is_finite() {
            continue;
        }
        // One pass over the samples for every statistic of the axis below: over the
        // commanded ones (a tenth of the largest command or more) the gain's sums, the
        // measurement's and the command's ranges and the sums of its correlations with
        // every axis's command; over all, the samples equal to their command.
        let on = |c: &drive_traits::Input| c[i].abs() >= 0.1 * largest;
        let (mut n, mut dead, mut cc, mut cm) = (0usize, 0usize, 0.0, 0.0);
        let (mut all, mut equal) = (0usize, 0usize);
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut c_low, mut c_high) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut with = vec![Correlation::default(); axes.len()];
        for (c, m) in samples() {
            all += 1;
            equal += usize::from(c[i] == m[i]);
            if !on(c) {
                continue;
            }
            n += 1;
            dead += usize::from(m[i].abs() <= 1e-3 * largest);
            (low, high) = (low.min(m[i]), high.max(m[i]));
            (c_low, c_high) = (c_low.min(c[i]), c_high.max(c[i]));
            // Scaled by the largest command, so that tiny commands (1e-300) do not
            // underflow to a gain of infinity.
            let (ci, mi) = (c[i] / largest, m[i] / largest);
            cc += ci * ci;
            cm += ci * mi;
            for (j, sums) in with.iter_mut().enumerate() {
                sums.add(c[j] / largest, mi);
            }
        }
        // Commanded in five intervals at least: fewer commands are chance (a mecanum base's
        // linear sampler drives its yaw rate in two or three of a minute's ten intervals,
        // its yaw-rate column then read as in another unit or sign-flipped).
        let commanded_intervals = {
            let mut seen: Vec<usize> = windows
                .iter()
                .filter(|w| w.command.iter().any(&on))
                .map(|w| w.interval)
                .collect();
            seen.sort_unstable();
            seen.dedup();
            seen.len()
        };
        if n < 100 || commanded_intervals < 5 {
            continue;
        }
        // The measurement equal to its command to the bit on nearly every sample (the
        // commands written into the encoder columns: no powertrain answers with no lag and
        // no noise), or holding one value while its commands vary (stuck, or not recorded).
        let commands_vary = c_high - c_low > 1e-3 * largest;
        if equal * 100 >= all * 99 {
            out.push(Finding {
                check: Check::EncoderCommand,
                severity: Severity::Fatal,
                message: format!(
                    "'{}' equals its command '{}' to the bit on {equal} of {all} samples: the commands written into the measured column (no powertrain answers without lag or noise)?",
                    axis.measured_column, axis.command_column
                ),
            });
            continue;
        }
        // The measurement a copy of its commands, delayed by a few samples or scaled, with
        // noise or rounding under 0.5% of its size: a powertrain's answer is no pure
        // delay (its lag and the transients alone leave far more), nor are encoders that
        // clean.
        let copied = (whole && commands_vary)
            .then(|| commands_copied(windows, i))
            .flatten();
        if let Some((lag, gain, rms)) = copied {
            let delayed = match lag {
                0 => String::new(),
                1 => " delayed by 1 sample".to_string(),
                k => format!(" delayed by {k} samples"),
            };
            let within = if rms < 1e-6 {
                "exactly".to_string()
            } else {
                format!(
                    "to within {}% of its size",
                    Short(three_digits(100.0 * rms))
                )
            };
            out.push(Finding {
                check: Check::EncoderCommand,
                severity: Severity::Fatal,
                message: format!(
                    "'{}' is its command '{}'{delayed} times {}, {within}: the commands copied into the measured column (no powertrain answers with a pure delay and no noise)?",
                    axis.measured_column,
                    axis.command_column,
                    Short(three_digits(gain)),
                ),
            });
            continue;
        }
        // The command column holding one value while its measurement drives elsewhere
        // (off that value by more than the value itself on a tenth of the samples; a
        // start from rest stays between zero and the command): a stuck command column,
        // or not recorded, and the powertrain would be fitted to commands never sent.
        if !commands_vary {
            let held = c_high;
            let all = samples().count();
            let away = samples()
                .filter(|(_, m)| (m[i] - held).abs() > 1.5 * held.abs())
                .count();
            if all >= 100 && away * 10 >= all {
                out.push(Finding {
                    check: Check::EncoderCommand,
                    severity: Severity::Fatal,
                    message: format!(
                        "'{}' holds {} on every commanded sample while its measurement '{}' is off it by more than one and a half times that on {away} of {all} samples (from {} to {}): a stuck command column, or not recorded?",
                        axis.command_column,
                        Short(three_digits(held)),
                        axis.measured_column,
                        Short(three_digits(samples().map(|(_, m)| m[i]).fold(f64::INFINITY, f64::min))),
                        Short(three_digits(samples().map(|(_, m)| m[i]).fold(f64::NEG_INFINITY, f64::max))),
                    ),
                });
                continue;
            }
        }
        if commands_vary && high - low <= 1e-9 * largest {
            out.push(Finding {
                check: Check::EncoderCommand,
                severity: Severity::Fatal,
                message: format!(
                    "'{}' holds {} throughout {n} samples whose commands '{}' vary: a stuck or unrecorded measurement?",
                    axis.measured_column,
                    Short(three_digits(low)),
                    axis.command_column
                ),
            });
            continue;
        }
        let gain = cm / cc;
        // The other axis this measurement follows best (a two-input vehicle's other side).
        let own = with[i].value();
        let (other, cross) = (0..axes.len())
            .filter(|&j| j != i)
            .map(|j| (j, with[j].value()))
            .fold(
                (i, f64::NEG_INFINITY),
                |best, c| if c.1 > best.1 { c } else { best },
            );
        // Fatal where the column is plainly another's or flipped: a measurement moving
        // against its own command (a gain of -0.1 or less; a twin's protocol in another
        // geometry leaves a wheel barely answering, -0.009) with a correlation of -0.5 or
        // less, or following another axis's command (0.7 or more) and not its own (under
        // 0.3: a mecanum base's forward and sideways columns swapped; a short run's few
        // commands may correlate by chance, so ten intervals at least); a warning where it
        // may be a weak or odd axis. (A skid-steer's two sides are correlated through the
        // turns: its swapped sides are `direction`'s, and a protocol recorded in another
        // geometry than the robot's leaves one wheel following the other side's command:
        // no fatal there.)
        // And where it follows its own command closely (0.5 or more) at a gain no robot's
        // powertrain explains (over [`MAX_ENCODER_GAIN`], the warning's bound, or under 0.02:
        // encoders in rpm against commands in rad/s give 9.5, a steering angle in degrees
        // against its command in radians 57 or 0.017, a Warthog's commands in m/s at the
        // wheel's rim against encoders in rad/s 2.6).
        let plain = intervals >= 10
            && ((gain <= -0.1 && own <= -0.5)
                || (!skid_steer && cross >= 0.7 && own < 0.3)
                || (own >= 0.5 && !(0.02..=MAX_ENCODER_GAIN).contains(&gain)));
        let message = if dead * 10 >= n * 9 && own < 0.5 {
            format!(
                "'{}' stays under a thousandth of its largest command ({} {}) on {dead} of {n} commanded samples: that encoder dead, or not recorded?",
                axis.measured_column,
                Short(largest),
                axis.unit
            )
        } else if gain < 0.0 {
            format!(
                "'{}' moves against its commands '{}' (least-squares gain {} over {n} commanded samples): sign flipped, or sides swapped?",
                axis.measured_column,
                axis.command_column,
                Short(three_digits(gain))
            )
        } else if cross > own + 0.3 {
            format!(
                "'{}' follows '{}' (correlation {}) better than its own command '{}' ({}): sides swapped?",
                axis.measured_column,
                axes[other].command_column,
                Short((cross * 100.0).round() / 100.0),
                axis.command_column,
                Short((own * 100.0).round() / 100.0)
            )
        } else if !(0.1..=MAX_ENCODER_GAIN).contains(&gain) {
            format!(
                "'{}' follows its commands '{}' with a gain of {} (over {n} commanded samples): commands or encoders in another unit?",
                axis.measured_column,
                axis.command_column,
                Short(three_digits(gain))
            )
        } else {
            followed[i] = Some((gain, own));
            if own >= 0.5 && !TYPICAL_ENCODER_GAIN.contains(&gain) {
                out.push(Finding {
                    check: Check::EncoderCommand,
                    severity: Severity::Warning,
                    message: format!(
                        "'{}' answers {} of its commands '{}' (least-squares gain over {n} commanded samples; DRIVE runs of real robots answer 0.42-0.84, simulated ones up to 1.0): commands scaled or in another unit, {}?",
                        axis.measured_column,
                        Short(three_digits(gain)),
                        axis.command_column,
                        if gain < 1.0 {
                            "or commanded far beyond what the wheels reach"
                        } else {
                            "or a powertrain that overshoots its commands"
                        }
                    ),
                });
            }
            continue;
        };
        out.push(Finding {
            check: Check::EncoderCommand,
            severity: Severity::fatal_if(plain),
            message,
        });
    }
    if !whole {
        return out;
    }
    // Only on the axes that follow their commands (a dead or scaled one is said above).
    let following: Vec<usize> = (0..axes.len()).filter(|&i| followed[i].is_some()).collect();
    if let Some(f) = answered_late(data, windows, &following) {
        out.push(f);
    }
    if skid_steer && axes.len() == 2 {
        sides_compared(windows, axes, &followed, intervals, &mut out);
    }
    out
}

/// Pearson's correlation of pairs `(a, b)` from sums gathered in one pass (the pairs scaled
/// to order one by the caller); 0 when either side does not vary.
#[derive(Debug, Clone, Copy, Default)]
struct Correlation {
    n: f64,
    a: f64,
    b: f64,
    aa: f64,
    bb: f64,
    ab: f64,
}

impl Correlation {
    /// Adds the pair `(a, b)`.
    #[inline]
    fn add(&mut self, a: f64, b: f64) {
        self.n += 1.0;
        self.a += a;
        self.b += b;
        self.aa += a * a;
        self.bb += b * b;
        self.ab += a * b;
    }

    /// The correlation of the pairs added.
    fn value(&self) -> f64 {
        if self.n < 2.0 {
            return 0.0;
        }
        let var_a = self.aa - self.a * self.a / self.n;
        let var_b = self.bb - self.b * self.b / self.n;
        let cov = self.ab - self.a * self.b / self.n;
        // A side constant to rounding: its variance a vanishing share of its square.
        if var_a <= 1e-12 * self.aa || var_b <= 1e-12 * self.bb {
            return 0.0;
        }
        (cov / (var_a * var_b).sqrt()).clamp(-1.0, 1.0)
    }
}

/// `encoder-command`, on a skid-steer: the commanded forward speed and yaw rate exchanged
/// (a log's `cmd_vel` linear and angular columns read for each other before they were turned
/// into wheel commands). The body velocity the commands ask for (eq. 4) against the one the
/// encoders imply: exchanged, each commanded axis follows the other measured axis (a
/// correlation of 0.5 or more) and not its own (under 0.3), and no one side's command is
/// sign-flipped (which looks alike but for the axes' scales). Real runs: 0.8 or more on
/// their own axes. Fatal; the wheels' own findings, each a consequence naming another cause
/// (a side moving against its commands, answering late), are not said.
fn body_axes_exchanged(data: &Dataset, windows: &[&Window]) -> Option<Finding> {
    let vehicle = &data.robot.vehicle;
    // Each sample's commanded and implied body velocity, computed once for the four
    // correlations.
    let body: Vec<[f64; 4]> = windows
        .iter()
        .flat_map(|w| w.command.iter().zip(&w.measured))
        .map(|(c, m)| {
            let (f, v) = (vehicle.body_velocity(c), vehicle.body_velocity(m));
            [f.x, f.z, v.x, v.z]
        })
        .collect();
    let corr = |a: usize, b: usize| localization::correlation(body.iter().map(|r| (r[a], r[b])));
    let (own_x, own_z) = (corr(0, 2), corr(1, 3));
    let (x_as_z, z_as_x) = (corr(0, 3), corr(1, 2));
    // Each far less its own: under 0.3 on a skid-steer, whose commanded forward speed and
    // yaw rate are drawn apart (one side's command negated in part of a run mixes the two
    // and leaves 0.3-0.5); on another vehicle by 0.3 of correlation (a car's commanded
    // speed and yaw rate go together, its steering needing speed: own correlations of
    // 0.2-0.5 exchanged, 0.95 and more across).
    let skid_steer = drive_traits::vehicle_tag(vehicle.as_ref()).as_deref() == Some("differential");
    let own_bound = |across: f64| {
        if skid_steer {
            0.3
        } else {
            (across - 0.3).min(0.6)
        }
    };
    let exchanged =
        x_as_z >= 0.5 && z_as_x >= 0.5 && own_x < own_bound(x_as_z) && own_z < own_bound(z_as_x);
    if !exchanged {
        return None;
    }
    // Localization, where it moved, tells the commands exchanged (it follows the encoders,
    // each commanded axis the other) from one encoder negated (its sum and difference
    // exchanged alike through eq. 4; localization follows the commands' own axes, and the
    // wheels' findings name the encoder). Per window: the mean commanded forward speed and
    // yaw rate against the travel and turn localization saw.
    let seen: Vec<[f64; 4]> = windows
        .iter()
        .filter(|w| w.len() >= 2)
        .map(|w| {
            let (travel, _, _) = localization::body_travel(data, w);
            let n = w.command.len() as f64;
            let f = w
                .command
                .iter()
                .map(|c| vehicle.body_velocity(c))
                .fold([0.0; 2], |a, f| [a[0] + f.x / n, a[1] + f.z / n]);
            [f[0], f[1], travel[0], drive_traits::net_turn(&w.pose)]
        })
        .collect();
    let seen_corr =
        |a: usize, b: usize| localization::correlation(seen.iter().map(|r| (r[a], r[b])));
    if seen_corr(0, 2) >= 0.5 && seen_corr(1, 3) >= 0.5 {
        return None;
    }
    // One side's command sign-flipped looks the same through eq. 4 (its sum and difference
    // exchanged), and so does the exchange itself once that side is negated back: but the
    // exchange also scales the forward speed by half the baseline and the yaw rate by its
    // inverse, so that the two axes' gains then differ by the baseline squared over four
    // (13 on a Husky, 3.4 on a Warthog), where a side flipped keeps them alike (a gain under
    // twice the other's: the wheels' findings say it). A vehicle whose baseline is near 2 m
    // tells them apart no further.
    let side = |i: usize| {
        localization::correlation(
            windows
                .iter()
                .flat_map(|w| w.command.iter().zip(&w.measured))
                .map(|(c, m)| (c[i], m[i])),
        )
    };
    if let Some(flipped) = (0..2).find(|&i| side(i) <= -0.5) {
        let (mut fx, mut fz) = ([0.0; 2], [0.0; 2]);
        for w in windows {
            for (c, m) in w.command.iter().zip(&w.measured) {
                let mut c = *c;
                c[flipped] = -c[flipped];
                let (f, v) = (vehicle.body_velocity(&c), vehicle.body_velocity(m));
                fx = [fx[0] + f.x * f.x, fx[1] + f.x * v.x];
                fz = [fz[0] + f.z * f.z, fz[1] + f.z * v.z];
            }
        }
        let (gx, gz) = (fx[1] / fx[0], fz[1] / fz[0]);
        let ratio = (gz / gx).abs();
        // The exchange scales the gains apart by the baseline squared over four (from one
        // side's input alone: r / 2 forward, r / b turning); a side flipped keeps them
        // alike. The bound is halfway between, on a log scale (3.6 on a Husky, 1.85 on a
        // Warthog), and 2 at least: a side flipped in most of a part of the run only (the
        // rest not) scatters them further than on a whole run.
        let unit = vehicle.body_velocity(&drive_traits::Input::new(1.0, 0.0, 0.0));
        let apart = (unit.x / unit.z).powi(2);
        let bound = apart.max(1.0 / apart).sqrt();
        let bound = if bound.is_finite() {
            bound.max(2.0)
        } else {
            2.0
        };
        if ratio.is_finite() && (1.0 / bound..=bound).contains(&ratio) {
            return None;
        }
    }
    let two = |x: f64| Short((x * 100.0).round() / 100.0);
    Some(Finding {
        check: Check::EncoderCommand,
        severity: Severity::Fatal,
        message: format!(
            "the commanded forward speed follows the yaw rate the encoders imply (correlation {}) and the commanded yaw rate their forward speed ({}), each far less its own ({} and {}): the commands' forward speed and yaw rate exchanged (a log's cmd_vel linear and angular columns read for each other)?",
            two(x_as_z),
            two(z_as_x),
            two(own_x),
            two(own_z)
        ),
    })
}

/// A skid-steer's two sides against each other (`encoder-command`): one powertrain design on
/// one ground answers both alike, whatever the ground's slip (on ice the wheels spin at
/// their commands on both sides alike), so a side answering otherwise is scaled or another's.
/// `followed` holds each side's gain and correlation with its own command where neither is
/// suspect on its own; `intervals` the run's intervals.
fn sides_compared(
    windows: &[&Window],
    axes: &[drive_traits::InputAxis],
    followed: &[Option<(f64, f64)>],
    intervals: usize,
    out: &mut Vec<Finding>,
) {
    // The largest command of either side.
    let largest = windows
        .iter()
        .flat_map(|w| w.command.iter())
        .map(|c| c[0].abs().max(c[1].abs()))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    // One encoder read for both sides (a topic or column given twice): the two equal to the
    // bit where their commands differ (a turn's wheels stalling together still differ by
    // their noise). And one command written for both sides (the mirror case): the two
    // commands equal to the bit where the wheels turn the robot (their measurements a tenth
    // of the largest apart): a DRIVE run's commands turn as its wheels do.
    for (columns, turning_by, says) in [
        (
            [&axes[0].measured_column, &axes[1].measured_column],
            Column::Command,
            "whose commands turn: one encoder read for both sides (a topic or column given twice)?",
        ),
        (
            [&axes[0].command_column, &axes[1].command_column],
            Column::Measured,
            "whose wheels turn the robot: one command written for both sides (a column given twice)?",
        ),
    ] {
        let (equal, turning) = sides_equal(windows, turning_by);
        if turning >= 100 && equal * 10 >= turning * 9 {
            out.push(Finding {
                check: Check::EncoderCommand,
                severity: Severity::Fatal,
                message: format!(
                    "'{}' equals '{}' to the bit on {equal} of the {turning} samples {says}",
                    columns[0], columns[1]
                ),
            });
            return;
        }
    }
    if let ([Some((gain_left, own_left)), Some((gain_right, own_right))], true) =
        (followed, intervals >= 10)
    {
        // Over every command, the sides' gains: 2.5 times apart is beyond what a turn's
        // stalls leave by chance (a Husky twin's 240 s runs: up to 1.6), and a side's
        // commands scaled shows there (where, driving straight, it leaves few samples).
        let ratio = gain_left / gain_right;
        let apart = ratio.max(1.0 / ratio);
        if *own_left >= 0.5 && *own_right >= 0.5 && apart >= 2.5 {
            out.push(Finding {
                check: Check::EncoderCommand,
                severity: Severity::Fatal,
                message: format!(
                    "'{}' follows its commands with a gain of {} and '{}' with {}: the sides {} times apart, where one powertrain on one ground answers both alike (one side's commands or encoders scaled: another unit, another wheel radius)?",
                    axes[0].measured_column,
                    Short(three_digits(*gain_left)),
                    axes[1].measured_column,
                    Short(three_digits(*gain_right)),
                    Short(three_digits(apart))
                ),
            });
            return;
        }
        // Where the two sides are commanded alike (driving straight, in the steady windows:
        // within a fifth of each other, at a fifth of the largest command or more), their
        // measurements are alike too, whatever the ground and the wheel limits; over every
        // command the gains differ by chance where a turn's inner wheel stalls (a Husky
        // twin's 240 s runs: 0.31 against 0.49). Signed by the direction driven; 200
        // samples at least.
        let (mut sums, mut commanded, mut n) = ([0.0f64; 2], [0.0f64; 2], 0usize);
        // Steady windows only: in a transient one the sides' lags differ with the turn.
        for w in windows.iter().filter(|w| w.phase == Phase::Steady) {
            for (c, m) in w.command.iter().zip(&w.measured) {
                let top = c[0].abs().max(c[1].abs());
                if c[0] * c[1] > 0.0
                    && (c[0] - c[1]).abs() <= 0.2 * top
                    && top >= 0.2 * largest
                    && m[0].is_finite()
                    && m[1].is_finite()
                {
                    let sign = c[0].signum();
                    sums[0] += sign * m[0];
                    sums[1] += sign * m[1];
                    commanded[0] += sign * c[0];
                    commanded[1] += sign * c[1];
                    n += 1;
                }
            }
        }
        // Each side's measurement over its command there (the commands a fifth apart at
        // most: their own ratio taken out).
        let (left, right) = if n >= 200 && sums[0] > 0.0 && sums[1] > 0.0 {
            (sums[0] / commanded[0], sums[1] / commanded[1])
        } else {
            (f64::NAN, f64::NAN)
        };
        let ratio = left / right;
        let apart = ratio.max(1.0 / ratio);
        if *own_left >= 0.5 && *own_right >= 0.5 && apart >= 1.25 {
            out.push(Finding {
                check: Check::EncoderCommand,
                severity: Severity::fatal_if(apart >= 1.5),
                message: format!(
                    "'{}' answers {} of its commands and '{}' {} where both sides are commanded alike (driving straight): the sides {} times apart, where one powertrain on one ground answers both alike (one side's encoders or commands scaled: another unit, another wheel radius)?",
                    axes[0].measured_column,
                    Short(three_digits(left)),
                    axes[1].measured_column,
                    Short(three_digits(right)),
                    Short(three_digits(apart))
                ),
            });
        }
    }
}

/// Which of a skid-steer's two columns [`sides_equal`] reads the turn from.
#[derive(Clone, Copy)]
enum Column {
    Command,
    Measured,
}

/// Over the samples where the `turning_by` column's two sides are a tenth of its largest
/// value apart (the robot turning), how many hold the other column's two sides equal to
/// the bit, and of how many.
fn sides_equal(windows: &[&Window], turning_by: Column) -> (usize, usize) {
    fn pick(w: &Window, c: Column) -> &[drive_traits::Input] {
        match c {
            Column::Command => &w.command,
            Column::Measured => &w.measured,
        }
    }
    let other = match turning_by {
        Column::Command => Column::Measured,
        Column::Measured => Column::Command,
    };
    let largest = windows
        .iter()
        .flat_map(|w| pick(w, turning_by))
        .map(|u| u[0].abs().max(u[1].abs()))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let (mut turning, mut equal) = (0usize, 0usize);
    for w in windows {
        for (t, e) in pick(w, turning_by).iter().zip(pick(w, other)) {
            if (t[0] - t[1]).abs() >= 0.1 * largest {
                turning += 1;
                equal += usize::from(e[0] == e[1]);
            }
        }
    }
    (equal, turning)
}

/// The measurements answering their commands late: in the transient windows, on every
/// axis of `axes` (by index) whose command steps by 30% of its largest or more away from
/// the measurement at the window's start, the time until the measurement has gone a fifth of the way (the window's
/// length where it never does); the median over ten such steps at least. The bundled runs
/// take 0.35-0.65 s, the simulator 0.3-0.9 s (its skid-steers on ice). 1.5 s or more is
/// fatal, 1.2 s a warning: measurements timestamped late against their commands (or the
/// commands early), which no wheel velocity loop explains, and every model would learn.
fn answered_late(data: &Dataset, windows: &[&Window], axes: &[usize]) -> Option<Finding> {
    let dt = data.robot.dt();
    let mut rises = Vec::new();
    for &i in axes {
        let largest = windows
            .iter()
            .flat_map(|w| w.command.iter())
            .map(|c| c[i].abs())
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        if largest <= 0.0 {
            continue;
        }
        for w in windows.iter().filter(|w| w.phase == Phase::Transient) {
            let (Some(first), Some(last)) = (w.measured.first(), w.command.last()) else {
                continue;
            };
            let (start, step) = (first[i], last[i] - first[i]);
            if step.is_nan() || step.abs() < 0.3 * largest {
                continue;
            }
            let k = w
                .measured
                .iter()
                .position(|m| (m[i] - start) * step >= 0.2 * step * step)
                .unwrap_or(w.len());
            rises.push(k as f64 * dt);
        }
    }
    if rises.len() < 10 {
        return None;
    }
    let late = drive_traits::median(&mut rises);
    // How far the measurements reach of the commands (the least over the axes): commands in
    // another unit (a forward speed in km/h) ask for steps the wheels never go a fifth of
    // the way to, which reads as late. A DRIVE run commands beyond what its wheels reach
    // (the bundled Husky run: 0.47), so only under 0.35 (a Husky's in km/h: 0.29).
    let reach = axes
        .iter()
        .map(|&i| {
            let most = |f: &dyn Fn(&Window) -> &[drive_traits::Input]| {
                windows
                    .iter()
                    .flat_map(|w| f(w).iter())
                    .map(|u| u[i].abs())
                    .filter(|v| v.is_finite())
                    .fold(0.0, f64::max)
            };
            most(&|w| &w.measured) / most(&|w| &w.command)
        })
        .filter(|r| r.is_finite())
        .fold(f64::INFINITY, f64::min);
    (late >= 1.2).then(|| Finding {
        check: Check::EncoderCommand,
        severity: Severity::fatal_if(late >= 1.5),
        message: format!(
            "the measured inputs go a fifth of the way to a new command {} s after it (median over {} steps of the transient windows; 0.35-0.65 s on the bundled runs): measurements timestamped late against their commands, or the commands early?{}",
            Short((late * 100.0).round() / 100.0),
            rises.len(),
            if reach < 0.35 {
                format!(
                    " Or the commands in another unit than the measurements: these reach {} of the largest command",
                    Short(three_digits(reach))
                )
            } else {
                String::new()
            }
        ),
    })
}

/// Whether measured axis `i` is its command delayed by 0 to 10 samples (within each
/// window) times a gain, to within 0.5% of its RMS: the lag, the least-squares gain
/// and the relative RMS of what is left, at the best lag. `None` over fewer than 100
/// samples, or where the measurement is no such copy.
fn commands_copied(windows: &[&Window], i: usize) -> Option<(usize, f64, f64)> {
    let mut best: Option<(usize, f64, f64)> = None;
    for lag in 0..=10usize {
        let (mut cc, mut cm, mut mm, mut n) = (0.0, 0.0, 0.0, 0usize);
        for w in windows {
            for t in lag..w.len() {
                let (c, m) = (w.command[t - lag][i], w.measured[t][i]);
                if c.is_finite() && m.is_finite() {
                    cc += c * c;
                    cm += c * m;
                    mm += m * m;
                    n += 1;
                }
            }
        }
        if n < 100 || cc <= 0.0 || mm <= 0.0 {
            continue;
        }
        let gain = cm / cc;
        // What the gain leaves, over the measurement's own size.
        let left = ((mm - gain * cm).max(0.0) / mm).sqrt();
        if best.is_none_or(|b| left < b.2) {
            best = Some((lag, gain, left));
        }
    }
    // The simulator's speed loops come closest: 0.023-0.035 of the measurement left at
    // their best lag (a car's, a mecanum base's); the bundled runs 0.30-0.70.
    best.filter(|b| b.2 <= 0.005 && b.1 > 0.0)
}

/// `x` rounded to three significant digits (a gain of 0.000812, not 0.001).
fn three_digits(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let unit = 10f64.powf(x.abs().log10().floor() - 2.0);
    (x / unit).round() * unit
}

/// An `outside-limits` warning when the dataset's vehicle is not the robot description's:
/// another type, or a geometry parameter more than 10% away (a Warthog's 0.3 m wheels and
/// 1.17 m track checked as a Husky's 0.165 m and 0.55 m).
pub fn vehicle_mismatch(
    data: &dyn drive_traits::CommandModel,
    robot: &dyn drive_traits::CommandModel,
    robot_name: &str,
) -> Option<Finding> {
    let (a, b) = (
        serde_json::to_value(data).ok()?,
        serde_json::to_value(robot).ok()?,
    );
    let differs = match (a.as_object(), b.as_object()) {
        (Some(x), Some(y)) => {
            x.get("type") != y.get("type")
                || x.iter().any(
                    |(k, v)| match (v.as_f64(), y.get(k).and_then(|w| w.as_f64())) {
                        (Some(p), Some(q)) => (p - q).abs() > 0.1 * p.abs().max(q.abs()),
                        _ => false,
                    },
                )
        }
        _ => a != b,
    };
    differs.then(|| Finding {
        check: Check::OutsideLimits,
        severity: Severity::Warning,
        message: format!(
            "the data's vehicle {a} is not the robot {robot_name}'s {b}: is it the right robot?"
        ),
    })
}

/// `localization-frame`, from a raw log's orientations (`icp_quat_x/y/z/w`, those that are
/// rotations): a ground robot drives upright, its orientation tilted a few degrees at most;
/// a median tilt beyond 30 degrees is a quaternion read in another order (written w,x,y,z:
/// a planar heading h then reads as a tilt of 180 degrees minus h, and every yaw as 0).
/// Fatal: the yaw read from it is wrong (the import refused it as a robot that did not move).
///
/// ```
/// let upright: Vec<[f64; 4]> = (0..100).map(|i| {
///     let h = i as f64 * 0.06;
///     [0.0, 0.0, (h / 2.0).sin(), (h / 2.0).cos()]
/// }).collect();
/// assert!(drive_data::quality::orientation_tilt(&upright).is_none());
/// let w_first: Vec<[f64; 4]> = upright.iter().map(|[x, y, z, w]| [*w, *x, *y, *z]).collect();
/// assert!(drive_data::quality::orientation_tilt(&w_first).unwrap().message.contains("w,x,y,z"));
/// ```
pub fn orientation_tilt(quaternions: &[[f64; 4]]) -> Option<Finding> {
    let mut tilts: Vec<f64> = quaternions
        .iter()
        .filter(|q| {
            let n2: f64 = q.iter().map(|v| v * v).sum();
            (0.8..=1.2).contains(&n2)
        })
        .map(|[x, y, _, _]| {
            (1.0 - 2.0 * (x * x + y * y))
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
        })
        .collect();
    if tilts.len() < 20 {
        return None;
    }
    let n = tilts.len();
    let median = drive_traits::median(&mut tilts);
    (median > 30.0).then(|| Finding {
        check: Check::LocalizationFrame,
        severity: Severity::Fatal,
        message: format!(
            "localization's orientation tilts a median {} degrees from upright (over {n} rows with a rotation), where a ground robot drives upright: a quaternion written w,x,y,z where the log's columns are x,y,z,w (icp_quat_x holding w)? Its yaw read so is wrong",
            Short(median.round())
        ),
    })
}

/// The yaw rate localization implies at each sample, from that sample and earlier ones only
/// (a start state never reads the window it predicts): the wrapped change of the yaw over
/// the two samples before (which spans the held values of a localization slower than the
/// command rate). The first two samples take the same backward difference at the end of
/// `before`, the window just before when it runs on into this one ([`Window::continued_by`]),
/// or else the encoders' yaw rate through `vehicle` (eq. 4) at the sample. What the
/// `imu_yaw_rate` column holds when the IMU was not recorded.
///
/// ```
/// # use drive_traits::{Input, Phase, Pose, Window};
/// use drive_traits::vehicles::DifferentialDrive;
/// // Turning at 1 rad/s through +-pi, localized every other sample.
/// let pose = [3.0, 3.0, 3.1, 3.1, -3.083185307179586].iter().map(|&z| Pose::new(0.0, 0.0, z)).collect();
/// let w = Window::new(0, 0, Phase::Steady, vec![Input::zeros(); 5], vec![Input::new(-1.0, 1.0, 0.0); 5],
///     pose, vec![0.0; 5]);
/// let vehicle = DifferentialDrive::new(0.25, 1.0); // the wheels say 0.5 rad/s
/// let r = drive_data::quality::yaw_rate_from_localization(&w, None, &vehicle, 0.05);
/// assert_eq!(&r[..2], &[0.5, 0.5]);
/// assert!(r[2..].iter().all(|v| (v - 1.0).abs() < 1e-9), "{r:?}");
/// ```
pub fn yaw_rate_from_localization(
    w: &Window,
    before: Option<&Window>,
    vehicle: &dyn drive_traits::CommandModel,
    dt: f64,
) -> Vec<f64> {
    let backward = |w: &Window, k: usize| -> f64 {
        let d = w.pose[k].z - w.pose[k - 2].z;
        d.sin().atan2(d.cos()) / (2.0 * dt)
    };
    let from_before = before
        .filter(|b| b.len() >= 3)
        .map(|b| backward(b, b.len() - 1));
    (0..w.len())
        .map(|k| {
            if k >= 2 {
                backward(w, k)
            } else {
                from_before.unwrap_or_else(|| vehicle.body_velocity(&w.measured[k]).z)
            }
        })
        .collect()
}

/// Findings as text, one line each.
pub fn to_text(findings: &[Finding]) -> String {
    findings
        .iter()
        .map(|f| {
            format!(
                "  check {} ({}): {}\n",
                f.check,
                match f.severity {
                    Severity::Warning => "warning",
                    Severity::Fatal => "fatal",
                },
                f.message
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_traits::vehicles::DifferentialDrive;
    use drive_traits::{Input, Phase, Pose, RobotDescription};

    /// A differential drive (0.5 m wheels, 1 m track) spinning in place at `wheel` rad/s
    /// per side for one 2 s window at 20 Hz; localization turns `seen` of it.
    fn spin(wheel: f64, seen: f64) -> Dataset {
        let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.5, 1.0));
        let rate = 2.0 * 0.5 * wheel / 1.0; // body yaw rate (rad/s)
        let pose = (0..40)
            .map(|k| {
                let yaw = seen * rate * k as f64 * 0.05;
                Pose::new(0.0, 0.0, yaw.sin().atan2(yaw.cos()))
            })
            .collect();
        let u = Input::new(-wheel, wheel, 0.0);
        // The wheels answer their command within a few hundredths, on average exactly (no
        // powertrain echoes its command to the bit, nor within its encoders' noise).
        let measured = (0..40)
            .map(|k| u * (1.0 + if k % 2 == 0 { 0.02 } else { -0.02 }))
            .collect();
        Dataset {
            robot,
            windows: vec![Window::new(
                0,
                0,
                Phase::Steady,
                vec![u; 40],
                measured,
                pose,
                vec![rate; 40],
            )],
        }
    }

    /// Twelve windows of `spin`, four intervals of three spinning left and right in turn at 2 rad/s per side, each
    /// turning `seen` of it in localization (a negative share: turning the other way), each
    /// spinning a micrometre further along x than the one before (no two windows the same).
    fn spins(seen: f64) -> Dataset {
        let mut data = spin(2.0, seen);
        let one = data.windows[0].clone();
        data.windows = (0..12)
            .map(|i| {
                let mut w = one.clone();
                w.pose.iter_mut().for_each(|p| p.x = 1e-6 * i as f64);
                w.index = i;
                // Intervals of three windows, each opening with its transient window (none
                // at all is `phases`'), the steps to a new command at their start.
                w.interval = i / 3;
                if i % 3 == 0 {
                    w.phase = Phase::Transient;
                }
                if (i / 3) % 2 == 1 {
                    w.command
                        .iter_mut()
                        .for_each(|u| *u = Input::new(u.y, u.x, 0.0));
                    w.measured
                        .iter_mut()
                        .for_each(|u| *u = Input::new(u.y, u.x, 0.0));
                    w.pose.iter_mut().for_each(|p| p.z = -p.z);
                    w.imu_yaw_rate.iter_mut().for_each(|r| *r = -*r);
                }
                w
            })
            .collect();
        data
    }

    #[test]
    fn localization_turning_against_the_encoders_is_fatal_and_one_command_a_warning() {
        // Each window turns the way its encoders do: nothing found.
        assert_eq!(check(&spins(1.0), None), vec![]);
        // Mirrored (or the encoders swapped): every turn the other way.
        let mirrored = check(&spins(-1.0), None);
        let f = mirrored
            .iter()
            .find(|f| f.check == Check::Direction)
            .unwrap();
        assert_eq!(f.severity, Severity::Fatal);
        assert!(f.message.contains("12 of 12 windows"), "{}", f.message);
        // One window in three the other way (a spin-out, a glitch): the same way mostly.
        let mut some = spins(1.0);
        for w in some.windows.iter_mut().step_by(3) {
            w.pose.iter_mut().for_each(|p| p.z = -p.z);
        }
        assert!(!check(&some, None)
            .iter()
            .any(|f| f.check == Check::Direction));
        // Localization turning three times what the encoders imply: no vehicle does (a
        // baseline three times too wide).
        let wide = check(&spins(3.0), None);
        let f = wide
            .iter()
            .find(|f| f.check == Check::EncoderUnits && f.message.contains("baseline too wide"))
            .unwrap();
        assert_eq!(f.severity, Severity::Warning);
        assert!(
            f.message.contains("turns 3x what the encoders imply"),
            "{}",
            f.message
        );
        // Over five times (a yaw in degrees turns 57 times): no geometry explains it, fatal.
        let degrees = check(&spins(57.3), None);
        let f = degrees
            .iter()
            .find(|f| f.check == Check::EncoderUnits && f.message.contains("a yaw in degrees?"))
            .unwrap();
        assert_eq!(f.severity, Severity::Fatal, "{}", f.message);
        // The same spin commanded in every window: the data shows nothing else.
        let mut one = spins(1.0);
        let first = one.windows[0].clone();
        for w in one.windows.iter_mut() {
            w.command = first.command.clone();
            w.measured = first.measured.clone();
            w.pose = first.pose.clone();
        }
        let f = check(&one, None)
            .into_iter()
            .find(|f| f.check == Check::CommandsConstant)
            .unwrap();
        assert_eq!(f.severity, Severity::Warning);
        assert!(f.message.contains("(-2, 2)"), "{}", f.message);
    }

    #[test]
    fn a_fast_spin_through_pi_is_motion() {
        // 4 rad/s for 2 s: the localized yaw wraps twice.
        assert_eq!(check(&spin(4.0, 1.0), None), vec![]);
        let still = check(&spin(4.0, 0.02), None);
        let stand = still.iter().find(|f| f.check == Check::NotMoving).unwrap();
        assert_eq!(stand.severity, Severity::Fatal);
        // The localization's yaw rate follows the spin across the wraps.
        let data = spin(4.0, 1.0);
        let w = &data.windows[0];
        let r = yaw_rate_from_localization(w, None, data.robot.vehicle.as_ref(), 0.05);
        // (Within the encoders' 2% where a sample reads them.)
        assert!(r.iter().all(|v| (v - 4.0).abs() < 0.081), "{r:?}");
    }

    #[test]
    fn a_yaw_in_degrees_is_noticed() {
        // Five windows spinning at 1 rad/s (195 yaw changes), in radians and in degrees.
        let spins = |scale: f64| {
            let mut data = spin(1.0, 1.0);
            let w = data.windows[0].clone();
            data.windows = (0..5)
                .map(|i| {
                    let mut v = w.clone();
                    v.index = i;
                    for q in &mut v.pose {
                        q.z *= scale;
                    }
                    v
                })
                .collect();
            check(&data, None)
        };
        let says = |f: &[Finding]| f.iter().any(|f| f.message.contains("yaw in degrees"));
        assert!(!says(&spins(1.0)), "{:?}", spins(1.0));
        let degrees = spins(180.0 / std::f64::consts::PI);
        assert!(says(&degrees), "{degrees:?}");
    }

    #[test]
    fn a_run_where_nothing_is_driven_is_useless() {
        // 0.01 rad/s of spin for 2 s: 0.02 rad, a tenth of what any check looks at, and
        // localization did not turn.
        let findings = check(&spin(0.005, 0.0), None);
        assert_eq!(findings.len(), 1, "{findings:?}");
        assert_eq!(
            (findings[0].check, findings[0].severity),
            (Check::NotMoving, Severity::Fatal)
        );
        assert!(findings[0].message.contains("nothing was driven"));
        // The same spin seen by localization: a slow robot, which moved as asked (a
        // warning: the other checks cannot judge it).
        let slow = check(&spin(0.005, 1.0), None);
        assert_eq!(
            slow.iter()
                .map(|f| (f.check, f.severity))
                .collect::<Vec<_>>(),
            [(Check::NotMoving, Severity::Warning)],
            "{slow:?}"
        );
        assert!(slow[0].message.contains("a slow robot?"), "{slow:?}");
        // Commands of 1e-300 (a limit in another unit): the same, with no infinite gain.
        let tiny = check(&spin(1e-300, 1.0), None);
        assert!(tiny.iter().all(|f| !f.message.contains("inf")), "{tiny:?}");
        assert!(tiny
            .iter()
            .any(|f| f.message.contains("nothing was driven")));
    }

    #[test]
    fn the_yaw_rate_from_localization_reads_no_later_sample() {
        let data = spin(4.0, 1.0);
        let (before, w) = (&data.windows[0], &data.windows[0]);
        let vehicle = data.robot.vehicle.as_ref();
        let r = yaw_rate_from_localization(w, Some(before), vehicle, 0.05);
        for k in 0..w.len() {
            // Every sample after k made up: the rates up to k stay.
            let mut altered = w.clone();
            for (j, q) in altered.pose.iter_mut().enumerate().skip(k + 1) {
                q.z = (j as f64 * 1.7).sin() * 3.0;
            }
            for m in altered.measured.iter_mut().skip(k + 1) {
                *m = Input::new(9.0, -9.0, 0.0);
            }
            let a = yaw_rate_from_localization(&altered, Some(before), vehicle, 0.05);
            assert_eq!(&a[..=k], &r[..=k], "k = {k}");
        }
        // The window before gives the start; without it, the encoders do (here they say
        // 1 rad/s while the localization turns at 4).
        let mut slipping = w.clone();
        slipping.measured = vec![Input::new(-1.0, 1.0, 0.0); 40];
        let r = yaw_rate_from_localization(&slipping, Some(before), vehicle, 0.05);
        assert!(
            (r[0] - 4.0).abs() < 1e-9 && (r[1] - 4.0).abs() < 1e-9,
            "{r:?}"
        );
        let alone = yaw_rate_from_localization(&slipping, None, vehicle, 0.05);
        assert_eq!(&alone[..2], &[1.0, 1.0]);
    }
}
