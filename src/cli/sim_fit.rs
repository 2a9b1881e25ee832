//! `drive sim-fit`: a twin of a real robot for the simulator, fitted on a DRIVE dataset.

use super::common::{emit, load, outputs_for, robot_input, DataArgs};
use crate::Registries;
use anyhow::Result;
use clap::builder::TypedValueParser;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    data: DataArgs,
    /// The robot the data was recorded with (a registered name or a robot TOML file): its
    /// mass and build; the geometry is the data's.
    #[arg(long)]
    robot: String,
    /// Output terrain TOML (`drive simulate --terrain FILE`). Optional with --twin (the
    /// checked twin is then written only when given).
    #[arg(long, required_unless_present = "twin")]
    out: Option<PathBuf>,
    /// Check this twin (a terrain TOML file, e.g. one `sim-fit` wrote, or a preset's name)
    /// against the data instead of fitting one: the same check and the same refusal, in a
    /// fraction of the time. A twin fitted on one run, checked on another run of the same
    /// robot and terrain, says whether it holds beyond the run it was fitted on: the twin is
    /// given the checked run's commands (with --check-commands draw, fresh draws of its own
    /// file's protocol instead: check it then on runs driven the same way; docs/twins.md).
    #[arg(long)]
    twin: Option<String>,
    /// The twin's name (default: the dataset's name and "twin").
    #[arg(long)]
    name: Option<String>,
    /// Print the fit as JSON on stdout: `parameters` (each fitted parameter with `name`,
    /// `value`, its range and `at_bound`), `check` (per model: `real_translational_m`,
    /// `twin_translational_m`, `real_rotational_rad`, `twin_rotational_rad`, and the real
    /// medians' 95% bootstrap intervals `real_translational_ci_m`, `real_rotational_ci_rad`),
    /// `scatter` (the steady windows' body velocity around a smooth function of their wheel
    /// speeds, `real` and `twin`), `command_scatter` (their wheel speeds around a smooth
    /// function of their commands: how consistently the wheels follow the commands;
    /// `command_scatter_off` names those further than 30% from the real run's, reported),
    /// `speed_kept` (the share of the commanded forward speed, driving nearly straight, and
    /// of the commanded yaw rate, turning, the body keeps on held commands: medians over the
    /// steady windows, `real` and `twin`; `speed_kept_off` names those further than 30%,
    /// reported),
    /// `check_seeds`, `check_commands`, `poor`, `written`, `fitted` (false with
    /// --twin), and the twin (`terrain`), the fit's `report` and `variability_choice`
    /// (whether the fitted variability was kept: `kept`, the `fitted` variability, and the
    /// mean distance of the models' medians from the real run's and how many are beyond 30%,
    /// `with` and `without` it, on two runs of its own `seeds`, the real commands replayed;
    /// absent with --twin or when no variability was fitted), and `contact_spread_choice`
    /// (the contacts' spread along each side the twin keeps, a share of the baseline: `kept`,
    /// `vehicle_own`, `chosen` (false with --contact-spread own or a share), and each spread
    /// `tried` with its `distance`, the same measure on the same seeds; another spread than
    /// the vehicle's is kept only when its twin comes clearly closer; absent with --twin). A
    /// twin
    /// refused by the check is printed too, with `"written": false`, and the command fails.
    #[arg(long)]
    json: bool,
    /// Write the twin even when the check finds a median (naive, powertrain, slip-blr,
    /// slip-ipem; translational or rotational) more than 30% from the real run's.
    #[arg(long)]
    allow_poor_twin: bool,
    /// Seeds of the twin's runs in the check (1, 2, ...): each as long as the real run.
    #[arg(long, default_value_t = 3)]
    check_seeds: usize,
    /// What the twin's runs in the check are commanded: the real run's commands in their
    /// order (replay: twin and robot on the same inputs, the seeds varying the twin's noise),
    /// or fresh draws of the twin's protocol, one sequence per seed (draw).
    #[arg(
        long,
        default_value = "replay",
        value_parser = clap::builder::PossibleValuesParser::new(["replay", "draw"])
            .try_map(|name| crate::studies::CheckCommands::parse(&name))
    )]
    check_commands: crate::studies::CheckCommands,
    /// The contacts' spread along each side the twin's ground is fitted with, a share of
    /// the baseline: choose (the vehicle's own and 0.6, 0.75 and 1.2, the one whose twin
    /// comes clearly closer to the real run's model errors kept: four fits), own (the
    /// vehicle's own only: a quarter of the time) or a share (that one only, kept in the
    /// twin file).
    #[arg(
        long,
        default_value = "choose",
        conflicts_with = "twin",
        value_parser = |s: &str| crate::studies::ContactSpreads::parse(s)
    )]
    contact_spread: crate::studies::ContactSpreads,
}

