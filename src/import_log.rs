//! `drive import`: a raw DRIVE logger CSV into the window CSV and sidecar. The keep/drop
//! report goes to stdout (text, or JSON with `--json`); errors to stderr.

use anyhow::{bail, Result};
use drive::data::{import_raw, read_raw_log, write_dataset, ImportConfig};
use drive::samplers::{window_len, RobotSpec};
use drive::traits::RobotDescription;
use std::path::Path;

/// Imports `raw` for `robot`, writes the windows to `out` (and the sidecar beside it) and
/// prints the keep/drop report on stdout (text, or JSON with `json`). Writes
/// nothing and fails when no window is usable.
pub fn run(raw: &Path, robot: &str, out: &Path, config: &ImportConfig, json: bool) -> Result<()> {
    let spec = RobotSpec::load(robot)?;
    let log = read_raw_log(raw)?;
    let stem = raw
        .file_stem()
        .map_or("raw".into(), |s| s.to_string_lossy().into_owned());
    let description = RobotDescription {
        name: stem,
        robot: spec.name.clone(),
        rate_hz: spec.rate_hz,
        window_len: window_len(&spec),
        wheel_radius: spec.wheel_radius,
        baseline: spec.baseline,
    };
    let (data, report) = import_raw(&log, &description, config)?;
    let failure = report.nothing_usable();
    if failure.is_none() {
        write_dataset(&data, out)?;
    }
    if json {
        let mut v = report.to_json();
        v["out"] = match failure {
            None => serde_json::json!(out.display().to_string()),
            Some(_) => serde_json::Value::Null,
        };
        println!("{v}");
    } else {
        print!("{}", report.to_text());
    }
    match failure {
        Some(why) => bail!("{why}; nothing written"),
        None => {
            if !json {
                println!(
                    "{} windows ({} intervals) saved to {}",
                    data.windows.len(),
                    data.windows.len() / drive::traits::WINDOWS_PER_INTERVAL,
                    out.display()
                );
            }
            Ok(())
        }
    }
}
