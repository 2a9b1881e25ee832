//! Localization's motion sample by sample against the encoders' (`localization-sync`):
//! localization written from the encoders themselves, a jump at one sample of every window,
//! noise far beyond the motion, and a drift where the encoders drive none; an IMU written
//! from the encoders (`imu-yaw-rate`); and encoders with an offset (`encoder-units`). The
//! window-level checks (travel and turn per window against one another) do not see these:
//! a window's net motion can follow the encoders' while every sample, or every window's
//! start, is off.

use super::{three_digits, Check, Finding, Severity, Windows};
use drive_traits::limits::Short;

/// Fewest windows (of the common length) these checks judge on.
const MIN_WINDOWS: usize = 10;
/// Fewest moving steps the copies' rule judges on.
const MIN_STEPS: usize = 200;
/// The samples the copies' rule reads at most: every n-th of a longer run (a copy is one
/// at every sample, so a regular subsample tells it as well as the whole run).
const COPY_SAMPLES: usize = 4000;

/// The stride that reads at most [`COPY_SAMPLES`] of `windows`' samples.
fn stride(windows: &[&drive_traits::Window]) -> usize {
    let samples: usize = windows.iter().map(|w| w.len()).sum();
    samples.div_ceil(COPY_SAMPLES).max(1)
}

/// A copy of the encoders: the share of moving steps whose ratio to the encoders' is the
/// median ratio to within [`COPY_TOLERANCE`], at or beyond which a signal is computed from
/// the encoders (real localization holds between its updates and has noise: none of the
/// bundled, norlab or simulated runs comes near).
const COPY_SHARE: f64 = 0.9;
/// See [`COPY_SHARE`]: relative.
const COPY_TOLERANCE: f64 = 1e-3;

/// A jump at one sample of every window: the mean excess of localization's step at that
/// sample over the encoders' (localization's holds between its updates spread out), against
/// the mean step, from which a warning and fatal. The bundled and norlab runs give 0.1-1.4
/// (their window's first step the largest), simulated runs up to 1.2; a 1 m jump at one
/// sample of every window 4.7-23 (a car at 5 m/s the least), 0.3 m 0.9-11.5.
const JUMP_WARNING: f64 = 3.0;
/// See [`JUMP_WARNING`].
const JUMP_FATAL: f64 = 5.0;
/// See [`JUMP_WARNING`]: the excess (m) under which no jump is named (a robot at rest).
const JUMP_FLOOR: f64 = 0.02;

/// Noise: localization's mean step against the encoders' (holds spread out), from which a
/// warning and fatal, where the excess is also [`NOISE_SPEED_WARNING`] (m/s) or more. The
/// bundled, norlab and simulated runs give 0.2-1.12 (slip: a robot moves less than its
/// wheels); positions with noise of 0.05 m added 0.6-6, 0.3 m 3.4-34.
const NOISE_RATIO_WARNING: f64 = 2.0;
/// See [`NOISE_RATIO_WARNING`].
const NOISE_RATIO_FATAL: f64 = 4.0;
/// See [`NOISE_RATIO_WARNING`]: the mean excess speed (m/s) from which noise is named (the
/// real runs: 0.08 at most), and from which fatal.
const NOISE_SPEED_WARNING: f64 = 0.5;
/// See [`NOISE_SPEED_WARNING`].
const NOISE_SPEED_FATAL: f64 = 2.0;

/// Each window's positions with localization's holds spread out: where a position repeats
/// the one before (localization slower than the log's rate), the positions between two
/// updates are interpolated, so that each step carries its share of the motion.
fn spread_holds(x: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = x.len();
    let mut updates: Vec<usize> = vec![0];
    updates.extend((1..n).filter(|&k| x[k] != x[k - 1] || y[k] != y[k - 1]));
    if *updates.last().unwrap_or(&0) != n - 1 {
        updates.push(n - 1);
    }
    let (mut xs, mut ys) = (x.to_vec(), y.to_vec());
    for pair in updates.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        for k in a + 1..b {
            let s = (k - a) as f64 / (b - a) as f64;
            xs[k] = x[a] + s * (x[b] - x[a]);
            ys[k] = y[a] + s * (y[b] - y[a]);
        }
    }
    (xs, ys)
}