/// What `drive sim-fit --json` prints.
#[derive(serde::Serialize)]
struct Output<'a> {
    parameters: Vec<crate::sim::FittedParameter>,
    check: &'a [crate::studies::TwinCheckRow],
    scatter: Option<crate::studies::ScatterCheck>,
    command_scatter: Option<crate::studies::ScatterCheck>,
    speed_kept: Option<crate::studies::ScatterCheck>,
    check_seeds: &'a [u64],
    check_commands: crate::studies::CheckCommands,
    tolerance: f64,
    poor: &'a [String],
    scatter_off: &'a [String],
    command_scatter_off: &'a [String],
    speed_kept_off: &'a [String],
    written: bool,
    fitted: bool,
    /// The simulator the twin's check ran on.
    simulator: crate::sim::SimulatorUsed,
    terrain: &'a crate::sim::Terrain,
    #[serde(skip_serializing_if = "Option::is_none")]
    report: Option<&'a crate::sim::SimFitReport>,
    /// The ground fit of a vehicle of another type than the differential drive (absent
    /// otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    ground_fit: Option<&'a crate::sim::AnyVehicleFitReport>,
    /// Whether the fitted twin kept its variability (absent with --twin, or without one).
    #[serde(skip_serializing_if = "Option::is_none")]
    variability_choice: Option<&'a crate::studies::VariabilityChoice>,
    /// Which contact spread the fitted twin kept (absent with --twin).
    #[serde(skip_serializing_if = "Option::is_none")]
    contact_spread_choice: Option<&'a crate::studies::ContactSpreadChoice>,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    if let Some(name) = &args.name {
        if !crate::sim::Terrain::is_valid_name(name) {
            let why = if name.trim().is_empty() {
                "is blank"
            } else if name.chars().count() > 200 {
                "is longer than 200 characters"
            } else {
                "holds a control character or a line break"
            };
            anyhow::bail!(
                "--name {why}: it must be 1 to 200 characters, not all blank, without control characters (it names the terrain in every output line)"
            );
        }
    }
    if let Some(out) = args.out.as_ref().filter(|o| o.is_dir()) {
        anyhow::bail!("cannot write {}: it is a directory", out.display());
    }
    if args.twin.is_some() && args.name.is_some() {
        anyhow::bail!("--name names a fitted twin; a checked twin (--twin) keeps its own name");
    }
    let mut inputs = args.data.inputs();
    inputs.extend(robot_input(&args.robot));
    if let Some(twin) = &args.twin {
        inputs.extend(super::common::terrain_input("--twin", twin));
    }
    let planned: Vec<(&str, &std::path::Path)> =
        args.out.iter().map(|o| ("--out", o.as_path())).collect();
    let mut outputs = outputs_for(&inputs, &planned)?;
    // An input replaced is said first; then a name of another kind of file.
    if let Some(out) = &args.out {
        super::common::named_output(
            "--out",
            out,
            "a twin (TOML)",
            &[".json", ".yaml", ".yml", ".md", ".html", ".svg", ".png"],
        )?;
    }
    let spec = registries.robot(&args.robot)?;
    // A twin to check is read before the data: a mistyped name fails at once.
    let given = args
        .twin
        .as_deref()
        .map(|t| registries.terrain(t))
        .transpose()?;
    let data = load(registries, &args.data)?;
    // What the data checks warn of (their fatal findings refuse the data, below).
    super::common::note_quality(&data, false);
    let name = args
        .name
        .clone()
        // Within a terrain name's 200 characters, whatever the dataset's name.
        .unwrap_or_else(|| {
            let base: String = data.robot.name.chars().take(195).collect();
            format!("{base} twin")
        });
    if args.check_seeds == 0 {
        anyhow::bail!("--check-seeds must be at least 1");
    }
    crate::traits::limits::at_most(
        "--check-seeds",
        args.check_seeds as f64,
        crate::traits::limits::MAX_SEEDS as f64,
        "",
    )?;
    let models = registries
        .models()
        .resolve_list(&crate::studies::TWIN_CHECK_MODELS)?;
    // The twin: fitted on the data (its variability kept, and its contact spread other
    // than the vehicle's, only where that brings the models' errors closer to the real
    // run's: drive_studies::fit_twin), or the one given to check.
    let differential = |v: &dyn crate::traits::CommandModel| {
        crate::traits::vehicle_as::<crate::models::DifferentialDrive>(v).is_some()
    };
    let skid_steer =
        differential(data.robot.vehicle.as_ref()) && differential(spec.vehicle.as_ref());
    if !skid_steer
        && given.is_none()
        && args.contact_spread != crate::studies::ContactSpreads::Choose
    {
        anyhow::bail!(
            "--contact-spread is a skid-steer twin's (the contacts along each side); a twin of the vehicle type '{}' fits its ground only",
            crate::traits::vehicle_tag(data.robot.vehicle.as_ref()).unwrap_or_default()
        );
    }
    // A vehicle of another type: the ground of its own simulator, fitted on the real run's
    // motion (drive_sim::fit_any_vehicle); the skid-steer fit's stages are a differential
    // drive's.
    let ground_fit = match (&given, skid_steer) {
        (None, false) => Some(crate::sim::fit_any_vehicle(
            &registries.simulators,
            &data,
            &spec,
            &name,
        )?),
        _ => None,
    };
    let (terrain, report, variability_choice, contact_spread_choice) = match given {
        None if ground_fit.is_some() => {
            // Set just above when there is no twin to check and the vehicle is not a skid-steer.
            let fit = ground_fit.as_ref().expect("a ground fit");
            (fit.terrain.clone(), None, None, None)
        }
        // A twin is checked only against data a twin could be fitted on (the same
        // refusals: another robot's geometry, too few windows, a frozen localization, ...).
        Some(terrain) => {
            crate::sim::check_real_run(&data, &spec)?;
            (terrain, None, None, None)
        }
        None => {
            let twin = crate::studies::fit_twin_with(
                registries,
                &data,
                &spec,
                &name,
                &models,
                args.contact_spread,
            )?;
            (
                twin.fit.terrain,
                Some(twin.fit.report),
                twin.variability,
                Some(twin.contact_spread),
            )
        }
    };
    // The twin check: the twin's runs against the real one.
    let seeds: Vec<u64> = (1..=args.check_seeds as u64).collect();
    let check = crate::studies::twin_check(
        registries,
        &data,
        &spec,
        &terrain,
        &seeds,
        &models,
        args.check_commands,
    )?;
    let window_s = data.robot.window_len as f64 / data.robot.rate_hz;
    // A fitted twin's variability is at a bound at the limit its fit searched to.
    let limits = report.as_ref().and_then(|r| r.variability_limits);
    let parameters = crate::sim::fitted_parameters_within(&terrain, window_s, limits);
    let poor = !check.poor.is_empty();
    let accepted = !poor || args.allow_poor_twin;
    let written = accepted && args.out.is_some();
    let output = Output {
        parameters,
        check: &check.check,
        scatter: check.scatter,
        command_scatter: check.command_scatter,
        speed_kept: check.speed_kept,
        check_seeds: &check.seeds,
        check_commands: check.commands,
        tolerance: check.tolerance,
        poor: &check.poor,
        scatter_off: &check.scatter_off,
        command_scatter_off: &check.command_scatter_off,
        speed_kept_off: &check.speed_kept_off,
        written,
        fitted: report.is_some() || ground_fit.is_some(),
        ground_fit: ground_fit.as_ref().map(|f| &f.report),
        simulator: crate::sim::simulator_used(&registries.simulators, &spec),
        terrain: &terrain,
        report: report.as_ref(),
        variability_choice: variability_choice.as_ref(),
        contact_spread_choice: contact_spread_choice.as_ref(),
    };
    if !accepted {
        // A refused twin's fit and check are still printed with --json (`"written": false`):
        // what to look at before deciding on --allow-poor-twin.
        if args.json {
            outln!("{}", serde_json::to_string(&output)?);
        }
        anyhow::bail!(
            "the twin {}: it does not drive like the real run within {:.0}%: {}; {} anyway with --allow-poor-twin",
            if args.out.is_some() { "was not written" } else { "fails its check" },
            100.0 * check.tolerance,
            check.poor.join("; "),
            if args.out.is_some() { "write it" } else { "accept it" },
        );
    }
    if let Some(out) = &args.out {
        outputs.write(out, terrain.to_toml())?;
    }
    if poor {
        super::common::note(format!(
            "note: a poor twin, {} with --allow-poor-twin: {}",
            if written { "written" } else { "accepted" },
            check.poor.join("; ")
        ));
    }
    emit(args.json, &output, |o| {
        let t = o.terrain;
        let saved = args
            .out
            .as_ref()
            .filter(|_| o.written)
            .map_or(String::new(), |out| format!("; saved to {}", out.display()));
        let mut text = match o.report {
            Some(r) => fit_text(
                t,
                r,
                &data,
                &saved,
                o.variability_choice,
                o.contact_spread_choice,
            ),
            None if o.ground_fit.is_some() => {
                // Matched by this arm's guard.
                ground_fit_text(t, o.ground_fit.expect("a ground fit"), &data, &saved)
            }
            None => format!(
                "twin '{}' ({}) checked against {}, not fitted{saved}\n",
                t.name,
                args.twin.as_deref().unwrap_or_default(),
                data.robot.name,
            ),
        };
        text += &format!("simulator: {}\n", o.simulator);
        text += &format!(
            "twin check ({} runs of the twin as long as the real run, seeds {}, {}; each split in halves, eq. 8 medians over the evaluation halves, {} real and {} twin windows):\n",
            o.check_seeds.len(),
            o.check_seeds
                .iter()
                .map(u64::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            match o.check_commands {
                crate::studies::CheckCommands::Replay => "each given the real run's commands",
                crate::studies::CheckCommands::Draw => "each drawing its own commands",
            },
            check.windows[0],
            check.windows[1]
        );
        text += &format!(
            "  {:<11} {:>10} {:>16} {:>10} {:>6}   {:>10} {:>16} {:>10} {:>6}\n",
            "model",
            "real [m]",
            "real 95% [m]",
            "twin [m]",
            "off",
            "real [rad]",
            "real 95% [rad]",
            "twin [rad]",
            "off"
        );
        let interval = |[lo, hi]: [f64; 2]| format!("[{lo:.3}, {hi:.3}]");
        for c in o.check {
            text += &format!(
                "  {:<11} {:>10.4} {:>16} {:>10.4} {:>+5.0}%   {:>10.4} {:>16} {:>10.4} {:>+5.0}%\n",
                c.model,
                c.real_translational_m,
                interval(c.real_translational_ci_m),
                c.twin_translational_m,
                c.translational_off_percent,
                c.real_rotational_rad,
                interval(c.real_rotational_ci_rad),
                c.twin_rotational_rad,
                c.rotational_off_percent
            );
        }
        for (what, scatter, off) in [
            ("steady scatter", o.scatter, o.scatter_off),
            (
                "wheels around a smooth function of the commands (steady)",
                o.command_scatter,
                o.command_scatter_off,
            ),
        ] {
            let Some(s) = scatter else { continue };
            let outside = if off.is_empty() {
                String::new()
            } else {
                format!(" (outside {:.0}%: {})", 100.0 * o.tolerance, off.join("; "))
            };
            text += &format!(
                "  {what}: real {:.3} m/s and {:.3} rad/s, twin {:.3} and {:.3}{outside}\n",
                s.real[0], s.real[1], s.twin[0], s.twin[1],
            );
        }
        if let Some(s) = o.speed_kept {
            let outside = if o.speed_kept_off.is_empty() {
                String::new()
            } else {
                format!(
                    " (outside {:.0}%: {})",
                    100.0 * o.tolerance,
                    o.speed_kept_off.join("; ")
                )
            };
            text += &format!(
                "  speed kept on held commands (body over commanded, steady): forward {:.2} real, {:.2} twin; yaw {:.2} real, {:.2} twin{outside}\n",
                s.real[0], s.twin[0], s.real[1], s.twin[1],
            );
        }
        text += &if o.poor.is_empty() {
            format!(
                "  every median within {:.0}% of the real run's\n",
                100.0 * o.tolerance
            )
        } else {
            format!(
                "  outside {:.0}% ({} with --allow-poor-twin): {}\n",
                100.0 * o.tolerance,
                if o.written { "written" } else { "accepted" },
                o.poor.join("; ")
            )
        };
        if let Some(q) = &t.protocol {
            let [[l0, l1], [r0, r1]] = q.input_limits;
            text += &format!(
                "protocol: wheel speeds drawn in left [{l0:.2}, {l1:.2}] and right [{r0:.2}, {r1:.2}] rad/s with a {:.3} m baseline (the data's {:.3} m){}, commands {}\n",
                q.baseline,
                data_baseline(&data),
                q.body_limits.map_or(String::new(), |[[v0, v1], [w0, w1]]| format!(
                    " within forward speeds [{v0:.2}, {v1:.2}] m/s and yaw rates [{w0:.2}, {w1:.2}] rad/s"
                )),
                match (q.max_linear_acceleration, q.max_angular_acceleration) {
                    (Some(a), Some(b)) => format!("ramped at {a:.2} m/s^2 and {b:.2} rad/s^2"),
                    _ => "stepped".to_string(),
                }
            );
        }
        text
    })?;
    // The standard output first: a command that cannot write it fails with nothing new
    // published.
    if args.out.is_some() {
        super::common::publish(outputs)?;
    }
    Ok(())
}

