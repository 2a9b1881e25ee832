//! The plant side of a run: the robot as the controller commands it (a twin's protocol
//! geometry), its top speed on the ground, and one run driven to its end or its time limit.

use super::*;

/// The robot as the controller commands it, and how its commands reach the plant.
pub(super) struct Driven {
    /// The robot the plant simulates.
    pub(super) plant: RobotSpec,
    /// The robot as the controller sees it (a twin's protocol geometry and input box).
    pub(super) controller: RobotSpec,
    pub(super) to_vehicle: InputMap,
}

/// For a twin whose real run drew its commands in another geometry than the robot's
/// (`drive_sim::TwinProtocol`), the controller commands in that geometry and its box, as
/// the real run's node did, and its commands reach the robot with their wheel-speed
/// difference scaled; otherwise the robot itself.
pub(super) fn driven(robot: &RobotSpec, terrain: &Terrain) -> Result<Driven, TrackError> {
    // A twin of another vehicle (a ground fitted for it) drives that vehicle only.
    if let Some(why) = terrain
        .fitted_for
        .as_ref()
        .and_then(|f| f.refuses(robot.vehicle.as_ref()))
    {
        return Err(TrackError::Invalid(format!(
            "terrain '{}' cannot drive robot '{}': {why}",
            terrain.name, robot.name
        )));
    }
    let Some(p) = terrain.protocol else {
        return Ok(Driven {
            plant: robot.clone(),
            controller: robot.clone(),
            to_vehicle: InputMap::identity(),
        });
    };
    let nominal: DifferentialDrive = vehicle_as(robot.vehicle.as_ref()).ok_or_else(|| {
        TrackError::Invalid(format!(
            "terrain '{}' is a twin of a differential drive; robot '{}' is not one",
            terrain.name, robot.name
        ))
    })?;
    if let Some(why) = p.refuses(nominal.wheel_radius, nominal.baseline) {
        return Err(TrackError::Invalid(format!(
            "terrain '{}' cannot drive robot '{}': {why}",
            terrain.name, robot.name
        )));
    }
    let space = p.space().ok_or_else(|| {
        TrackError::Invalid(format!(
            "terrain '{}': its protocol's input limits are not a box",
            terrain.name
        ))
    })?;
    let gain = p.difference_gain(nominal.baseline);
    let mut controller = robot.clone();
    controller.vehicle = Arc::new(DifferentialDrive::new(nominal.wheel_radius, p.baseline));
    controller.input_limits = Some(space);
    controller.input_rate_limits = None;
    Ok(Driven {
        plant: robot.clone(),
        controller,
        to_vehicle: InputMap::new(move |u: &Input| scale_difference(*u, gain)),
    })
}

/// The input of the controller's space that drives fastest straight ahead: among the
/// corners, edge and face midpoints and centre of the box (every axis of it), the largest
/// forward speed, then the smallest yaw rate.
pub(super) fn fastest_straight(robot: &RobotSpec) -> Input {
    let j = robot.input_space();
    let dim = j.dim();
    let (lo, mid, hi) = (j.min, j.center(), j.max);
    let mut best = mid;
    let mut key = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for index in 0..3usize.pow(dim as u32) {
        // Axis 0 slowest, as the loops over (first axis, second axis) this replaces.
        let u = Input::from_fn(|i, _| {
            if i >= dim {
                return 0.0;
            }
            match index / 3usize.pow((dim - 1 - i) as u32) % 3 {
                0 => lo[i],
                1 => mid[i],
                _ => hi[i],
            }
        });
        let v = robot.vehicle.body_velocity(&u);
        let k = (v.x, -v.z.abs());
        if k.0 > key.0 + 1e-9 || ((k.0 - key.0).abs() <= 1e-9 && k.1 > key.1) {
            key = k;
            best = u;
        }
    }
    best
}

/// Seconds the top-speed probe holds its input, and the span it measures over.
pub(super) const PROBE_S: f64 = 6.0;
pub(super) const PROBE_SPAN_S: f64 = 2.0;

/// The robot's top speed on this terrain (m/s): the straightest fastest input held for 6 s
/// within its acceleration limits, the true speed over the last 2 s.
pub(super) fn top_speed(
    registries: &Registries,
    d: &Driven,
    terrain: &Terrain,
    seed: u64,
) -> Result<f64, TrackError> {
    let poses = probe(
        registries,
        d,
        terrain,
        seed,
        fastest_straight(&d.controller),
    )?;
    let (ticks, span) = probe_ticks(d);
    let (a, b) = (poses[ticks - span], poses[ticks]);
    let speed = (b.x - a.x).hypot(b.y - a.y) / PROBE_SPAN_S;
    if !(speed.is_finite() && speed > 1e-3) {
        return Err(TrackError::Invalid(format!(
            "robot '{}' does not drive forward on terrain '{}' (top speed measured {} m/s driving its fastest straight input; check the robot's geometry and limits): nothing to follow a path with",
            d.plant.name,
            terrain.name,
            Short(speed)
        )));
    }
    Ok(speed)
}

