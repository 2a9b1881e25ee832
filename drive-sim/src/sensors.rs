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
    pub icp_mount: [f64; 3],
    /// IMU yaw-rate noise (rad/s).
    pub imu_noise: f64,
    /// IMU bias (rad/s).
    pub imu_bias: f64,
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
    /// The true poses of the last ticks, for a localization with latency.
    past: VecDeque<(f64, Pose)>,
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
            past: VecDeque::new(),
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
    /// at the ICP rate, held between updates), the inputs with noise of standard deviation
    /// `input_noise` per axis, and the IMU yaw rate with noise and bias.
    pub fn measure(
        &mut self,
        input: Input,
        input_noise: &[f64],
        pose: Pose,
        yaw_rate: f64,
    ) -> Measured {
        let period = (self.rate_hz / self.sensors.icp_rate_hz).round().max(1.0) as usize;
        let fresh_pose = self.tick % period == 0;
        let now = self.time();
        let pose = self.mounted(&pose);
        let delayed = self.sensors.icp_latency > 0.0 || self.sensors.icp_jitter > 0.0;
        let pose = if delayed {
            self.past.push_back((now, pose));
            let delay = self.sensors.icp_latency
                + match Uniform::new(0.0, self.sensors.icp_jitter) {
                    Ok(u) if fresh_pose => u.sample(&mut self.rng),
                    _ => 0.0,
                };
            // Keep what the longest delay can still ask for.
            let oldest = now - self.sensors.icp_latency - self.sensors.icp_jitter;
            while self.past.len() > 2 && self.past[1].0 <= oldest {
                self.past.pop_front();
            }
            pose_at(&self.past, now - delay)
        } else {
            pose
        };
        if fresh_pose {
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
        }
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
