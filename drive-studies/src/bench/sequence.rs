//! One drive recognised by its sequence of commands: a copy of a run with noise on every
//! column (commands, encoders, IMU and localization alike) shares no window's print, track
//! or inputs within their tolerances, but it keeps the run's commands window after window,
//! which no other run holds (a DRIVE run draws them at random), and its IMU differs from the
//! run's by the noise added alone. The same commands driven on another ground (a
//! simulator's same seed) keep the sequence too, but the ground changes how the body turns.

use super::Inputs;
use drive_traits::Dataset;
use std::collections::HashMap;

/// A dataset's windows in recorded order, for [`one_drive`].
pub(crate) struct Sequence {
    /// Every window's [`Inputs`] (`None` where one is not finite).
    windows: Vec<Option<Inputs>>,
    /// The IMU's noise per sample: the RMS of its second differences within the windows
    /// over the square root of 6 (white noise's), rad/s.
    imu_noise: f64,
    /// The windows' median number of samples.
    samples: f64,
    /// Every window's net motion as its localization saw it, in the frame of its first
    /// pose: forward and sideways travel (m) and turn (rad); `None` where not finite.
    motions: Vec<Option<[f64; 3]>>,
}

impl Sequence {
    /// The sequence of `data`'s windows of two samples or more, whose [`Inputs`] are
    /// `means` (in the same order: [`super::window_means`]).
    pub(crate) fn of(data: &Dataset, means: Vec<Option<Inputs>>) -> Sequence {
        let windows: Vec<&drive_traits::Window> =
            data.windows.iter().filter(|w| w.len() >= 2).collect();
        let (mut squares, mut n) = (0.0, 0usize);
        for w in &windows {
            for r in w.imu_yaw_rate.windows(3) {
                let second = r[2] - 2.0 * r[1] + r[0];
                if second.is_finite() {
                    squares += second * second;
                    n += 1;
                }
            }
        }
        let mut lengths: Vec<usize> = windows.iter().map(|w| w.len()).collect();
        lengths.sort_unstable();
        let motions = windows
            .iter()
            .map(|w| {
                let (first, last) = (w.pose[0], w.pose[w.len() - 1]);
                let (dx, dy) = (last.x - first.x, last.y - first.y);
                let (sin, cos) = first.z.sin_cos();
                let m = [
                    cos * dx + sin * dy,
                    -sin * dx + cos * dy,
                    drive_traits::net_turn(&w.pose),
                ];
                m.iter().all(|v| v.is_finite()).then_some(m)
            })
            .collect();
        Sequence {
            motions,
            windows: means,
            imu_noise: if n > 0 {
                (squares / n as f64 / 6.0).sqrt()
            } else {
                0.0
            },
            samples: lengths.get(lengths.len() / 2).copied().unwrap_or(1) as f64,
        }
    }
}

/// How far two windows' mean commands may be apart, per axis, against the commands' range
/// over both runs (2%: a copy with noise of 5% of each column's largest value on every
/// sample moves a window's mean command by about 0.6% of the range), to be one drive's.
const COMMAND_TOLERANCE: f64 = 0.02;

/// The windows in a row that must agree so: three (a DRIVE interval's three windows hold
/// one command: its own three tell it from an interval of a close command only by their
/// distance, three in a row from a later window cross into the next interval's).
const RUN_LENGTH: usize = 3;

/// How the IMU of one drive's copy may differ from the run's: the least-squares gain of the
/// windows' mean yaw-rate difference on the run's, at most 0.01 in size (copies with noise
/// of 1-5% of the largest rate on every sample: under 0.002; the same commands simulated on
/// two grounds, five robots and four grounds: 0.014 or more, or the ground's difference
/// leaving four times what noise explains or more), and what that gain leaves, at most
/// [`NOISE_EXPLAINS`] times what the noise one adds over the other's explains.
const COPY_GAIN: f64 = 0.01;

/// See [`COPY_GAIN`]: how many times the difference of the two IMUs' noise (per window mean:
/// over the square root of its samples) the windows' differences may leave, plus a
/// thousandth of the run's spread (rounding).
const NOISE_EXPLAINS: f64 = 2.0;