/// The probe's ticks and the ticks of its measured span at the robot's rate.
pub(super) fn probe_ticks(d: &Driven) -> (usize, usize) {
    (
        (PROBE_S * d.plant.rate_hz).round() as usize,
        (PROBE_SPAN_S * d.plant.rate_hz).round() as usize,
    )
}

/// The plant's true poses, one per tick, holding the controller's `input` for [`PROBE_S`]
/// from rest within the robot's acceleration limits (what the characterization's probes
/// do): the top speed's and the feasibility's measurements.
pub(super) fn probe(
    registries: &Registries,
    d: &Driven,
    terrain: &Terrain,
    seed: u64,
    input: Input,
) -> Result<Vec<Pose>, TrackError> {
    let mut plant = plant_for(&registries.simulators, &d.plant, terrain, seed)
        .map_err(|reason| TrackError::Invalid(format!("simulating {}: {reason}", d.plant.name)))?;
    let mut sent = SentCommand::default();
    let (ticks, _) = probe_ticks(d);
    let mut poses = Vec::with_capacity(ticks + 1);
    for _ in 0..=ticks {
        let m = plant.measure();
        poses.push(plant.true_pose().unwrap_or(m.pose));
        let u = next_command(&d.controller, &mut sent, &input);
        plant.advance(d.to_vehicle.apply(&u));
    }
    Ok(poses)
}

/// One run's settings.
pub(super) struct RunPlan<'a> {
    pub(super) model: &'a Arc<dyn MotionModel>,
    pub(super) spec: &'a ModelSpec,
    pub(super) train: String,
    pub(super) path: &'a ReferencePath,
    pub(super) path_name: String,
    pub(super) fraction: f64,
    pub(super) speed: f64,
    pub(super) seed: u64,
    pub(super) time_limit_s: f64,
    /// Samples per window of the training data (the open-loop scores' windows).
    pub(super) window_len: usize,
    /// For a model that adapts in the loop: the training data's robot (the windows driven
    /// are fed to its [`crate::AdaptiveFit`] as that data's).
    pub(super) adapt_robot: Option<drive_traits::RobotDescription>,
}

