//! A planar skid-steer rigid body on a terrain: wheels or tracks touching the ground at
//! discrete contact points, each with a combined-slip friction force on a friction ellipse;
//! driven by torque-limited velocity-controlled motors behind a low-level controller.

use crate::Terrain;
use drive_models::DifferentialDrive;
use drive_samplers::RobotSpec;
use drive_traits::{Input, Pose};
use serde::{Deserialize, Serialize};

const G: f64 = 9.81;

/// Slip ratios are taken relative to the larger of the wheel and contact speeds, and at
/// least this speed (m/s): what keeps the ratio finite at rest.
const SLIP_SPEED_FLOOR: f64 = 0.3;

/// The motors and their velocity loop, per side.
///
/// The wheel follows its target with a first-order response (`rise` when it speeds up,
/// `fall` when it slows down) after a dead time, within an acceleration limit; the torque
/// this asks, plus the ground's reaction on the wheel, is limited to `torque_limit`: a side
/// whose traction load exceeds it slows down (what a current limit does), so the wheel
/// speed is not in the first-order plus dead time class.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PowertrainParams {
    /// Time constants of the velocity loop (s): speeding up, slowing down.
    #[serde(deserialize_with = "drive_traits::exact::array")]
    pub time_constant: [f64; 2],
    /// Dead time (s) of the left side.
    pub dead_time: f64,
    /// The right side's time constants and dead time, relative to the left's.
    pub right_lag: f64,
    /// Gain of the right side's velocity loop (1 for a symmetric robot).
    pub right_gain: f64,
    /// Largest wheel speed (rad/s), both directions.
    pub wheel_limit: f64,
    /// Largest wheel acceleration the loop asks (rad/s^2).
    pub acceleration_limit: f64,
    /// Largest motor torque per side, at the wheel (N m).
    pub torque_limit: f64,
    /// Rotating inertia per side, at the wheel (kg m^2).
    pub inertia: f64,
}

impl PowertrainParams {
    /// The project's default for a robot: the loop of the bundled Husky data's FOPDT fit
    /// (1.0 s rising, 0.8 s falling, 0.3 s dead time), the right side 15% slower, 7% later
    /// and 3% weaker; the wheels saturate at the top speed; accelerations up to four times
    /// the robot's linear acceleration limit; each side's motors push with at most 0.7 of
    /// the side's weight (so that they stall before the wheels spin on dry ground); the
    /// rotating parts weigh, at the wheel, a quarter of the robot's mass per side.
    pub fn for_robot(spec: &RobotSpec, wheel_radius: f64) -> Self {
        let side_weight = spec.mass_kg * G / 2.0;
        PowertrainParams {
            time_constant: [1.0, 0.8],
            dead_time: 0.3,
            right_lag: 1.07,
            right_gain: 0.97,
            wheel_limit: spec.max_speed / wheel_radius,
            acceleration_limit: 4.0 * spec.max_linear_acceleration.min(1e3) / wheel_radius,
            torque_limit: 0.7 * side_weight * wheel_radius,
            inertia: 0.25 * spec.mass_kg * wheel_radius.powi(2),
        }
    }

    /// The side's time constants and dead time (0 left, 1 right).
    pub fn lags(&self, side: usize) -> ([f64; 2], f64) {
        let k = if side == 1 { self.right_lag } else { 1.0 };
        (self.time_constant.map(|t| t * k), self.dead_time * k)
    }
}

/// The robot's low-level controller between the commanded wheel velocities and the
/// motors' targets: it reads the command as a body velocity (with the robot's nominal
/// geometry), scales and limits it, ramps towards it within body acceleration limits, and
/// converts it back to wheel targets (a Husky's controller, ROS `diff_drive_controller`,
/// for instance, turns with a wheel separation of its own, caps its speed and yaw rate and
/// limits the linear and angular accelerations separately, so that a wheel can first move
/// away from its new target). The identity by default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerParams {
    /// Gain on the commanded linear velocity.
    pub linear_gain: f64,
    /// Gain on the commanded yaw rate.
    pub angular_gain: f64,
    /// Largest linear velocity (m/s) the controller passes on.
    pub max_linear: Option<f64>,
    /// Largest yaw rate (rad/s) the controller passes on.
    pub max_angular: Option<f64>,
    /// Largest linear acceleration (m/s^2) of the controller's output.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_linear_acceleration: Option<f64>,
    /// Largest angular acceleration (rad/s^2) of the controller's output.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_angular_acceleration: Option<f64>,
}

