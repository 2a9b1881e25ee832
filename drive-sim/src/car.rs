//! A simulated car: the plant of the `ackermann` vehicle. A dynamic bicycle (single-track)
//! model with tyre slip on the same terrain parameters as the skid-steer, behind a speed
//! controller and a steering servo.
//!
//! - **Body**: a planar rigid body (mass, yaw inertia `m l_f l_r`, the dynamic index of one
//!   usual for cars), centre of mass 40% of the wheelbase ahead of the rear axle (the
//!   AutoRally's 0.23 m of 0.57 m), static axle loads.
//! - **Tyres**: one per axle. The force of a tyre is `mu N (1 - exp(-|s| / k))` of its
//!   combined slip `s = (s_x, s_y)`, shared between the directions along `s` (a friction
//!   ellipse of semi-axes `mu_x = traction` and `mu_y = lateral`, so that a tyre that
//!   drives hard grips less sideways); `s_x` is the slip ratio of the driven rear wheel,
//!   `s_y` the sideways velocity of the tyre over its rolling speed (the tangent of the
//!   slip angle), `k = slip_modulus`. The same shear curve as the skid-steer's traction
//!   (Janosi-Hanamoto), so both vehicles live on the same terrains. Rolling resistance on
//!   both axles.
//! - **Speed**: the rear wheels follow the speed command as a velocity source (a motor
//!   speed loop) through a dead time of 0.1 s and a first-order lag of 0.2 s, ramping at
//!   most at 1.4 times the robot's speed rate limit (for the AutoRally 7.0 m/s^2, what its
//!   URDF's rear axle torque limit of 2 x 8 N m gives on 0.095 m tyres and 23.9 kg) and
//!   saturated at the top speed: on loose ground the wheels spin.
//! - **Steering**: a servo with a dead time of 0.05 s, a first-order lag of 0.08 s and half
//!   the robot's steering rate limit (a servo under the load of the tyres turns at about
//!   half its no-load speed), saturated at the vehicle's steering limit, with a trim error
//!   of 0.01 rad (the car drifts a little to the left when steering straight).
//! - **Sensors**: rear wheel speed (0.02 m/s noise), steering angle (0.005 rad), localization
//!   at 10 Hz of the rear axle centre (the body frame of [`Ackermann`]), an IMU yaw rate
//!   with noise and bias ([`Sensors::default`](crate::Sensors::default)).
//!
//! The dead times, lags and the trim are this project's assumptions for a hobby-grade
//! speed controller and servo, not measured on a platform.

use crate::{Instruments, Measured, Terrain};
use drive_models::vehicles::Ackermann;
use drive_samplers::RobotSpec;
use drive_traits::{Input, Pose};

const G: f64 = 9.81;

/// Below this speed (m/s) slips are taken relative to it: keeps the tyre forces continuous
/// through standstill.
const MIN_SLIP_SPEED: f64 = 0.3;

/// An actuator: dead time, first-order lag, rate limit and saturation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Actuator {
    /// Dead time (s).
    pub delay: f64,
    /// Time constant (s).
    pub time_constant: f64,
    /// Largest rate of change (units per second).
    pub max_rate: f64,
    /// Saturation, both directions.
    pub limit: f64,
}

impl Actuator {
    /// The value after `h` seconds from `value` towards `target` (already delayed).
    fn step(&self, value: f64, target: f64, h: f64) -> f64 {
        let target = target.clamp(-self.limit, self.limit);
        let rate = ((target - value) / self.time_constant).clamp(-self.max_rate, self.max_rate);
        value + rate * h
    }
}

/// The simulated car's physical parameters (from a robot description).
#[derive(Debug, Clone, PartialEq)]
pub struct CarParams {
    /// Mass (kg).
    pub mass: f64,
    /// Yaw inertia (kg m^2).
    pub yaw_inertia: f64,
    /// Centre of mass to front axle (m).
    pub cg_to_front: f64,
    /// Centre of mass to rear axle (m).
    pub cg_to_rear: f64,
    /// The speed controller (rear wheel surface speed, m/s).
    pub speed: Actuator,
    /// The steering servo (rad).
    pub steering: Actuator,
    /// Steering trim error (rad): added to every steering command.
    pub steering_trim: f64,
}

