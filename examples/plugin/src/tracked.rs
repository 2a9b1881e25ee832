//! A vehicle with its own simulator: a tracked robot commanded in body velocity (v, omega)
//! whose tracks skid more the harder it turns. The vehicle is `TrackedVw`; its plant,
//! `TrackedPlant`, is registered in the simulator registry under the vehicle's type, so
//! every command that simulates (simulate, compare-protocols, matrix, track) runs it and
//! names it (`simulator: tracked-vw (registered for the vehicle type tracked-vw)`).
//! docs/plugins.md ("A vehicle with its own simulator") walks through this file.

use drive::samplers::RobotSpec;
use drive::serde::{Deserialize, Serialize};
use drive::sim::{Instruments, Measured, Plant, PlantError, Terrain};
use drive::traits::{
    euler_step, vehicle_as, BodyVelocity, CommandModel, Input, InputAxis, InputSpace, Pose, Probe,
    ProbeResult, Tagged,
};
use drive::typetag;
use std::sync::Arc;

/// Registers the vehicle, then its simulator under the vehicle's type (a simulator is
/// registered for a registered vehicle only), then `tracked-robot`: the Husky's mass, speed
/// and rates with this vehicle. What the plug-in example and its Python module both call.
pub fn register(r: &mut drive::Registries) -> Result<(), drive::traits::RegistryError> {
    let vehicle = TrackedVw { max_yaw_rate: 1.2 };
    r.vehicles.register(
        "tracked-vw",
        "a tracked robot commanded in body velocity (v, omega)",
        Arc::new(vehicle.clone()),
    )?;
    r.simulators.register(
        "tracked-vw",
        "tracks that lose a terrain share of the speed and skid more the harder they turn",
        Arc::new(TrackedPlant::make),
    )?;
    let mut robot = r.robot("husky").expect("the husky preset is registered");
    robot.name = "tracked-robot".into();
    // A positive top speed and yaw rate (literals): the box is valid.
    robot.nominal_input_space = vehicle
        .nominal_input_space(robot.max_speed)
        .expect("positive limits");
    robot.vehicle = Arc::new(vehicle);
    r.robots.register(
        "tracked-robot",
        "a 75 kg tracked robot commanded in (v, omega), 1 m/s, 1.2 rad/s",
        Arc::new(robot),
    )?;
    Ok(())
}

/// A tracked robot commanded in (v, omega), with its top yaw rate.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
pub struct TrackedVw {
    /// Top yaw rate (rad/s).
    pub max_yaw_rate: f64,
}

impl Tagged for TrackedVw {
    const TAG: &'static str = "tracked-vw";
}

#[typetag::serde(name = "tracked-vw")]
impl CommandModel for TrackedVw {
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        BodyVelocity::new(u.x, 0.0, u.y)
    }

    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        (v.y == 0.0).then(|| Input::new(v.x, v.z, 0.0))
    }

    fn axes(&self) -> Vec<InputAxis> {
        vec![
            InputAxis {
                name: "v",
                unit: "m/s",
                command_column: "cmd_v",
                measured_column: "meas_v",
            },
            InputAxis {
                name: "omega",
                unit: "rad/s",
                command_column: "cmd_omega",
                measured_column: "meas_omega",
            },
        ]
    }

    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        InputSpace::new(
            Input::new(-top_speed, -self.max_yaw_rate, 0.0),
            Input::new(top_speed, self.max_yaw_rate, 0.0),
        )
    }

    /// Forward and backward at twice the top speed, then turning both ways at twice the top
    /// yaw rate: both axes get their range.
    fn probe(&self, index: usize, top_speed: f64, _done: &[ProbeResult]) -> Option<Probe> {
        let (name, command) = match index {
            0 => ("forward", Input::new(2.0 * top_speed, 0.0, 0.0)),
            1 => ("backward", Input::new(-2.0 * top_speed, 0.0, 0.0)),
            2 => ("left", Input::new(0.0, 2.0 * self.max_yaw_rate, 0.0)),
            3 => ("right", Input::new(0.0, -2.0 * self.max_yaw_rate, 0.0)),
            _ => return None,
        };
        Some(Probe {
            name,
            command,
            needs_localization: false,
        })
    }

    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}

/// The tracked robot's simulator: each input follows its command through a first-order lag
/// with a dead time, saturated at the robot's input space; the tracks lose a terrain share
/// of the forward speed (rolling over traction) and skid in turns, more the harder they
/// turn (the yaw rate kept falls with it); the sensors are the project's [`Instruments`]
/// (encoders on each input, a localization at its rate, an IMU).
pub struct TrackedPlant {
    instruments: Instruments,
    limits: InputSpace,
    forward_loss: f64,
    skid: f64,
    inputs: Input,
    velocity: BodyVelocity,
    pose: Pose,
}

/// Time constant and dead time of each input (s).
const LAG_S: f64 = 0.25;
const DEAD_TIME_S: f64 = 0.1;

impl TrackedPlant {
    /// The plant of `robot` on `terrain`, seeded: what the simulator registry calls.
    pub fn make(
        robot: &RobotSpec,
        terrain: &Terrain,
        seed: u64,
    ) -> Result<Box<dyn Plant>, PlantError> {
        // Registered under this vehicle's type: any other vehicle is refused by name.
        if vehicle_as::<TrackedVw>(robot.vehicle.as_ref()).is_none() {
            return Err("the tracked plant simulates the tracked-vw vehicle only".into());
        }
        Ok(Box::new(TrackedPlant {
            instruments: Instruments::new(terrain.sensors.unwrap_or_default(), robot.rate_hz, seed),
            limits: robot.input_space(),
            forward_loss: (terrain.rolling / terrain.traction).clamp(0.0, 0.5),
            skid: (terrain.lateral / (terrain.lateral + terrain.traction)).clamp(0.0, 0.9),
            inputs: Input::zeros(),
            velocity: BodyVelocity::zeros(),
            pose: Pose::zeros(),
        }))
    }
}

impl Plant for TrackedPlant {
    /// Called at the start of every tick, before the runner chooses the tick's command.
    fn measure(&mut self) -> Measured {
        let e = self.instruments.sensors.encoder_noise;
        self.instruments
            .measure(self.inputs, &[e, e], self.pose, self.velocity.z)
    }

    /// Called once per tick with that tick's command: record it, integrate one command
    /// period in substeps, end the tick.
    fn advance(&mut self, command: Input) {
        self.instruments.record(command);
        let substeps = 10;
        let h = self.instruments.dt() / substeps as f64;
        let t0 = self.instruments.tick_start();
        for i in 0..substeps {
            let held = self.instruments.delayed(t0 + i as f64 * h, DEAD_TIME_S);
            let target = self.limits.clamp(&held);
            self.inputs += (target - self.inputs) * (h / LAG_S);
            let (v, w) = (self.inputs.x, self.inputs.y);
            // Tracks skid in turns: the share of the yaw rate lost grows with the yaw rate.
            let kept = 1.0 - self.skid * (w.abs() / (1.0 + w.abs()));
            let goal = BodyVelocity::new(v * (1.0 - self.forward_loss), 0.0, w * kept);
            self.velocity += (goal - self.velocity) * (h / LAG_S);
            self.pose = euler_step(&self.pose, &self.velocity, h);
        }
        self.instruments.end_tick();
    }

    /// Where the localization truly is (what `drive track` scores).
    fn true_pose(&self) -> Option<Pose> {
        Some(self.instruments.mounted(&self.pose))
    }
}
