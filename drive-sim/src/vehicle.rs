//! A planar skid-steer rigid body on a terrain, driven through a saturating first-order
//! plus dead time powertrain with a left/right asymmetry.

use crate::Terrain;
use drive_models::DifferentialDrive;
use drive_samplers::RobotSpec;
use drive_traits::{Input, Pose};

const G: f64 = 9.81;

/// The vehicle's physical parameters (derived from a robot description).
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleParams {
    /// Mass (kg).
    pub mass: f64,
    /// Yaw inertia (kg m^2): a uniform box of length `wheelbase` and width `baseline`.
    pub inertia: f64,
    /// Wheel or sprocket radius (m).
    pub wheel_radius: f64,
    /// Distance between the left and right contact lines (m).
    pub baseline: f64,
    /// Length of the contact along each side (m): 0.9 x baseline for wheels, 1.1 x for tracks.
    pub wheelbase: f64,
    /// Wheel velocity saturation (rad/s), both directions.
    pub wheel_limit: f64,
    /// Powertrain time constant (s) and dead time (s), left and right.
    pub powertrain: [(f64, f64); 2],
    /// Gain of the right side's motor controller (asymmetry), 1 for a symmetric robot.
    pub right_gain: f64,
}

impl VehicleParams {
    /// Parameters for a robot description with a differential-drive vehicle of that
    /// geometry. The wheels saturate at the top speed; the powertrain is 1.0 s / 0.3 s (what
    /// the FOPDT fit finds on the bundled Husky data), with the right side 15% slower and
    /// 20 ms later, and a 3% lower gain.
    pub fn from_spec(spec: &RobotSpec, geometry: &DifferentialDrive) -> Self {
        let baseline = geometry.baseline;
        let wheelbase = if spec.tracked { 1.1 } else { 0.9 } * baseline;
        let mass = spec.mass_kg;
        VehicleParams {
            mass,
            inertia: mass * (wheelbase.powi(2) + baseline.powi(2)) / 12.0,
            wheel_radius: geometry.wheel_radius,
            baseline,
            wheelbase,
            wheel_limit: spec.max_speed / geometry.wheel_radius,
            powertrain: [(1.0, 0.3), (1.15, 0.32)],
            right_gain: 0.97,
        }
    }
}

/// The true state of the simulated vehicle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleState {
    /// Pose in the world.
    pub pose: Pose,
    /// Body velocity: longitudinal, lateral (m/s) and yaw rate (rad/s).
    pub velocity: [f64; 3],
    /// Wheel angular velocities, left and right (rad/s).
    pub wheels: Input,
}

/// Smooth sign: `tanh(x / scale)`, to keep Coulomb-type forces continuous.
fn smooth_sign(x: f64, scale: f64) -> f64 {
    (x / scale).tanh()
}

/// Longitudinal traction of one side (N) for a slip velocity `slip = r w - v_contact`,
/// Janosi-Hanamoto shear model: `mu N (1 - exp(-|s| / k)) sign(s)` on the slip ratio `s`.
fn traction(terrain: &Terrain, normal: f64, slip: f64, speed: f64) -> f64 {
    let ratio = slip / speed.max(0.3);
    terrain.traction * normal * (1.0 - (-ratio.abs() / terrain.slip_modulus).exp()) * ratio.signum()
}

/// One physics step of `h` seconds with wheel velocities `wheels` (already through the
/// powertrain): forces, then semi-implicit Euler on the body velocity and the pose.
pub fn step_body(p: &VehicleParams, terrain: &Terrain, state: &mut VehicleState, h: f64) {
    let [vx, vy, w] = state.velocity;
    let normal = p.mass * G / 2.0;
    let half = p.baseline / 2.0;
    // Contact-line speeds: left side at y = +b/2, right at -b/2.
    let v_left = vx - w * half;
    let v_right = vx + w * half;
    let f_left = traction(
        terrain,
        normal,
        p.wheel_radius * state.wheels.x - v_left,
        (p.wheel_radius * state.wheels.x).abs().max(v_left.abs()),
    );
    let f_right = traction(
        terrain,
        normal,
        p.wheel_radius * state.wheels.y - v_right,
        (p.wheel_radius * state.wheels.y).abs().max(v_right.abs()),
    );
    let weight = p.mass * G;
    let rolling = -terrain.rolling * weight * smooth_sign(vx, 0.05);
    // Lateral skid resistance and the moment of turning resistance (Wong: mu_t W l / 4 for
    // a uniform pressure along contact lines of length l).
    let lateral = -terrain.lateral * weight * smooth_sign(vy, 0.05);
    let turning =
        -terrain.lateral * weight * p.wheelbase / 4.0 * smooth_sign(w * p.wheelbase / 2.0, 0.05);
    let ax = (f_left + f_right + rolling) / p.mass + w * vy;
    let ay = lateral / p.mass - w * vx;
    let aw = ((f_right - f_left) * half + turning) / p.inertia;
    let (vx, vy, w) = (vx + ax * h, vy + ay * h, w + aw * h);
    state.velocity = [vx, vy, w];
    let (s, c) = state.pose.z.sin_cos();
    state.pose += Pose::new((c * vx - s * vy) * h, (s * vx + c * vy) * h, w * h);
}
