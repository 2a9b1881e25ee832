//! `drive track`: the learned models inside a model-predictive controller, on the
//! simulator (a preset terrain or a twin of a real run): path following per model, training
//! data, path, speed and seed.

use super::common::{emit, outputs_for, parse_number, Progress};
use crate::control::{MakeController, Mppi, PathShape, ReferencePath};
use crate::studies::{run_track, PathChoice, TrackStudy, Training};
use crate::traits::limits;
use crate::Registries;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// Largest path file read (bytes): 100,000 points of two numbers.
const MAX_PATH_FILE_BYTES: u64 = 8 << 20;

#[derive(clap::Args)]
pub struct Args {
    /// The robot (a registered name or a robot TOML file).
    #[arg(long, default_value = "husky")]
    robot: String,
    /// The ground: a registered terrain, or a twin's terrain file (`drive sim-fit`).
    #[arg(long, default_value = "gravel")]
    terrain: String,
    /// A ground that changes along the path, comma-separated (registered terrains or
    /// twins' terrain files): the path cut into as many equal stretches, the first
    /// driven on the first ground (the robot's, as --terrain), each next one on the next.
    /// The JSON's runs and summary add `cross_track_rms_after_change_m`.
    #[arg(long, value_delimiter = ',', conflicts_with = "terrain")]
    terrains: Vec<String>,
    /// Window CSVs (or bundled:NAME) to fit the models on, every window of each,
    /// comma-separated; recorded with the robot.
    #[arg(long, value_delimiter = ',')]
    train_data: Vec<PathBuf>,
    /// The sidecars of --train-data, comma-separated, one per file (default: beside each
    /// CSV, `run.csv` -> `run.meta.json`, or the older `run.json`).
    #[arg(long, value_delimiter = ',', requires = "train_data")]
    train_sidecar: Vec<PathBuf>,
    /// Samplers of simulated DRIVE training runs on the same robot and ground (one run per
    /// seed each), comma-separated: uniform (DRIVE), linear, angular, ...; the closed-loop
    /// Table I with all three. Default: uniform, when no --train-data is given.
    #[arg(long, value_delimiter = ',')]
    train_sampler: Vec<String>,
    /// Driving time of each simulated training run (s).
    #[arg(long, default_value_t = 300.0, value_parser = parse_number, allow_hyphen_values = true)]
    train_duration: f64,
    /// Paths, comma-separated: line, circle, figure8, zigzag (scaled to the robot: 4 s at
    /// its top speed, at least 2 m), or a CSV file with the header x,y (placed at the
    /// robot's start, leaving along its heading).
    #[arg(long, value_delimiter = ',', default_value = "figure8,zigzag")]
    path: Vec<String>,
    /// Speeds along the path as fractions of the robot's top speed on this ground (measured
    /// on the simulator), comma-separated, each in (0, 1].
    #[arg(long, value_delimiter = ',', default_value = "0.5", value_parser = parse_number, allow_hyphen_values = true)]
    speed: Vec<f64>,
    /// Models, comma-separated (see drive list), or model files (`drive train --out`,
    /// ending in .json: driven as they are, on every training source); the first is the
    /// one the others are compared with.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "naive,slip-blr,slip-ipem"
    )]
    models: Vec<String>,
    /// What the models' predictions start from (and are fitted for): encoders,
    /// encoders+imu or encoders+imu+localization.
    #[arg(long, default_value = "encoders+imu", value_parser = crate::traits::StartInfo::NAMES)]
    start: String,
    /// Number of seeds (seed, seed+1, ...): the simulator's noise and the simulated
    /// training runs.
    #[arg(long, default_value_t = 1)]
    seeds: usize,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The controller (see drive list).
    #[arg(long, default_value = "mppi")]
    controller: String,
    /// MPPI settings from a TOML file (any of samples, horizon, temperature, noise,
    /// noise_correlation, position_weight, heading_weight, terminal_weight, effort_weight,
    /// smoothness_weight, uncertainty_weight, seed; see docs/closed-loop.md); the flags below
    /// override it.
    #[arg(long)]
    mppi_config: Option<PathBuf>,
    /// MPPI: candidate input sequences per tick (default 1024).
    #[arg(long)]
    samples: Option<usize>,
    /// MPPI: horizon in steps (default 40: 2 s at 20 Hz).
    #[arg(long)]
    horizon: Option<usize>,
    /// MPPI: temperature, relative to the spread of a tick's costs (default 0.1).
    #[arg(long, value_parser = parse_number, allow_hyphen_values = true)]
    temperature: Option<f64>,
    /// MPPI: weight of the predicted variance in the position and heading costs (default 0:
    /// the mean poses only; 1: the expected squared errors under the model's predictive
    /// distribution, the calibrated one by default). A model without a covariance is
    /// scored on its mean poses, and the output says so.
    #[arg(long, value_parser = parse_number, allow_hyphen_values = true)]
    uncertainty_weight: Option<f64>,
    /// Time limit of a run (s); default: twice the path's length at its speed, plus 20 s.
    #[arg(long, value_parser = parse_number, allow_hyphen_values = true)]
    time_limit: Option<f64>,
    /// How far back the controller's predictions start (s, 0 to 10): from the state this
    /// long ago through the commands sent since, so that the commands still in flight (dead
    /// time, lag) act in them; 0 starts them from now. Default: each model's powertrain's
    /// settling time (its dead time plus one time constant for eq. 3's FOPDT; 0.5 to 3 s).
    #[arg(long, value_parser = parse_number, allow_hyphen_values = true)]
    history: Option<f64>,
    /// Hand the controller each localization fix without the time it was measured (its
    /// stamp): the tracker then takes a fix as measured when it arrives, its latency unseen
    /// (a robot whose localization does not stamp its poses). Default: stamped.
    #[arg(long)]
    no_pose_stamps: bool,
    /// Hold the robot to a schedule along the path at the asked speed, the reference
    /// starting where the schedule is, within SECONDS of travel of the robot (ahead of it,
    /// it pulls; behind, it holds back): a model that misjudges the speed is corrected by
    /// the loop. 0: the reference starts where the robot is at every tick.
    #[arg(long, value_name = "SECONDS", value_parser = parse_number, allow_hyphen_values = true)]
    schedule: Option<f64>,
    /// Beside each model, the same model adapting to the ground inside the loop (named
    /// NAME-adaptive): every 2 s window the run drives is fed to `drive adapt`'s adaptive
    /// model, which the controller predicts with from the next tick on. With --terrains,
    /// how it follows a change of ground against the frozen model.
    #[arg(long)]
    adapt: bool,
    #[command(flatten)]
    useless: super::common::UselessArg,
    /// Print one JSON object on stdout instead of the tables.
    #[arg(long)]
    json: bool,
    /// Also write DIR/track.json, runs.csv, summary.csv, track.md and the paths figures
    /// (paths_<training>.png and .svg).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `Err` naming `flag` when `items` holds one twice (results are grouped by them).
