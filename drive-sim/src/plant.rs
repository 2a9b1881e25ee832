//! Plants: what is simulated for a vehicle. The `differential` vehicle has the skid-steer
//! rigid body of [`Simulator`]; a vehicle without a registered plant is simulated by the
//! [`KinematicPlant`], so that any vehicle (a plug-in's) can run the protocol.

use crate::{CarSimulator, Instruments, Measured, OmniPlant, Simulator, Terrain};
use drive_models::vehicles::{Ackermann, Omnidirectional};
use drive_models::DifferentialDrive;
use drive_samplers::RobotSpec;
use drive_traits::{
    euler_step, vehicle_as, vehicle_tag, BodyVelocity, Input, InputSpace, Pose, Registry,
    RegistryItem,
};
use std::sync::Arc;

/// A simulated vehicle advanced one command tick at a time.
///
/// ```
/// use drive_sim::{Measured, Plant};
/// use drive_traits::{Input, Pose};
///
/// /// A vehicle that reaches every command at once and never moves (a robot on a stand).
/// struct OnAStand { t: f64, last: Input }
/// impl Plant for OnAStand {
///     fn measure(&mut self) -> Measured {
///         Measured { t: self.t, input: self.last, pose: Pose::zeros(), fresh_pose: true, imu_yaw_rate: 0.0, pose_time: self.t }
///     }
///     fn advance(&mut self, command: Input) { self.last = command; self.t += 0.05; }
/// }
/// let mut p = OnAStand { t: 0.0, last: Input::zeros() };
/// p.advance(Input::new(1.0, 2.0, 0.0));
/// assert_eq!(p.measure().input, Input::new(1.0, 2.0, 0.0));
/// ```
pub trait Plant: Send {
    /// What the robot's sensors report at the current tick.
    fn measure(&mut self) -> Measured;
    /// Applies `command` (the vehicle's inputs) for one command tick.
    fn advance(&mut self, command: Input);
    /// Where the localization's frame truly is now: the pose the localization measures,
    /// without its noise, latency or update rate (what a closed-loop experiment scores);
    /// `None` for a plant that does not know (the default).
    fn true_pose(&self) -> Option<Pose> {
        None
    }
    /// Drives on from now on `ground` (a ground that changes along the way: `drive track
    /// --terrains`): its grip, slip and resistances replace the plant's, while the robot
    /// (its powertrain, controller, sensors and contact spread, a twin's included) stays
    /// the one the plant was made with. An error for a plant that keeps one ground (the
    /// default), saying so.
    fn change_ground(&mut self, ground: &Terrain) -> Result<(), PlantError> {
        Err(PlantError(format!(
            "this simulator keeps the ground it was made with (cannot drive onto '{}')",
            ground.name
        )))
    }
}

/// Builds the plant of a robot on a terrain, seeded: what the simulator registry holds, by
/// vehicle type. Implemented for every function or closure `Fn(&RobotSpec, &Terrain, u64)
/// -> Result<Box<dyn Plant>, PlantError>`.
///
/// ```
/// use drive_samplers::RobotSpec;
/// use drive_sim::{builtin_plants, KinematicPlant, Plant, Terrain};
/// use std::sync::Arc;
/// let mut plants = builtin_plants();
/// // The kinematic stand-in, registered for a vehicle type of one's own.
/// plants
///     .register("my-vehicle", "kinematic, for now", Arc::new(|robot: &RobotSpec, terrain: &Terrain, seed: u64| {
///         Ok(Box::new(KinematicPlant::new(robot, terrain, seed)) as Box<dyn Plant>)
///     }))
///     .unwrap();
/// assert_eq!(plants.names(), ["differential", "ackermann", "omnidirectional", "my-vehicle"]);
/// ```
pub trait MakePlant: Send + Sync {
    /// The plant; an error when the robot's vehicle is not the kind this plant simulates.
    fn make(
        &self,
        robot: &RobotSpec,
        terrain: &Terrain,
        seed: u64,
    ) -> Result<Box<dyn Plant>, PlantError>;
}

/// Why a simulator cannot simulate a robot (its vehicle is not the kind the plant
/// simulates, its geometry is out of the plant's range), with why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct PlantError(pub String);

impl From<String> for PlantError {
    fn from(message: String) -> Self {
        PlantError(message)
    }
}

