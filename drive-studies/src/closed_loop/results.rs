//! The training data's checks and the runs' summary per model, training, path and speed.

use super::*;

/// A dataset the models are fitted on must be of the plant's robot: its rate and vehicle.
pub(super) fn check_data(
    name: &str,
    data: &Dataset,
    robot: &RobotSpec,
    notes: &mut Vec<String>,
) -> Result<(), TrackError> {
    if data.windows.is_empty() {
        return Err(TrackError::Invalid(format!("{name}: no windows to fit on")));
    }
    if (data.robot.rate_hz - robot.rate_hz).abs() > 1e-9 * robot.rate_hz {
        return Err(TrackError::Invalid(format!(
            "{name} is recorded at {} Hz; robot '{}' is commanded at {} Hz",
            Short(data.robot.rate_hz),
            robot.name,
            Short(robot.rate_hz)
        )));
    }
    let (a, b) = (
        vehicle_tag(data.robot.vehicle.as_ref()),
        vehicle_tag(robot.vehicle.as_ref()),
    );
    if a != b {
        return Err(TrackError::Invalid(format!(
            "{name} is of a '{}' vehicle; robot '{}' is a '{}'",
            a.unwrap_or_default(),
            robot.name,
            b.unwrap_or_default()
        )));
    }
    let (ga, gb) = (data.robot.vehicle.geometry(), robot.vehicle.geometry());
    let differs = ga.len() != gb.len()
        || ga
            .iter()
            .zip(&gb)
            .any(|(x, y)| (x.1 - y.1).abs() > 0.01 * y.1.abs().max(1e-9));
    if differs {
        notes.push(format!(
            "{name}: its vehicle geometry {ga:?} is not robot '{}''s {gb:?}; the models keep the data's",
            robot.name
        ));
    }
    Ok(())
}

/// The share of the asked speed below which a run's robot stood (almost) still (a note).
pub(super) const STOOD_STILL: f64 = 0.05;

/// The ratios of the speed kept to the powertrain model's within which two models' runs
/// are of about the same speed (beyond them, a note).
pub(super) const SPEED_KEPT_ALIKE: (f64, f64) = (0.8, 1.25);