/// The jump and noise rules: per sample of the windows' common length, the mean step
/// localization saw (holds spread out) and the mean step the encoders imply.
pub(super) fn jumps_and_noise(w: &Windows<'_>) -> Option<Finding> {
    let data = w.data;
    let dt = data.robot.dt();
    // The windows' most common length, and the windows at least that long.
    let mut lengths: Vec<usize> = w.windows.iter().map(|win| win.len()).collect();
    lengths.sort_unstable();
    let len = lengths[lengths.len() / 2];
    let windows: Vec<_> = w.windows.iter().filter(|win| win.len() >= len).collect();
    if windows.len() < MIN_WINDOWS || len < 3 {
        return None;
    }
    let (mut seen, mut implied) = (vec![0.0; len - 1], vec![0.0; len - 1]);
    for win in &windows {
        let x: Vec<f64> = win.pose[..len].iter().map(|p| p.x).collect();
        let y: Vec<f64> = win.pose[..len].iter().map(|p| p.y).collect();
        if x.iter().chain(&y).any(|v| !v.is_finite()) {
            continue;
        }
        let (x, y) = spread_holds(&x, &y);
        for k in 0..len - 1 {
            seen[k] += (x[k + 1] - x[k]).hypot(y[k + 1] - y[k]);
            let v = data.robot.vehicle.body_velocity(&win.measured[k]);
            implied[k] += v.x.hypot(v.y) * dt;
        }
    }
    let n = windows.len() as f64;
    seen.iter_mut().for_each(|s| *s /= n);
    implied.iter_mut().for_each(|s| *s /= n);
    let steps = (len - 1) as f64;
    let (seen_mean, implied_mean) = (seen.iter().sum::<f64>() / steps, {
        implied.iter().sum::<f64>() / steps
    });
    if !(seen_mean.is_finite() && implied_mean.is_finite()) || seen_mean <= 0.0 {
        return None;
    }
    let scale = seen_mean.max(implied_mean);
    let (at, excess) = seen
        .iter()
        .zip(&implied)
        .map(|(s, i)| s - i)
        .enumerate()
        .fold(
            (0, f64::NEG_INFINITY),
            |b, (k, e)| if e > b.1 { (k, e) } else { b },
        );
    let ratio = excess / scale;
    if excess >= JUMP_FLOOR && ratio >= JUMP_WARNING {
        return Some(Finding {
            check: Check::LocalizationSync,
            severity: Severity::fatal_if(ratio >= JUMP_FATAL),
            message: format!(
                "localization jumps between samples {at} and {} of its windows: {} m further on average over {} windows than the encoders imply, {} times the mean step of {} m: a pose at that sample from another source or time (the windows' start written from elsewhere)?",
                at + 1,
                Short(three_digits(excess)),
                windows.len(),
                Short(three_digits(ratio)),
                Short(three_digits(scale)),
            ),
        });
    }
    let speed = (seen_mean - implied_mean) / dt;
    let ratio = seen_mean / implied_mean.max(f64::MIN_POSITIVE);
    if ratio >= NOISE_RATIO_WARNING && speed >= NOISE_SPEED_WARNING {
        return Some(Finding {
            check: Check::LocalizationSync,
            severity: Severity::fatal_if(ratio >= NOISE_RATIO_FATAL && speed >= NOISE_SPEED_FATAL),
            message: format!(
                "localization's positions move {} m/s from sample to sample on average where the encoders imply {} m/s ({} times, over {} windows): noise of several centimetres or more on every position, which every error measured on it includes?",
                Short(three_digits(seen_mean / dt)),
                Short(three_digits(implied_mean / dt)),
                Short(three_digits(ratio)),
                windows.len(),
            ),
        });
    }
    None
}

/// The share of `pairs` (signal, encoders' value) whose ratio is the median ratio to within
/// [`COPY_TOLERANCE`], and that median; `None` under [`MIN_STEPS`] pairs.
fn copied_share(pairs: &[(f64, f64)]) -> Option<(f64, f64)> {
    if pairs.len() < MIN_STEPS {
        return None;
    }
    let mut ratios: Vec<f64> = pairs.iter().map(|(s, e)| s / e).collect();
    let half = ratios.len() / 2;
    let median = *ratios.select_nth_unstable_by(half, f64::total_cmp).1;
    if !median.is_finite() || median <= 0.0 {
        return None;
    }
    let close = ratios
        .iter()
        .filter(|r| (*r / median - 1.0).abs() <= COPY_TOLERANCE)
        .count();
    Some((close as f64 / ratios.len() as f64, median))
}