/// The fit's part of `drive sim-fit`'s text: each stage's parameters and how well they fit.
fn fit_text(
    t: &crate::sim::Terrain,
    r: &crate::sim::SimFitReport,
    data: &crate::traits::Dataset,
    saved: &str,
    choice: Option<&crate::studies::VariabilityChoice>,
    spread: Option<&crate::studies::ContactSpreadChoice>,
) -> String {
    let c = t.controller.unwrap_or_default();
    // sim_fit always fits the powertrain (this text is a fit's only).
    let p = t.powertrain.expect("a fitted twin has a powertrain");
    let s = t.sensors.unwrap_or_default();
    let limit =
        |a: Option<f64>, unit: &str| a.map_or("none".to_string(), |a| format!("{a:.2} {unit}"));
    let mut text = format!(
        "twin '{}' of {} fitted on {} steady and {} transient windows{saved}\n",
        t.name, data.robot.name, r.steady_windows, r.transient_windows,
    );
    let st = &r.turn_stall;
    text += &match st.stall {
        Some(stall) => format!(
            "turn stall: {} of {} commands starting or reversing a turn left the wheels turning together (under 0.3 of a followed turn's share, {:.2}), {} of {} continuing one: each such command stalls with probability {:.3}, its wheels keeping {:.3} of its turn (the stalled ones left out of the controller's and powertrain's fits)\n",
            st.stalled_starts, st.starts, st.followed_share, st.stalled_continued, st.continued, stall.probability, stall.share,
        ),
        None if st.followed_share.is_nan() => format!(
            "turn stall: none ({} turn commands continued a turn the wheels made, fewer than the 5 a followed turn's share is measured on; {} started or reversed one)\n",
            st.continued, st.starts,
        ),
        None => format!(
            "turn stall: none ({} of {} commands starting or reversing a turn left the wheels turning together, {} of {} continuing one; a stall needs 3)\n",
            st.stalled_starts, st.starts, st.stalled_continued, st.continued,
        ),
    };
    text += &format!(
        "controller: linear gain {:.3}, angular gain {:.3}, max {:.3} m/s and {:.3} rad/s, acceleration limits {} and {}; wheel limit {:.2} rad/s, right side x{:.3} (steady encoders RMS {:.3} rad/s)\n",
        c.linear_gain,
        c.angular_gain,
        c.max_linear.unwrap_or(f64::INFINITY),
        c.max_angular.unwrap_or(f64::INFINITY),
        limit(c.max_linear_acceleration, "m/s^2"),
        limit(c.max_angular_acceleration, "rad/s^2"),
        p.wheel_limit,
        p.right_gain,
        r.controller_rms,
    );
    text += &format!(
        "powertrain: time constant {:.3} s rising, {:.3} s falling, dead time {:.3} s (transient encoders RMS {:.3} rad/s)\n",
        p.time_constant[0], p.time_constant[1], p.dead_time, r.powertrain_rms,
    );
    let [[sv, sw], [tv, tw]] = r.terrain_rms;
    let [[sv0, sw0], [tv0, tw0]] = r.terrain_rms_start;
    text += &format!(
        "ground: traction {:.3}, lateral {:.3}, slip modulus {:.3}, rolling {:.3} (body velocity RMS {sv:.3} m/s and {sw:.3} rad/s steady, {tv:.3} and {tw:.3} transient; from the gravel preset {sv0:.3}, {sw0:.3}, {tv0:.3}, {tw0:.3})\n",
        t.traction, t.lateral, t.slip_modulus, t.rolling,
    );
    text += &match (&t.variability, &r.scatter, choice.map(|c| c.fitted)) {
        (Some(v), Some(sc), _) => format!(
            "variability: traction {:.3}, lateral {:.3}, rolling {:.3} (log standard deviations), correlation time {:.2} s (steady scatter {:.3} m/s and {:.3} rad/s; the twin's {:.3} and {:.3}, {:.3} and {:.3} without)\n",
            v.traction, v.lateral, v.rolling, v.correlation_time,
            sc.real.rms[0], sc.real.rms[1], sc.twin.rms[0], sc.twin.rms[1], sc.without.rms[0], sc.without.rms[1],
        ),
        (None, Some(sc), Some(v)) => format!(
            "variability: fitted traction {:.3}, lateral {:.3}, rolling {:.3} (log standard deviations), correlation time {:.2} s, and dropped (below); none in the twin (steady scatter {:.3} m/s and {:.3} rad/s; the twin's {:.3} and {:.3} without it)\n",
            v.traction, v.lateral, v.rolling, v.correlation_time,
            sc.real.rms[0], sc.real.rms[1], sc.twin.rms[0], sc.twin.rms[1],
        ),
        (None, Some(sc), None) => format!(
            "variability: none (steady scatter {:.3} m/s and {:.3} rad/s; the twin's already {:.3} and {:.3})\n",
            sc.real.rms[0], sc.real.rms[1], sc.twin.rms[0], sc.twin.rms[1],
        ),
        _ => "variability: none (fewer than 30 steady windows to measure it)\n".to_string(),
    };
    if let Some(c) = choice {
        // The models' errors decide (drive_studies::choose_variability).
        text += &format!(
            "variability {}: on two runs of its own (seeds {}, not the check's below; the real commands replayed), the twin's medians are {:.1}% from the real run's on average with it ({} beyond 30%), {:.1}% ({}) without\n",
            if c.kept { "kept" } else { "dropped" },
            c.seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", "),
            c.with.mean_off_percent,
            c.with.beyond_tolerance,
            c.without.mean_off_percent,
            c.without.beyond_tolerance,
        );
    }
    if let Some(s) = spread {
        text += &contact_spread_text(s);
    }
    text += &format!(
        "sensors: localization {:.1} Hz with {:.4} m and {:.4} rad noise and timestamps jittering by up to {:.3} s, encoders {:.3} rad/s, IMU {:.4} rad/s with a {:+.4} rad/s bias\n",
        s.icp_rate_hz, s.icp_noise[0], s.icp_noise[1], s.icp_jitter, s.encoder_noise, s.imu_noise, s.imu_bias,
    );
    if let Some((mean, long)) = s.gap_summary() {
        text += &format!(
            "sensors: the localization's pose changes every {mean:.3} s on average, {:.1}% of its updates 0.5 s or more after the previous one (held, then caught up)\n",
            100.0 * long
        );
    }
    let [[dv, dw], [tv, tw]] = r.motion;
    text += &format!(
        "check: the twin's steady windows move at {tv:.3} m/s and {tw:.3} rad/s on average (mean absolute forward speed and yaw rate; the data's {dv:.3} and {dw:.3})\n"
    );
    if !r.at_bounds.is_empty() {
        text += &format!(
            "note: at a bound of its range, not pinned down by the data: {}\n",
            r.at_bounds.join(", ")
        );
    }
    text
}

