//! What every plant shares around its physics: the command clock and history (for dead
//! times), the localization held between its updates, and the sensor noise.

use crate::Measured;
use drive_traits::{Input, Pose};
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal, Uniform};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Sensor noise and rates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Sensors {
    /// Noise of the measured inputs, standard deviation (encoders: rad/s).
    pub encoder_noise: f64,
    /// ICP localization rate (Hz); poses are held between updates.
    pub icp_rate_hz: f64,
    /// ICP position noise (m) and yaw noise (rad), standard deviations.
    #[serde(deserialize_with = "drive_traits::exact::array")]
    pub icp_noise: [f64; 2],
    /// ICP latency (s): an update reports the pose of this long before.
    pub icp_latency: f64,
    /// ICP timestamp jitter (s): each update's latency is longer by a uniform draw in
    /// `[0, icp_jitter]`.
    pub icp_jitter: f64,
    /// Where the localization's frame sits on the body: forward and left offsets (m) and
    /// yaw (rad) from the centre the body turns about. A lidar ahead of that centre sees
    /// the robot slide sideways as it turns; a yawed one sees straight driving as a
    /// crab.
    #[serde(deserialize_with = "drive_traits::exact::array")]
    pub icp_mount: [f64; 3],
    /// IMU yaw-rate noise (rad/s).
    pub imu_noise: f64,
    /// IMU bias (rad/s).
    pub imu_bias: f64,
    /// When the localization's pose changes: the share of its updates that come
    /// [`ICP_GAP_STEP_S`] (0.05 s), 0.10 s, ..., 1 s (the last bin: 1 s or more, drawn as
    /// 1 s) after the previous one ([`ICP_GAP_BINS`] bins; they need not sum to one), each
    /// gap rounded to whole command ticks. All zero (the default): every `1 / icp_rate_hz`.
    /// A real localization falls behind now and then (a scan matched late, a map update):
    /// its pose holds for half a second or more, then catches up in one jump. Between its
    /// updates it is still published at `icp_rate_hz`, unchanged, as a localization node
    /// republishes its last estimate (so at a rate above 2 Hz the runner's 0.5 s watchdog
    /// does not pause).
    #[serde(
        skip_serializing_if = "no_gaps",
        deserialize_with = "drive_traits::exact::array"
    )]
    pub icp_gaps: [f64; ICP_GAP_BINS],
}

impl Sensors {
    /// The mean gap between the localization's updates (s) and the share of its updates
    /// that come half a second or more after the previous one, from
    /// [`Sensors::icp_gaps`]; `None` without gaps.
    ///
    /// ```
    /// use drive_sim::{Sensors, ICP_GAP_BINS};
    /// let mut gaps = [0.0; ICP_GAP_BINS];
    /// gaps[1] = 0.75; // 0.10 s
    /// gaps[9] = 0.25; // 0.50 s
    /// let s = Sensors { icp_gaps: gaps, ..Sensors::default() };
    /// let (mean, long) = s.gap_summary().unwrap();
    /// assert!((mean - 0.2).abs() < 1e-12 && (long - 0.25).abs() < 1e-12);
    /// assert_eq!(Sensors::default().gap_summary(), None);
    /// ```
    pub fn gap_summary(&self) -> Option<(f64, f64)> {
        const LONG_S: f64 = 0.5;
        let total: f64 = self.icp_gaps.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let mean = (0..ICP_GAP_BINS)
            .map(|i| self.icp_gaps[i] * gap_seconds(i))
            .sum::<f64>()
            / total;
        let long = (0..ICP_GAP_BINS)
            .filter(|&i| gap_seconds(i) >= LONG_S - 1e-9)
            .map(|i| self.icp_gaps[i])
            .sum::<f64>()
            / total;
        Some((mean, long))
    }
}

/// Bins of [`Sensors::icp_gaps`].
pub const ICP_GAP_BINS: usize = 20;

/// Width of a bin of [`Sensors::icp_gaps`] (s).
pub const ICP_GAP_STEP_S: f64 = 0.05;

/// The gap (s) bin `bin` of [`Sensors::icp_gaps`] stands for.
fn gap_seconds(bin: usize) -> f64 {
    (bin + 1) as f64 * ICP_GAP_STEP_S
}

fn no_gaps(gaps: &[f64; ICP_GAP_BINS]) -> bool {
    gaps.iter().all(|&g| g == 0.0)
}