impl Default for ControllerParams {
    fn default() -> Self {
        ControllerParams {
            linear_gain: 1.0,
            angular_gain: 1.0,
            max_linear: None,
            max_angular: None,
            max_linear_acceleration: None,
            max_angular_acceleration: None,
        }
    }
}

impl ControllerParams {
    /// The body velocity (forward speed, yaw rate) the controller aims at for commanded
    /// wheel velocities `u` on wheels of `radius` a `baseline` apart: scaled and capped.
    pub fn body_target(&self, u: Input, radius: f64, baseline: f64) -> [f64; 2] {
        let v = radius * (u.x + u.y) / 2.0 * self.linear_gain;
        let w = radius * (u.y - u.x) / baseline * self.angular_gain;
        [
            self.max_linear.map_or(v, |m| v.clamp(-m, m)),
            self.max_angular.map_or(w, |m| w.clamp(-m, m)),
        ]
    }

    /// Steps the controller's output `body` towards `target` for `h` seconds within its
    /// acceleration limits.
    ///
    /// ```
    /// let c = drive_sim::ControllerParams { max_linear_acceleration: Some(1.0), ..Default::default() };
    /// let mut body = [0.0, 0.0];
    /// c.ramp(&mut body, [2.0, -3.0], 0.5);
    /// assert_eq!(body, [0.5, -3.0]); // the yaw rate has no limit
    /// ```
    pub fn ramp(&self, body: &mut [f64; 2], target: [f64; 2], h: f64) {
        for (i, limit) in [self.max_linear_acceleration, self.max_angular_acceleration]
            .into_iter()
            .enumerate()
        {
            let step = limit.map_or(f64::INFINITY, |a| a * h);
            body[i] += (target[i] - body[i]).clamp(-step, step);
        }
    }

    /// The wheel targets of a body velocity (forward speed, yaw rate).
    pub fn wheels(body: [f64; 2], radius: f64, baseline: f64) -> Input {
        let [v, w] = body;
        Input::new(
            (v - w * baseline / 2.0) / radius,
            (v + w * baseline / 2.0) / radius,
            0.0,
        )
    }

    /// The wheel targets for commanded wheel velocities `u`, the output settled (no
    /// acceleration limit in the way).
    pub fn targets(&self, u: Input, radius: f64, baseline: f64) -> Input {
        if *self == ControllerParams::default() {
            return u;
        }
        Self::wheels(self.body_target(u, radius, baseline), radius, baseline)
    }

    /// True when the output ramps (an acceleration limit is set).
    pub fn ramps(&self) -> bool {
        self.max_linear_acceleration.is_some() || self.max_angular_acceleration.is_some()
    }
}

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
    /// Length of the contact along each side (m): 0.9 x baseline for wheels (the distance
    /// between the front and rear axles), 1.1 x for tracks.
    pub wheelbase: f64,
    /// Longitudinal positions of the contact points of each side (m, from the centre): the
    /// two axles for wheels, five points along the track for tracks.
    pub contacts: Vec<f64>,
    /// The motors.
    pub powertrain: PowertrainParams,
    /// The low-level controller.
    pub controller: ControllerParams,
}

impl VehicleParams {
    /// Parameters for a robot description with a differential-drive vehicle of that
    /// geometry, with the default powertrain ([`PowertrainParams::for_robot`]) and an
    /// identity controller.
    pub fn from_spec(spec: &RobotSpec, geometry: &DifferentialDrive) -> Self {
        let baseline = geometry.baseline;
        let wheelbase = Self::nominal_contact_spread(spec.tracked) * baseline;
        let mass = spec.mass_kg;
        VehicleParams {
            mass,
            inertia: mass * (wheelbase.powi(2) + baseline.powi(2)) / 12.0,
            wheel_radius: geometry.wheel_radius,
            baseline,
            wheelbase,
            contacts: Self::contacts(spec.tracked, wheelbase),
            powertrain: PowertrainParams::for_robot(spec, geometry.wheel_radius),
            controller: ControllerParams::default(),
        }
    }