impl From<&str> for PlantError {
    fn from(message: &str) -> Self {
        PlantError(message.to_string())
    }
}

/// The message.
impl std::ops::Deref for PlantError {
    type Target = str;
    fn deref(&self) -> &str {
        &self.0
    }
}

/// Any closure `Fn(&RobotSpec, &Terrain, u64) -> Result<Box<dyn Plant>, PlantError>` (a
/// `&str` or a `String` becomes one with `?` or `.into()`).
impl<F> MakePlant for F
where
    F: Fn(&RobotSpec, &Terrain, u64) -> Result<Box<dyn Plant>, PlantError> + Send + Sync,
{
    fn make(
        &self,
        robot: &RobotSpec,
        terrain: &Terrain,
        seed: u64,
    ) -> Result<Box<dyn Plant>, PlantError> {
        self(robot, terrain, seed)
    }
}

impl RegistryItem for dyn MakePlant {}

/// The plants of this project by vehicle type: `differential`, the skid-steer rigid body;
/// `ackermann`, the car ([`CarSimulator`]); `omnidirectional`, a mecanum base
/// ([`OmniPlant`]).
pub fn builtin_plants() -> Registry<dyn MakePlant> {
    let mut r: Registry<dyn MakePlant> = Registry::new("simulator");
    let skid_steer = |robot: &RobotSpec, terrain: &Terrain, seed: u64| {
        let geometry: DifferentialDrive = vehicle_as(robot.vehicle.as_ref())
            .ok_or("the skid-steer simulator needs a differential-drive vehicle")?;
        Ok(Box::new(Simulator::new(robot, &geometry, terrain.clone(), seed)) as Box<dyn Plant>)
    };
    let car = |robot: &RobotSpec, terrain: &Terrain, seed: u64| {
        let geometry: Ackermann = vehicle_as(robot.vehicle.as_ref())
            .ok_or("the car simulator needs an ackermann vehicle")?;
        reads_ground_only("car", terrain)?;
        Ok(Box::new(CarSimulator::new(robot, &geometry, terrain.clone(), seed)) as Box<dyn Plant>)
    };
    let omni = |robot: &RobotSpec, terrain: &Terrain, seed: u64| {
        let _: Omnidirectional = vehicle_as(robot.vehicle.as_ref())
            .ok_or("the omnidirectional simulator needs an omnidirectional vehicle")?;
        reads_ground_only("omnidirectional", terrain)?;
        Ok(Box::new(OmniPlant::new(robot, terrain, seed)) as Box<dyn Plant>)
    };
    let parts: [(&str, &str, Arc<dyn MakePlant>); 3] = [
        (
            "differential",
            "planar rigid body with Janosi-Hanamoto traction per side, turning resistance, rolling resistance, a saturating asymmetric FOPDT powertrain, encoders, 10 Hz ICP, IMU",
            Arc::new(skid_steer),
        ),
        (
            "ackermann",
            "dynamic bicycle: combined-slip tyres on a friction ellipse, rear-wheel drive behind a rate-limited speed loop, a steering servo with trim, wheel speed and steering sensors, 10 Hz ICP of the rear axle, IMU",
            Arc::new(car),
        ),
        (
            "omnidirectional",
            "kinematic mecanum base: a lag and dead time per body-velocity axis, the rollers' terrain slip (forward, a larger share sideways, in yaw), drifts in turns and a yaw when crabbing, wheel odometry, 10 Hz ICP, IMU",
            Arc::new(omni),
        ),
    ];
    for (name, description, part) in parts {
        // Distinct built-in names.
        r.register_trusted(name, description, part)
            .expect("distinct built-in plants");
    }
    r
}

/// The plant of `robot` on `terrain`: the one registered for its vehicle type, or the
/// [`KinematicPlant`].
pub fn plant_for(
    plants: &Registry<dyn MakePlant>,
    robot: &RobotSpec,
    terrain: &Terrain,
    seed: u64,
) -> Result<Box<dyn Plant>, PlantError> {
    let tag = vehicle_tag(robot.vehicle.as_ref()).unwrap_or_default();
    match plants.find(&tag) {
        Some(p) => p.part().make(robot, terrain, seed),
        None => {
            reads_ground_only("kinematic stand-in", terrain)?;
            Ok(Box::new(KinematicPlant::new(robot, terrain, seed)))
        }
    }
}

