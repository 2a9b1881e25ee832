use super::*;

#[test]
fn decoded_values_beyond_the_readers_bounds_are_refused() {
    assert!(plausible(Value::Number(3.0)).is_ok());
    assert!(plausible(Value::Pose([1.0, 2.0, 0.0], [0.0, 0.0, 0.0, 1.0])).is_ok());
    let refused = [
        (Value::Number(1e300), "the value 1e300"),
        (Value::Twist([0.0, 1e15]), "a command 1e15"),
        (
            Value::Pose([1e12, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
            "a position 1e12",
        ),
        (
            Value::Pose([0.0; 3], [f64::NAN, 0.0, 0.0, 1.0]),
            "a quaternion component NaN",
        ),
        (
            Value::Imu([0.0, 0.0, 1e300], [0.0; 3]),
            "an angular velocity",
        ),
    ];
    for (v, says) in refused {
        let e = plausible(v).unwrap_err();
        assert!(e.contains(says) && e.contains("within +-"), "{e}");
    }
}

#[test]
fn the_metadata_says_which_files_make_the_bag() {
    let rosbag2 = "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  duration:\n    nanoseconds: 1\n  relative_file_paths:\n    - run_0.mcap\n    - \"run_1.mcap\"\n  files:\n    - path: run_0.mcap\n";
    assert_eq!(bag_metadata(rosbag2).unwrap(), ["run_0.mcap", "run_1.mcap"]);
    // Quoted storage, an inline list, items at the key's indentation.
    let inline = "storage_identifier: \"mcap\"\nrelative_file_paths: [a.mcap, 'b.mcap']\n";
    assert_eq!(bag_metadata(inline).unwrap(), ["a.mcap", "b.mcap"]);
    let flush = "relative_file_paths:\n- a.mcap\nstarting_time: 0\n";
    assert_eq!(bag_metadata(flush).unwrap(), ["a.mcap"]);
    // Refused: another storage, no list, a file outside the folder.
    let sqlite = "storage_identifier: sqlite3\nrelative_file_paths:\n  - a.db3\n";
    assert!(bag_metadata(sqlite)
        .unwrap_err()
        .contains("storage is sqlite3"));
    assert!(bag_metadata("storage_identifier: mcap\n")
        .unwrap_err()
        .contains("no relative_file_paths"));
    let outside = "relative_file_paths:\n  - ../other/run.mcap\n";
    assert!(bag_metadata(outside)
        .unwrap_err()
        .contains("not inside the bag's folder"));
}