    /// The contacts' spread along each side of a vehicle as a share of its baseline: 0.9
    /// for wheels (the axles' distance), 1.1 for tracks.
    pub fn nominal_contact_spread(tracked: bool) -> f64 {
        if tracked {
            1.1
        } else {
            0.9
        }
    }

    /// The contact points along a side spread over `length` (m): the two axles for wheels,
    /// five points for tracks.
    fn contacts(tracked: bool, length: f64) -> Vec<f64> {
        if tracked {
            (0..5).map(|i| (i as f64 / 4.0 - 0.5) * length).collect()
        } else {
            vec![length / 2.0, -length / 2.0]
        }
    }

    /// The same vehicle with its contacts spread over `share` of the baseline along each
    /// side ([`Terrain::contact_spread`](crate::Terrain::contact_spread)): where the ground
    /// holds the wheels, not the body's mass, so the yaw inertia stays.
    ///
    /// ```
    /// use drive_sim::VehicleParams;
    /// let robot = drive_samplers::RobotSpec::load(&drive_samplers::builtin_robots(), "husky").unwrap();
    /// let geometry = drive_models::DifferentialDrive::new(0.165, 0.55);
    /// let nominal = VehicleParams::from_spec(&robot, &geometry);
    /// let short = nominal.clone().with_contact_spread(0.6);
    /// assert!((short.wheelbase - 0.6 * nominal.baseline).abs() < 1e-12);
    /// assert_eq!(short.contacts, vec![short.wheelbase / 2.0, -short.wheelbase / 2.0]);
    /// assert_eq!(short.inertia, nominal.inertia);
    /// ```
    pub fn with_contact_spread(mut self, share: f64) -> Self {
        let tracked = self.contacts.len() > 2;
        self.wheelbase = share * self.baseline;
        self.contacts = Self::contacts(tracked, self.wheelbase);
        self
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

impl VehicleState {
    /// At the origin, its wheels at `wheels` and the body moving as they give without slip
    /// (eq. 4): where a settling from the measured wheel speeds starts.
    pub(crate) fn without_slip(p: &VehicleParams, wheels: Input) -> Self {
        VehicleState {
            pose: Pose::zeros(),
            velocity: [
                p.wheel_radius * (wheels.x + wheels.y) / 2.0,
                0.0,
                p.wheel_radius * (wheels.y - wheels.x) / p.baseline,
            ],
            wheels,
        }
    }
}

/// Smooth sign: `tanh(x / scale)`, to keep Coulomb-type forces continuous.
fn smooth_sign(x: f64, scale: f64) -> f64 {
    (x / scale).tanh()
}

/// The ground's force on one contact point (N, body frame) with normal load `normal`, for a
/// wheel surface moving at `surface` (m/s, forward) over a contact point moving at
/// `(vx, vy)`: the slip vector `(surface - vx, -vy)` relative to the larger speed, each
/// component over its slip modulus (`k` along the wheel, the lateral one across it, `k` when
/// the terrain gives none), the magnitude of that on the Janosi-Hanamoto curve
/// `1 - exp(-|s|)`, the force along it on the friction ellipse of semi-axes `mu_x N`
/// (traction) and `mu_y N` (lateral).
pub fn contact_force(terrain: &Terrain, normal: f64, surface: f64, vx: f64, vy: f64) -> [f64; 2] {
    let speed = slip_reference_speed(surface.abs(), vx, vy);
    let (sx, sy) = ((surface - vx) / speed, -vy / speed);
    let k = terrain.slip_modulus;
    let Some(across) = terrain.lateral_slip_modulus else {
        // One modulus: the slip's magnitude over it.
        let s = sx.hypot(sy);
        if s < 1e-12 {
            return [0.0, 0.0];
        }
        let shear = normal * (1.0 - (-s / k).exp()) / s;
        return [terrain.traction * shear * sx, terrain.lateral * shear * sy];
    };
    let (sx, sy) = (sx / k, sy / across);
    let s = sx.hypot(sy);
    if s < 1e-12 {
        return [0.0, 0.0];
    }
    let shear = normal * (1.0 - (-s).exp()) / s;
    [terrain.traction * shear * sx, terrain.lateral * shear * sy]
}

/// `surface.max(vx.hypot(vy)).max(SLIP_SPEED_FLOOR)`, bit for bit, without the `hypot`
/// (a sixth of a simulation's time) where squares tell the result: when the contact point's
/// speed is clearly below the wheel surface's or the floor (by a relative 1e-9, far beyond
/// `hypot`'s rounding), the maximum is the other one.
fn slip_reference_speed(surface: f64, vx: f64, vy: f64) -> f64 {
    const MARGIN: f64 = 1.0 + 1e-9;
    let ground2 = vx * vx + vy * vy;
    let above = surface.max(SLIP_SPEED_FLOOR);
    if above * above > ground2 * MARGIN {
        // NaNs fail the comparison and take the full path.
        above
    } else {
        // max is exact and order-free here (the floor is positive): the same bits.
        above.max(vx.hypot(vy))
    }
}

/// The ground's forces on the body: longitudinal and lateral force (N) and yaw moment
/// (N m), and the traction of each side (N, what loads its motors).
fn ground_forces(p: &VehicleParams, terrain: &Terrain, state: &VehicleState) -> ([f64; 3], Input) {
    let [vx, vy, w] = state.velocity;
    let n = p.contacts.len().max(1) as f64;
    let normal = p.mass * G / (2.0 * n);
    let half = p.baseline / 2.0;
    let (mut fx, mut fy, mut mz) = (0.0, 0.0, 0.0);
    let mut sides = Input::zeros();
    // Left side at y = +b/2, right at -b/2 (x forward, y left).
    for (side, y) in [(0usize, half), (1, -half)] {
        let surface = p.wheel_radius * state.wheels[side];
        for &x in &p.contacts {
            let [cx, cy] = contact_force(terrain, normal, surface, vx - w * y, vy + w * x);
            fx += cx;
            fy += cy;
            mz += x * cy - y * cx;
            sides[side] += cx;
        }
    }
    let rolling = -terrain.rolling * p.mass * G * smooth_sign(vx, 0.05);
    ([fx + rolling, fy, mz], sides)
}

/// One physics step of `h` seconds with the motors' targets `targets` (rad/s, after the
/// controller and the dead time): the wheels' velocity loops against the ground's reaction,
/// then semi-implicit Euler on the body velocity and the pose.
pub fn step_body(
    p: &VehicleParams,
    terrain: &Terrain,
    state: &mut VehicleState,
    targets: Input,
    h: f64,
) {
    let ([fx, fy, mz], sides) = ground_forces(p, terrain, state);
    let pt = &p.powertrain;
    for side in 0..2 {
        let w = state.wheels[side];
        let u = targets[side].clamp(-pt.wheel_limit, pt.wheel_limit);
        let ([rise, fall], _) = pt.lags(side);
        let speeding_up = (u - w) * w >= 0.0;
        let tau = if speeding_up { rise } else { fall };
        let wanted = ((u - w) / tau).clamp(-pt.acceleration_limit, pt.acceleration_limit);
        // The torque that acceleration needs against the ground's reaction on the wheel.
        let load = p.wheel_radius * sides[side];
        let torque = (pt.inertia * wanted + load).clamp(-pt.torque_limit, pt.torque_limit);
        let accel = (torque - load) / pt.inertia;
        // Never past the target within a step (the loop does not overshoot).
        let next = w + accel * h;
        state.wheels[side] = if (next - u) * (w - u) < 0.0 && torque.abs() < pt.torque_limit {
            u
        } else {
            next
        };
    }
    let [vx, vy, w] = state.velocity;
    let ax = fx / p.mass + w * vy;
    let ay = fy / p.mass - w * vx;
    let aw = mz / p.inertia;
    let (vx, vy, w) = (vx + ax * h, vy + ay * h, w + aw * h);
    state.velocity = [vx, vy, w];
    let (s, c) = state.pose.z.sin_cos();
    state.pose += Pose::new((c * vx - s * vy) * h, (s * vx + c * vy) * h, w * h);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::Xoshiro256PlusPlus;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn the_slip_reference_speed_is_the_hypot_formulas_bit_for_bit() {
        let full = |s: f64, vx: f64, vy: f64| s.max(vx.hypot(vy)).max(SLIP_SPEED_FLOOR);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let mut shortcut = 0;
        for i in 0..200_000 {
            // Speeds over six decades, and ties: the surface at the contact point's speed.
            let scale = 10f64.powf(rng.random_range(-3.0..3.0));
            let (vx, vy) = (
                scale * rng.random_range(-1.0..1.0),
                scale * rng.random_range(-1.0..1.0),
            );
            let s = if i % 5 == 0 {
                vx.hypot(vy)
            } else {
                scale * rng.random_range(0.0..1.5)
            };
            let (a, b) = (slip_reference_speed(s, vx, vy), full(s, vx, vy));
            assert_eq!(a.to_bits(), b.to_bits(), "{s} {vx} {vy}");
            let ground2 = vx * vx + vy * vy;
            let above = s.max(SLIP_SPEED_FLOOR);
            shortcut += usize::from(above * above > ground2 * (1.0 + 1e-9));
        }
        // Both paths are taken.
        assert!(shortcut > 50_000 && shortcut < 150_000, "{shortcut}");
        for (s, vx, vy) in [(f64::NAN, 1.0, 0.0), (1.0, f64::NAN, 0.0), (0.0, 0.0, 0.0)] {
            assert_eq!(
                slip_reference_speed(s, vx, vy).to_bits(),
                full(s, vx, vy).to_bits()
            );
        }
    }

    /// The steady forward speed and yaw rate of `p` on `terrain` with its wheels held at
    /// `wheels`, from the no-slip velocity.
    fn steady(p: &VehicleParams, terrain: &Terrain, wheels: Input) -> [f64; 2] {
        let mut state = VehicleState::without_slip(p, wheels);
        for _ in 0..3000 {
            step_body(p, terrain, &mut state, wheels, 1e-3);
            state.wheels = wheels;
        }
        [state.velocity[0], state.velocity[2]]
    }

    #[test]
    fn a_shorter_contact_spread_costs_a_turn_less_speed_and_leaves_straight_driving_alone() {
        let robot =
            drive_samplers::RobotSpec::load(&drive_samplers::builtin_robots(), "husky").unwrap();
        let g = drive_models::DifferentialDrive::new(0.165, 0.55);
        let own = VehicleParams::from_spec(&robot, &g);
        assert!((own.wheelbase - 0.9 * 0.55).abs() < 1e-12);
        let short = own.clone().with_contact_spread(0.6);
        let gravel = Terrain::preset("gravel").unwrap();
        // A curve: the left wheels at 2 rad/s, the right at 6.
        let curve = Input::new(2.0, 6.0, 0.0);
        let (a, b) = (steady(&own, &gravel, curve), steady(&short, &gravel, curve));
        // The ideal (eq. 4): 0.66 m/s and 1.2 rad/s. The ground's turning resistance has a
        // shorter lever: both kept closer to it.
        assert!(b[0] > a[0] + 0.01 && b[0] < 0.66, "{a:?} {b:?}");
        assert!(b[1] > a[1] + 0.01 && b[1] < 1.2, "{a:?} {b:?}");
        // Straight ahead, nothing scrubs sideways: the spread does not matter.
        let straight = Input::new(4.0, 4.0, 0.0);
        let (a, b) = (
            steady(&own, &gravel, straight),
            steady(&short, &gravel, straight),
        );
        assert!((a[0] - b[0]).abs() < 1e-9 && a[1].abs() < 1e-9 && b[1].abs() < 1e-9);
        // Tracks keep their five points along the shorter spread.
        let tracked = VehicleParams {
            contacts: vec![-0.3, -0.15, 0.0, 0.15, 0.3],
            ..own
        }
        .with_contact_spread(0.6);
        let half = 0.3 * 0.55;
        assert_eq!(tracked.contacts.len(), 5);
        assert!(
            (tracked.contacts[0] + half).abs() < 1e-12
                && (tracked.contacts[4] - half).abs() < 1e-12
        );
    }
}