/// The text of a ground fit of a vehicle of another type ([`crate::sim::fit_any_vehicle`]).
fn ground_fit_text(
    t: &crate::sim::Terrain,
    r: &crate::sim::AnyVehicleFitReport,
    data: &crate::traits::Dataset,
    saved: &str,
) -> String {
    let rms = |m: [f64; 3]| format!("{:.3} m/s, {:.3} m/s, {:.3} rad/s", m[0], m[1], m[2]);
    let mut text = format!(
        "twin '{}' fitted on {} ({} steady windows, {} intervals compared){saved}: the ground of the {} simulator{}, from the preset '{}'\n",
        t.name,
        data.robot.name,
        r.steady_windows,
        r.intervals_compared,
        r.simulator,
        if r.stand_in {
            " (the kinematic stand-in: no simulator is registered for this vehicle type)"
        } else {
            ""
        },
        r.start
    );
    text += &format!(
        "ground: traction {:.3}, lateral {:.3}, rolling {:.3}, slip_modulus {:.3}\n",
        t.traction, t.lateral, t.rolling, t.slip_modulus
    );
    text += &format!(
        "steady motion, RMS twin minus real per interval (forward, sideways, yaw): {} at the start, {} fitted\n",
        rms(r.motion_rms_start),
        rms(r.motion_rms)
    );
    if !r.insensitive.is_empty() {
        text += &format!(
            "note: not pinned down by the data (the simulator barely responds to it): {}\n",
            r.insensitive.join(", ")
        );
    }
    if !r.at_bounds.is_empty() {
        text += &format!(
            "note: at a bound of its range, not pinned down by the data: {}\n",
            r.at_bounds.join(", ")
        );
    }
    text += &format!(
        "not fitted (a twin of this vehicle type fits its ground only): {}\n",
        r.not_fitted.join("; ")
    );
    text
}

