//! The entry points the fuzz targets in `fuzz/` exercise, shared with the test that replays
//! their corpus (`tests/integration/fuzz_corpus.rs`): each takes arbitrary bytes, must never panic, and
//! returns whether the input was accepted.
//!
//! ```
//! assert!(!drive::fuzz::window_csv(b"window,phase\n0,steady\n"));
//! assert!(!drive::fuzz::raw_log(b"\xff\xfe"));
//! assert!(!drive::fuzz::model_file(b"{\"format_version\": 1}"));
//! assert!(!drive::fuzz::sidecar(b"{\"rate_hz\": 1e999}"));
//! assert!(!drive::fuzz::robot_toml(b"max_speed = 1e308"));
//! assert!(!drive::fuzz::bag(b"\x89MCAP0\r\n"));
//! ```

use crate::data::{import_raw, parse_dataset, parse_raw_log, ImportConfig};
use crate::models::model_file::model_from_json;
use crate::traits::{Input, Pose, RobotDescription, StartState};

/// The sidecar the window-CSV target reads its CSV with: a short window so that small inputs
/// reach the window logic.
const SIDECAR: &str =
    r#"{"name": "fuzz", "rate_hz": 20, "window_len": 3, "wheel_radius": 0.1, "baseline": 0.5}"#;

/// The window CSV reader (and the sidecar reader on the same bytes).
pub fn window_csv(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return false;
    };
    let _ = crate::data::parse_sidecar("fuzz.json", text);
    match parse_dataset("fuzz.csv", text, "fuzz.json", SIDECAR) {
        Ok(data) => {
            let _ = crate::data::quality::check(&data, None);
            true
        }
        Err(_) => false,
    }
}

/// A small window CSV for the sidecar target: two 3-sample windows of a differential
/// drive (the columns of another vehicle are refused, which is also an outcome).
const CSV: &str = "window,phase,k,t,cmd_left,cmd_right,enc_left,enc_right,x,y,yaw,imu_yaw_rate
0,transient,0,0,1,1,0,0,0,0,0,0
0,transient,1,0.05,1,1,0.5,0.5,0.01,0,0,0
0,transient,2,0.1,1,1,1,1,0.02,0,0,0
1,steady,0,0,1,1,1,1,0,0,0,0
1,steady,1,0.05,1,1,1,1,0.02,0,0,0
1,steady,2,0.1,1,1,1,1,0.04,0,0,0
";

/// The sidecar reader, then a dataset read with the sidecar, its data checks, and the
/// sidecar written back and read again.
pub fn sidecar(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return false;
    };
    let Ok((robot, _)) = crate::data::parse_sidecar("fuzz.json", text) else {
        return false;
    };
    if let Ok(data) = parse_dataset("fuzz.csv", CSV, "fuzz.json", text) {
        let _ = crate::data::quality::check(&data, None);
    }
    if let Ok(again) = crate::data::sidecar_json(&robot, 2, None) {
        // What the writer writes, the reader reads.
        assert!(crate::data::parse_sidecar("again.json", &again).is_ok());
    }
    true
}

/// The robot TOML reader, then what a command does with a robot: its input space, body
/// limits, and a one-interval schedule.
pub fn robot_toml(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return false;
    };
    let Ok(spec) = crate::samplers::RobotSpec::from_toml("fuzz.toml", text) else {
        return false;
    };
    let _ = spec.input_space();
    let _ = spec.body_limits();
    let registries = crate::Registries::builtin();
    if let Ok(mut sampler) = crate::samplers::build_sampler(
        &registries.samplers,
        "uniform",
        &crate::samplers::SamplerContext::new(&spec, 1),
    ) {
        let rows = crate::samplers::schedule(&spec, sampler.as_mut(), 1);
        let _ = crate::samplers::schedule_csv(&spec, &rows);
    }
    true
}

/// The raw log reader, then the import of what it read.
pub fn raw_log(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return false;
    };
    let Ok(log) = parse_raw_log("fuzz.csv", text, &crate::data::RAW_COLUMNS) else {
        return false;
    };
    let robot = RobotDescription::new(
        "fuzz",
        "fuzz",
        20.0,
        2,
        crate::models::DifferentialDrive::new(0.3, 1.2),
    );
    import_raw(&log, &robot, &ImportConfig::default()).is_ok()
}

/// The model loader, then a short prediction with what it loaded.
pub fn model_file(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return false;
    };
    let Ok((model, _robot)) = model_from_json("fuzz.json", text) else {
        return false;
    };
    let start = StartState {
        input: Input::new(1.0, -1.0, 0.0),
        ..StartState::at_rest(Pose::zeros())
    }
    .with_yaw_rate(0.5);
    let commands = [Input::new(2.0, 1.0, 0.0); 8];
    let _ = model.predict(&start, &commands);
    let mut poses = Vec::new();
    let mut covariances = Vec::new();
    let _ = model.predict_with_covariance_into(&start, &commands, &mut poses, &mut covariances);
    true
}

/// The rosbag2 (MCAP) reader on one file's bytes with the DRIVE logger's topics of a
/// differential drive, then the import of the rows it made.
pub fn bag(bytes: &[u8]) -> bool {
    let vehicle = crate::models::DifferentialDrive::new(0.165, 0.555);
    let topics = crate::data::BagTopics::drive_logger(&vehicle);
    let Ok(log) = crate::data::read_bag_bytes("fuzz.mcap", bytes, &topics) else {
        return false;
    };
    let robot = RobotDescription::new("fuzz", "fuzz", 20.0, 2, vehicle);
    let _ = import_raw(&log, &robot, &ImportConfig::default());
    true
}
