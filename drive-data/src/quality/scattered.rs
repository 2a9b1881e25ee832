//! The consistency checks interval by interval: a corruption scattered over the run (a
//! random fifth of its intervals, its first and last eighths, a stretch no half or third
//! holds) is diluted in every part's statistics as in the whole run's, and passes
//! [`super::parts`]. Each DRIVE interval's steady windows are one point: the commanded and
//! measured inputs, the forward speed and yaw rate the commands and the encoders imply
//! (eq. 4), the ones localization saw, and the IMU's yaw rate. On 22 real and simulated runs
//! of three robots and four grounds, wherever two of these clearly move (a fifth of what the
//! column does in the run's busiest intervals), they move the same way in every interval but
//! a handful (at most 4% of them); a column of the other sign in a tenth of the intervals
//! (and three or more) is that column flipped there. Likewise, a measured input whose share
//! of its command is over 2.2 times its median share on both body axes in a tenth of the
//! intervals is in another unit there.

use super::{Check, Finding, Severity, Short, Windows};
use drive_traits::{Phase, MAX_INPUTS};

/// The share of a column's busiest intervals' magnitude (its 90th percentile over the
/// intervals) from which an interval's value is judged by its sign.
const CLEAR: f64 = 0.2;
/// The share of an input axis's busiest intervals' magnitude (commanded and measured) from
/// which its interval is judged by the signs of its command and measurement: larger than
/// [`CLEAR`], for a powertrain that limits the body's velocity turns a slow wheel slowly
/// backwards under a fast spin (the Husky's firmware, and its twin: in 3-4% of the real
/// run's intervals at a fifth, up to 5 of 37 in a stretch of a quarter of it, 4 of 10 in a
/// minute of its twin under the angular sampler); a sign flipped keeps the magnitude.
const CLEAR_INPUT: f64 = 0.4;
/// The share of the judged intervals from which columns of other signs are a finding (the
/// real and simulated runs: at most 0.04).
const SHARE: f64 = 0.1;
/// The fewest such intervals for a finding.
const MIN_INTERVALS: usize = 3;
/// The factor of a measured input's share of its command over its median share beyond which
/// an interval's encoders read in another unit (as [`super::parts`]' gains).
const FACTOR: f64 = 2.2;

/// The columns compared on a body axis.
const SOURCES: [&str; 4] = ["commands", "encoders", "localization", "IMU"];

/// One interval's steady windows, averaged.
struct Interval {
    /// The DRIVE interval's number.
    number: usize,
    command: [f64; MAX_INPUTS],
    measured: [f64; MAX_INPUTS],
    /// Forward speed (m/s) by commands, encoders, localization.
    forward: [f64; 3],
    /// Yaw rate (rad/s) by commands, encoders, localization, IMU (NaN where not recorded).
    turn: [f64; 4],
}

/// Each interval with steady windows, in order.
fn intervals(w: &Windows<'_>) -> Vec<Interval> {
    let data = w.data;
    let dt = data.robot.dt();
    let mut out: Vec<(Interval, usize)> = Vec::new();
    for (i, win) in w.windows.iter().enumerate() {
        if win.phase != Phase::Steady || win.len() < 2 {
            continue;
        }
        let n = win.len() - 1;
        let span = n as f64 * dt;
        let (mut c, mut m) = ([0.0; MAX_INPUTS], [0.0; MAX_INPUTS]);
        let (mut cv, mut mv, mut imu) = ([0.0; 2], [0.0; 2], 0.0);
        for k in 0..n {
            for a in 0..MAX_INPUTS {
                c[a] += win.command[k][a] / n as f64;
                m[a] += win.measured[k][a] / n as f64;
            }
            let (bc, bm) = (
                data.robot.vehicle.body_velocity(&win.command[k]),
                data.robot.vehicle.body_velocity(&win.measured[k]),
            );
            cv[0] += bc.x / n as f64;
            cv[1] += bc.z / n as f64;
            mv[0] += bm.x / n as f64;
            mv[1] += bm.z / n as f64;
            imu += win.imu_yaw_rate[k] / n as f64;
        }
        let seen_forward = w.travels[i].0[0] / span;
        let seen_turn = w.motions[i].3 / span;
        let point = Interval {
            number: win.interval,
            command: c,
            measured: m,
            forward: [cv[0], mv[0], seen_forward],
            turn: [cv[1], mv[1], seen_turn, imu],
        };
        match out.last_mut() {
            Some((last, count)) if last.number == win.interval => {
                let k = *count as f64;
                let mean = |a: f64, b: f64| (a * k + b) / (k + 1.0);
                for a in 0..MAX_INPUTS {
                    last.command[a] = mean(last.command[a], point.command[a]);
                    last.measured[a] = mean(last.measured[a], point.measured[a]);
                }
                for a in 0..3 {
                    last.forward[a] = mean(last.forward[a], point.forward[a]);
                }
                for a in 0..4 {
                    last.turn[a] = mean(last.turn[a], point.turn[a]);
                }
                *count += 1;
            }
            _ => out.push((point, 1)),
        }
    }
    out.into_iter().map(|(p, _)| p).collect()
}

