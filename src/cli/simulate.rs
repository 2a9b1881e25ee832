//! `drive simulate`: the protocol on a simulated robot, written as a window dataset.

use crate::samplers::RunnerConfig;
use crate::studies::{simulate_run, SimRun};
use crate::Registries;
use anyhow::{bail, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A registered robot (husky, hd2, warthog, ...; see drive list) or a robot TOML file.
    #[arg(long)]
    robot: String,
    /// Terrain: tile, gravel, snow, ice, ... (see drive list).
    #[arg(long)]
    terrain: String,
    /// Input sampler: uniform (DRIVE), grid, linear, angular, ... (see drive list).
    #[arg(long, default_value = "uniform")]
    sampler: String,
    /// Duration of the run (s), characterization included.
    #[arg(long, allow_negative_numbers = true)]
    duration: f64,
    /// Seed of the sampler and of the simulator's noise.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0)]
    seed: u64,
    /// Output window CSV (its sidecar JSON is written beside it).
    #[arg(long)]
    out: PathBuf,
    /// Also write what the DRIVE logger would have recorded (the raw CSV `drive
    /// import` reads).
    #[arg(long)]
    raw_out: Option<PathBuf>,
    /// Most samples the run may record (a guard against a mistyped --duration; about
    /// 0.5 kB of memory each).
    #[arg(long, allow_negative_numbers = true, default_value_t = crate::traits::limits::MAX_RUN_SAMPLES)]
    max_samples: usize,
    /// Print one JSON object on stdout (the run's windows, robot, terrain, input space
    /// and the simulator it ran on) instead of the text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    if !(args.duration.is_finite() && args.duration > 0.0) {
        bail!(
            "--duration must be a positive number of seconds, got {}",
            crate::traits::limits::Short(args.duration)
        );
    }
    let sidecar = crate::data::sidecar_path(&args.out);
    let mut planned = vec![
        ("--out", args.out.as_path()),
        ("sidecar of --out", &sidecar),
    ];
    if let Some(raw) = &args.raw_out {
        planned.push(("--raw-out", raw));
    }
    let mut inputs = super::common::robot_input(&args.robot);
    inputs.extend(super::common::terrain_input("--terrain", &args.terrain));
    let mut outputs = super::common::outputs_for(&inputs, &planned)?;
    super::common::csv_output_name("--out", &args.out)?;
    if let Some(raw) = &args.raw_out {
        super::common::csv_output("--raw-out", raw, "a raw log (CSV, uncompressed)", false)?;
    }
    super::common::check_max_samples(args.max_samples)?;
    let spec = registries.robot(&args.robot)?;
    if args.raw_out.is_some() {
        crate::data::check_raw_vehicle(spec.vehicle.as_ref())
            .map_err(|e| anyhow::anyhow!("--raw-out: {e}"))?;
    }
    let ground = registries.terrain(&args.terrain)?;
    let run = simulate_run(
        registries,
        &SimRun {
            robot: spec.clone(),
            terrain: ground.clone(),
            sampler: args.sampler.clone(),
            runner: RunnerConfig {
                max_duration_s: Some(args.duration),
                max_samples: args.max_samples,
                ..RunnerConfig::default()
            },
            seed: args.seed,
        },
    )?;
    if let crate::samplers::RunnerState::Done(
        crate::samplers::StopReason::CharacterizationFailed(why),
    ) = &run.stop
    {
        bail!("the characterization of {} failed: {why}", spec.name);
    }
    if run.dataset.windows.is_empty() {
        use crate::samplers::{PauseReason, RunnerState};
        // What held it up, when the runner was pausing.
        let paused = run.states.iter().rev().find_map(|(_, s)| match s {
            RunnerState::Paused { reason, .. } => Some(reason.clone()),
            _ => None,
        });
        let why = match paused {
            Some(PauseReason::LocalizationStale) => "; the runner kept pausing: the localization updates too rarely for its watchdog (sensors.icp_rate_hz against the 0.5 s stale timeout)",
            Some(PauseReason::EncodersStale) => "; the runner kept pausing: no encoder data within its watchdog's 0.5 s",
            Some(PauseReason::DeadmanReleased) => "; the dead-man switch was released",
            None if ground.protocol.is_some() => " (a twin skips the characterization; an interval takes 6 s)",
            None => " (characterization takes about 24 s, an interval 6 s)",
        };
        bail!(
            "the run of {} s recorded no complete interval{why}",
            crate::traits::limits::Short(args.duration)
        );
    }
    crate::data::stage_dataset(&mut outputs, &run.dataset, &args.out)?;
    if let Some(path) = &args.raw_out {
        let mut text = String::new();
        let columns = crate::data::raw_columns(spec.vehicle.as_ref());
        crate::data::write_raw_log(&run.raw, &columns, &[], &mut text);
        outputs.write(path, text)?;
    }
    let space = match &run.characterization {
        None => "user-given".to_string(),
        Some(c) => {
            let axes = spec.vehicle.axes();
            // Two decimals, or a short form for a number too large to read that way.
            let n = |v: f64| {
                if v.abs() < 1e6 {
                    format!("{v:.2}")
                } else {
                    crate::traits::limits::Short(v).to_string()
                }
            };
            let mut text = axes
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    format!(
                        "{} [{}, {}] {}",
                        a.name,
                        n(c.space.min[i]),
                        n(c.space.max[i]),
                        a.unit
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            for (name, value) in &c.geometry {
                text += &format!(", effective {name} {value:.3}");
            }
            if let Some(p) = &ground.protocol {
                text += &format!(
                    " (the twin's protocol: drawn with a {:.3} m baseline)",
                    p.baseline
                );
            }
            text
        }
    };
    let simulator = crate::sim::simulator_used(&registries.simulators, &spec);
    if args.json {
        let json = serde_json::json!({
            "windows": run.dataset.windows.len(),
            "intervals": run.dataset.windows.len() / 3,
            "robot": spec.name,
            "terrain": ground.name,
            "sampler": args.sampler,
            "seed": args.seed,
            "input_space": run.characterization.as_ref().map(|c| c.space),
            "geometry": run.characterization.as_ref().map(|c| c.geometry.clone()),
            "simulator": simulator,
            "out": args.out.display().to_string(),
        });
        outln!("{json}");
        // After the standard output: a command that cannot write it fails with nothing
        // new published.
        super::common::publish(outputs)?;
        return Ok(());
    }
    super::common::publish(outputs)?;
    say!(
        "{} windows ({} intervals) of {} on {}; input space {space}; saved to {}",
        run.dataset.windows.len(),
        run.dataset.windows.len() / 3,
        spec.name,
        ground.name,
        args.out.display()
    );
    say!("simulator: {simulator}");
    Ok(())
}