/// Localization's positions (or its heading) the encoders' dead reckoning, to within a
/// factor: no slip is left to learn, and every slip model learns none. Fatal.
pub(super) fn written_from_encoders(w: &Windows<'_>) -> Option<Finding> {
    let data = w.data;
    let dt = data.robot.dt();
    let (mut forward, mut turn) = (Vec::new(), Vec::new());
    let stride = stride(&w.windows);
    for win in &w.windows {
        for k in (0..win.len() - 1).step_by(stride) {
            let (p, q) = (win.pose[k], win.pose[k + 1]);
            let v = data.robot.vehicle.body_velocity(&win.measured[k]);
            let (sin, cos) = p.z.sin_cos();
            let ahead = cos * (q.x - p.x) + sin * (q.y - p.y);
            // Moving steps only: a thousandth of a metre or of a radian.
            if (v.x * dt).abs() >= 1e-3 && ahead.is_finite() {
                forward.push((ahead, v.x * dt));
            }
            let turned = q.z - p.z;
            if (v.z * dt).abs() >= 1e-3 && turned.abs() < 1.0 {
                turn.push((turned, v.z * dt));
            }
        }
    }
    let (share, factor) = copied_share(&forward)?;
    if share < COPY_SHARE {
        return None;
    }
    let heading = copied_share(&turn)
        .filter(|(s, _)| *s >= COPY_SHARE)
        .map(|(_, f)| {
            format!(
                ", and its heading's steps equal their turn times {}",
                Short(three_digits(f))
            )
        })
        .unwrap_or_default();
    Some(Finding {
        check: Check::LocalizationSync,
        severity: Severity::Fatal,
        message: format!(
            "localization's steps forward equal the encoders' dead reckoning times {} on {} of {} moving steps (to within {}%){heading}: localization computed from the encoders (wheel odometry), which holds no slip to learn?",
            Short(three_digits(factor)),
            (share * forward.len() as f64).round(),
            forward.len(),
            Short(COPY_TOLERANCE * 100.0),
        ),
    })
}

/// The IMU's yaw rate the encoders' implied one, to within a factor, on nearly every turning
/// sample: the models that start from the IMU then take the wheels' turn for the body's. A
/// warning.
pub(super) fn imu_from_encoders(w: &Windows<'_>) -> Option<Finding> {
    let data = w.data;
    let pairs: Vec<(f64, f64)> = w
        .windows
        .iter()
        .flat_map(|win| win.measured.iter().zip(&win.imu_yaw_rate))
        .step_by(stride(&w.windows))
        .map(|(m, r)| (*r, data.robot.vehicle.body_velocity(m).z))
        .filter(|(r, z)| z.abs() >= 1e-2 && r.is_finite())
        .collect();
    let (share, factor) = copied_share(&pairs)?;
    (share >= COPY_SHARE).then(|| Finding {
        check: Check::ImuYawRate,
        severity: Severity::Warning,
        message: format!(
            "the IMU's yaw rate equals the one the encoders imply times {} on {} of {} turning samples (to within {}%): computed from the encoders, not measured? The models that start from the IMU then take the wheels' turn for the body's",
            Short(three_digits(factor)),
            (share * pairs.len() as f64).round(),
            pairs.len(),
            Short(COPY_TOLERANCE * 100.0),
        ),
    })
}

/// Localization moving where the encoders say the robot stands or spins in place: the
/// median distance localization saw over the windows whose encoders imply a path under a
/// twentieth of the largest window's (ten at least), against that largest travel, from which a
/// warning and fatal. The bundled and norlab runs give 0.001-0.10 (a Warthog spinning in
/// place slides, a Husky's positions in the paper's frame); localization drifting 0.5 m/s
/// forwards in every window 0.49, 0.8 m/s sideways 0.20.
const DRIFT_WARNING: f64 = 0.18;
/// See [`DRIFT_WARNING`].
const DRIFT_FATAL: f64 = 0.3;