impl Default for Sensors {
    /// Encoders 0.05 rad/s, ICP at 10 Hz with 1 cm and 0.2 degree, no latency, at the
    /// centre of the body, IMU 0.01 rad/s with a 0.005 rad/s bias.
    fn default() -> Self {
        Sensors {
            encoder_noise: 0.05,
            icp_rate_hz: 10.0,
            icp_noise: [0.01, 0.0035],
            icp_latency: 0.0,
            icp_jitter: 0.0,
            icp_mount: [0.0; 3],
            imu_noise: 0.01,
            imu_bias: 0.005,
            icp_gaps: [0.0; ICP_GAP_BINS],
        }
    }
}

/// A plant's clock, command history and sensors, seeded.
///
/// ```
/// use drive_sim::{Instruments, Sensors};
/// use drive_traits::{Input, Pose};
/// let mut i = Instruments::new(Sensors::default(), 20.0, 1);
/// i.record(Input::new(1.0, 2.0, 0.0));
/// // Commands reach the plant after their dead time; before the first, at rest.
/// assert_eq!(i.delayed(0.01, 0.0), Input::new(1.0, 2.0, 0.0));
/// assert_eq!(i.delayed(0.01, 0.1), Input::zeros());
/// // The localization updates at 10 Hz: every other tick at 20 Hz.
/// let m = i.measure(Input::zeros(), &[0.0; 2], Pose::new(1.0, 0.0, 0.0), 0.0);
/// assert!(m.fresh_pose && (m.pose.x - 1.0).abs() < 0.1);
/// i.end_tick();
/// let m = i.measure(Input::zeros(), &[0.0; 2], Pose::new(5.0, 0.0, 0.0), 0.0);
/// assert!(!m.fresh_pose && (m.pose.x - 1.0).abs() < 0.1);
/// ```
#[derive(Debug, Clone)]
pub struct Instruments {
    /// Sensor noise and rates.
    pub sensors: Sensors,
    rate_hz: f64,
    tick: usize,
    history: Vec<Input>,
    icp: Pose,
    /// When `icp` was measured (s).
    icp_time: f64,
    /// The true poses of the last ticks, for a localization with latency.
    past: VecDeque<(f64, Pose)>,
    /// The tick of the localization's next update, with [`Sensors::icp_gaps`].
    next_update: usize,
    rng: Xoshiro256PlusPlus,
}

