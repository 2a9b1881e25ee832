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

/// Every registered combination (its canonical name and the model) fitted with its defaults
/// on the bundled Husky data's training half (the first half of its intervals), fitted once
/// for the whole test binary: the fits run side by side on rayon's threads, and every test
/// that needs one of these models shares them.
pub fn husky_half_models() -> &'static [(String, Box<dyn drive::traits::MotionModel>)] {
    use rayon::prelude::*;
    use std::sync::OnceLock;
    static MODELS: OnceLock<Vec<(String, Box<dyn drive::traits::MotionModel>)>> = OnceLock::new();
    MODELS.get_or_init(|| {
        let data = drive::bundled::husky().unwrap();
        let (train, _) = drive::eval::split_by_interval(&data, 0.5).unwrap();
        drive::Registries::builtin()
            .models()
            .all()
            .par_iter()
            .map(|spec| (spec.canonical(), spec.fit(&train).unwrap()))
            .collect()
    })
}

/// The model `name` (any name the registries resolve) of [`husky_half_models`].
pub fn husky_half_model(name: &str) -> &'static dyn drive::traits::MotionModel {
    let canonical = drive::Registries::builtin()
        .models()
        .resolve(name)
        .unwrap()
        .canonical();
    let (_, model) = husky_half_models()
        .iter()
        .find(|(n, _)| *n == canonical)
        .unwrap_or_else(|| panic!("{name} ({canonical}) is not a registered combination"));
    model.as_ref()
}

/// Rewrites column `column` of the CSV file `from` into `to`: each data row's cell becomes
/// `cell(row, old)` (row 0 the first after the header); the other cells are kept as written.
pub fn rewrite_csv_column(
    from: &std::path::Path,
    to: &std::path::Path,
    column: &str,
    mut cell: impl FnMut(usize, &str) -> String,
) {
    let text = std::fs::read_to_string(from).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let i = header.split(',').position(|c| c == column).unwrap();
    let mut out = String::from(header) + "\n";
    for (row, line) in lines.enumerate() {
        let mut cells: Vec<String> = line.split(',').map(String::from).collect();
        cells[i] = cell(row, &cells[i]);
        out += &(cells.join(",") + "\n");
    }
    std::fs::write(to, out).unwrap();
}
