//! The simulator: physics at fine substeps, the powertrain, and sensors as on the real
//! robots, advanced one command tick at a time.

use crate::stall::StallState;
use crate::vehicle::{step_body, VehicleParams, VehicleState};
use crate::{ControllerParams, Instruments, Plant, Terrain};
use drive_models::DifferentialDrive;
use drive_samplers::RobotSpec;
use drive_traits::{Input, Pose};
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

fn standard_normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    StandardNormal.sample(rng)
}

/// The physics step (s): stable with a margin of about two for the stiffest preset (dry
/// tile: the contacts' slip stiffness over the mass, the yaw inertia and the wheels'
/// rotating inertia stay below 1 / step).
const PHYSICS_STEP_S: f64 = 5e-4;

/// What the robot measures at a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// Time (s).
    pub t: f64,
    /// Measured inputs: encoder wheel velocities for a skid-steer (rad/s).
    pub input: Input,
    /// ICP pose (held between updates).
    pub pose: Pose,
    /// True when the localization published its pose at this tick: an update, or, between
    /// the updates of a localization with [`Sensors::icp_gaps`](crate::Sensors::icp_gaps),
    /// its last estimate again at its rate (what the runner and the logger take for a fix).
    pub fresh_pose: bool,
    /// IMU yaw rate (rad/s).
    pub imu_yaw_rate: f64,
    /// When the pose was measured (s): `t` less the localization's latency at its last
    /// update ([`Sensors::icp_latency`](crate::Sensors::icp_latency) and its jitter), what
    /// a ROS pose message's header stamps. `t` itself for a localization without latency.
    pub pose_time: f64,
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
    /// The ground as it is at this tick (the terrain with its grip varied).
    ground: Terrain,
    /// The log multipliers of traction, lateral friction and rolling resistance (see
    /// [`Variability`](crate::Variability)).
    grip: [f64; 3],
    grip_rng: Xoshiro256PlusPlus,
    /// The controller's output (forward speed, yaw rate) as each side sees it (each side's
    /// command arrives after its own dead time).
    controller_output: [[f64; 2]; 2],
    /// The ground's hold on a turn's start (see [`TurnStall`](crate::TurnStall)).
    stall: Option<StallState>,
}

impl Simulator {
    /// A simulator for a robot with a differential-drive vehicle of `geometry` on a
    /// terrain, at rest at the origin, seeded. The terrain's `powertrain`, `controller` and
    /// `sensors`, when it has them (a fitted twin), replace the defaults; its grip varies
    /// as its [`Variability`](crate::Variability) says.
    pub fn new(
        spec: &RobotSpec,
        geometry: &DifferentialDrive,
        terrain: Terrain,
        seed: u64,
    ) -> Self {
        let substeps = ((1.0 / spec.rate_hz) / PHYSICS_STEP_S).ceil().max(1.0) as usize;
        let mut params = VehicleParams::from_spec(spec, geometry);
        if let Some(share) = terrain.contact_spread {
            params = params.with_contact_spread(share);
        }
        if let Some(pt) = terrain.powertrain {
            params.powertrain = pt;
        }
        if let Some(c) = terrain.controller {
            params.controller = c;
        }
        let sensors = terrain.sensors.unwrap_or_default();
        let mut grip_rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x6121_7000_5EED);
        // Drawn from the processes' stationary distributions.
        let grip = terrain.variability.map_or([0.0; 3], |v| {
            v.deviations().map(|sd| sd * standard_normal(&mut grip_rng))
        });
        let stall = terrain.turn_stall.map(|s| StallState::new(s, seed));
        Simulator {
            params,
            ground: terrain.clone(),
            terrain,
            grip,
            grip_rng,
            controller_output: [[0.0; 2]; 2],
            stall,
            instruments: Instruments::new(sensors, spec.rate_hz, seed),
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
            &[e, e],
            self.state.pose,
            self.state.velocity[2],
        )
    }

    /// Applies `command` (wheel velocities, rad/s) for one command tick.
    pub fn advance(&mut self, command: Input) {
        Plant::advance(self, command)
    }

    /// The ground of this tick: the terrain, its grip varied (when it varies).
    fn vary_ground(&mut self, dt: f64) {
        let Some(v) = self.terrain.variability else {
            return;
        };
        self.ground.clone_from(&self.terrain);
        let a = (-dt / v.correlation_time).exp();
        let keep = (1.0 - a * a).max(0.0).sqrt();
        let sd = v.deviations();
        for (x, sd) in self.grip.iter_mut().zip(sd) {
            *x = a * *x + sd * keep * standard_normal(&mut self.grip_rng);
        }
        // Log-normal factors of mean one: the terrain's coefficients are the means.
        let factor = |i: usize| (self.grip[i] - sd[i] * sd[i] / 2.0).exp();
        self.ground.traction *= factor(0);
        self.ground.lateral *= factor(1);
        // Within the range a terrain file may give.
        self.ground.rolling = (self.ground.rolling * factor(2)).min(0.99);
    }

    fn step(&mut self, command: Input) {
        // A stalled turn's wheels are commanded a share of it (the command as sent is what
        // the run logs).
        let command = match self.stall.as_mut() {
            Some(stall) => stall.command(command, self.state.wheels),
            None => command,
        };
        self.instruments.record(command);
        let dt = self.instruments.dt();
        self.vary_ground(dt);
        let h = dt / self.substeps as f64;
        let t0 = self.instruments.tick_start();
        let p = &self.params;
        let (radius, baseline) = (p.wheel_radius, p.baseline);
        let ramps = p.controller.ramps();
        for i in 0..self.substeps {
            let t = t0 + i as f64 * h;
            let mut targets = Input::zeros();
            for side in 0..2 {
                let (_, delay) = p.powertrain.lags(side);
                let u = self.instruments.delayed(t, delay);
                let gain = if side == 1 {
                    p.powertrain.right_gain
                } else {
                    1.0
                };
                let wheels = if ramps {
                    let out = &mut self.controller_output[side];
                    p.controller
                        .ramp(out, p.controller.body_target(u, radius, baseline), h);
                    ControllerParams::wheels(*out, radius, baseline)
                } else {
                    p.controller.targets(u, radius, baseline)
                };
                targets[side] = gain * wheels[side];
            }
            let ground = if self.terrain.variability.is_some() {
                &self.ground
            } else {
                &self.terrain
            };
            step_body(p, ground, &mut self.state, targets, h);
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
    fn true_pose(&self) -> Option<Pose> {
        Some(self.instruments.mounted(&self.state.pose))
    }
    fn change_ground(&mut self, ground: &Terrain) -> Result<(), crate::PlantError> {
        let t = &mut self.terrain;
        t.name.clone_from(&ground.name);
        t.traction = ground.traction;
        t.slip_modulus = ground.slip_modulus;
        t.lateral_slip_modulus = ground.lateral_slip_modulus;
        t.lateral = ground.lateral;
        t.rolling = ground.rolling;
        t.variability = ground.variability;
        t.turn_stall = ground.turn_stall;
        self.ground.clone_from(&self.terrain);
        // The new ground's grip drawn from its processes' stationary distributions, as a
        // plant made on it starts.
        let rng = &mut self.grip_rng;
        self.grip = ground.variability.map_or([0.0; 3], |v| {
            v.deviations().map(|sd| sd * standard_normal(rng))
        });
        let seed = standard_normal(rng).to_bits();
        self.stall = ground.turn_stall.map(|s| StallState::new(s, seed));
        Ok(())
    }
}
