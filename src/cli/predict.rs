//! `drive predict`: poses from a saved model and a command sequence.

use super::common::{parse_number, parse_pair, parse_triplet};
use crate::models::known_inputs::KnownInputs;
use crate::traits::limits::Exact as Num;
use crate::traits::{Input, MotionError, Pose, StartState};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Model file written by `drive train`.
    #[arg(long)]
    model: PathBuf,
    /// CSV with columns t and the vehicle's command columns (cmd_left,cmd_right for a
    /// differential drive), at the model's command rate, or a schedule `drive protocol`
    /// wrote (t,interval,phase and the command columns); at most 1,000,000 commands, lines
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
    let crate::models::model_file::ModelFile {
        model,
        robot,
        fitted_with,
    } = crate::models::model_file::read_model_file(&name, &text)?;
    registries
        .check_vehicle(robot.vehicle.as_ref())
        .with_context(|| format!("{name}: the model's vehicle"))?;
    let axes = robot.vehicle.axes();
    let columns: Vec<&str> = axes.iter().map(|a| a.command_column).collect();
    // The output's t runs on the command file's clock (from its first t).
    let crate::data::CommandFile { commands: cmds, t0 } =
        crate::data::read_commands(&args.commands, &columns, model.dt())?;
    let known = KnownInputs::of(model.as_ref(), fitted_with.as_ref(), &robot);
    let note = |n: String| super::common::note(format!("note: {n}"));
    if let Some(n) = known
        .as_ref()
        .and_then(|k| k.command_note(&robot, cmds.iter().copied()))
    {
        note(n);
    }
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
    if let Some(k) = &known {
        let flags = ("--start-wheels", "--start-velocity");
        for n in k.start_notes(&robot, measured, args.start_velocity, flags.0, flags.1) {
            note(n);
        }
        let yaw_rate = args.start_yaw_rate;
        if let Some(n) = yaw_rate.and_then(|w| k.yaw_rate_note(&robot, w, "--start-yaw-rate")) {
            note(n);
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
    if let Some(n) = known
        .as_ref()
        .and_then(|k| k.speed_note(&robot, model.dt(), &poses))
    {
        note(n);
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