/// The sets of a window's [`Inputs`] that pair two runs' windows: the commands (axes 0-2)
/// or the measured inputs (axes 3-5: a copy whose commands alone were rescaled).
const COMMANDS: [usize; 3] = [0, 1, 2];

/// See [`COMMANDS`].
const MEASURED: [usize; 3] = [3, 4, 5];

/// The mirror images of a window's [`Inputs`] a copy of a run in a mirrored world may have,
/// whatever the vehicle's inputs mean: its two sides swapped (wheels left and right), or its
/// second input (a yaw rate), or its second and third (a sideways speed and a yaw rate),
/// negated; its IMU's rate negated in each.
const MIRRORS: [fn(&Inputs) -> Inputs; 3] = [
    |i| [i[1], i[0], i[2], i[4], i[3], i[5], -i[6]],
    |i| [i[0], -i[1], i[2], i[3], -i[4], i[5], -i[6]],
    |i| [i[0], -i[1], -i[2], i[3], -i[4], -i[5], -i[6]],
];

/// How many windows of the shorter of two runs' sequences lie in three windows in a row
/// whose commands agree with three in a row of the other, and of how many, where those are
/// at least `share` of them and the localization saw one motion in the paired windows or the
/// IMU differs by noise alone ([`COPY_GAIN`]). Failing that, the same where the windows
/// pair by their measured inputs, or mirrored (a copy whose commands were rescaled, or whose
/// world was mirrored), and the localization saw one motion (mirrored). `None` otherwise.
pub(super) fn one_drive(a: &Sequence, b: &Sequence, share: f64) -> Option<(usize, usize)> {
    let noise =
        ((a.imu_noise.powi(2) - b.imu_noise.powi(2)).abs() / a.samples.min(b.samples)).sqrt();
    let (few, many) = if a.windows.len() <= b.windows.len() {
        (a, b)
    } else {
        (b, a)
    };
    let found = |pairs: &[(usize, usize)]| Some((pairs.len(), few.windows.len()));
    if let Some(pairs) = paired(&few.windows, &many.windows, COMMANDS, share) {
        // The localization saw one motion in the paired windows (within a twentieth of it,
        // on travel and on turn): one drive, whatever was done to its IMU (scaled, biased,
        // late, negated). The same commands on another ground move the body otherwise.
        if same_motions(&pairs, &few.motions, &many.motions)
            || imu_differs_by_noise(&pairs, &few.windows, &many.windows, noise)
        {
            return found(&pairs);
        }
    }
    let mirrored: Vec<Option<[f64; 3]>> = few
        .motions
        .iter()
        .map(|m| m.map(|[x, y, z]| [x, -y, -z]))
        .collect();
    // By the measured inputs (the commands rescaled), then mirrored by either.
    let one_motion = |inputs: &[Option<Inputs>], axes, motions: &[Option<[f64; 3]>]| {
        paired(inputs, &many.windows, axes, share)
            .filter(|pairs| same_motions(pairs, motions, &many.motions))
    };
    if let Some(pairs) = one_motion(&few.windows, MEASURED, &few.motions) {
        return found(&pairs);
    }
    for mirror in MIRRORS {
        let inputs: Vec<Option<Inputs>> =
            few.windows.iter().map(|i| i.as_ref().map(mirror)).collect();
        for axes in [COMMANDS, MEASURED] {
            if let Some(pairs) = one_motion(&inputs, axes, &mirrored) {
                return found(&pairs);
            }
        }
    }
    None
}

