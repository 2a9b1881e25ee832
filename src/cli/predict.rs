//! `drive predict`: poses from a saved model and a command sequence.

use super::common::{parse_number, parse_pair, parse_triplet};
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
    let known = known_range(model.as_ref(), fitted_with.as_ref(), &robot);
    note_beyond_known(known.as_ref(), &robot, &cmds);
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
    note_start_beyond_known(known.as_ref(), &robot, measured, args.start_velocity);
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
    note_implausible_speed(known.as_ref(), &robot, model.dt(), &poses);
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

/// Notes (on stderr) a command beyond what the model knows: the commands of its training
/// windows (`fitted_with.commanded`), or, in a file that does not keep them, its
/// powertrain's fitted limits; saying whether the powertrain saturates it (the prediction is
/// that of its limits) or the model extrapolates.
/// The inputs a model knows: the commands it was trained on, else its powertrain's fitted
/// limits; what they are called, and whether its powertrain saturates beyond them.
struct Known {
    range: crate::models::model_file::CommandRange,
    what: &'static str,
    saturates: bool,
}

fn known_range(
    model: &dyn crate::traits::MotionModel,
    fitted_with: Option<&crate::models::model_file::FitSettings>,
    robot: &crate::traits::RobotDescription,
) -> Option<Known> {
    use crate::models::model_file::CommandRange;
    let axes = robot.vehicle.axes();
    // The powertrain's limits, from its parameters (`axis i min`, `axis i max`).
    let limits = model.powertrain().and_then(|p| {
        let params = p.parameters();
        let find = |key: String| params.iter().find(|(k, _)| *k == key).map(|(_, v)| *v);
        let min: Option<Vec<f64>> = (0..axes.len())
            .map(|i| find(format!("axis {i} min")))
            .collect();
        let max: Option<Vec<f64>> = (0..axes.len())
            .map(|i| find(format!("axis {i} max")))
            .collect();
        Some(CommandRange {
            min: min?,
            max: max?,
        })
    });
    // The training commands first: a DRIVE run commands beyond what its wheels reach, and
    // the fit learned that saturation.
    let saturates = limits.is_some();
    let (range, what) = match (fitted_with.and_then(|f| f.commanded.clone()), limits) {
        (Some(c), _) => (c, "the commands it was trained on"),
        (None, Some(l)) => (l, "its powertrain's fitted limits"),
        (None, None) => return None,
    };
    Some(Known {
        range,
        what,
        saturates,
    })
}

/// A note when a command lies beyond the inputs the model knows ([`known_range`]).
fn note_beyond_known(
    known: Option<&Known>,
    robot: &crate::traits::RobotDescription,
    cmds: &[Input],
) {
    let Some(Known {
        range,
        what,
        saturates,
    }) = known
    else {
        return;
    };
    let axes = robot.vehicle.axes();
    let consequence = if *saturates {
        "its powertrain saturates it at its fitted limits"
    } else {
        "the model extrapolates beyond its data"
    };
    let found = cmds.iter().enumerate().find_map(|(k, u)| {
        let values: Vec<f64> = (0..axes.len()).map(|i| u[i]).collect();
        range.beyond(&values).map(|(i, v)| (k, i, v))
    });
    if let Some((k, i, v)) = found {
        let (lo, hi) = (range.min[i], range.max[i]);
        super::common::note(format!(
            "note: command {k} holds {} {} on axis '{}', beyond {what} ([{}, {}]): {consequence}; in the robot's units?",
            crate::traits::limits::Short(v),
            axes[i].unit,
            axes[i].command_column,
            crate::traits::limits::Short(lo),
            crate::traits::limits::Short(hi)
        ));
    }
}

/// A note when the start's measured inputs (`--start-wheels`) lie beyond the inputs the
/// model knows, or its body velocity (`--start-velocity`) beyond twice the fastest those
/// inputs drive the vehicle: a start no data showed, from which the model's state runs
/// wherever its dynamics take it (a wheel at 1e6 rad/s: 1e7 m in two seconds).
fn note_start_beyond_known(
    known: Option<&Known>,
    robot: &crate::traits::RobotDescription,
    measured: Input,
    velocity: Option<[f64; 2]>,
) {
    use crate::traits::limits::Short;
    let Some(Known { range, what, .. }) = known else {
        return;
    };
    let axes = robot.vehicle.axes();
    let values: Vec<f64> = (0..axes.len()).map(|i| measured[i]).collect();
    if let Some((i, v)) = range.beyond(&values) {
        super::common::note(format!(
            "note: --start-wheels holds {} {} on axis '{}', beyond {what} ([{}, {}]): a start no data showed; in the robot's units?",
            Short(v),
            axes[i].unit,
            axes[i].measured_column,
            Short(range.min[i]),
            Short(range.max[i])
        ));
    }
    let Some([vx, vy]) = velocity else {
        return;
    };
    let (fastest, _) = fastest_known(range, robot);
    let speed = vx.hypot(vy);
    if fastest.is_finite() && fastest > 0.0 && speed > 2.0 * fastest {
        super::common::note(format!(
            "note: --start-velocity is {} m/s, over twice the fastest {what} drive the vehicle ({} m/s): a start no data showed; in m/s?",
            Short(speed),
            Short(fastest)
        ));
    }
}

/// The fastest the known inputs drive the body (m/s) and turn it (rad/s): over the corners
/// of their box.
fn fastest_known(
    range: &crate::models::model_file::CommandRange,
    robot: &crate::traits::RobotDescription,
) -> (f64, f64) {
    let n = robot.vehicle.axes().len();
    (0..1usize << n)
        .map(|corner| {
            let u = Input::from_fn(|i, _| {
                if i >= n {
                    0.0
                } else if corner >> i & 1 == 1 {
                    range.max[i]
                } else {
                    range.min[i]
                }
            });
            let b = robot.vehicle.body_velocity(&u);
            (b.x.hypot(b.y), b.z.abs())
        })
        .fold((0.0, 0.0), |(v, w), (a, b)| {
            (f64::max(v, a), f64::max(w, b))
        })
}

/// A note when the predicted poses move faster than ten times the fastest the known inputs
/// drive the vehicle (a model file whose weights were edited to 1e8 went 25,000 km in two
/// seconds without a word): no robot moves so, whatever its ground.
fn note_implausible_speed(
    known: Option<&Known>,
    robot: &crate::traits::RobotDescription,
    dt: f64,
    poses: &[Pose],
) {
    use crate::traits::limits::Short;
    let Some(Known { range, .. }) = known else {
        return;
    };
    let (fastest, turning) = fastest_known(range, robot);
    if !(fastest.is_finite() && turning.is_finite() && dt > 0.0) {
        return;
    }
    let found = poses.windows(2).enumerate().find_map(|(k, p)| {
        let speed = (p[1].x - p[0].x).hypot(p[1].y - p[0].y) / dt;
        // The predicted yaw runs on unwrapped (a turn of 1e6 rad is no small one).
        let rate = (p[1].z - p[0].z).abs() / dt;
        if fastest > 0.0 && speed > 10.0 * fastest {
            Some((k + 1, speed, "m/s", fastest, "drive"))
        } else if turning > 0.0 && rate > 10.0 * turning {
            Some((k + 1, rate, "rad/s", turning, "turn"))
        } else {
            None
        }
    });
    if let Some((k, value, unit, most, how)) = found {
        super::common::note(format!(
            "note: the model predicts {} {unit} at step {k}, over ten times the fastest the inputs it knows {how} the vehicle ({} {unit}): no robot moves so; a model file edited, or fitted on data in other units?",
            Short(value),
            Short(most)
        ));
    }
}
