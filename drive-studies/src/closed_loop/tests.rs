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

#[test]
fn sign_changes_count_flips_beyond_a_tenth_of_the_rms() {
    // +1, -1, +1: two flips; the small values around zero in between do not count.
    assert_eq!(
        super::plant::sign_changes(&[1.0, 0.01, -0.02, -1.0, 0.05, 1.0]),
        2
    );
    // A steady turn never flips; nothing at all neither.
    assert_eq!(super::plant::sign_changes(&[0.5; 40]), 0);
    assert_eq!(super::plant::sign_changes(&[]), 0);
    // Dithering around zero with a real turn elsewhere: the dither is within the band.
    let mut rates = vec![1.0; 20];
    rates.extend([0.01, -0.01, 0.01, -0.01]);
    assert_eq!(super::plant::sign_changes(&rates), 0);
}

#[test]
fn a_zigzag_needs_its_corner_over_a_second_and_a_line_nothing() {
    use drive_control::PathShape;
    let line = PathShape::Line.at_scale(4.0).unwrap();
    assert!(super::yaw_rate_needed(&line, 1.0) < 1e-9);
    // The zigzag turns 120 degrees at each corner: 2.09 rad within one second of travel.
    let zigzag = PathShape::Zigzag.at_scale(4.0).unwrap();
    let w = super::yaw_rate_needed(&zigzag, 0.5);
    assert!((w - 2.0 * std::f64::consts::PI / 3.0).abs() < 0.05, "{w}");
}

#[test]
fn a_recording_is_cut_into_whole_windows_in_order() {
    let mut r = super::plant::Recording::default();
    for k in 0..7 {
        r.command.push(Input::new(k as f64, 0.0, 0.0));
        r.measured.push(Input::new(0.0, k as f64, 0.0));
        r.pose.push(Pose::new(k as f64, 0.0, 0.0));
        r.imu.push(k as f64);
    }
    // Seven ticks in windows of three: two windows (ticks 0-2 and 3-5), the last tick
    // dropped.
    let w = r.windows(3);
    assert_eq!(w.len(), 2);
    assert_eq!(w[1].command[0].x, 3.0);
    assert_eq!(w[1].measured[2].y, 5.0);
    assert_eq!(w[1].pose[0].x, 3.0);
    assert_eq!(w[1].imu_yaw_rate, vec![3.0, 4.0, 5.0]);
}