/// Drives one run.
pub(super) fn drive(
    registries: &Registries,
    study: &TrackStudy,
    d: &Driven,
    plan: &RunPlan<'_>,
) -> Result<(TrackRun, Vec<String>), TrackError> {
    let control = |reason| TrackError::Control {
        model: plan.spec.name.clone(),
        path: plan.path_name.clone(),
        reason,
    };
    let mut plant = plant_for(&registries.simulators, &d.plant, &study.terrain, plan.seed)
        .map_err(|reason| TrackError::Invalid(format!("simulating {}: {reason}", d.plant.name)))?;
    let first = plant.measure();
    let start = plant.true_pose().unwrap_or(first.pose);
    let path = plan.path.placed_at(&start);
    // A model that adapts in the loop: the controller holds the adapted model now.
    let mut in_loop = match &plan.adapt_robot {
        None => None,
        Some(robot) => {
            let prior = drive_models::adapt::composed_of(plan.model.as_ref()).ok_or_else(|| {
                TrackError::Invalid(format!(
                    "{}: only a model composed of a powertrain and a slip model adapts",
                    plan.spec.name
                ))
            })?;
            let spec = plan.spec.clone().with_uncertainty(
                drive_models::calibration::Uncertainty::Paper,
                plan.spec.start,
            );
            let config = drive_models::adapt::AdapterConfig {
                start: plan.spec.start,
                ..Default::default()
            };
            Some(super::adaptive::InLoop {
                model: Arc::new(super::adaptive::LoopModel::new(prior.clone())),
                fit: crate::AdaptiveFit::new(prior, &spec, robot, config),
            })
        }
    };
    let mut adapted = super::LoopAdaptation {
        changed_from_s: None,
        refit_from_s: None,
        changed_at_end: false,
    };
    let setup = ControlSetup {
        model: match &in_loop {
            Some(a) => Arc::clone(&a.model) as Arc<dyn MotionModel>,
            None => Arc::clone(plan.model),
        },
        robot: d.controller.clone(),
        to_vehicle: d.to_vehicle.clone(),
        speed: plan.speed,
        seed: plan.seed,
    };
    let config = TrackerConfig {
        start: plan.spec.start,
        history_s: study.history_s,
        schedule_s: study.schedule_s,
        ..TrackerConfig::new(plan.speed)
    };
    let mut tracker = Tracker::new(
        study.controller.as_ref(),
        &setup,
        path.clone(),
        config,
        Arc::clone(&d.plant.vehicle),
    )
    .map_err(control)?;
    let history_s = tracker.history_s();
    let space = d.controller.input_space();
    let half = space.scale() * 0.5;
    let axes = space.dim() as f64;
    let centre = space.center();
    let window = (2.0 * plan.speed).max(1.0);
    let (mut progress, mut cross2, mut cross_max, mut head2, mut effort2) =
        (0.0, 0.0, 0.0f64, 0.0, 0.0);
    let mut ticks_ms = Vec::new();
    let mut trajectory = Vec::new();
    // The commanded yaw rate of every tick (through the controller's vehicle), and the
    // squared changes of the normalised command from one tick to the next.
    let mut yaw_rates = Vec::new();
    let (mut change2, mut previous) = (0.0, None::<Input>);
    // What the run drove, tick by tick (the vehicle's commands, the measured inputs, the
    // true poses, the IMU): cut into windows for the models' open-loop scores.
    let mut recorded = Recording::default();
    let (mut course2, mut courses, mut last_position) = (0.0, 0usize, None::<[f64; 2]>);
    // The ground's changes along the path: the next to come, and whether one came.
    let (mut next_change, mut changed) = (0usize, false);
    let (mut after2, mut after_n) = (0.0, 0usize);
    let mut published = None::<Pose>;
    let mut m = first;
    let (completed, duration) = loop {
        let obs = Observation {
            t: m.t,
            input: m.input,
            pose: m.fresh_pose.then_some(m.pose),
            imu_yaw_rate: Some(m.imu_yaw_rate),
            pose_time: (study.pose_stamps && m.fresh_pose).then_some(m.pose_time),
        };
        let clock = Instant::now();
        let tick = tracker.tick(&obs).map_err(control)?;
        ticks_ms.push(clock.elapsed().as_secs_f64() * 1e3);
        let truth: Pose = plant.true_pose().unwrap_or(m.pose);
        trajectory.push([truth.x, truth.y]);
        let near = path.project_near(
            [truth.x, truth.y],
            progress - window / 2.0,
            progress + window,
            progress,
            drive_control::path::CONTINUITY,
        );
        progress = near.point.s;
        cross2 += near.cross_track * near.cross_track;
        while let Some(c) = study
            .ground_changes
            .get(next_change)
            .filter(|c| progress >= c.at * path.length())
        {
            plant.change_ground(&c.terrain).map_err(|reason| {
                TrackError::Invalid(format!("simulating {}: {reason}", d.plant.name))
            })?;
            changed = true;
            next_change += 1;
        }
        if changed {
            after2 += near.cross_track * near.cross_track;
            after_n += 1;
        }
        cross_max = cross_max.max(near.cross_track.abs());
        let yaw = wrap_angle(truth.z - near.point.heading);
        head2 += yaw * yaw;
        // The direction the robot moves in (since the last tick) against the path's: a
        // skid-steer turning with a sideslip angle heads off the path's direction while its
        // course follows it.
        if let Some(last) = last_position {
            let (dx, dy): (f64, f64) = (truth.x - last[0], truth.y - last[1]);
            if dx.hypot(dy) > 1e-6 {
                let course = wrap_angle(dy.atan2(dx) - near.point.heading);
                course2 += course * course;
                courses += 1;
            }
        }
        last_position = Some([truth.x, truth.y]);
        effort2 += (tick.controller_input - centre)
            .component_div(&half)
            .norm_squared()
            / axes;
        yaw_rates.push(d.controller.vehicle.body_velocity(&tick.controller_input).z);
        if let Some(p) = previous {
            change2 += (tick.controller_input - p)
                .component_div(&half)
                .norm_squared()
                / axes;
        }
        previous = Some(tick.controller_input);
        recorded.command.push(tick.command);
        recorded.measured.push(m.input);
        recorded.pose.push(truth);
        recorded.imu.push(m.imu_yaw_rate);
        // What the robot's localization published last (held between its updates), as a
        // DRIVE log records it: what a model adapting in the loop learns from, never the
        // simulator's true pose.
        if m.fresh_pose {
            published = Some(m.pose);
        }
        recorded.localized.push(published.unwrap_or(m.pose));
        if let Some(a) = in_loop.as_mut() {
            let len = plan.window_len;
            let ticks = recorded.command.len();
            if len >= 2 && ticks % len == 0 {
                a.add(&recorded.localized_window(ticks / len - 1, len));
                if a.fit.changed() {
                    adapted.changed_from_s.get_or_insert(m.t);
                }
                if a.fit.refit_kept() {
                    adapted.refit_from_s.get_or_insert(m.t);
                }
            }
        }
        if tick.done {
            break (true, m.t);
        }
        if m.t >= plan.time_limit_s {
            break (false, m.t);
        }
        plant.advance(tick.command);
        m = plant.measure();
    };
    let n = ticks_ms.len() as f64;
    ticks_ms.sort_by(f64::total_cmp);
    let covered = if completed { path.length() } else { progress };
    let flips = sign_changes(&yaw_rates);
    let notes = tracker
        .notes()
        .into_iter()
        .map(|note| format!("{}: {note}", plan.spec.name))
        .collect();
    let run = TrackRun {
        model: plan.spec.name.clone(),
        train: plan.train.clone(),
        path: plan.path_name.clone(),
        speed_fraction: plan.fraction,
        speed_m_s: plan.speed,
        seed: plan.seed,
        cross_track_rms_m: (cross2 / n).sqrt(),
        cross_track_max_m: cross_max,
        heading_rms_rad: (head2 / n).sqrt(),
        course_rms_rad: (course2 / courses.max(1) as f64).sqrt(),
        completed,
        duration_s: duration,
        speed_kept: if duration > 0.0 && plan.speed > 0.0 {
            covered / duration / plan.speed
        } else {
            0.0
        },
        effort: (effort2 / n).sqrt(),
        command_change_rms: (change2 / (n - 1.0).max(1.0)).sqrt(),
        yaw_rate_sign_changes: flips,
        yaw_rate_sign_changes_per_m: if covered > 0.0 {
            flips as f64 / covered
        } else {
            0.0
        },
        cross_track_rms_after_change_m: (after_n > 0).then(|| (after2 / after_n as f64).sqrt()),
        adapted: in_loop.as_ref().map(|a| super::LoopAdaptation {
            changed_at_end: a.fit.changed(),
            ..adapted
        }),
        tick_ms_median: ticks_ms[ticks_ms.len() / 2],
        history_s,
        length_m: path.length(),
        trajectory,
        recorded: recorded.windows(plan.window_len),
    };
    Ok((run, notes))
}

