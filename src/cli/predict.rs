//! `drive predict`: poses from a saved model and a command sequence.

use super::common::{parse_number, parse_pair, parse_triplet};
use crate::models::model_file::model_from_json;
use crate::traits::limits::Exact as Num;
use crate::traits::limits::Short;
use crate::traits::{Input, MotionError, Pose, StartState};
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Model file written by `drive train`.
    #[arg(long)]
    model: PathBuf,
    /// CSV with columns t and the vehicle's command columns (cmd_left,cmd_right for a
    /// differential drive), at the model's command rate; at most 1,000,000 commands, lines
    /// of at most 4096 bytes.
    #[arg(long)]
    commands: PathBuf,
    /// Start pose x,y,yaw (m, m, rad) (default: origin).
    #[arg(long, value_parser = parse_triplet, allow_hyphen_values = true)]
    start: Option<[f64; 3]>,
    /// Measured inputs at the start, one per input axis of the model's vehicle, e.g.
    /// left,right wheel velocities (rad/s), or v_x,v_y,w of an omnidirectional base
    /// (default: at rest).
    #[arg(long, alias = "start-input", value_parser = super::common::parse_axes, allow_hyphen_values = true)]
    start_wheels: Option<super::common::AxisValues>,
    /// The yaw rate the IMU measured at the start (rad/s), as `drive eval` starts by
    /// default (`--start encoders+imu`): models that read it (slip-ipem's yaw disturbance,
    /// acc-BLR's velocity state) start from it (default: none, the encoders only).
    #[arg(long, value_parser = parse_number, allow_hyphen_values = true)]
    start_yaw_rate: Option<f64>,
    /// The body velocity x,y (m/s, body frame: forward, left) the localization measured
    /// just before the start, as `drive eval --start encoders+imu+localization` starts:
    /// models that read it (slip-ipem's lagging velocity, acc-BLR's velocity state) start
    /// from it (default: none).
    #[arg(long, value_parser = parse_pair, allow_hyphen_values = true)]
    start_velocity: Option<[f64; 2]>,
}

/// Longest line of a command file (bytes): a line is three numbers.
const MAX_COMMAND_LINE_BYTES: u64 = 4096;

/// Most commands of one prediction (`--commands`): about 14 hours at 20 Hz.
const MAX_COMMANDS: usize = 1_000_000;

/// Reads a command file with the header `t,<columns>` sampled at period `dt`.
fn read_commands(path: &Path, columns: &[&str], dt: f64) -> Result<(Vec<Input>, f64)> {
    use std::io::BufRead as _;
    use std::io::Read as _;
    let name = path.display().to_string();
    crate::traits::files::regular(path).with_context(|| format!("reading {name}"))?;
    let file = std::fs::File::open(path).with_context(|| format!("reading {name}"))?;
    // Line by line (the file is never held whole), each line capped.
    let mut reader = std::io::BufReader::new(file);
    let mut number = 0;
    let mut failed = false;
    let mut lines = std::iter::from_fn(|| {
        if failed {
            return None;
        }
        let mut line = String::new();
        let read = (&mut reader)
            .take(MAX_COMMAND_LINE_BYTES + 1)
            .read_line(&mut line);
        let i = number;
        number += 1;
        match read {
            Ok(0) => None,
            Ok(n) if n as u64 > MAX_COMMAND_LINE_BYTES => {
                failed = true;
                Some(Err(anyhow::anyhow!(
                    "{name}, line {}: longer than {MAX_COMMAND_LINE_BYTES} bytes: not a command file",
                    i + 1
                )))
            }
            Ok(_) => Some(Ok((i, line.trim_end_matches(['\n', '\r']).to_string()))),
            Err(e) => {
                failed = true;
                Some(Err(anyhow::anyhow!("{name}, line {}: cannot read: {e}", i + 1)))
            }
        }
    })
    .filter(|l| l.as_ref().map_or(true, |(_, l)| !l.trim().is_empty()));
    let Some(first) = lines.next() else {
        bail!("{name}: the file is empty")
    };
    let (_, header) = first?;
    let header = header.trim_start_matches('\u{feff}');
    let expected: Vec<&str> = std::iter::once("t")
        .chain(columns.iter().copied())
        .collect();
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    if cols != expected {
        bail!(
            "{name}, line 1: expected the header '{}', found '{header}'",
            expected.join(",")
        );
    }
    let mut out = Vec::new();
    let mut t0 = None;
    for line in lines {
        let (i, line) = line?;
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != expected.len() {
            bail!(
                "{name}, line {}: {} fields where the header has {}",
                i + 1,
                fields.len(),
                expected.len()
            );
        }
        let mut v = [0.0; 1 + crate::traits::MAX_INPUTS];
        for (j, f) in fields.iter().enumerate() {
            let x: f64 = f.trim().parse().map_err(|_| {
                anyhow::anyhow!(
                    "{name}, line {}, column '{}': '{}' is not a number",
                    i + 1,
                    cols[j],
                    f.trim()
                )
            })?;
            if !x.is_finite() {
                bail!(
                    "{name}, line {}, column '{}': '{}' is not a finite number",
                    i + 1,
                    cols[j],
                    f.trim()
                );
            }
            // As the CSV readers: a value beyond 1e9 is a corrupted number.
            crate::traits::limits::at_most(
                &format!("{name}, line {}, column '{}'", i + 1, cols[j]),
                x.abs(),
                crate::traits::limits::MAX_ABS_MEASUREMENT,
                "",
            )?;
            v[j] = x;
        }
        let t0 = *t0.get_or_insert(v[0]);
        let expected = t0 + out.len() as f64 * dt;
        if (v[0] - expected).abs() > 0.5 * dt {
            bail!(
                "{name}, line {}, column 't': t = {} but the model's command period is {} s (expected t = {})",
                i + 1,
                Short(v[0]),
                Short(dt),
                Short(expected)
            );
        }
        if out.len() == MAX_COMMANDS {
            bail!(
                "{name}, line {}: more than {MAX_COMMANDS} commands (the limit of one prediction)",
                i + 1
            );
        }
        out.push(Input::new(v[1], v[2], v[3]));
    }
    match t0 {
        Some(t0) if !out.is_empty() => Ok((out, t0)),
        _ => bail!("{name}: no command rows"),
    }
}