/// Per model, training, path and speed: the runs' means, and the improvements over the
/// first model and over the powertrain model (the study's model `powertrain`, when there);
/// a note in `notes` where a model kept a speed unlike the powertrain model's.
pub(super) fn summarise(
    study: &TrackStudy,
    runs: &[TrackRun],
    feasibility: &[Feasibility],
    powertrain: Option<usize>,
    notes: &mut Vec<String>,
) -> Vec<TrackSummary> {
    let mut out: Vec<TrackSummary> = Vec::new();
    for t in &study.training {
        for p in &study.paths {
            for &f in &study.speeds {
                let feasible = feasibility
                    .iter()
                    .find(|x| x.path == p.name() && x.speed_fraction == f)
                    .and_then(|x| x.feasible);
                let mut block: Vec<TrackSummary> = Vec::new();
                for spec in &study.models {
                    let these: Vec<&TrackRun> = runs
                        .iter()
                        .filter(|r| {
                            r.train == t.label()
                                && r.path == p.name()
                                && r.speed_fraction == f
                                && r.model == spec.name
                        })
                        .collect();
                    if these.is_empty() {
                        continue;
                    }
                    let n = these.len() as f64;
                    let mean =
                        |g: fn(&TrackRun) -> f64| these.iter().map(|r| g(r)).sum::<f64>() / n;
                    let done: Vec<f64> = these
                        .iter()
                        .filter(|r| r.completed)
                        .map(|r| r.duration_s)
                        .collect();
                    block.push(TrackSummary {
                        model: spec.name.clone(),
                        train: t.label(),
                        path: p.name(),
                        speed_fraction: f,
                        runs: these.len(),
                        cross_track_rms_m: mean(|r| r.cross_track_rms_m),
                        cross_track_max_m: these
                            .iter()
                            .map(|r| r.cross_track_max_m)
                            .fold(0.0, f64::max),
                        heading_rms_rad: mean(|r| r.heading_rms_rad),
                        course_rms_rad: mean(|r| r.course_rms_rad),
                        completed_share: done.len() as f64 / n,
                        duration_s: (!done.is_empty())
                            .then(|| done.iter().sum::<f64>() / done.len() as f64),
                        speed_kept: mean(|r| r.speed_kept),
                        effort: mean(|r| r.effort),
                        command_change_rms: mean(|r| r.command_change_rms),
                        yaw_rate_sign_changes_per_m: mean(|r| r.yaw_rate_sign_changes_per_m),
                        history_s: mean(|r| r.history_s),
                        cross_track_rms_after_change_m: these
                            .iter()
                            .map(|r| r.cross_track_rms_after_change_m)
                            .sum::<Option<f64>>()
                            .map(|total| total / n),
                        feasible,
                        improvement_over_first_percent: None,
                        improvement_over_powertrain_percent: None,
                        heading_rms_ratio_to_powertrain: None,
                        speed_kept_ratio_to_powertrain: None,
                        open_loop_translational_median_m: None,
                        open_loop_rotational_median_rad: None,
                    });
                }
                // A robot that barely moved is near its path's start all along: its small
                // errors are not tracking, and said so (settings that leave the controller
                // standing still, a model that predicts no motion).
                for s in block.iter().filter(|s| s.speed_kept < STOOD_STILL) {
                    notes.push(format!(
                        "{} ({}) on {} at {:.0}%: the robot kept {} of the asked speed and reached the end in {:.0}% of the runs: it stood (almost) still, and its cross-track {:.3} m and heading {:.3} rad are errors of a robot near the path's start, not of tracking",
                        s.model,
                        s.train,
                        p.name(),
                        100.0 * f,
                        Short((s.speed_kept * 1000.0).round() / 1000.0),
                        100.0 * s.completed_share,
                        s.cross_track_rms_m,
                        s.heading_rms_rad
                    ));
                }
                // Against the first model of the study, when it ran here; only between runs
                // that all reached the end: a robot that stops (or never starts) has a small
                // cross-track error over the little of the path it covered.
                let base = block
                    .first()
                    .filter(|s| s.model == study.models[0].name && s.completed_share == 1.0)
                    .map(|s| s.cross_track_rms_m);
                if let Some(base) = base.filter(|b| *b > 0.0) {
                    for s in block.iter_mut().skip(1) {
                        s.improvement_over_first_percent = (s.completed_share == 1.0)
                            .then(|| 100.0 * (base - s.cross_track_rms_m) / base);
                    }
                }
                // Against the powertrain model, between models that both reached the end in
                // every run (on a path the robot cannot drive at this speed too: the block
                // says so, `feasible`, for the reader to weigh).
                let base = powertrain
                    .map(|i| &study.models[i].name)
                    .and_then(|name| block.iter().find(|s| &s.model == name))
                    .filter(|s| s.completed_share == 1.0)
                    .map(|s| {
                        (
                            s.model.clone(),
                            s.cross_track_rms_m,
                            s.heading_rms_rad,
                            s.speed_kept,
                        )
                    });
                if let Some((name, cross, heading, kept)) = base.filter(|b| b.1 > 0.0) {
                    for s in block
                        .iter_mut()
                        .filter(|s| s.model != name && s.completed_share == 1.0)
                    {
                        s.improvement_over_powertrain_percent =
                            Some(100.0 * (cross - s.cross_track_rms_m) / cross);
                        s.heading_rms_ratio_to_powertrain =
                            (heading > 0.0).then(|| s.heading_rms_rad / heading);
                        s.speed_kept_ratio_to_powertrain =
                            (kept > 0.0).then(|| s.speed_kept / kept);
                        if let Some(ratio) = s
                            .speed_kept_ratio_to_powertrain
                            .filter(|r| !(SPEED_KEPT_ALIKE.0..=SPEED_KEPT_ALIKE.1).contains(r))
                        {
                            notes.push(format!(
                                "{} ({}) on {} at {:.0}% kept {:.2} of the asked speed, the powertrain model {:.2} ({:.2}x): their cross-track errors are of different speeds",
                                s.model,
                                s.train,
                                p.name(),
                                100.0 * f,
                                s.speed_kept,
                                kept,
                                ratio
                            ));
                        }
                    }
                }
                out.extend(block);
            }
        }
    }
    out
}

/// The window length of training `i`'s data (every set of one training has the same).
pub(super) fn window_len(sets: &[(usize, Option<u64>, Arc<Dataset>)], i: usize) -> usize {
    sets.iter()
        .find(|(t, _, _)| *t == i)
        .map_or(0, |(_, _, d)| d.robot.window_len)
}

/// Every summary row's open-loop medians: its model (fitted on the row's training, for the
/// seed of each run) predicting the windows of every run of the row's training, path and
/// speed, from their recorded commands (eq. 8).
pub(super) fn open_loop_scores(
    study: &TrackStudy,
    runs: &[TrackRun],
    sets: &[(usize, Option<u64>, Arc<Dataset>)],
    fits: &[Fitted],
    summary: &mut [TrackSummary],
) {
    summary.par_iter_mut().for_each(|row| {
        let Some(training) = study.training.iter().position(|t| t.label() == row.train) else {
            return;
        };
        let Some(model) = study.models.iter().position(|m| m.name == row.model) else {
            return;
        };
        let (mut translational, mut rotational) = (Vec::new(), Vec::new());
        for run in runs.iter().filter(|r| {
            r.train == row.train && r.path == row.path && r.speed_fraction == row.speed_fraction
        }) {
            let fitted = fits.iter().find(|f| {
                f.training == training
                    && f.model == model
                    && (f.seed.is_none() || f.seed == Some(run.seed))
            });
            let data = sets
                .iter()
                .find(|(t, seed, _)| *t == training && (seed.is_none() || *seed == Some(run.seed)));
            let (Some(fitted), Some((_, _, data))) = (fitted, data) else {
                continue;
            };
            let set = WindowSet::new(&data.robot, &run.recorded);
            let report = drive_eval::evaluate_errors(
                fitted.fitted.as_ref(),
                &set,
                study.models[model].start,
            );
            for w in &report.windows {
                translational.push(w.error.translational);
                rotational.push(w.error.rotational);
            }
        }
        row.open_loop_translational_median_m = crate::bench::finite_median(&translational);
        row.open_loop_rotational_median_rad = crate::bench::finite_median(&rotational);
    });
}
