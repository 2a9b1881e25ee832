//! The simulator: physics at fine substeps, the powertrain, and sensors as on the real
//! robots, advanced one command tick at a time.

use crate::vehicle::{step_body, VehicleParams, VehicleState};
use crate::{Plant, Terrain};
use drive_models::DifferentialDrive;
use drive_samplers::RobotSpec;
use drive_traits::{Input, Pose};
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// Sensor noise and rates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensors {
    /// Encoder noise, standard deviation (rad/s).
    pub encoder_noise: f64,
    /// ICP localization rate (Hz); poses are held between updates.
    pub icp_rate_hz: f64,
    /// ICP position noise (m) and yaw noise (rad), standard deviations.
    pub icp_noise: [f64; 2],
    /// IMU yaw-rate noise (rad/s) and bias (rad/s).
    pub imu_noise: f64,
    /// IMU bias (rad/s).
    pub imu_bias: f64,
}

impl Default for Sensors {
    /// Encoders 0.05 rad/s, ICP at 10 Hz with 1 cm and 0.2 degree, IMU 0.01 rad/s with a
    /// 0.005 rad/s bias.
    fn default() -> Self {
        Sensors {
            encoder_noise: 0.05,
            icp_rate_hz: 10.0,
            icp_noise: [0.01, 0.0035],
            imu_noise: 0.01,
            imu_bias: 0.005,
        }
    }
}

/// What the robot measures at a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// Time (s).
    pub t: f64,
    /// Measured inputs: encoder wheel velocities for a skid-steer (rad/s).
    pub input: Input,
    /// ICP pose (held between updates).
    pub pose: Pose,
    /// True when the ICP pose was updated at this tick.
    pub fresh_pose: bool,
    /// IMU yaw rate (rad/s).
    pub imu_yaw_rate: f64,
}

/// A simulated skid-steer UGV on a terrain: the plant of the `differential` vehicle.
#[derive(Debug, Clone)]
pub struct Simulator {
    /// Physical parameters.
    pub params: VehicleParams,
    /// The ground.
    pub terrain: Terrain,
    /// Sensors.
    pub sensors: Sensors,
    state: VehicleState,
    rate_hz: f64,
    substeps: usize,
    history: Vec<Input>,
    tick: usize,
    icp: Pose,
    rng: Xoshiro256PlusPlus,
}

impl Simulator {
    /// A simulator for a robot with a differential-drive vehicle of `geometry` on a
    /// terrain, at rest at the origin, seeded.
    pub fn new(
        spec: &RobotSpec,
        geometry: &DifferentialDrive,
        terrain: Terrain,
        seed: u64,
    ) -> Self {
        let substeps = ((1.0 / spec.rate_hz) / 2.5e-4).ceil().max(1.0) as usize;
        Simulator {
            params: VehicleParams::from_spec(spec, geometry),
            terrain,
            sensors: Sensors::default(),
            state: VehicleState {
                pose: Pose::zeros(),
                velocity: [0.0; 3],
                wheels: Input::zeros(),
            },
            rate_hz: spec.rate_hz,
            substeps,
            history: Vec::new(),
            tick: 0,
            icp: Pose::zeros(),
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    /// The true state.
    pub fn state(&self) -> &VehicleState {
        &self.state
    }

    /// Current time (s).
    pub fn time(&self) -> f64 {
        self.tick as f64 / self.rate_hz
    }

    /// Measures the current state (the sensors' view at this tick).
    pub fn measure(&mut self) -> Measured {
        let period = (self.rate_hz / self.sensors.icp_rate_hz).round().max(1.0) as usize;
        let fresh_pose = self.tick % period == 0;
        let n = |rng: &mut Xoshiro256PlusPlus, s: f64| {
            if s > 0.0 {
                Normal::new(0.0, s).map_or(0.0, |d| d.sample(rng))
            } else {
                0.0
            }
        };
        if fresh_pose {
            let p = self.state.pose;
            self.icp = Pose::new(
                p.x + n(&mut self.rng, self.sensors.icp_noise[0]),
                p.y + n(&mut self.rng, self.sensors.icp_noise[0]),
                p.z + n(&mut self.rng, self.sensors.icp_noise[1]),
            );
        }
        let w = self.state.wheels;
        let encoder = Input::new(
            w.x + n(&mut self.rng, self.sensors.encoder_noise),
            w.y + n(&mut self.rng, self.sensors.encoder_noise),
        );
        let imu_yaw_rate = self.state.velocity[2]
            + self.sensors.imu_bias
            + n(&mut self.rng, self.sensors.imu_noise);
        Measured {
            t: self.time(),
            input: encoder,
            pose: self.icp,
            fresh_pose,
            imu_yaw_rate,
        }
    }

    /// Applies `command` (wheel velocities, rad/s) for one command tick.
    pub fn advance(&mut self, command: Input) {
        Plant::advance(self, command)
    }

    fn step(&mut self, command: Input) {
        self.history.push(command);
        let dt = 1.0 / self.rate_hz;
        let h = dt / self.substeps as f64;
        let p = self.params.clone();
        for i in 0..self.substeps {
            let t = self.tick as f64 * dt + i as f64 * h;
            for side in 0..2 {
                let (tc, td) = p.powertrain[side];
                let delayed = ((t - td) / dt).floor();
                let u = if delayed < 0.0 {
                    0.0
                } else {
                    self.history[delayed as usize][side]
                };
                let gain = if side == 1 { p.right_gain } else { 1.0 };
                let u = (gain * u).clamp(-p.wheel_limit, p.wheel_limit);
                self.state.wheels[side] += (u - self.state.wheels[side]) * h / tc;
            }
            step_body(&p, &self.terrain, &mut self.state, h);
        }
        self.tick += 1;
    }
}

impl Plant for Simulator {
    fn measure(&mut self) -> Measured {
        Simulator::measure(self)
    }
    fn advance(&mut self, command: Input) {
        self.step(command)
    }
}