impl Instruments {
    /// At tick 0 with no command sent, at a command rate of `rate_hz`.
    pub fn new(sensors: Sensors, rate_hz: f64, seed: u64) -> Self {
        Instruments {
            sensors,
            rate_hz,
            tick: 0,
            history: Vec::new(),
            icp: Pose::zeros(),
            icp_time: 0.0,
            past: VecDeque::new(),
            next_update: 0,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    /// Command period (s).
    pub fn dt(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// The start of the current tick (s).
    pub fn time(&self) -> f64 {
        self.tick as f64 / self.rate_hz
    }

    /// The start of the current tick (s) as the physics steps from it: `tick x dt` (the
    /// same instant as [`Instruments::time`], rounded another way).
    pub fn tick_start(&self) -> f64 {
        self.tick as f64 * self.dt()
    }

    /// Records the command of the current tick.
    pub fn record(&mut self, command: Input) {
        self.history.push(command);
    }

    /// Ends the current tick.
    pub fn end_tick(&mut self) {
        self.tick += 1;
    }

    /// The command in force `delay` seconds before time `t` (zero-order hold; at rest
    /// before the first).
    pub fn delayed(&self, t: f64, delay: f64) -> Input {
        let k = ((t - delay) / self.dt()).floor();
        match self.history.len() {
            0 => Input::zeros(),
            _ if k < 0.0 => Input::zeros(),
            n => self.history[(k as usize).min(n - 1)],
        }
    }

    /// `pose` (of the body's turning centre) moved to where the localization's frame sits
    /// on the body ([`Sensors::icp_mount`]).
    ///
    /// ```
    /// use drive_sim::{Instruments, Sensors};
    /// use drive_traits::Pose;
    /// let i = Instruments::new(Sensors { icp_mount: [0.5, 0.0, 0.1], ..Sensors::default() }, 20.0, 1);
    /// let p = i.mounted(&Pose::new(1.0, 0.0, std::f64::consts::FRAC_PI_2));
    /// assert!((p - Pose::new(1.0, 0.5, std::f64::consts::FRAC_PI_2 + 0.1)).norm() < 1e-12);
    /// ```
    pub fn mounted(&self, pose: &Pose) -> Pose {
        let [mx, my, myaw] = self.sensors.icp_mount;
        let (sin, cos) = pose.z.sin_cos();
        Pose::new(
            pose.x + cos * mx - sin * my,
            pose.y + sin * mx + cos * my,
            pose.z + myaw,
        )
    }

    /// A normal draw of standard deviation `sd` (zero when `sd` is not positive).
    pub fn noise(&mut self, sd: f64) -> f64 {
        if sd > 0.0 {
            Normal::new(0.0, sd).map_or(0.0, |d| d.sample(&mut self.rng))
        } else {
            0.0
        }
    }

    /// What the sensors report at this tick: the localization (a noisy copy of `pose`
    /// at the ICP rate, or at the gaps of [`Sensors::icp_gaps`], held between updates), the inputs with noise of standard deviation
    /// `input_noise` per axis, and the IMU yaw rate with noise and bias.
    pub fn measure(
        &mut self,
        input: Input,
        input_noise: &[f64],
        pose: Pose,
        yaw_rate: f64,
    ) -> Measured {
        let period = (self.rate_hz / self.sensors.icp_rate_hz).round().max(1.0) as usize;
        let published = self.tick % period == 0;
        // Whether the pose changes at this tick: at every publication, or when the next
        // update's gap has passed.
        let (fresh_pose, update) = if no_gaps(&self.sensors.icp_gaps) {
            (published, published)
        } else if self.tick >= self.next_update {
            let gap = self.gap_ticks();
            self.next_update = self.tick + gap;
            (true, true)
        } else {
            (published, false)
        };
        let now = self.time();
        let pose = self.mounted(&pose);
        let delayed = self.sensors.icp_latency > 0.0 || self.sensors.icp_jitter > 0.0;
        if delayed {
            self.past.push_back((now, pose));
            // Keep what the longest delay can still ask for.
            let oldest = now - self.sensors.icp_latency - self.sensors.icp_jitter;
            while self.past.len() > 2 && self.past[1].0 <= oldest {
                self.past.pop_front();
            }
        }
        if update {
            let pose = if delayed {
                let delay = self.sensors.icp_latency
                    + Uniform::new(0.0, self.sensors.icp_jitter)
                        .map_or(0.0, |u| u.sample(&mut self.rng));
                self.icp_time = now - delay;
                pose_at(&self.past, now - delay)
            } else {
                self.icp_time = now;
                pose
            };
            let [sp, sy] = self.sensors.icp_noise;
            self.icp = Pose::new(
                pose.x + self.noise(sp),
                pose.y + self.noise(sp),
                pose.z + self.noise(sy),
            );
        }
        // Axis by axis, in order (a two-input plant draws exactly two noises).
        let mut noisy = input;
        for (i, sd) in input_noise
            .iter()
            .enumerate()
            .take(drive_traits::MAX_INPUTS)
        {
            noisy[i] += self.noise(*sd);
        }
        let input = noisy;
        let imu_yaw_rate = yaw_rate + self.sensors.imu_bias + self.noise(self.sensors.imu_noise);
        Measured {
            t: now,
            input,
            pose: self.icp,
            fresh_pose,
            imu_yaw_rate,
            pose_time: self.icp_time,
        }
    }
}

impl Instruments {
    /// The ticks to the localization's next update: a gap drawn from
    /// [`Sensors::icp_gaps`], at least one tick.
    fn gap_ticks(&mut self) -> usize {
        let gaps = &self.sensors.icp_gaps;
        let total: f64 = gaps.iter().sum();
        let mut u = Uniform::new(0.0, total).map_or(0.0, |d| d.sample(&mut self.rng));
        let mut bin = ICP_GAP_BINS - 1;
        for (i, &g) in gaps.iter().enumerate() {
            if u < g {
                bin = i;
                break;
            }
            u -= g;
        }
        ((gap_seconds(bin) * self.rate_hz).round() as usize).max(1)
    }
}

/// The pose at time `t`, interpolated between the recorded ticks (the oldest before them).
fn pose_at(past: &VecDeque<(f64, Pose)>, t: f64) -> Pose {
    let Some(&(t0, p0)) = past.front() else {
        return Pose::zeros();
    };
    if t <= t0 {
        return p0;
    }
    for k in 1..past.len() {
        let ((ta, pa), (tb, pb)) = (past[k - 1], past[k]);
        if t <= tb {
            let a = ((t - ta) / (tb - ta)).clamp(0.0, 1.0);
            // Yaw interpolated along the short way round.
            let dz = drive_traits::wrap_angle(pb.z - pa.z);
            return Pose::new(
                pa.x + a * (pb.x - pa.x),
                pa.y + a * (pb.y - pa.y),
                pa.z + a * dz,
            );
        }
    }
    past.back().map_or(p0, |b| b.1)
}