/// The windows of `few` that lie in three in a row whose `axes` agree with three in a row of
/// `many`, each with its window of `many`; `None` when they are fewer than `share` of
/// `few`'s.
fn paired(
    few: &[Option<Inputs>],
    many: &[Option<Inputs>],
    axes: [usize; 3],
    share: f64,
) -> Option<Vec<(usize, usize)>> {
    if few.len() < RUN_LENGTH {
        return None;
    }
    // The range per axis over both runs.
    let mut tolerance = [0.0; 3];
    for (t, &axis) in tolerance.iter_mut().zip(&axes) {
        let (low, high) = few
            .iter()
            .chain(many)
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
                (lo.min(i[axis]), hi.max(i[axis]))
            });
        *t = COMMAND_TOLERANCE * (high - low);
        if !t.is_finite() {
            return None;
        }
    }
    // An axis that barely varies (a third input a vehicle does not use: zero in both) within
    // a thousandth of the largest range.
    let widest = tolerance.iter().copied().fold(0.0, f64::max);
    if widest <= 0.0 {
        return None;
    }
    tolerance.iter_mut().for_each(|t| *t = t.max(widest / 20.0));
    let cell = |i: &Inputs| [0, 1].map(|k| (i[axes[k]] / tolerance[k]).floor() as i64);
    let mut cells: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
    for (j, i) in many.iter().enumerate() {
        if let Some(i) = i {
            cells.entry(cell(i)).or_default().push(j);
        }
    }
    let close = |p: &Option<Inputs>, q: &Option<Inputs>| match (p, q) {
        (Some(p), Some(q)) => (0..3).all(|k| (p[axes[k]] - q[axes[k]]).abs() <= tolerance[k]),
        _ => false,
    };
    // How far a run of windows of `many` from `j` is from `few`'s from `i` (their values, in
    // units of the tolerance, summed).
    let distance = |i: usize, j: usize| -> f64 {
        (0..RUN_LENGTH)
            .map(|k| match (&few[i + k], &many[j + k]) {
                (Some(p), Some(q)) => (0..3)
                    .map(|a| (p[axes[a]] - q[axes[a]]).abs() / tolerance[a])
                    .sum::<f64>(),
                _ => f64::INFINITY,
            })
            .sum()
    };
    // Each window's pair, from the first run of three it lies in: a copy whose intervals
    // were reordered keeps each interval's three windows in a row.
    let mut pair_of: Vec<Option<usize>> = vec![None; few.len()];
    for i in 0..=few.len() - RUN_LENGTH {
        let Some(x) = &few[i] else { continue };
        let [ca, cb] = cell(x);
        // Of the runs of windows that agree, the closest: an interval's windows hold one
        // command, so a run one window off can agree too where two intervals' commands
        // are close, and its windows are other windows (their IMU another turn).
        let found = (-1..=1)
            .flat_map(|da| (-1..=1).map(move |db| [ca + da, cb + db]))
            .filter_map(|c| cells.get(&c))
            .flatten()
            .copied()
            .filter(|&j| {
                j + RUN_LENGTH <= many.len()
                    && (0..RUN_LENGTH).all(|k| close(&few[i + k], &many[j + k]))
            })
            .min_by(|&j, &k| distance(i, j).total_cmp(&distance(i, k)).then(j.cmp(&k)));
        if let Some(j) = found {
            for k in 0..RUN_LENGTH {
                pair_of[i + k].get_or_insert(j + k);
            }
        }
    }
    let pairs: Vec<(usize, usize)> = pair_of
        .iter()
        .enumerate()
        .filter_map(|(i, j)| Some((i, (*j)?)))
        .collect();
    (!pairs.is_empty() && pairs.len() as f64 >= share * few.len() as f64).then_some(pairs)
}

