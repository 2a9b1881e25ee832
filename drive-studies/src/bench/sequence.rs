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

/// The windows in a row that must agree so: three (a DRIVE interval's windows hold one
/// command, so three in a row cross into the next interval's).
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

/// How many windows of the shorter of two runs' sequences open three windows in a row whose
/// commands agree with three in a row of the other, and of how many, where those are at
/// least `share` of them and the IMU differs by noise alone ([`COPY_GAIN`]); `None`
/// otherwise.
pub(super) fn one_drive(a: &Sequence, b: &Sequence, share: f64) -> Option<(usize, usize)> {
    let noise =
        ((a.imu_noise.powi(2) - b.imu_noise.powi(2)).abs() / a.samples.min(b.samples)).sqrt();
    let (few_motions, many_motions) = if a.windows.len() <= b.windows.len() {
        (&a.motions, &b.motions)
    } else {
        (&b.motions, &a.motions)
    };
    let (a, b) = (&a.windows, &b.windows);
    let (few, many) = if a.len() <= b.len() { (a, b) } else { (b, a) };
    if few.len() < RUN_LENGTH {
        return None;
    }
    // The commands' range per axis over both runs.
    let mut tolerance = [0.0; 3];
    for (axis, t) in tolerance.iter_mut().enumerate() {
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
    let cell = |i: &Inputs| [0, 1].map(|axis| (i[axis] / tolerance[axis]).floor() as i64);
    let mut cells: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
    for (j, i) in many.iter().enumerate() {
        if let Some(i) = i {
            cells.entry(cell(i)).or_default().push(j);
        }
    }
    let close = |p: &Option<Inputs>, q: &Option<Inputs>| match (p, q) {
        (Some(p), Some(q)) => (0..3).all(|axis| (p[axis] - q[axis]).abs() <= tolerance[axis]),
        _ => false,
    };
    // How far a run of windows of `many` from `j` is from `few`'s from `i` (their commands,
    // in units of the tolerance, summed).
    let distance = |i: usize, j: usize| -> f64 {
        (0..RUN_LENGTH)
            .map(|k| match (&few[i + k], &many[j + k]) {
                (Some(p), Some(q)) => (0..3)
                    .map(|axis| (p[axis] - q[axis]).abs() / tolerance[axis])
                    .sum::<f64>(),
                _ => f64::INFINITY,
            })
            .sum()
    };
    let mut pairs: Vec<(usize, usize)> = Vec::new();
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
            pairs.push((i, j));
        }
    }
    if pairs.is_empty() || (pairs.len() as f64) < share * few.len() as f64 {
        return None;
    }
    // The localization saw one motion in the paired windows (within a twentieth of it, on
    // travel and on turn): one drive, whatever was done to its IMU (scaled, biased, late,
    // negated). The same commands on another ground move the body otherwise.
    if same_motions(&pairs, few_motions, many_motions) {
        return Some((pairs.len(), few.len()));
    }
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
        return None;
    }
    let gain = rates.iter().map(|(x, y)| (y - x) * x).sum::<f64>() / squares;
    let left = (rates
        .iter()
        .map(|(x, y)| (y - x - gain * x).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    (gain.abs() <= COPY_GAIN && left <= NOISE_EXPLAINS * noise + 1e-3 * spread)
        .then_some((pairs.len(), few.len()))
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
        assert_eq!(one_drive(&original, &copy, 0.5), Some((298, 300)));
        // Its second half alone.
        let half = Sequence {
            windows: copy.windows[150..].to_vec(),
            ..run(100, 0.2, 0.05)
        };
        assert_eq!(one_drive(&original, &half, 0.5), Some((148, 150)));
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
}
