//! Test support: a synthetic skid-steer dataset generator for "another robot" checks.
//!
//! The ground truth is deliberately outside the slip-BLR model family (saturating,
//! speed-dependent slip, body inertia, an asymmetric powertrain), so that a good score is
//! not circular. It is a test fixture, not the project's simulator.
#![allow(dead_code)]

use drive::traits::{Dataset, Input, Phase, Pose, RobotDescription, Window};

/// Deterministic generator (splitmix64) with Gaussian draws, so fixtures need no crate.
pub struct Rng(u64);
impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A synthetic robot.
pub struct SyntheticRobot {
    pub wheel_radius: f64,
    pub baseline: f64,
    pub rate_hz: f64,
    pub window_len: usize,
    /// wheel velocity limit (rad/s)
    pub wheel_limit: f64,
    /// commands are drawn in +-command_range (rad/s)
    pub command_range: f64,
    /// (time constant, delay) left and right (s)
    pub powertrain: [(f64, f64); 2],
}

impl SyntheticRobot {
    /// A Warthog-like robot: r = 0.3 m, b = 1.1652 m, 5 m/s top speed.
    pub fn warthog_like() -> Self {
        SyntheticRobot {
            wheel_radius: 0.3,
            baseline: 1.1652,
            rate_hz: 20.0,
            window_len: 40,
            wheel_limit: 5.0 / 0.3,
            command_range: 25.0,
            powertrain: [(0.45, 0.15), (0.6, 0.2)],
        }
    }

    /// Drives `intervals` DRIVE intervals with uniformly drawn commands and records windows.
    pub fn record(&self, name: &str, intervals: usize, seed: u64) -> Dataset {
        let mut rng = Rng::new(seed);
        let dt = 1.0 / self.rate_hz;
        let sub = 20; // physics substeps per sample
        let h = dt / sub as f64;
        let (r, b) = (self.wheel_radius, self.baseline);
        let mut wheel = [0.0f64; 2];
        let mut body = [0.0f64; 3]; // vx, vy, w
        let mut pose = Pose::zeros();
        let mut history: Vec<[f64; 2]> = Vec::new(); // commands per sample, for the delay
        let mut windows = Vec::new();
        let imu_bias = 0.01;
        let mut icp = pose;
        for interval in 0..intervals {
            let cmd = [
                (rng.uniform() * 2.0 - 1.0) * self.command_range,
                (rng.uniform() * 2.0 - 1.0) * self.command_range,
            ];
            for w in 0..3 {
                let mut win = Window {
                    index: windows.len(),
                    interval,
                    phase: if w == 0 {
                        Phase::Transient
                    } else {
                        Phase::Steady
                    },
                    command: Vec::new(),
                    encoder: Vec::new(),
                    pose: Vec::new(),
                    imu_yaw_rate: Vec::new(),
                };
                let mut start_icp = None;
                for _ in 0..self.window_len {
                    let k = history.len();
                    // Sensors at the sample instant.
                    if k % 2 == 0 {
                        icp = Pose::new(
                            pose.x + 0.01 * rng.normal(),
                            pose.y + 0.01 * rng.normal(),
                            pose.z + 0.003 * rng.normal(),
                        );
                    }
                    let s0 = *start_icp.get_or_insert(icp);
                    let (s, c) = s0.z.sin_cos();
                    let (dx, dy) = (icp.x - s0.x, icp.y - s0.y);
                    let rel_yaw = drive::traits::wrap_angle(icp.z - s0.z);
                    win.pose
                        .push(Pose::new(c * dx + s * dy, -s * dx + c * dy, rel_yaw));
                    win.encoder.push(Input::new(
                        wheel[0] + 0.05 * rng.normal(),
                        wheel[1] + 0.05 * rng.normal(),
                    ));
                    win.imu_yaw_rate
                        .push(body[2] + imu_bias + 0.02 * rng.normal());
                    win.command.push(Input::new(cmd[0], cmd[1]));
                    history.push(cmd);
                    // Physics until the next sample.
                    for i in 0..sub {
                        let t = k as f64 * dt + i as f64 * h;
                        for side in 0..2 {
                            let (tc, td) = self.powertrain[side];
                            let delayed = ((t - td) / dt).floor();
                            let u = if delayed < 0.0 {
                                0.0
                            } else {
                                history[delayed as usize][side]
                            };
                            let u = u.clamp(-self.wheel_limit, self.wheel_limit);
                            wheel[side] += (u - wheel[side]) * h / tc;
                        }
                        let fx = r * 0.5 * (wheel[0] + wheel[1]);
                        let fw = r * (wheel[1] - wheel[0]) / b;
                        // Saturating longitudinal slip, speed-dependent skid, centripetal drift.
                        let vx_ss = fx * (1.0 - 0.08 - 0.07 * (fx.abs() / 3.0).tanh());
                        let w_ss = fw * 0.55 / (1.0 + 0.15 * fw.abs()) + 0.02 * fx;
                        let vy_ss = -0.03 * fx * fw;
                        let target = [vx_ss, vy_ss, w_ss];
                        let tau = [0.25, 0.25, 0.15];
                        for d in 0..3 {
                            body[d] += (target[d] - body[d]) * h / tau[d];
                        }
                        let (s, c) = pose.z.sin_cos();
                        pose = Pose::new(
                            pose.x + (c * body[0] - s * body[1]) * h,
                            pose.y + (s * body[0] + c * body[1]) * h,
                            pose.z + body[2] * h,
                        );
                    }
                }
                windows.push(win);
            }
        }
        let robot = RobotDescription {
            name: name.to_string(),
            robot: "synthetic skid-steer".to_string(),
            rate_hz: self.rate_hz,
            window_len: self.window_len,
            wheel_radius: self.wheel_radius,
            baseline: self.baseline,
        };
        Dataset { robot, windows }
    }
}