/// Whether the IMU of `few`'s paired windows differs from `many`'s by noise alone: the gain
/// of the windows' mean-rate difference at most [`COPY_GAIN`] and what it leaves at most
/// [`NOISE_EXPLAINS`] times `noise` (the difference of the two IMUs' noise per window mean).
fn imu_differs_by_noise(
    pairs: &[(usize, usize)],
    few: &[Option<Inputs>],
    many: &[Option<Inputs>],
    noise: f64,
) -> bool {
    // The IMU's mean rates of the paired windows: the run's and the other's.
    let rates: Vec<(f64, f64)> = pairs
        .iter()
        .filter_map(|&(i, j)| Some((few[i]?[6], many[j]?[6])))
        .collect();
    let n = rates.len() as f64;
    let mean = rates.iter().map(|r| r.0).sum::<f64>() / n;
    let spread = (rates.iter().map(|r| (r.0 - mean).powi(2)).sum::<f64>() / n).sqrt();
    let squares: f64 = rates.iter().map(|r| r.0 * r.0).sum();
    // An IMU that does not vary tells no copy from another ground.
    if !(spread > 1e-9 && squares > 0.0) {
        return false;
    }
    let gain = rates.iter().map(|(x, y)| (y - x) * x).sum::<f64>() / squares;
    let left = (rates
        .iter()
        .map(|(x, y)| (y - x - gain * x).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    gain.abs() <= COPY_GAIN && left <= NOISE_EXPLAINS * noise + 1e-3 * spread
}

/// How far the paired windows' net motions may differ, over their size (RMS over the
/// pairs), travel and turn both, to be one drive's: a copy with 1 cm and 5 mrad of noise on
/// every pose differs by about 0.005 on a Warthog run (2-8 m a window) and 0.02 on a Husky
/// run; the same commands driven on two simulated grounds (a Husky and a Warthog, each on
/// tile, gravel, snow and ice, seed 1) differ by 0.086 or more in travel and 0.044 or more
/// in turn, never both under 0.086.
const SAME_MOTION: f64 = 0.05;

/// Whether the paired windows (`pairs`: a window of `few` with one of `many`) moved alike as
/// their localizations saw them: the RMS difference of their travel within [`SAME_MOTION`]
/// of the RMS travel, and the same of their turns (an axis that does not move, under 1 cm
/// or 0.01 rad RMS, within that); at least ten pairs with both motions.
fn same_motions(
    pairs: &[(usize, usize)],
    few: &[Option<[f64; 3]>],
    many: &[Option<[f64; 3]>],
) -> bool {
    let (mut n, mut size, mut off) = (0usize, [0.0; 2], [0.0; 2]);
    for &(i, j) in pairs {
        let (Some(p), Some(q)) = (
            few.get(i).copied().flatten(),
            many.get(j).copied().flatten(),
        ) else {
            continue;
        };
        n += 1;
        size[0] += p[0] * p[0] + p[1] * p[1];
        off[0] += (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
        size[1] += p[2] * p[2];
        off[1] += (p[2] - q[2]).powi(2);
    }
    if n < 10 {
        return false;
    }
    let nf = n as f64;
    let floor = [0.01, 0.01];
    (0..2).all(|k| {
        let (rms, diff) = ((size[k] / nf).sqrt(), (off[k] / nf).sqrt());
        diff <= SAME_MOTION * rms.max(floor[k])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of `intervals` DRIVE intervals (three windows of one command each), its IMU
    /// turning at `yaw` times the difference of the command's axes, with `noise` (uniform,
    /// of that width) on each window's means: an IMU whose noise per sample (40 samples a
    /// window) averages to it.
    fn run(intervals: usize, yaw: f64, noise: f64) -> Sequence {
        let mut state = 99u64;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut windows = Vec::new();
        for _ in 0..intervals {
            let (c0, c1) = (10.0 * uniform(), 10.0 * uniform());
            for _ in 0..3 {
                windows.push(Some([c0, c1, 0.0, c0, c1, 0.0, yaw * (c1 - c0)]));
            }
        }
        // The noise drawn after the commands: the same commands whatever the noise.
        for i in windows.iter_mut().flatten() {
            // Not on the third input, which this vehicle does not have.
            for axis in [0, 1, 3, 4, 6] {
                i[axis] += noise * uniform();
            }
        }
        // No localization: these runs are told apart by their IMU alone.
        Sequence {
            motions: vec![None; windows.len()],
            windows,
            imu_noise: 0.01 + noise / 12f64.sqrt() * 40f64.sqrt(),
            samples: 40.0,
        }
    }

    #[test]
    fn one_motion_within_a_twentieth_is_one_drive_and_another_grounds_is_not() {
        let pairs: Vec<(usize, usize)> = (0..20).map(|i| (i, i)).collect();
        let run: Vec<Option<[f64; 3]>> = (0..20)
            .map(|i| Some([1.0 + 0.1 * i as f64, 0.05, 0.3 - 0.03 * i as f64]))
            .collect();
        // Noise of a centimetre and 5 mrad on each window's net motion.
        let copy: Vec<Option<[f64; 3]>> = run
            .iter()
            .enumerate()
            .map(|(i, m)| {
                m.map(|[x, y, z]| {
                    let s = if i % 2 == 0 { 1.0 } else { -1.0 };
                    [x + 0.01 * s, y - 0.01 * s, z + 0.005 * s]
                })
            })
            .collect();
        assert!(same_motions(&pairs, &run, &copy));
        // A ground that keeps 8% less of the travel, or turns 8% less.
        let slower: Vec<_> = run
            .iter()
            .map(|m| m.map(|[x, y, z]| [0.92 * x, 0.92 * y, z]))
            .collect();
        let turns: Vec<_> = run
            .iter()
            .map(|m| m.map(|[x, y, z]| [x, y, 0.92 * z]))
            .collect();
        assert!(!same_motions(&pairs, &run, &slower));
        assert!(!same_motions(&pairs, &run, &turns));
        // Too few pairs tell nothing.
        assert!(!same_motions(&pairs[..9], &run, &copy));
    }

    #[test]
    fn a_copy_with_noise_is_one_drive_and_another_ground_is_not() {
        let original = run(100, 0.2, 0.0);
        let copy = run(100, 0.2, 0.05);
        assert_eq!(one_drive(&original, &copy, 0.5), Some((300, 300)));
        // Its second half alone.
        let half = Sequence {
            windows: copy.windows[150..].to_vec(),
            ..run(100, 0.2, 0.05)
        };
        assert_eq!(one_drive(&original, &half, 0.5), Some((150, 150)));
        // The same commands on a ground that turns the body 5% less.
        assert_eq!(one_drive(&original, &run(100, 0.19, 0.05), 0.5), None);
        // Or that turns it otherwise where it turns one way, with noise as the run's.
        let mut ground = run(100, 0.2, 0.0);
        for i in ground.windows.iter_mut().flatten() {
            i[6] += 0.05 * i[6].max(0.0) - 0.05 * i[6].min(0.0);
        }
        assert_eq!(one_drive(&original, &ground, 0.5), None);
        // Another run's commands.
        let mut other = run(100, 0.2, 0.0);
        for i in other.windows.iter_mut().flatten() {
            i[0] = -i[0];
        }
        assert_eq!(one_drive(&original, &other, 0.5), None);
    }

    /// `run`'s windows with a localization that saw each window's motion: forward as the
    /// commands' mean, a turn as their difference (a body that keeps 0.2 of it).
    fn with_motions(mut s: Sequence) -> Sequence {
        s.motions = s
            .windows
            .iter()
            .map(|i| i.map(|i| [0.5 * (i[0] + i[1]), 0.0, 0.2 * (i[1] - i[0])]))
            .collect();
        s
    }

    #[test]
    fn a_copy_reordered_rescaled_or_mirrored_is_one_drive_where_its_motions_are_the_runs() {
        let original = with_motions(run(100, 0.2, 0.0));
        let copy = with_motions(run(100, 0.2, 0.05));
        // Its intervals (three windows each) in another order.
        let mut reordered = with_motions(run(100, 0.2, 0.05));
        let order: Vec<usize> = (0..100).map(|k| (37 * k) % 100).collect();
        reordered.windows = order
            .iter()
            .flat_map(|&k| copy.windows[3 * k..3 * k + 3].to_vec())
            .collect();
        reordered.motions = order
            .iter()
            .flat_map(|&k| copy.motions[3 * k..3 * k + 3].to_vec())
            .collect();
        assert_eq!(one_drive(&original, &reordered, 0.8), Some((300, 300)));
        // Its commands alone rescaled by 1.1: its wheels and motions are the run's.
        let mut rescaled = with_motions(run(100, 0.2, 0.05));
        for i in rescaled.windows.iter_mut().flatten() {
            i[0] *= 1.1;
            i[1] *= 1.1;
        }
        assert_eq!(one_drive(&original, &rescaled, 0.8), Some((300, 300)));
        // Mirrored: the sides swapped, the IMU and the sideways motion and turn negated.
        let mut mirrored = with_motions(run(100, 0.2, 0.05));
        for i in mirrored.windows.iter_mut().flatten() {
            *i = [i[1], i[0], i[2], i[4], i[3], i[5], -i[6]];
        }
        for m in mirrored.motions.iter_mut().flatten() {
            *m = [m[0], -m[1], -m[2]];
        }
        assert_eq!(one_drive(&original, &mirrored, 0.8), Some((300, 300)));
        // Rescaled on a ground that turns the body 8% less: two drives.
        for m in rescaled.motions.iter_mut().flatten() {
            m[2] *= 0.92;
        }
        for i in rescaled.windows.iter_mut().flatten() {
            i[6] *= 0.92;
        }
        assert_eq!(one_drive(&original, &rescaled, 0.8), None);
    }
}
