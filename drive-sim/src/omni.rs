//! The omnidirectional base's plant: a body-velocity command through per-axis motor
//! dynamics, and the slip of mecanum rollers on the terrain.

use crate::{Instruments, Measured, Plant, Terrain};
use drive_samplers::RobotSpec;
use drive_traits::{euler_step, BodyVelocity, Input, InputSpace, Pose};

/// A kinematic simulator of an omnidirectional (mecanum) base commanded in body velocity
/// (`v_x, v_y, w`, [`Omnidirectional`](drive_models::vehicles::Omnidirectional)), with
/// slip.
///
/// Each input axis follows the command through a first-order lag (0.25 s) with a 0.1 s
/// dead time, saturated at the robot's input space: what the base's wheel odometry reports.
/// The body velocity follows, with a 0.15 s lag, the odometry's velocity less what the
/// rollers lose on the terrain:
/// - forward, the ratio of rolling resistance to traction (`rolling / traction`), and a
///   drift of `0.1 v_y w` (the rollers' side force turns with the body);
/// - sideways, where mecanum rollers slip most, `lateral / (lateral + traction)` plus the
///   forward loss, and an outward drift of `0.1 v_x w` in turns;
/// - in yaw, `lateral / (lateral + traction)` of the yaw rate (the wheels scrub to turn),
///   and `0.15 v_y` rad/m of the lateral speed (a base heavier at one end yaws when it
///   crabs).
///
/// Sensors as [`Sensors::default`](crate::Sensors::default) (or the terrain's); the
/// localization at their rate.
///
/// ```
/// use drive_sim::{OmniPlant, Plant, Terrain};
/// let robot = drive_samplers::builtin_robots().get("ridgeback").unwrap().part().as_ref().clone();
/// let terrain = Terrain::preset("tile").unwrap();
/// let mut plant = OmniPlant::new(&robot, &terrain, 1);
/// for _ in 0..100 {
///     plant.advance(drive_traits::Input::new(0.0, 0.5, 0.0));
/// }
/// let truth = plant.true_pose().unwrap();
/// // Five seconds sideways: it moved left, less than the 2.5 m commanded.
/// assert!(truth.y > 1.0 && truth.y < 2.5, "{truth}");
/// ```
pub struct OmniPlant {
    terrain: Terrain,
    instruments: Instruments,
    limits: InputSpace,
    inputs: Input,
    velocity: BodyVelocity,
    pose: Pose,
}

/// Time constant of each input axis (s).
const INPUT_LAG_S: f64 = 0.25;
/// Dead time of each input axis (s).
const INPUT_DELAY_S: f64 = 0.1;
/// Time constant of the body velocity (s).
const BODY_LAG_S: f64 = 0.15;
/// Forward drift per lateral speed and yaw rate (s).
const FORWARD_DRIFT: f64 = 0.1;
/// Outward drift per forward speed and yaw rate (s).
const OUTWARD_DRIFT: f64 = 0.1;
/// Yaw rate per lateral speed (rad/m).
const CRAB_YAW: f64 = 0.15;

impl OmniPlant {
    /// At rest at the origin, seeded.
    pub fn new(robot: &RobotSpec, terrain: &Terrain, seed: u64) -> Self {
        OmniPlant {
            terrain: terrain.clone(),
            instruments: Instruments::new(terrain.sensors.unwrap_or_default(), robot.rate_hz, seed),
            limits: robot.input_space(),
            inputs: Input::zeros(),
            velocity: BodyVelocity::zeros(),
            pose: Pose::zeros(),
        }
    }

    /// The body velocity the rollers deliver for the odometry's velocity `f`.
    fn delivered(&self, f: &BodyVelocity) -> BodyVelocity {
        let t = &self.terrain;
        let forward_loss = (t.rolling / t.traction).clamp(0.0, 1.0);
        let turn_loss = (t.lateral / (t.lateral + t.traction)).clamp(0.0, 1.0);
        let side_loss = (turn_loss + forward_loss).clamp(0.0, 1.0);
        BodyVelocity::new(
            f.x * (1.0 - forward_loss) + FORWARD_DRIFT * f.y * f.z,
            f.y * (1.0 - side_loss) - OUTWARD_DRIFT * f.x * f.z,
            f.z * (1.0 - turn_loss) - CRAB_YAW * f.y,
        )
    }
}

impl Plant for OmniPlant {
    fn measure(&mut self) -> Measured {
        let e = self.instruments.sensors.encoder_noise;
        // The odometry's velocities: the wheel-speed noise (rad/s) on wheels of about 0.1 m.
        let noise = [0.1 * e; 3];
        self.instruments
            .measure(self.inputs, &noise, self.pose, self.velocity.z)
    }

    fn advance(&mut self, command: Input) {
        self.instruments.record(command);
        let dt = self.instruments.dt();
        let substeps = 10;
        let h = dt / substeps as f64;
        let t0 = self.instruments.tick_start();
        for i in 0..substeps {
            let now = t0 + i as f64 * h;
            let target = self
                .limits
                .clamp(&self.instruments.delayed(now, INPUT_DELAY_S));
            self.inputs += (target - self.inputs) * (h / INPUT_LAG_S);
            let goal = self.delivered(&self.inputs);
            self.velocity += (goal - self.velocity) * (h / BODY_LAG_S);
            self.pose = euler_step(&self.pose, &self.velocity, h);
        }
        self.instruments.end_tick();
    }

    fn true_pose(&self) -> Option<Pose> {
        Some(self.instruments.mounted(&self.pose))
    }
}