/// `Err` naming the parts of `terrain` a simulator that reads the ground and the sensors
/// only (the car, the mecanum base, the kinematic stand-in) would ignore: a skid-steer
/// twin's powertrain, controller, variability, turn stall, contact spread or lateral slip
/// modulus. A terrain is never driven with parts of it silently left out.
///
/// ```
/// use drive_sim::{builtin_plants, plant_for, Terrain};
/// let base = drive_traits::robot::ridgeback();
/// let mut ground = Terrain::preset("gravel").unwrap();
/// assert!(plant_for(&builtin_plants(), &base, &ground, 1).is_ok());
/// ground.contact_spread = Some(0.8);
/// let e = plant_for(&builtin_plants(), &base, &ground, 1).err().unwrap();
/// assert!(e.contains("contact_spread"), "{e}");
/// ```
pub fn reads_ground_only(simulator: &str, terrain: &Terrain) -> Result<(), PlantError> {
    let unread: Vec<&str> = [
        ("[powertrain]", terrain.powertrain.is_some()),
        ("[controller]", terrain.controller.is_some()),
        ("[variability]", terrain.variability.is_some()),
        ("[turn_stall]", terrain.turn_stall.is_some()),
        ("contact_spread", terrain.contact_spread.is_some()),
        (
            "lateral_slip_modulus",
            terrain.lateral_slip_modulus.is_some(),
        ),
    ]
    .into_iter()
    .filter_map(|(name, given)| given.then_some(name))
    .collect();
    if unread.is_empty() {
        Ok(())
    } else {
        Err(PlantError(format!(
            "the {simulator} simulator reads the terrain's ground (traction, slip_modulus, lateral, rolling) and [sensors] only; terrain '{}' also gives {} (a skid-steer twin's parts), which it would ignore",
            terrain.name,
            unread.join(", ")
        )))
    }
}

/// Which simulator [`plant_for`] runs for `robot`: the name registered for its vehicle type,
/// or `None` for the [`KinematicPlant`] stand-in (no simulator registered for it).
///
/// ```
/// use drive_sim::{builtin_plants, simulator_of};
/// let robot = drive_samplers::RobotSpec::load(&drive_samplers::builtin_robots(), "husky").unwrap();
/// assert_eq!(simulator_of(&builtin_plants(), &robot).as_deref(), Some("differential"));
/// // Nothing registered for it: the kinematic stand-in runs.
/// let none = drive_traits::Registry::<dyn drive_sim::MakePlant>::new("simulator");
/// assert_eq!(simulator_of(&none, &robot), None);
/// ```
pub fn simulator_of(plants: &Registry<dyn MakePlant>, robot: &RobotSpec) -> Option<String> {
    let tag = vehicle_tag(robot.vehicle.as_ref()).unwrap_or_default();
    plants.find(&tag).map(|_| tag)
}

/// Which simulator runs a robot, as every simulating command reports it (text and JSON):
/// the one registered for its vehicle type, or the kinematic stand-in.
///
/// ```
/// use drive_sim::{builtin_plants, simulator_used};
/// let robot = drive_samplers::RobotSpec::load(&drive_samplers::builtin_robots(), "husky").unwrap();
/// let used = simulator_used(&builtin_plants(), &robot);
/// assert_eq!((used.name.as_str(), used.stand_in), ("differential", false));
/// let none = drive_traits::Registry::<dyn drive_sim::MakePlant>::new("simulator");
/// let used = simulator_used(&none, &robot);
/// assert!(used.stand_in && used.to_string().starts_with("kinematic stand-in"));
/// ```
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct SimulatorUsed {
    /// The simulator's registered name, or `kinematic` for the stand-in.
    pub name: String,
    /// Whether it is the [`KinematicPlant`] stand-in (no simulator is registered for the
    /// vehicle type): not a physics model.
    pub stand_in: bool,
    /// The vehicle type it was chosen for.
    pub vehicle: String,
}

impl std::fmt::Display for SimulatorUsed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.stand_in {
            write!(
                f,
                "kinematic stand-in (no simulator is registered for the vehicle type {}: a lag per input axis and a terrain loss on the commanded body velocity, not a physics model)",
                self.vehicle
            )
        } else {
            write!(
                f,
                "{} (registered for the vehicle type {})",
                self.name, self.vehicle
            )
        }
    }
}