/// Localization drifting: moving in the windows where the encoders imply none
/// ([`DRIFT_WARNING`]).
pub(super) fn drifting(w: &Windows<'_>) -> Option<Finding> {
    // The path each window's encoders imply (its length, not its chord: a robot driving a
    // circle ends near its start).
    let dt = w.data.robot.dt();
    let paths: Vec<f64> = w
        .windows
        .iter()
        .map(|win| {
            win.measured[..win.len() - 1]
                .iter()
                .map(|u| {
                    let v = w.data.robot.vehicle.body_velocity(u);
                    v.x.hypot(v.y) * dt
                })
                .sum()
        })
        .collect();
    let largest = paths
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max);
    if largest <= 0.0 {
        return None;
    }
    let mut seen: Vec<f64> = paths
        .iter()
        .zip(&w.motions)
        .filter(|(p, m)| **p < 0.05 * largest && m.2.is_finite())
        .map(|(_, m)| m.2)
        .collect();
    if seen.len() < MIN_WINDOWS {
        return None;
    }
    let still = seen.len();
    let share = drive_traits::median(&mut seen) / largest;
    if share < DRIFT_WARNING {
        return None;
    }
    // A unit: the positions' where the encoders turn as localization does (their unit and
    // the geometry hold), else the encoders' as likely.
    let cause = match scaled_positions(&paths, w, largest) {
        Some(factor) => format!(
            "{}? The windows that drive see {}x the path the encoders imply, slow and fast alike, as a unit scales them (a drift adds most to the slow)",
            if super::usual_turn(&w.motions).is_some() {
                "localization's positions in another unit (cm, feet)"
            } else {
                "encoders in another unit (or localization's positions)"
            },
            Short((factor * 100.0).round() / 100.0)
        ),
        None => "localization drifting (a velocity added to its positions), or another robot's?".into(),
    };
    Some(Finding {
        check: Check::LocalizationSync,
        severity: Severity::fatal_if(share >= DRIFT_FATAL),
        message: format!(
            "localization moves a median {} m over the {still} windows whose encoders imply a path under a twentieth of the longest window's {} m: {cause}",
            Short(three_digits(share * largest)),
            Short(three_digits(largest)),
        ),
    })
}

/// The factor by which localization's positions are scaled, where the windows whose
/// encoders imply a fifth of the longest window's path or more see (net) a path beyond 2 or
/// under 0.5 times it, the slower half of them at most 1.3 times the faster half's (ten
/// windows in each): a unit scales every window alike (the Husky run's slower half sees
/// 0.73 of the faster half's, turning more, in metres or feet alike), a drift (a velocity
/// added) adds most to the slow ones (0.5 m/s on the Husky: 1.7 times). `None` otherwise.
fn scaled_positions(paths: &[f64], w: &Windows<'_>, largest: f64) -> Option<f64> {
    let mut moving: Vec<(f64, f64)> = paths
        .iter()
        .zip(&w.motions)
        .filter(|(p, m)| **p >= 0.2 * largest && m.2.is_finite())
        .map(|(p, m)| (*p, m.2 / p))
        .collect();
    if moving.len() < 20 {
        return None;
    }
    moving.sort_by(|a, b| a.0.total_cmp(&b.0));
    let half = moving.len() / 2;
    let median_of = |part: &[(f64, f64)]| {
        let mut r: Vec<f64> = part.iter().map(|m| m.1).collect();
        drive_traits::median(&mut r)
    };
    let (slow, fast) = (median_of(&moving[..half]), median_of(&moving[half..]));
    let factor = median_of(&moving);
    let scaled = !(0.5..=2.0).contains(&factor) && slow <= 1.3 * fast;
    scaled.then_some(factor)
}

/// An offset on the encoders: over the windows whose commands drive (almost) no travel
/// (the forward body velocity of their mean command under a twentieth of the largest; ten
/// at least: turns in place among them), the median signed travel the encoders imply there,
/// against the largest they imply, from which a warning and fatal. Where no travel is
/// commanded the wheels drive none, whatever the ground (on ice they spin as commanded); an
/// offset drives them one way. The bundled and norlab runs give 0.04 at most, 200 simulated
/// runs 0.045; 1-2 rad/s added to a real run's encoders 0.07-0.21. (The turn is
/// [`TURN_OFFSET_WARNING`]'s.)
const OFFSET_WARNING: f64 = 0.08;
/// See [`OFFSET_WARNING`].
const OFFSET_FATAL: f64 = 0.15;
/// The same of the turn, on a vehicle whose wheels command its turn (not a car): over the
/// steady windows whose mean command turns under a fifth of the largest (ten at least), the
/// median signed turn the encoders imply less what those commands turn (the intercept of
/// Theil and Sen's line through them) against the largest window's turn, a warning from
/// here and fatal from [`TURN_OFFSET_FATAL`]. The real runs give 0.015 at most, 200
/// simulated runs 0.055 (the linear-focused sampler's); one side's encoder offset by 1 rad/s
/// gives 0.14 on the Husky (2 rad/s: 0.24), a Warthog side by 2 rad/s 0.11-0.13 (by 1 rad/s
/// not seen); before the slow windows alone were read ([`SLOW`]), 0.30 on a simulated HD2
/// and a mecanum base's yaw-rate input by 0.5 rad/s 0.23.
const TURN_OFFSET_WARNING: f64 = 0.09;
/// See [`TURN_OFFSET_WARNING`].
const TURN_OFFSET_FATAL: f64 = 0.2;
/// The windows [`encoder_offset`] reads the turn's offset on command at most this share of
/// the largest commanded forward speed.
const SLOW: f64 = 0.35;

