//! The registered robots: the paper's platforms and a car.

use super::*;

/// The paper's platforms: `husky` (75 kg, 1 m/s), `hd2` (tracked, 80 kg, 1.2 m/s),
/// `warthog` (470 kg, 5 m/s), differential drives; and a car, `autorally` (see
/// [`autorally`]). Acceleration limits are this project's defaults (about one top speed
/// per second), not the manufacturers'.
///
/// Masses are the paper's (Sec. IV-A). Body footprints: the Husky's (0.8382 m x 0.6604 m)
/// and the Warthog's (2.13 m x 1.52 m) are those of the T-FR 2025 follow-up's
/// unpredictability metric (norlab-ulaval/doughnut_calib,
/// `drive/model_training/data_utils/robot_param.yaml`), so that the metric reads as theirs;
/// the HD2's is not published with the DRIVE material and is left unset (give `body_length`
/// and `body_width` in a robot file).
pub fn builtin_robots() -> Registry<RobotSpec> {
    let mut r: Registry<RobotSpec> = Registry::new("robot");
    for (name, description, mass_kg, max_speed, wheel_radius, baseline, tracked, body) in [
        (
            "husky",
            "Clearpath Husky: wheeled skid-steer, 75 kg, 1 m/s",
            75.0,
            1.0,
            0.165,
            0.55,
            false,
            Some((0.8382, 0.6604)),
        ),
        (
            "hd2",
            "Superdroid HD2: tracked skid-steer, 80 kg, 1.2 m/s",
            80.0,
            1.2,
            0.116,
            0.5927,
            true,
            None,
        ),
        (
            "warthog",
            "Clearpath Warthog on wheels: skid-steer, 470 kg, 5 m/s",
            470.0,
            5.0,
            0.3,
            1.1652,
            false,
            Some((2.13, 1.52)),
        ),
    ] {
        let vehicle = DifferentialDrive::new(wheel_radius, baseline);
        let spec = RobotSpec {
            name: name.to_string(),
            mass_kg,
            max_speed,
            controller_max_linear: None,
            controller_max_angular: None,
            max_lateral_acceleration: None,
            rate_hz: 20.0,
            max_linear_acceleration: max_speed,
            max_angular_acceleration: 2.0 * max_speed / baseline,
            input_rate_limits: None,
            input_limits: None,
            nominal_input_space: InputSpace::new(
                Input::new(-max_speed / wheel_radius, -max_speed / wheel_radius, 0.0),
                Input::new(max_speed / wheel_radius, max_speed / wheel_radius, 0.0),
            )
            .expect("positive presets"),
            vehicle: Arc::new(vehicle),
            tracked,
            body: body.map(|(length_m, width_m)| BodySize { length_m, width_m }),
        };
        // Distinct names (autorally follows).
        r.register_trusted(name, description, Arc::new(spec))
            .expect("distinct presets");
    }
    r.register_trusted(
        "autorally",
        "AutoRally: 1/5-scale rally car (Ackermann), 23.9 kg, wheelbase 0.57 m, steering +-21 deg; 5 m/s for the protocol",
        Arc::new(autorally()),
    )
    .expect("distinct presets");
    r.register_trusted(
        "ridgeback",
        "Clearpath Ridgeback: omnidirectional mecanum base (v_x, v_y, w), 135 kg, 1.1 m/s",
        Arc::new(ridgeback()),
    )
    .expect("distinct presets");
    r
}

/// The Clearpath Ridgeback, an omnidirectional mecanum base commanded in body velocity
/// (`v_x, v_y, w`, [`Omnidirectional`]): 135 kg, top speed 1.1 m/s, footprint 0.96 m x
/// 0.793 m (Clearpath's published specifications). The wheel positions (`l_x` = 0.319 m,
/// `l_y` = 0.2775 m) are this project's reading of the footprint, not published values;
/// the acceleration limits follow the other presets' rule (about one top speed per second,
/// the yaw rate's through the lever `l_x + l_y`).
///
/// ```
/// let base = drive_traits::robot::ridgeback();
/// assert_eq!(base.vehicle.input_dim(), 3);
/// let j = base.input_space();
/// assert_eq!((j.dim(), j.max.x, j.max.y), (3, 1.1, 1.1));
/// ```
pub fn ridgeback() -> RobotSpec {
    let vehicle = Omnidirectional::new(0.319, 0.2775);
    let max_speed = 1.1;
    let angular = max_speed / (0.319 + 0.2775);
    // Positive presets: the constructor's checks hold.
    RobotSpec::new(
        "ridgeback",
        Arc::new(vehicle),
        135.0,
        max_speed,
        max_speed,
        angular,
    )
    .expect("a valid preset")
    .with_body(BodySize {
        length_m: 0.96,
        width_m: 0.793,
    })
}

/// The AutoRally platform (Goldfain et al., "AutoRally: An Open Platform for Aggressive
/// Autonomous Driving", IEEE Control Systems Magazine 39(1), 2019), a 1/5-scale rally car
/// used in off-road learning and model-predictive control papers. From its published
/// description (AutoRally/autorally on GitHub, `autorally_description/urdf/
/// autoRallyPlatform.urdf.xacro`): wheelbase 0.570 m; steering limit 21 deg (0.3665 rad);
/// chassis 20.5 kg, front wheels 0.82 kg and rear wheels 0.89 kg (23.9 kg); steering servo
/// Savox SV-0235MG at 7.4 V, 0.13 s per 60 deg at no load (8.055 rad/s), the steering
/// rate limit here; top speed 60 mph (26.8 m/s).
///
/// This project's choices, not the platform's: the protocol's speed limit, 5 m/s (the
/// Warthog's top speed in the paper; a test area is not a race track), and the speed rate
/// limit of one top speed per second (5 m/s^2), the rule of the other presets.
///
/// ```
/// let car = drive_traits::robot::autorally();
/// assert_eq!(car.vehicle.geometry()[0], ("wheelbase", 0.57));
/// let j = car.input_space();
/// assert_eq!((j.max.x, j.max.y), (5.0, 0.3665191429));
/// ```
pub fn autorally() -> RobotSpec {
    let max_speed = 5.0;
    let vehicle = Ackermann::new(0.570, 0.3665191429);
    RobotSpec {
        name: "autorally".into(),
        mass_kg: 20.5 + 2.0 * 0.82 + 2.0 * 0.89,
        max_speed,
        controller_max_linear: None,
        controller_max_angular: None,
        max_lateral_acceleration: Some(3.0),
        rate_hz: 20.0,
        max_linear_acceleration: f64::INFINITY,
        max_angular_acceleration: f64::INFINITY,
        input_rate_limits: Some(Input::new(max_speed, 8.05536578, 0.0)),
        input_limits: None,
        // Positive speed and steering limit.
        nominal_input_space: vehicle
            .nominal_input_space(max_speed)
            .expect("a positive preset"),
        vehicle: Arc::new(vehicle),
        tracked: false,
        body: None,
    }
}