impl CarParams {
    /// The parameters of a robot with a car-like vehicle of `geometry` (see the module
    /// documentation).
    ///
    /// ```
    /// let car = drive_samplers::autorally();
    /// let g = drive_models::vehicles::Ackermann::new(0.57, 0.3665191429);
    /// let p = drive_sim::CarParams::from_spec(&car, &g);
    /// assert!((p.speed.max_rate - 7.0).abs() < 1e-9);
    /// assert!((p.cg_to_front + p.cg_to_rear - 0.57).abs() < 1e-12);
    /// ```
    pub fn from_spec(spec: &RobotSpec, geometry: &Ackermann) -> Self {
        let l = geometry.wheelbase;
        let (cg_to_front, cg_to_rear) = (0.6 * l, 0.4 * l);
        // Speed and steering rates of the schedule; without per-axis limits (a car given
        // body limits), the linear acceleration and the steering limit per 0.1 s.
        let rates = spec.input_rate_limits.unwrap_or(Input::new(
            spec.max_linear_acceleration,
            geometry.max_steering / 0.1,
            0.0,
        ));
        CarParams {
            mass: spec.mass_kg,
            yaw_inertia: spec.mass_kg * cg_to_front * cg_to_rear,
            cg_to_front,
            cg_to_rear,
            speed: Actuator {
                delay: 0.1,
                time_constant: 0.2,
                max_rate: 1.4 * rates.x,
                limit: spec.max_speed,
            },
            steering: Actuator {
                delay: 0.05,
                time_constant: 0.08,
                max_rate: 0.5 * rates.y,
                limit: geometry.max_steering,
            },
            steering_trim: 0.01,
        }
    }
}

/// The true state of the simulated car.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarState {
    /// Pose of the centre of mass in the world.
    pub pose: Pose,
    /// Body velocity at the centre of mass: longitudinal, lateral (m/s), yaw rate (rad/s).
    pub velocity: [f64; 3],
    /// Rear wheel surface speed (m/s).
    pub wheel_speed: f64,
    /// Steering angle (rad).
    pub steering: f64,
}

impl CarState {
    /// The pose of the rear axle centre (the body frame of the kinematic bicycle).
    pub fn rear_axle_pose(&self, p: &CarParams) -> Pose {
        let (s, c) = self.pose.z.sin_cos();
        Pose::new(
            self.pose.x - p.cg_to_rear * c,
            self.pose.y - p.cg_to_rear * s,
            self.pose.z,
        )
    }
}

/// The force of a tyre (along, across its heading) for slips `(sx, sy)` under load `normal`:
/// the shear curve of the combined slip, on the friction ellipse.
fn tyre_force(terrain: &Terrain, normal: f64, sx: f64, sy: f64) -> (f64, f64) {
    let s = sx.hypot(sy);
    if s < 1e-12 {
        return (0.0, 0.0);
    }
    let share = (1.0 - (-s / terrain.slip_modulus).exp()) * normal / s;
    (terrain.traction * share * sx, -terrain.lateral * share * sy)
}

