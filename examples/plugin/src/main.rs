//! A researcher's crate with its own parts, and the whole `drive` command line with them:
//! `cargo run --release -- list`, `-- eval --models all`, `-- simulate --robot
//! cmd-vel-robot ...`, `-- simulate --robot offset-robot ...`, `-- simulate --robot
//! loader-robot ...`, `-- simulate --robot tracked-robot ...` (a vehicle with its own
//! simulator). Each part is one file and one `register` call.

mod articulated;
mod halton;
mod offset_unicycle;
mod ridge_slip;
mod second_order;
mod tracked;
mod unicycle;

use drive::Registries;
use std::process::ExitCode;
use std::sync::Arc;

fn registries() -> Result<Registries, drive::traits::RegistryError> {
    let mut r = Registries::builtin();
    r.slip_learners.register(
        "ridge-slip",
        "ridge regression of the slip on a basis with saturating terms",
        Arc::new(ridge_slip::RidgeSlip::default()),
    )?;
    r.powertrains.register(
        "second-order",
        "critically damped second order with dead time per axis (grid fit)",
        Arc::new(second_order::SecondOrder),
    )?;
    r.samplers.register(
        "halton",
        "the Halton sequence over J (a low-discrepancy design)",
        Arc::new(halton::make),
    )?;
    let vehicle = unicycle::Unicycle { max_yaw_rate: 1.5 };
    r.vehicles.register(
        "unicycle",
        "commanded in body velocity (v, omega), as cmd_vel",
        Arc::new(vehicle.clone()),
    )?;
    // A robot driven through cmd_vel: the Husky's mass, speed and rates with that vehicle.
    let mut robot = r.robot("husky").expect("the husky preset is registered");
    robot.name = "cmd-vel-robot".into();
    robot.nominal_input_space = vehicle.clone().nominal_input_space_at(robot.max_speed);
    robot.vehicle = Arc::new(vehicle);
    r.robots.register(
        "cmd-vel-robot",
        "a 75 kg robot commanded in body velocity, 1 m/s, 1.5 rad/s",
        Arc::new(robot),
    )?;
    // A vehicle whose lateral velocity follows its yaw rate (its reference point 0.3 m
    // ahead of the axle), and a robot with it.
    let offset = offset_unicycle::OffsetUnicycle {
        unicycle: unicycle::Unicycle { max_yaw_rate: 1.5 },
        offset: 0.3,
    };
    r.vehicles.register(
        "offset-unicycle",
        "a unicycle seen from a point ahead of its axle: v_y = offset * omega",
        Arc::new(offset.clone()),
    )?;
    let mut robot = r.robot("husky").expect("the husky preset is registered");
    robot.name = "offset-robot".into();
    robot.nominal_input_space = {
        use drive::traits::CommandModel;
        // Positive limits (the literals above): the box is valid.
        offset
            .nominal_input_space(robot.max_speed)
            .expect("positive limits")
    };
    robot.vehicle = Arc::new(offset);
    r.robots.register(
        "offset-robot",
        "a 75 kg unicycle localized 0.3 m ahead of its axle, 1 m/s, 1.5 rad/s",
        Arc::new(robot),
    )?;
    // A frame-steered vehicle (the hinge 0.7 m behind the front axle and 0.5 m ahead of
    // the rear one, 40 degrees each way), and a small loader with it: 2 m/s, its speed and
    // articulation rate-limited as a steered vehicle's are.
    let loader = articulated::Articulated {
        front: 0.7,
        rear: 0.5,
        max_articulation: 40f64.to_radians(),
    };
    r.vehicles.register(
        "articulated",
        "frame-steered: front axle speed and articulation angle",
        Arc::new(loader.clone()),
    )?;
    // Positive literals and an articulation within 90 degrees: every value is valid.
    let robot =
        drive::samplers::RobotSpec::new("loader-robot", Arc::new(loader), 900.0, 2.0, 2.0, 1.0)
            .and_then(|r| r.with_input_rate_limits(drive::traits::Input::new(2.0, 0.5, 0.0)))
            .and_then(|r| r.with_lateral_acceleration(1.5))
            .expect("valid loader literals");
    r.robots.register(
        "loader-robot",
        "a 900 kg articulated loader, 2 m/s, 40 degrees of articulation",
        Arc::new(robot),
    )?;
    // A tracked robot with its own simulator (tracked.rs): the vehicle, its plant, a robot.
    tracked::register(&mut r)?;
    Ok(r)
}

impl unicycle::Unicycle {
    /// The nominal input space at a top speed.
    fn nominal_input_space_at(self, top_speed: f64) -> drive::traits::InputSpace {
        use drive::traits::CommandModel;
        // The yaw-rate limit is positive (a literal above), so the box is valid.
        self.nominal_input_space(top_speed)
            .expect("positive limits")
    }
}

fn main() -> ExitCode {
    match registries() {
        Ok(r) => drive::cli::main(r),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