pub fn run(args: &Args, registries: &crate::Registries) -> Result<()> {
    super::common::stdout_not_an_input(&[
        ("--model", args.model.clone()),
        ("--commands", args.commands.clone()),
    ])?;
    let name = args.model.display().to_string();
    let text = crate::traits::files::read_text(
        &args.model,
        crate::models::model_file::MAX_MODEL_FILE_BYTES,
    )
    .with_context(|| format!("reading {name}"))?;
    let (model, robot) = model_from_json(&name, &text)?;
    registries
        .check_vehicle(robot.vehicle.as_ref())
        .with_context(|| format!("{name}: the model's vehicle"))?;
    let axes = robot.vehicle.axes();
    let columns: Vec<&str> = axes.iter().map(|a| a.command_column).collect();
    // The output's t runs on the command file's clock (from its first t).
    let (cmds, t0) = read_commands(&args.commands, &columns, model.dt())?;
    let pose = args
        .start
        .map_or(Pose::zeros(), |[x, y, yaw]| Pose::new(x, y, yaw));
    let measured = match &args.start_wheels {
        Some(values) => values.input("--start-wheels", axes.len())?,
        None => Input::zeros(),
    };
    // The start's values within what the CSV readers accept (1e9): a start at 1e308 m
    // lost every step of the motion to rounding.
    let flags: [(&str, Vec<f64>); 4] = [
        ("--start", args.start.map(Vec::from).unwrap_or_default()),
        (
            "--start-wheels",
            (0..axes.len()).map(|i| measured[i]).collect(),
        ),
        (
            "--start-yaw-rate",
            args.start_yaw_rate.into_iter().collect(),
        ),
        (
            "--start-velocity",
            args.start_velocity.map(Vec::from).unwrap_or_default(),
        ),
    ];
    for (flag, values) in flags {
        for v in values {
            crate::traits::limits::at_most(
                flag,
                v.abs(),
                crate::traits::limits::MAX_ABS_MEASUREMENT,
                "",
            )?;
        }
    }
    let start = StartState::measured(pose, measured, robot.vehicle.as_ref());
    let start = args
        .start_yaw_rate
        .map_or(start, |w| start.with_yaw_rate(w));
    let start = args
        .start_velocity
        .map_or(start, |v| start.with_velocity(v));
    let (mut poses, mut covs) = (Vec::new(), Vec::new());
    let with_cov = model
        .predict_with_covariance_into(&start, &cmds, &mut poses, &mut covs)
        .is_ok();
    if !with_cov {
        model.predict_into(&start, &cmds, &mut poses);
    }
    // Nothing is printed unless every predicted value is a finite number.
    let covariances: &[_] = if with_cov { &covs } else { &[] };
    if let Some(e) = MotionError::not_finite(&model.name(), model.dt(), &poses, covariances) {
        return Err(e.into());
    }
    let mut header = String::from("k,t,x,y,yaw");
    if with_cov {
        header.push_str(",cov_xx,cov_xy,cov_xyaw,cov_yy,cov_yyaw,cov_yawyaw");
    }
    outln!("{header}");
    let rate_hz = 1.0 / model.dt();
    // Written in chunks of about 64 kB.
    let mut row = String::new();
    for (k, p) in poses.iter().enumerate() {
        let _ = write!(
            row,
            "{k},{},{},{},{}",
            Num(t0 + k as f64 / rate_hz),
            Num(p.x),
            Num(p.y),
            Num(p.z)
        );
        if with_cov {
            let c = &covs[k];
            let _ = write!(
                row,
                ",{},{},{},{},{},{}",
                Num(c[(0, 0)]),
                Num(c[(0, 1)]),
                Num(c[(0, 2)]),
                Num(c[(1, 1)]),
                Num(c[(1, 2)]),
                Num(c[(2, 2)])
            );
        }
        row.push('\n');
        if row.len() > 1 << 16 || k + 1 == poses.len() {
            out!("{row}");
            row.clear();
        }
    }
    Ok(())
}