fn distinct<T: PartialEq + std::fmt::Display>(flag: &str, items: &[T]) -> Result<()> {
    for (i, a) in items.iter().enumerate() {
        if items[..i].contains(a) {
            bail!("{flag} gives '{a}' twice (its results would be counted twice)");
        }
    }
    Ok(())
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    let schedule_s = match args.schedule {
        Some(s) if !(s.is_finite() && (0.0..=10.0).contains(&s)) => {
            bail!("--schedule {s}: give a number of seconds from 0 to 10")
        }
        Some(0.0) => None,
        s => s,
    };
    distinct("--path", &args.path)?;
    // `naive,,slip-blr` and `naive, slip-blr` as every command reads them; none is refused.
    let model_args = super::common::model_names(registries, &args.models)?;
    distinct("--models", &model_args)?;
    distinct("--train-sampler", &args.train_sampler)?;
    let speeds: Vec<String> = args.speed.iter().map(|s| s.to_string()).collect();
    distinct("--speed", &speeds)?;
    let data: Vec<String> = args
        .train_data
        .iter()
        .map(|d| d.display().to_string())
        .collect();
    distinct("--train-data", &data)?;
    if !args.train_sidecar.is_empty() && args.train_sidecar.len() != args.train_data.len() {
        bail!(
            "--train-sidecar gives {} sidecars for {} --train-data files: one each",
            args.train_sidecar.len(),
            args.train_data.len()
        );
    }
    if args
        .seed
        .checked_add(args.seeds.saturating_sub(1) as u64)
        .is_none()
    {
        bail!(
            "--seed {} with --seeds {} runs past the largest seed",
            args.seed,
            args.seeds
        );
    }
    let robot = registries.robot(&args.robot)?;
    if args.terrains.len() == 1 {
        bail!(
            "--terrains {} names one ground: give the grounds the path crosses, in order (two or more), or use --terrain",
            args.terrains[0]
        );
    }
    let terrain = registries.terrain(args.terrains.first().unwrap_or(&args.terrain))?;
    let stretches = args.terrains.len();
    let ground_changes = args
        .terrains
        .iter()
        .enumerate()
        .skip(1)
        .map(|(i, name)| {
            Ok(crate::studies::GroundChange {
                at: i as f64 / stretches as f64,
                terrain: registries.terrain(name)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    // A stretch on the ground of the one before changes nothing: its error "after the
    // change" would be scored as the adaptation's (the same terrain twice, or two files of
    // one ground).
    let mut before = &terrain;
    for (i, change) in ground_changes.iter().enumerate() {
        if ground_of(&change.terrain) == ground_of(before) {
            bail!(
                "--terrains: {} after {} is the same ground: the path changes nothing there; give grounds that differ (or use --terrain)",
                args.terrains[i + 1],
                args.terrains[i]
            );
        }
        before = &change.terrain;
    }
    let start = crate::traits::StartInfo::parse(&args.start).map_err(anyhow::Error::msg)?;
    // Model names, and model files driven as they are.
    let mut models = Vec::new();
    let mut given = Vec::new();
    let mut model_files = Vec::new();
    for m in &model_args {
        if !m.to_ascii_lowercase().ends_with(".json") {
            // A name (or `all`), in the order given.
            for s in registries.models().resolve_list(std::slice::from_ref(m))? {
                let u = s.uncertainty;
                models.push(s.with_uncertainty(u, start));
            }
            continue;
        }
        let (spec, model) = model_file(registries, m, &robot)?;
        given.push((models.len(), model));
        models.push(spec);
        model_files.push(PathBuf::from(m));
    }
    // The adaptive copies, after the models as listed.
    let mut adaptive = Vec::new();
    if args.adapt {
        for m in 0..models.len() {
            let mut copy = models[m].clone();
            copy.name = format!("{}-adaptive", copy.name);
            if let Some((_, model)) = given.iter().find(|(g, _)| *g == m) {
                let model = std::sync::Arc::clone(model);
                given.push((models.len(), model));
            }
            adaptive.push(models.len());
            models.push(copy);
        }
    }
    if args.seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    limits::at_most("--seeds", args.seeds as f64, limits::MAX_SEEDS as f64, "")?;
    let controller = controller(args, registries)?;
    let mut inputs: Vec<(&'static str, PathBuf)> = Vec::new();
    inputs.extend(super::common::robot_input(&args.robot));
    inputs.extend(super::common::terrain_input("--terrain", &args.terrain));
    for t in &args.terrains {
        inputs.extend(super::common::terrain_input("--terrains", t));
    }
    if let Some(f) = &args.mppi_config {
        inputs.push(("--mppi-config", f.clone()));
    }
    inputs.extend(model_files.into_iter().map(|f| ("--models", f)));
    // The paths, presets or files.
    let mut paths = Vec::new();
    for p in &args.path {
        match PathShape::parse(p) {
            Ok(shape) => paths.push(PathChoice::Preset(shape)),
            Err(unknown) => {
                let file = Path::new(p);
                if !(p.ends_with(".csv") || file.exists()) {
                    bail!(unknown);
                }
                inputs.push(("--path", file.to_path_buf()));
                let text = crate::traits::files::read_text(file, MAX_PATH_FILE_BYTES)
                    .with_context(|| format!("reading --path {p}"))?;
                // The file's name labels the tables' lines: one line, shown escaped.
                let label = if crate::traits::limits::breaks_text(p) {
                    p.escape_debug().to_string()
                } else {
                    p.clone()
                };
                paths.push(PathChoice::Given(ReferencePath::from_csv(&label, &text)?));
            }
        }
    }
    // The training data.
    let mut training = Vec::new();
    for (i, d) in args.train_data.iter().enumerate() {
        let sidecar = args.train_sidecar.get(i);
        if crate::data::bundled::name_in(d).is_none() {
            let s = sidecar
                .cloned()
                .unwrap_or_else(|| crate::data::sidecar_to_read(d));
            if sidecar.is_none() && d.is_file() && !s.exists() {
                bail!(
                    "the sidecar JSON of --train-data {} was not found (expected at {}; give it with --train-sidecar)",
                    d.display(),
                    s.display()
                );
            }
            inputs.push(("--train-data", d.clone()));
            inputs.push(("sidecar of --train-data", s));
        }
        let dataset = crate::data::read_dataset(d, sidecar.map(PathBuf::as_path))?;
        registries
            .check_vehicle(dataset.robot.vehicle.as_ref())
            .with_context(|| format!("{}: the data's vehicle", d.display()))?;
        super::common::refuse_useless(
            &dataset,
            &format!("--train-data {}", d.display()),
            args.useless.allow_useless,
            true,
        )?;
        training.push(Training::Data {
            name: d.display().to_string(),
            dataset: Arc::new(dataset),
        });
    }
    let samplers: Vec<String> = if args.train_sampler.is_empty() && args.train_data.is_empty() {
        vec!["uniform".into()]
    } else {
        args.train_sampler.clone()
    };
    for s in samplers {
        registries.samplers.get(&s)?;
        if !(args.train_duration.is_finite() && args.train_duration > 0.0) {
            bail!(
                "--train-duration must be positive seconds of driving, got {}",
                limits::Short(args.train_duration)
            );
        }
        training.push(Training::Protocol {
            sampler: s,
            driving_s: args.train_duration,
        });
    }
    let files: Vec<PathBuf> = match &args.out {
        Some(dir) => {
            let mut f: Vec<PathBuf> = ["track.json", "runs.csv", "summary.csv", "track.md"]
                .iter()
                .map(|n| dir.join(n))
                .collect();
            for t in &training {
                let stem = crate::report::track::figure_stem(&t.label());
                f.push(dir.join(format!("{stem}.png")));
                f.push(dir.join(format!("{stem}.svg")));
            }
            f
        }
        None => Vec::new(),
    };
    let mut planned: Vec<(&str, &Path)> = Vec::new();
    if let Some(dir) = &args.out {
        planned.push(("--out", dir.as_path()));
        planned.extend(files.iter().map(|f| ("a file of --out", f.as_path())));
    }
    let mut outputs = outputs_for(&inputs, &planned)?;
    let study = TrackStudy {
        robot,
        terrain,
        training,
        models,
        given,
        paths,
        speeds: args.speed.clone(),
        seeds: (0..args.seeds as u64)
            .map(|i| args.seed.wrapping_add(i))
            .collect(),
        controller_name: args.controller.clone(),
        controller,
        time_limit_s: args.time_limit,
        history_s: args.history,
        pose_stamps: !args.no_pose_stamps,
        schedule_s,
        ground_changes,
        adaptive,
    };
    let total = study.models.len()
        * study.training.len()
        * study.paths.len()
        * study.speeds.len()
        * study.seeds.len();
    let progress = Progress::new("track");
    let done = AtomicUsize::new(0);
    // A host running the command line in its process (Python's `drive.track`) is told too.
    let host = super::common::progress();
    let result = run_track(registries, &study, &|| {
        progress.update(done.fetch_add(1, Ordering::Relaxed) + 1, total);
        host(total);
    })?;
    progress.bar.finish_and_clear();
    if let Some(dir) = &args.out {
        outputs.own(dir);
        crate::report::track::stage(&result, &mut outputs, dir)?;
    }
    for n in &result.notes {
        super::common::note(format!("note: {n}"));
    }
    // The standard output first: a command that cannot write it fails with nothing new
    // published.
    emit(args.json, &result, crate::report::track::text)?;
    if args.out.is_some() {
        super::common::publish(outputs)?;
    }
    Ok(())
}

/// A model file of `--models`: its spec (named by the file, with the start it was fitted
/// for) and the model, refused when its vehicle type is not the robot's.
fn model_file(
    registries: &Registries,
    file: &str,
    robot: &crate::samplers::RobotSpec,
) -> Result<(
    crate::models::ModelSpec,
    Arc<dyn crate::traits::MotionModel>,
)> {
    let text = crate::traits::files::read_text(
        Path::new(file),
        crate::models::model_file::MAX_MODEL_FILE_BYTES,
    )
    .with_context(|| format!("reading --models {file}"))?;
    let read = crate::models::model_file::read_model_file(file, &text)?;
    registries
        .check_vehicle(read.robot.vehicle.as_ref())
        .with_context(|| format!("--models {file}: the model's vehicle"))?;
    let tag =
        |v: &dyn crate::traits::CommandModel| crate::traits::vehicle_tag(v).unwrap_or_default();
    let (theirs, ours) = (
        tag(read.robot.vehicle.as_ref()),
        tag(robot.vehicle.as_ref()),
    );
    if theirs != ours {
        bail!(
            "--models {file}: the model was fitted for a {theirs} vehicle, the robot '{}' is a {ours}: it cannot drive it",
            robot.name
        );
    }
    let saved = |v: &dyn crate::traits::CommandModel| serde_json::to_value(v).ok();
    if saved(read.robot.vehicle.as_ref()) != saved(robot.vehicle.as_ref()) {
        super::common::note(format!(
            "note: --models {file} was fitted for the geometry of '{}', not for that of the robot '{}': it is driven as it is",
            read.robot.robot, robot.name
        ));
    }
    // The model's parts, as its file names them (or as the model says), with its start.
    let canonical = read
        .fitted_with
        .as_ref()
        .map_or_else(|| read.model.name(), |f| f.canonical.clone());
    let mut spec = registries
        .models()
        .resolve(&canonical)
        .with_context(|| format!("--models {file}: its parts {canonical}"))?;
    spec.name = file.to_string();
    if let Some(f) = &read.fitted_with {
        spec = spec.with_uncertainty(f.uncertainty, f.start);
    }
    Ok((spec, Arc::from(read.model)))
}

/// The controller asked for, with the MPPI settings given.
fn controller(args: &Args, registries: &Registries) -> Result<Arc<dyn MakeController>> {
    // An unknown controller is said as such first.
    let registered = Arc::clone(registries.controllers.get(&args.controller)?.part());
    let tuned = args.samples.is_some()
        || args.horizon.is_some()
        || args.temperature.is_some()
        || args.uncertainty_weight.is_some()
        || args.mppi_config.is_some();
    if args.controller != "mppi" {
        if tuned {
            bail!("--mppi-config, --samples, --horizon, --temperature and --uncertainty-weight set the built-in mppi controller; controller '{}' takes its own settings", args.controller);
        }
        return Ok(registered);
    }
    // The registered `mppi` (which a program may have registered with its own settings),
    // unless settings are given on the command line.
    if !tuned {
        return Ok(registered);
    }
    let d = match &args.mppi_config {
        Some(file) => {
            let text = crate::traits::files::read_text(file, 1 << 20)
                .with_context(|| format!("reading --mppi-config {}", file.display()))?;
            Mppi::from_toml(&file.display().to_string(), &text)?
        }
        None => Mppi::default(),
    };
    let m = Mppi {
        samples: args.samples.unwrap_or(d.samples),
        horizon: args.horizon.unwrap_or(d.horizon),
        temperature: args.temperature.unwrap_or(d.temperature),
        uncertainty_weight: args.uncertainty_weight.unwrap_or(d.uncertainty_weight),
        ..d
    };
    m.check().map_err(|e| {
        anyhow::anyhow!("{e}")
            .context("--samples, --horizon, --temperature or --uncertainty-weight")
    })?;
    Ok(Arc::new(m))
}

/// A terrain without its name: what the robot drives on (two files of one ground, under two
/// names, are one ground).
fn ground_of(t: &crate::sim::Terrain) -> crate::sim::Terrain {
    crate::sim::Terrain {
        name: String::new(),
        ..t.clone()
    }
}