/// The magnitude from which a column's interval values are judged: [`CLEAR`] of the 90th
/// percentile of their magnitudes; `None` when the column never moves or is not recorded.
fn clear_from(values: impl Iterator<Item = f64>) -> Option<f64> {
    let mut v: Vec<f64> = values.map(f64::abs).collect();
    if v.iter().any(|x| !x.is_finite()) {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = drive_traits::quantile(&v, 0.9)?;
    (q > 0.0).then_some(CLEAR * q)
}

/// Whether `odd` intervals of `of` judged are a finding.
fn enough(odd: usize, of: usize) -> bool {
    odd >= MIN_INTERVALS && odd as f64 >= SHARE * of as f64
}

/// The intervals named in a message: the first six, and how many more.
fn named(numbers: &[usize]) -> String {
    let shown: Vec<String> = numbers.iter().take(6).map(|n| n.to_string()).collect();
    let more = numbers.len().saturating_sub(6);
    if more > 0 {
        format!("{}, and {more} more", shown.join(", "))
    } else {
        shown.join(", ")
    }
}

/// On one body axis (values per source, `None` where a source is not judged), the source of
/// the other sign from all the others, when two or more others are judged and agree.
fn odd_one(values: &[Option<f64>]) -> Option<usize> {
    let judged: Vec<(usize, f64)> = values
        .iter()
        .enumerate()
        .filter_map(|(s, v)| v.map(|v| (s, v.signum())))
        .collect();
    if judged.len() < 3 {
        return None;
    }
    judged.iter().find_map(|&(s, sign)| {
        let others: Vec<f64> = judged
            .iter()
            .filter(|&&(o, _)| o != s)
            .map(|&(_, g)| g)
            .collect();
        (others.iter().all(|&g| g == -sign)).then_some(s)
    })
}

/// The checks whose fatal findings a column corrupted in scattered intervals causes
/// elsewhere: the IMU against a localization turned backwards there, localization drifting
/// or at an angle from encoders negated there, nothing moving under scaled encoders.
const CONSEQUENCES: [Check; 4] = [
    Check::ImuYawRate,
    Check::LocalizationSync,
    Check::LocalizationFrame,
    Check::NotMoving,
];

/// Adds to `found` (what the other checks found) the findings of the interval-by-interval
/// comparison (see the module's doc): all of them where none of theirs is fatal; where
/// theirs are fatal only of [`CONSEQUENCES`], the fatal ones, said first as the cause (and
/// what the IMU findings said dropped where localization is the odd column); nothing where
/// another check is fatal (its cause named already).
pub(super) fn add_scattered(w: &Windows<'_>, found: &mut Vec<Finding>) {
    let fatal = |f: &Finding| f.severity == Severity::Fatal;
    if found
        .iter()
        .any(|f| fatal(f) && !CONSEQUENCES.contains(&f.check))
    {
        return;
    }
    let mut new = scattered(w, found);
    if !found.iter().any(fatal) {
        found.append(&mut new);
        return;
    }
    new.retain(fatal);
    if new.is_empty() {
        return;
    }
    if new
        .iter()
        .any(|f| f.message.starts_with("the localization") || f.message.starts_with("localization"))
    {
        found.retain(|f| f.check != Check::ImuYawRate);
    }
    found.splice(0..0, new);
}

/// On one body axis (`pick`: 0 the yaw rate, 1 the forward speed), each source's odd
/// intervals ([`odd_one`]) and how many intervals it was judged in beside two others.
fn votes(points: &[Interval], pick: usize) -> (Vec<Vec<usize>>, Vec<usize>) {
    let sources = if pick == 0 { 4 } else { 3 };
    let value = |p: &Interval, s: usize| if pick == 0 { p.turn[s] } else { p.forward[s] };
    let clear: Vec<Option<f64>> = (0..sources)
        .map(|s| clear_from(points.iter().map(|p| value(p, s))))
        .collect();
    let (mut odd, mut judged) = (vec![Vec::new(); sources], vec![0usize; sources]);
    for p in points {
        let values: Vec<Option<f64>> = (0..sources)
            .map(|s| clear[s].and_then(|c| (value(p, s).abs() >= c).then(|| value(p, s))))
            .collect();
        if values.iter().flatten().count() < 3 {
            continue;
        }
        for (s, v) in values.iter().enumerate() {
            judged[s] += usize::from(v.is_some());
        }
        if let Some(s) = odd_one(&values) {
            odd[s].push(p.number);
        }
    }
    (odd, judged)
}

/// The interval-by-interval comparison's findings (see the module's doc); `found` is what the
/// other checks found.
fn scattered(w: &Windows<'_>, found: &[Finding]) -> Vec<Finding> {
    let mut points = intervals(w);
    let mut out = Vec::new();
    let axes = w.data.robot.vehicle.axes();
    // An IMU read backwards through the run (a warning of its own, `imu-yaw-rate`) is odd in
    // most intervals: it votes the right way turned back.
    let (odd, judged) = votes(&points, 0);
    if odd[3].len() * 2 > judged[3] {
        points.iter_mut().for_each(|p| p.turn[3] = -p.turn[3]);
    }
    for pick in [0usize, 1] {
        let (odd, judged) = votes(&points, pick);
        for s in 0..odd.len() {
            if !enough(odd[s].len(), judged[s]) {
                continue;
            }
            let plural = s < 2;
            let moves = match (pick, plural) {
                (0, true) => "turn",
                (0, false) => "turns",
                (_, true) => "drive",
                (_, false) => "drives",
            };
            // Localization driving against the commands and the wheels is a car sliding
            // on ice after a reversal too (simulated: 7 of 250 runs): a warning.
            let (check, severity, cause) = match (s, pick) {
                (0, 0) => (
                    Check::Direction,
                    Severity::Fatal,
                    "the command columns swapped, or one sign-flipped, there?",
                ),
                (0, _) => (
                    Check::Direction,
                    Severity::Fatal,
                    "the commands sign-flipped there?",
                ),
                (1, 0) => (
                    Check::Direction,
                    Severity::Fatal,
                    "the encoder columns swapped, or one sign-flipped, there?",
                ),
                (1, _) => (
                    Check::Direction,
                    Severity::Fatal,
                    "the encoders sign-flipped there?",
                ),
                (2, 0) => (
                    Check::Direction,
                    Severity::Fatal,
                    "the localization mirrored (y and yaw negated) there?",
                ),
                (2, _) => (
                    Check::Direction,
                    Severity::Warning,
                    "the robot still sliding the other way (on ice, after a reversal), or the localization's heading turned half a turn there?",
                ),
                _ => (
                    Check::ImuYawRate,
                    Severity::Warning,
                    "the IMU read backwards there?",
                ),
            };
            if check == Check::ImuYawRate && found.iter().any(|f| f.check == check) {
                continue;
            }
            out.push(Finding {
                check,
                severity,
                message: format!(
                    "the {} {moves} the other way from the other columns in {} of the {} intervals where {} and two or more others {} clearly, scattered over the run ({} {}): {cause}",
                    SOURCES[s],
                    odd[s].len(),
                    judged[s],
                    if plural { "they" } else { "it" },
                    if pick == 0 { "turn" } else { "drive" },
                    if odd[s].len() == 1 { "interval" } else { "intervals" },
                    named(&odd[s])
                ),
            });
        }
    }
    if out.iter().any(|f| f.severity == Severity::Fatal) {
        return out;
    }
    // Each input axis: a measured input of the other sign from its command.
    for (a, axis) in axes.iter().enumerate().take(MAX_INPUTS) {
        let (cc, cm) = (
            clear_from(points.iter().map(|p| p.command[a])),
            clear_from(points.iter().map(|p| p.measured[a])),
        );
        let (Some(cc), Some(cm)) = (cc, cm) else {
            continue;
        };
        let (cc, cm) = (cc * CLEAR_INPUT / CLEAR, cm * CLEAR_INPUT / CLEAR);
        let both: Vec<&Interval> = points
            .iter()
            .filter(|p| p.command[a].abs() >= cc && p.measured[a].abs() >= cm)
            .collect();
        let against: Vec<usize> = both
            .iter()
            .filter(|p| p.command[a] * p.measured[a] < 0.0)
            .map(|p| p.number)
            .collect();
        if !enough(against.len(), both.len()) {
            continue;
        }
        out.push(Finding {
            check: Check::EncoderCommand,
            severity: Severity::Fatal,
            message: format!(
                "'{}' is of the other sign from its command '{}' in {} of the {} intervals where both clearly move, scattered over the run (intervals {}): one of the two sign-flipped there?",
                axis.measured_column,
                axis.command_column,
                against.len(),
                both.len(),
                named(&against)
            ),
        });
    }
    if out.iter().any(|f| f.severity == Severity::Fatal) {
        return out;
    }
    out.extend(scales(
        &points,
        found.iter().any(|f| f.check == Check::ImuYawRate),
    ));
    out
}

/// The encoders' share of the commands' forward speed and yaw rate, interval by interval:
/// over [`FACTOR`] times its median on both body axes in a tenth of the intervals where both
/// are commanded clearly is another unit there (fatal); under 1 / [`FACTOR`] on both, stalled
/// wheels or another unit (a warning: a robot held back by an obstacle does it too).
/// Localization's share of the encoders' forward speed over 1.5 and over [`FACTOR`] times
/// its median in a tenth of the intervals: no robot travels faster than its wheels (fatal;
/// on the real and simulated runs it is at most 1.22, and 1.45 times its median).
fn scales(points: &[Interval], imu_said: bool) -> Vec<Finding> {
    // Each judged interval's (number, share): the encoders' forward speed and yaw rate of
    // the commands', localization's forward speed of the encoders'.
    let share = |num: fn(&Interval) -> f64, den: fn(&Interval) -> f64| -> Vec<(usize, f64)> {
        let Some(clear) = clear_from(points.iter().map(den)) else {
            return Vec::new();
        };
        points
            .iter()
            .filter(|p| den(p).abs() >= clear && num(p) * den(p) > 0.0)
            .map(|p| (p.number, num(p) / den(p)))
            .collect()
    };
    let shares = [
        share(|p| p.forward[1], |p| p.forward[0]),
        share(|p| p.turn[1], |p| p.turn[0]),
        share(|p| p.forward[2], |p| p.forward[1]),
        share(|p| p.turn[3], |p| p.turn[2]),
        share(|p| p.turn[3], |p| p.turn[1]),
        share(|p| p.turn[2], |p| p.turn[1]),
    ];
    // [over, under] FACTOR times the median, per share.
    let mut beyond: [[Vec<usize>; 6]; 2] = Default::default();
    for (k, s) in shares.iter().enumerate() {
        let mut v: Vec<f64> = s.iter().map(|x| x.1).collect();
        let median = drive_traits::median(&mut v);
        // NaN (no shares) or zero: nothing to compare with.
        if median.is_nan() || median <= 0.0 {
            continue;
        }
        for &(n, x) in s {
            if x > median * FACTOR && (k != 2 || x > 1.5) {
                beyond[0][k].push(n);
            } else if x < median / FACTOR {
                beyond[1][k].push(n);
            }
        }
    }
    let found = |dir: usize, k: usize| enough(beyond[dir][k].len(), shares[k].len());
    let listed = |lists: &[Vec<usize>]| {
        let mut numbers: Vec<usize> = lists.concat();
        numbers.sort_unstable();
        numbers.dedup();
        named(&numbers)
    };
    let mut out = imu_scales(&found, &listed, &shares, &beyond);
    if imu_said {
        out.retain(|f| f.severity == Severity::Fatal || f.check != Check::ImuYawRate);
    }
    let encoders_under = found(1, 0) && found(1, 1);
    for (dir, severity, cause) in [
        (
            0usize,
            Severity::Fatal,
            "the encoders in another unit there?",
        ),
        (
            1,
            Severity::fatal_if(found(0, 2)),
            "wheels stalled, or the encoders in another unit there?",
        ),
    ] {
        if !(found(dir, 0) && found(dir, 1)) {
            continue;
        }
        out.push(Finding {
            check: Check::EncoderCommand,
            severity,
            message: format!(
                "the encoders read {} {} times their median share of the commanded forward speed in {} of {} intervals and of the commanded yaw rate in {} of {}, scattered over the run (intervals {}): {cause}",
                if dir == 0 { "over" } else { "under 1 /" },
                Short(FACTOR),
                beyond[dir][0].len(),
                shares[0].len(),
                beyond[dir][1].len(),
                shares[1].len(),
                listed(&beyond[dir][..2])
            ),
        });
    }
    if found(0, 2) && !encoders_under && !found(1, 0) {
        out.push(Finding {
            check: Check::EncoderUnits,
            severity: Severity::Fatal,
            message: format!(
                "localization saw over 1.5 and over {} times its median share of the forward speed the encoders imply in {} of {} intervals, scattered over the run (intervals {}): localization scaled there (no robot travels faster than its wheels)?",
                Short(FACTOR),
                beyond[0][2].len(),
                shares[2].len(),
                listed(&beyond[0][2..])
            ),
        });
    }
    out
}

/// The IMU's share of localization's yaw rate off its median (by [`FACTOR`], either way) in
/// a tenth of the intervals where localization turns clearly: on 136 real and simulated
/// runs it is within that in every interval but one. The encoders' turn tells the odd one:
/// the IMU's share of it off its median there too is the IMU scaled (fatal, as over a
/// whole run); localization's share of it off, localization's yaw scaled (fatal); neither
/// (a skid-steer's encoders turn as their slip makes them), one of the two (a warning).
fn imu_scales(
    found: &impl Fn(usize, usize) -> bool,
    listed: &impl Fn(&[Vec<usize>]) -> String,
    shares: &[Vec<(usize, f64)>; 6],
    beyond: &[[Vec<usize>; 6]; 2],
) -> Vec<Finding> {
    let mut out = Vec::new();
    for (dir, off) in beyond.iter().enumerate() {
        if !found(dir, 3) {
            continue;
        }
        let (check, severity, cause) = if found(dir, 4) {
            (
                Check::ImuYawRate,
                Severity::Fatal,
                "the IMU scaled there (its share of the encoders' turn is off too)?",
            )
        } else if found(dir ^ 1, 5) {
            (
                Check::EncoderUnits,
                Severity::Fatal,
                "localization's yaw scaled there (its share of the encoders' turn is off too)?",
            )
        } else {
            (
                Check::ImuYawRate,
                Severity::Warning,
                "the IMU or localization's yaw scaled there?",
            )
        };
        out.push(Finding {
            check,
            severity,
            message: format!(
                "the IMU's yaw rate reads {} {} times its median share of localization's turn in {} of {} intervals, scattered over the run (intervals {}): {cause}",
                if dir == 0 { "over" } else { "under 1 /" },
                Short(FACTOR),
                off[3].len(),
                shares[3].len(),
                listed(&off[3..4])
            ),
        });
    }
    out
}
