//! `drive import`: a raw DRIVE logger CSV, or a rosbag2 recording (MCAP), into the window
//! CSV and sidecar. The keep/drop report goes to stdout (text, or JSON with `--json`);
//! errors to stderr.

use crate::data::stage_dataset;
use crate::import::{import_recording, stopping, ImportOptions, Imported, Recording};
use crate::Registries;
use anyhow::{bail, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["raw", "bag"])))]
pub struct Args {
    /// The logger's raw CSV.
    #[arg(long)]
    raw: Option<PathBuf>,
    /// A rosbag2 recording in MCAP storage: the bag directory (with its metadata.yaml) or a
    /// .mcap file. One row per command message, the other topics' latest messages held, as
    /// the DRIVE logger records.
    #[arg(long)]
    bag: Option<PathBuf>,
    /// A topic of the bag other than the DRIVE logger's, KEY=/topic (repeatable). Keys and
    /// defaults: calib_step=/calib_step, joy_switch=/drive/joy_switch (optional),
    /// calib_state=/calib_state, odometry=/odometry_in, meas_left_vel=/wheel_vel_left_measured,
    /// meas_right_vel=/wheel_vel_right_measured (a car: meas_speed, meas_steering),
    /// imu=/imu_in (optional), cmd=/doughnut_cmd_vel. A sensor_msgs/JointState topic names its joint:
    /// meas_left_vel=/joint_states:left_wheel_joint.
    #[arg(long, requires = "bag")]
    topic: Vec<String>,
    /// The robot's vehicle, geometry and command rate: a registered robot (husky, hd2,
    /// warthog, ...) or a TOML file.
    #[arg(long)]
    robot: String,
    /// Output window CSV (its sidecar JSON is written beside it).
    #[arg(long)]
    out: PathBuf,
    /// A time between two rows longer than this (s) cuts an interval (never less than two
    /// command periods).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.25)]
    max_gap: f64,
    /// The longest time without a localization update inside an interval (s).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    localization_timeout: f64,
    /// The ground the run was recorded on, free text (written into the sidecar's
    /// `terrain`; `drive bench` groups datasets by it).
    #[arg(long, default_value = "")]
    terrain: String,
    /// Print the keep/drop report as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Data checks whose fatal finding does not stop the import, comma-separated
    /// (not-moving, encoders-zero; see drive check --help).
    #[arg(long, value_delimiter = ',')]
    allow: Vec<String>,
}

/// Imports the raw log for the robot, writes the windows (and the sidecar beside them) and
/// prints the keep/drop report on stdout. Writes nothing and fails when no window is usable.
pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    super::check::known_checks(&args.allow)?;
    let sidecar = crate::data::sidecar_path(&args.out);
    let (flag, source) = match (&args.raw, &args.bag) {
        (Some(raw), _) => ("--raw", raw.clone()),
        (None, Some(bag)) => ("--bag", bag.clone()),
        // clap requires one of them.
        (None, None) => bail!("give --raw or --bag"),
    };
    if args.raw.is_some() && !args.topic.is_empty() {
        bail!("--topic names topics of a bag (--bag), not columns of --raw");
    }
    let mut inputs = if args.bag.is_some() {
        super::common::bag_inputs("--bag", &source)
    } else {
        vec![(flag, source.clone())]
    };
    inputs.extend(super::common::robot_input(&args.robot));
    let mut outputs = super::common::outputs_for(
        &inputs,
        &[("--out", &args.out), ("sidecar of --out", &sidecar)],
    )?;
    super::common::csv_output_name("--out", &args.out)?;
    let recording = match &args.bag {
        Some(path) => Recording::Bag {
            path,
            topics: &args.topic,
        },
        None => Recording::Raw(&source),
    };
    let options = ImportOptions {
        max_gap_s: args.max_gap,
        localization_timeout_s: args.localization_timeout,
        terrain: args.terrain.clone(),
        name: None,
    };
    let Imported {
        dataset: data,
        report,
    } = import_recording(registries, &recording, &args.robot, &options)?;
    let failure = report.nothing_usable().or_else(|| {
        stopping(&report.checks, &args.allow).map(|f| {
            format!(
                "{}: check {}: {} (--allow {} to import anyway)",
                source.display(),
                f.check,
                f.message,
                f.check
            )
        })
    });
    if failure.is_none() {
        stage_dataset(&mut outputs, &data, &args.out)?;
    }
    if args.json {
        let mut v = report.to_json();
        v["out"] = match failure {
            None => serde_json::json!(args.out.display().to_string()),
            Some(_) => serde_json::Value::Null,
        };
        outln!("{v}");
    } else {
        out!("{}", report.to_text());
    }
    // After the standard output: a command that cannot write it fails with nothing new
    // published.
    if failure.is_none() {
        super::common::publish(outputs)?;
    }
    match failure {
        Some(why) => bail!("{why}; nothing written"),
        None => {
            if !args.json {
                outln!(
                    "{} windows ({} intervals) saved to {}",
                    data.windows.len(),
                    data.windows.len() / crate::traits::WINDOWS_PER_INTERVAL,
                    args.out.display()
                );
            }
            Ok(())
        }
    }
}