/// Encoders reading an offset ([`OFFSET_WARNING`], [`TURN_OFFSET_WARNING`]).
pub(super) fn encoder_offset(w: &Windows<'_>) -> Vec<Finding> {
    let vehicle = &w.data.robot.vehicle;
    // Per window: the forward body velocity and the yaw rate of its mean command, and the
    // travel and the turn implied.
    let rows: Vec<Idle> = w
        .windows
        .iter()
        .zip(&w.travels)
        .map(|(win, (seen, implied, turn))| {
            let n = win.command.len().max(1) as f64;
            let mean = win.command.iter().sum::<drive_traits::Input>() / n;
            let f = vehicle.body_velocity(&mean);
            Idle {
                commanded: [f.x, f.z],
                implied: [implied[0], *turn],
                steady: win.phase == drive_traits::Phase::Steady,
                seen: seen[0],
            }
        })
        .filter(|r| {
            r.commanded
                .iter()
                .chain(&r.implied)
                .chain([&r.seen])
                .all(|x| x.is_finite())
        })
        .collect();
    // What localization saw of the same windows' travel: where it saw the robot travel as
    // the encoders say (three tenths of it or more, the same way: the Husky on its real
    // ground saw half, where an offset on the encoders leaves localization still), the
    // encoders are right and the commands are offset (the robot drove where they command
    // none).
    let seen: Vec<Idle> = rows
        .iter()
        .map(|r| Idle {
            implied: [r.seen, r.implied[1]],
            ..*r
        })
        .collect();
    let seen_travel = idle_share(&seen, 0, false).map(|(median, _, _)| median);
    let mut out: Vec<Finding> = idle_share(&rows, 0, false)
        .filter(|(_, share, _)| share.abs() >= OFFSET_WARNING)
        .map(|(median, share, count)| {
            let commands = seen_travel.is_some_and(|s| s * median > 0.0 && s.abs() >= 0.3 * median.abs());
            Finding {
                check: Check::EncoderUnits,
                severity: Severity::fatal_if(share.abs() >= OFFSET_FATAL),
                message: if commands {
                    format!(
                        "the encoders imply a median forward travel of {} m over the {count} windows whose commands drive almost none ({} of the largest window's, one way), and localization saw the robot travel so too ({} m): an offset on the commands (a bias added, or a zero not subtracted)?",
                        Short(three_digits(median)),
                        Short(three_digits(share)),
                        Short(three_digits(seen_travel.unwrap_or(0.0))),
                    )
                } else {
                    format!(
                        "the encoders imply a median forward travel of {} m over the {count} windows whose commands drive almost none ({} of the largest window's, one way): an offset on the encoders (a bias added, or a zero not subtracted)?",
                        Short(three_digits(median)),
                        Short(three_digits(share)),
                    )
                },
            }
        })
        .into_iter()
        .collect();
    // The turn, on a vehicle whose turn its wheels command (a car's linear sampler holds
    // its steering while its speed turns it).
    if drive_traits::vehicle_tag(vehicle.as_ref()).as_deref() != Some("ackermann") {
        out.extend(
            idle_share(&rows, 1, true)
                .filter(|(_, share, _)| share.abs() >= TURN_OFFSET_WARNING)
                .map(|(median, share, count)| Finding {
                    check: Check::EncoderUnits,
                    severity: Severity::fatal_if(share.abs() >= TURN_OFFSET_FATAL),
                    message: format!(
                        "the encoders imply a median turn of {} rad over the {count} steady windows whose commands turn little, less what those commands turn ({} of the largest window's, one way): an offset on one side's encoder or on a yaw-rate input (a bias added, or a zero not subtracted)?",
                        Short(three_digits(median)),
                        Short(three_digits(share)),
                    ),
                }),
        );
    }
    out
}

/// A window's mean command and the motion its encoders imply, on the body's forward and
/// yaw axes ([`encoder_offset`]).
#[derive(Clone, Copy)]
struct Idle {
    commanded: [f64; 2],
    implied: [f64; 2],
    steady: bool,
    /// The forward travel localization saw.
    seen: f64,
}

