//! The simulator: physics at fine substeps, the powertrain, and sensors as on the real
//! robots, advanced one command tick at a time.

use crate::vehicle::{step_body, VehicleParams, VehicleState};
use crate::{Instruments, Plant, Sensors, Terrain};
use drive_models::DifferentialDrive;
use drive_samplers::RobotSpec;
use drive_traits::{Input, Pose};

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
    /// Clock, command history and sensors.
    pub instruments: Instruments,
    state: VehicleState,
    substeps: usize,
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
            instruments: Instruments::new(Sensors::default(), spec.rate_hz, seed),
            state: VehicleState {
                pose: Pose::zeros(),
                velocity: [0.0; 3],
                wheels: Input::zeros(),
            },
            substeps,
        }
    }

    /// The true state.
    pub fn state(&self) -> &VehicleState {
        &self.state
    }

    /// Current time (s).
    pub fn time(&self) -> f64 {
        self.instruments.time()
    }

    /// Measures the current state (the sensors' view at this tick).
    pub fn measure(&mut self) -> Measured {
        let e = self.instruments.sensors.encoder_noise;
        self.instruments.measure(
            self.state.wheels,
            [e, e],
            self.state.pose,
            self.state.velocity[2],
        )
    }

    /// Applies `command` (wheel velocities, rad/s) for one command tick.
    pub fn advance(&mut self, command: Input) {
        Plant::advance(self, command)
    }

    fn step(&mut self, command: Input) {
        self.instruments.record(command);
        let dt = self.instruments.dt();
        let h = dt / self.substeps as f64;
        let t0 = self.instruments.tick_start();
        let p = self.params.clone();
        for i in 0..self.substeps {
            let t = t0 + i as f64 * h;
            for side in 0..2 {
                let (tc, td) = p.powertrain[side];
                let u = self.instruments.delayed(t, td)[side];
                let gain = if side == 1 { p.right_gain } else { 1.0 };
                let u = (gain * u).clamp(-p.wheel_limit, p.wheel_limit);
                self.state.wheels[side] += (u - self.state.wheels[side]) * h / tc;
            }
            step_body(&p, &self.terrain, &mut self.state, h);
        }
        self.instruments.end_tick();
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