/// Which simulator [`plant_for`] runs for `robot`, named.
pub fn simulator_used(plants: &Registry<dyn MakePlant>, robot: &RobotSpec) -> SimulatorUsed {
    let vehicle = vehicle_tag(robot.vehicle.as_ref()).unwrap_or_default();
    match simulator_of(plants, robot) {
        Some(name) => SimulatorUsed {
            name,
            stand_in: false,
            vehicle,
        },
        None => SimulatorUsed {
            name: "kinematic".into(),
            stand_in: true,
            vehicle,
        },
    }
}

/// A simulator for any vehicle, from its command model alone: not a physics model, a
/// stand-in that lets a new vehicle run the protocol and the models before it has one.
///
/// Each input axis follows the command through a first-order lag (0.3 s) with a 0.1 s dead
/// time, saturated at the robot's input space; the vehicle's command model gives the
/// commanded body velocity, of which a terrain-dependent fraction is lost: forward, the
/// ratio of rolling resistance to traction (`rolling / traction`, 2% on tile to 27% on
/// snow), and as much of a commanded lateral velocity (a crab); in yaw, the share of
/// turning resistance (`lateral / (lateral + traction)`); a drift outwards in turns adds
/// `-0.1 v_x w` sideways. The body velocity follows that target with a 0.2 s lag. Sensors
/// as [`Sensors::default`](crate::Sensors::default), the encoders' noise on every input
/// axis; localization at 10 Hz.
pub struct KinematicPlant {
    robot: RobotSpec,
    terrain: Terrain,
    instruments: Instruments,
    limits: InputSpace,
    inputs: Input,
    velocity: BodyVelocity,
    pose: Pose,
}

/// Time constant of each input axis (s).
const INPUT_LAG_S: f64 = 0.3;
/// Dead time of each input axis (s).
const INPUT_DELAY_S: f64 = 0.1;
/// Time constant of the body velocity (s).
const BODY_LAG_S: f64 = 0.2;

impl KinematicPlant {
    /// At rest at the origin, seeded.
    pub fn new(robot: &RobotSpec, terrain: &Terrain, seed: u64) -> Self {
        KinematicPlant {
            robot: robot.clone(),
            terrain: terrain.clone(),
            instruments: Instruments::new(terrain.sensors.unwrap_or_default(), robot.rate_hz, seed),
            limits: robot.input_space(),
            inputs: Input::zeros(),
            velocity: BodyVelocity::zeros(),
            pose: Pose::zeros(),
        }
    }
}

impl Plant for KinematicPlant {
    fn measure(&mut self) -> Measured {
        // The encoders' noise on every input axis the vehicle has.
        let e = self.instruments.sensors.encoder_noise;
        let axes = self.robot.vehicle.input_dim().min(drive_traits::MAX_INPUTS);
        self.instruments.measure(
            self.inputs,
            &[e; drive_traits::MAX_INPUTS][..axes],
            self.pose,
            self.velocity.z,
        )
    }

    fn advance(&mut self, command: Input) {
        self.instruments.record(command);
        let dt = self.instruments.dt();
        let substeps = 10;
        let h = dt / substeps as f64;
        let t0 = self.instruments.tick_start();
        let t = &self.terrain;
        let forward_loss = (t.rolling / t.traction).clamp(0.0, 1.0);
        let yaw_loss = (t.lateral / (t.lateral + t.traction)).clamp(0.0, 1.0);
        for i in 0..substeps {
            let now = t0 + i as f64 * h;
            let target = self
                .limits
                .clamp(&self.instruments.delayed(now, INPUT_DELAY_S));
            self.inputs += (target - self.inputs) * (h / INPUT_LAG_S);
            let f = self.robot.vehicle.body_velocity(&self.inputs);
            // A commanded sideways velocity (a crab) rolls as a forward one does.
            let goal = BodyVelocity::new(
                f.x * (1.0 - forward_loss),
                f.y * (1.0 - forward_loss) - 0.1 * f.x * f.z,
                f.z * (1.0 - yaw_loss),
            );
            self.velocity += (goal - self.velocity) * (h / BODY_LAG_S);
            self.pose = euler_step(&self.pose, &self.velocity, h);
        }
        self.instruments.end_tick();
    }

    fn true_pose(&self) -> Option<Pose> {
        Some(self.instruments.mounted(&self.pose))
    }
}