/// What a run drove, one entry per tick.
#[derive(Default)]
pub(super) struct Recording {
    pub(super) command: Vec<Input>,
    pub(super) measured: Vec<Input>,
    pub(super) pose: Vec<Pose>,
    pub(super) imu: Vec<f64>,
    /// The localization's last published pose at each tick (what the robot knows).
    pub(super) localized: Vec<Pose>,
}

impl Recording {
    /// Consecutive windows of `len` ticks (the rest dropped): what a model is scored on as
    /// on DRIVE's windows (eq. 8), here the commands a controller sent.
    pub(super) fn windows(self, len: usize) -> Vec<Window> {
        if len < 2 {
            return Vec::new();
        }
        (0..self.command.len() / len)
            .map(|i| self.window(i, len))
            .collect()
    }

    /// The `i`-th window of `len` ticks as a DRIVE log gives it (which must be recorded):
    /// the localization's poses, re-based to the window's first in its body frame.
    pub(super) fn localized_window(&self, i: usize, len: usize) -> Window {
        let r = i * len..(i + 1) * len;
        let p0 = self.localized[r.start];
        Window::new(
            i,
            i,
            Phase::Steady,
            self.command[r.clone()].to_vec(),
            self.measured[r.clone()].to_vec(),
            self.localized[r.clone()]
                .iter()
                .map(|p| drive_traits::relative_pose(&p0, p))
                .collect(),
            self.imu[r].to_vec(),
        )
    }

    /// The `i`-th window of `len` ticks (each its own interval), which must be recorded.
    pub(super) fn window(&self, i: usize, len: usize) -> Window {
        let r = i * len..(i + 1) * len;
        Window::new(
            i,
            i,
            Phase::Steady,
            self.command[r.clone()].to_vec(),
            self.measured[r.clone()].to_vec(),
            self.pose[r.clone()].to_vec(),
            self.imu[r].to_vec(),
        )
    }
}

/// How many times `rates` (the commanded yaw rates of a run, one per tick) change sign,
/// counting only values beyond a tenth of their RMS (a rate that hovers around zero on a
/// straight does not count as weaving): how much a controller weaves.
pub(super) fn sign_changes(rates: &[f64]) -> usize {
    let n = rates.len().max(1) as f64;
    let rms = (rates.iter().map(|r| r * r).sum::<f64>() / n).sqrt();
    let band = 0.1 * rms;
    let mut last = 0.0f64;
    let mut flips = 0;
    for &r in rates.iter().filter(|r| r.abs() > band) {
        if last != 0.0 && r.signum() != last {
            flips += 1;
        }
        last = r.signum();
    }
    flips
}