/// Over the windows whose mean command asks for under a twentieth of the largest on body
/// axis `axis` (0 forward, 1 yaw; ten windows at least; with `steady`, the steady ones
/// alone, where the wheels no longer answer the interval before's command, under a tenth
/// of the largest), the median
/// signed motion the encoders imply on it, that median over the largest implied, and the
/// windows' count.
fn idle_share(rows: &[Idle], axis: usize, steady: bool) -> Option<(f64, f64, usize)> {
    // The steady windows' wheels are at their command, and the slope takes out what the
    // commands themselves turn: a wider band, more windows.
    let band = if steady { 0.2 } else { 0.05 };
    let commanded = rows
        .iter()
        .map(|r| r.commanded[axis].abs())
        .fold(0.0, f64::max);
    let largest = rows
        .iter()
        .map(|r| r.implied[axis].abs())
        .fold(0.0, f64::max);
    if largest <= 0.0 || commanded <= 0.0 {
        return None;
    }
    // On the turn, the windows that drive slowly too: the two sides' gains a few percent
    // apart turn a skid-steer in proportion to its speed until its wheels saturate (a
    // Warthog twin's fitted 1.05-1.07 under the linear sampler, which commands no turn,
    // read as an offset of 0.2-0.7 rad), an offset at any speed, standing too.
    let speed = rows
        .iter()
        .map(|r| r.commanded[0].abs())
        .fold(0.0, f64::max);
    let slow = |r: &Idle| axis == 0 || r.commanded[0].abs() <= SLOW * speed;
    let near: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.commanded[axis].abs() < band * commanded && (r.steady || !steady) && slow(r))
        .map(|r| (r.commanded[axis], r.implied[axis]))
        .collect();
    if near.len() < MIN_WINDOWS {
        return None;
    }
    let count = near.len();
    let mut idle: Vec<f64> = if steady {
        // What the windows' own small commands turn taken out: Theil and Sen's slope
        // (the median of the pairs' slopes) through the windows, its intercept the offset.
        let mut slopes: Vec<f64> = Vec::new();
        for (i, a) in near.iter().enumerate() {
            for b in &near[i + 1..] {
                if (b.0 - a.0).abs() > 1e-3 * band * commanded {
                    slopes.push((b.1 - a.1) / (b.0 - a.0));
                }
            }
        }
        let slope = if slopes.is_empty() {
            0.0
        } else {
            drive_traits::median(&mut slopes)
        };
        near.iter().map(|(c, i)| i - slope * c).collect()
    } else {
        near.iter().map(|r| r.1).collect()
    };
    let median = drive_traits::median(&mut idle);
    Some((median, median / largest, count))
}

/// Fewest localization updates a second (median over the windows) before
/// `localization-sync` warns: the released and norlab Warthog runs update 4.1-9.7 times a
/// second, the Husky run and the simulator's ICP about 10.
const MIN_UPDATES_PER_S: f64 = 3.0;

/// Localization updating slowly: the poses held between updates, every error measured on
/// them includes the hold (at 2 a second, slip-ipem's rotational error on a Warthog run
/// rose by 64% without a word). A warning under [`MIN_UPDATES_PER_S`], where the windows
/// move (a run standing still holds its poses for that).
pub(super) fn slow_updates(w: &Windows<'_>) -> Option<Finding> {
    let dt = w.data.robot.dt();
    let mut rates: Vec<f64> = w
        .windows
        .iter()
        .zip(&w.motions)
        .filter(|(win, m)| win.len() >= 3 && (m.2 >= 0.2 || m.3.abs() >= 0.2))
        .map(|(win, _)| {
            let changes = win.pose.windows(2).filter(|p| p[0] != p[1]).count();
            changes as f64 / ((win.len() - 1) as f64 * dt)
        })
        .collect();
    if rates.len() < MIN_WINDOWS || dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let median = drive_traits::median(&mut rates);
    // Only where the samples come faster than the least: a run sampled at 2 Hz cannot tell.
    (median < MIN_UPDATES_PER_S && 1.0 / dt > 2.0 * MIN_UPDATES_PER_S).then(|| Finding {
        check: Check::LocalizationSync,
        severity: Severity::Warning,
        message: format!(
            "localization's pose changes {} times a second (median over the {} windows that move; the samples come {} times a second): held between slow updates, which every error measured on it includes; a localization at {} Hz, or resampled?",
            Short(three_digits(median)),
            rates.len(),
            Short(three_digits(1.0 / dt)),
            Short(three_digits(median)),
        ),
    })
}
