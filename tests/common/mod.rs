//! Running the `drive` command line from the integration tests.

#![allow(dead_code)] // each test file uses some of these

use std::process::{Command, Output};

/// Runs `drive` with `args`.
pub fn drive(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drive"))
        .args(args)
        .output()
        .expect("the drive binary runs")
}

/// Runs `drive`, asserting success; its standard output.
pub fn ok(args: &[&str]) -> String {
    let out = drive(args);
    assert!(
        out.status.success(),
        "drive {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Writes the bag importer's committed fixtures (tests/bags: a Husky on snow) into `dir`: the
/// DRIVE logger's CSV as `raw` and its rosbag2 recording as the folder `bag`.
pub fn bag_fixtures(
    dir: &std::path::Path,
    raw: &str,
    bag: &str,
) -> (std::path::PathBuf, std::path::PathBuf) {
    use std::io::Read;
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bags");
    let gunzip = |name: &str| {
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(std::fs::File::open(here.join(name)).unwrap())
            .read_to_end(&mut out)
            .unwrap();
        out
    };
    let raw = dir.join(raw);
    std::fs::write(&raw, gunzip("husky_snow_raw.csv.gz")).unwrap();
    let bag = dir.join(bag);
    std::fs::create_dir(&bag).unwrap();
    std::fs::write(bag.join("bag.mcap"), gunzip("husky_snow.mcap.gz")).unwrap();
    std::fs::copy(
        here.join("husky_snow_metadata.yaml"),
        bag.join("metadata.yaml"),
    )
    .unwrap();
    (raw, bag)
}

/// A user error: non-zero exit, one clear line on stderr, nothing on stdout.
pub fn user_error(args: &[&str]) -> String {
    let out = drive(args);
    assert!(!out.status.success(), "drive {args:?} should fail");
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    assert!(err.starts_with("error: "), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.stdout.is_empty());
    err
}

/// Writes the bundled grass run with its localization frozen (every pose at the origin:
/// what `drive check` calls `not-moving`, fatal) as the window CSV `csv` and its sidecar.
pub fn write_frozen_grass_run(csv: &std::path::Path) {
    let mut frozen = drive::bundled::load("warthog_grass_2024-08-08").unwrap();
    for w in &mut frozen.windows {
        for p in &mut w.pose {
            *p = drive::traits::Pose::zeros();
        }
    }
    drive::data::write_dataset(&frozen, csv).unwrap();
}