/// One physics step of `h` seconds of the car body, given its wheel speed and steering.
pub fn step_car(p: &CarParams, terrain: &Terrain, state: &mut CarState, h: f64) {
    let [vx, vy, w] = state.velocity;
    let l = p.cg_to_front + p.cg_to_rear;
    let weight = p.mass * G;
    let (normal_front, normal_rear) = (weight * p.cg_to_rear / l, weight * p.cg_to_front / l);
    let rolling = |normal: f64, v: f64| -terrain.rolling * normal * (v / 0.05).tanh();
    // Front tyre: free rolling, steered. Its velocity in the tyre's frame.
    let (sd, cd) = state.steering.sin_cos();
    let (fx_b, fy_b) = (vx, vy + p.cg_to_front * w);
    let (along, across) = (cd * fx_b + sd * fy_b, -sd * fx_b + cd * fy_b);
    let (_, lateral_front) = tyre_force(
        terrain,
        normal_front,
        0.0,
        across / along.abs().max(MIN_SLIP_SPEED),
    );
    let long_front = rolling(normal_front, along);
    // In the body frame.
    let (front_x, front_y) = (
        cd * long_front - sd * lateral_front,
        sd * long_front + cd * lateral_front,
    );
    // Rear tyre: driven at the wheel speed.
    let (along, across) = (vx, vy - p.cg_to_rear * w);
    let reference = state.wheel_speed.abs().max(along.abs()).max(MIN_SLIP_SPEED);
    let (drive, lateral_rear) = tyre_force(
        terrain,
        normal_rear,
        (state.wheel_speed - along) / reference,
        across / reference,
    );
    let rear_x = drive + rolling(normal_rear, along);
    let ax = (front_x + rear_x) / p.mass + w * vy;
    let ay = (front_y + lateral_rear) / p.mass - w * vx;
    let aw = (p.cg_to_front * front_y - p.cg_to_rear * lateral_rear) / p.yaw_inertia;
    let (vx, vy, w) = (vx + ax * h, vy + ay * h, w + aw * h);
    state.velocity = [vx, vy, w];
    let (s, c) = state.pose.z.sin_cos();
    state.pose += Pose::new((c * vx - s * vy) * h, (s * vx + c * vy) * h, w * h);
}

/// A simulated car on a terrain: the plant of the `ackermann` vehicle.
#[derive(Debug, Clone)]
pub struct CarSimulator {
    /// Physical parameters.
    pub params: CarParams,
    /// The ground.
    pub terrain: Terrain,
    /// Clock, command history and sensors (the encoder noise is not used: see the module
    /// documentation).
    pub instruments: Instruments,
    state: CarState,
    substeps: usize,
}

/// Noise of the measured speed (m/s) and steering angle (rad).
const INPUT_NOISE: [f64; 2] = [0.02, 0.005];

impl CarSimulator {
    /// A car for a robot with a car-like vehicle of `geometry` on a terrain, at rest at the
    /// origin, seeded.
    pub fn new(spec: &RobotSpec, geometry: &Ackermann, terrain: Terrain, seed: u64) -> Self {
        let params = CarParams::from_spec(spec, geometry);
        let rest = CarState {
            pose: Pose::new(params.cg_to_rear, 0.0, 0.0),
            velocity: [0.0; 3],
            wheel_speed: 0.0,
            steering: 0.0,
        };
        let sensors = terrain.sensors.unwrap_or_default();
        CarSimulator {
            params,
            terrain,
            instruments: Instruments::new(sensors, spec.rate_hz, seed),
            state: rest,
            substeps: ((1.0 / spec.rate_hz) / 2.5e-4).ceil().max(1.0) as usize,
        }
    }

    /// The true state.
    pub fn state(&self) -> &CarState {
        &self.state
    }
}

impl crate::Plant for CarSimulator {
    fn measure(&mut self) -> Measured {
        let input = Input::new(self.state.wheel_speed, self.state.steering, 0.0);
        let pose = self.state.rear_axle_pose(&self.params);
        self.instruments
            .measure(input, &INPUT_NOISE, pose, self.state.velocity[2])
    }

    fn advance(&mut self, command: Input) {
        self.instruments.record(command);
        let h = self.instruments.dt() / self.substeps as f64;
        let t0 = self.instruments.tick_start();
        let p = self.params.clone();
        for i in 0..self.substeps {
            let t = t0 + i as f64 * h;
            let speed = self.instruments.delayed(t, p.speed.delay).x;
            let steering = self.instruments.delayed(t, p.steering.delay).y + p.steering_trim;
            self.state.wheel_speed = p.speed.step(self.state.wheel_speed, speed, h);
            self.state.steering = p.steering.step(self.state.steering, steering, h);
            step_car(&p, &self.terrain, &mut self.state, h);
        }
        self.instruments.end_tick();
    }

    fn true_pose(&self) -> Option<Pose> {
        Some(
            self.instruments
                .mounted(&self.state.rear_axle_pose(&self.params)),
        )
    }
}