/// The data's baseline (a differential drive: sim-fit refuses the others).
fn data_baseline(data: &crate::traits::Dataset) -> f64 {
    crate::traits::vehicle_as::<crate::models::DifferentialDrive>(data.robot.vehicle.as_ref())
        .map_or(f64::NAN, |g| g.baseline)
}

/// The `contact spread:` line of `drive sim-fit`'s text ([`crate::studies::fit_twin`]).
fn contact_spread_text(s: &crate::studies::ContactSpreadChoice) -> String {
    let seeds = s
        .seeds
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join(", ");
    let tried = |t: &crate::studies::SpreadTried| match (&t.distance, &t.error) {
        (Some(d), _) => format!(
            "{:.2}{}: {:.1}% ({} beyond 30%)",
            t.contact_spread,
            if t.vehicle_own {
                " (the vehicle's)"
            } else {
                ""
            },
            d.mean_off_percent,
            d.beyond_tolerance
        ),
        (None, e) => format!(
            "{:.2}: not fitted ({})",
            t.contact_spread,
            e.as_deref().unwrap_or("no reason given")
        ),
    };
    if !s.chosen {
        return format!(
            "contact spread: {:.2} of the baseline ({}, as asked: no other tried); the twin's medians from the real run's on two runs of its own (seeds {seeds}): {}\n",
            s.kept,
            if s.vehicle_own {
                "the vehicle's"
            } else {
                "given"
            },
            s.tried.iter().map(tried).collect::<Vec<_>>().join("; ")
        );
    }
    format!(
        "contact spread: {:.2} of the baseline{}; the twin's medians from the real run's on two runs of its own (seeds {seeds}), with each spread tried: {}\n",
        s.kept,
        if s.vehicle_own {
            " (the vehicle's: no other came clearly closer)"
        } else {
            " (its twin came clearly closer than the vehicle's)"
        },
        s.tried.iter().map(tried).collect::<Vec<_>>().join("; ")
    )
}
