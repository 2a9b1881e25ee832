//! The closed loop's unit tests.

use super::*;

#[test]
fn the_fastest_straight_input_of_a_differential_drive_is_both_wheels_at_the_top() {
    let husky = Registries::builtin().robot("husky").unwrap();
    let u = fastest_straight(&husky);
    let j = husky.input_space();
    assert_eq!(u, j.max);
}

#[test]
fn a_twin_is_commanded_in_its_protocol_geometry() {
    let r = Registries::builtin();
    let husky = r.robot("husky").unwrap();
    let twin = r
        .terrain(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../examples/husky_twin.toml"
        ))
        .unwrap();
    let d = driven(&husky, &twin).unwrap();
    let p = twin.protocol.unwrap();
    assert_eq!(d.controller.input_space(), p.space().unwrap());
    // A pure turn in the protocol's geometry reaches the robot with its wheel-speed
    // difference stretched by nominal / protocol baseline.
    let u = d.to_vehicle.apply(&Input::new(-1.0, 1.0, 0.0));
    assert!((u.y - 0.55 / p.baseline).abs() < 1e-12 && (u.x + u.y).abs() < 1e-12);
    // The preset terrains drive the robot itself.
    let d = driven(&husky, &r.terrain("gravel").unwrap()).unwrap();
    assert_eq!(
        d.to_vehicle.apply(&Input::new(-1.0, 1.0, 0.0)),
        Input::new(-1.0, 1.0, 0.0)
    );
}
