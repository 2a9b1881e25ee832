//! The calibration's tests.

use super::*;
use crate::DifferentialDrive;
use drive_traits::{Phase, RobotDescription, Window};

/// Predicts the start pose, with a unit covariance on every axis after the start.
#[derive(Debug, Serialize, Deserialize)]
struct Still;
#[typetag::serde(name = "still-calibration-test")]
impl MotionModel for Still {
    fn name(&self) -> String {
        "still".into()
    }
    fn dt(&self) -> f64 {
        0.05
    }
    fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) {
        p.clear();
        p.resize(c.len(), s.pose);
    }
    fn predict_with_covariance_into(
        &self,
        s: &StartState,
        c: &[Input],
        p: &mut Vec<Pose>,
        cov: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        self.predict_into(s, c, p);
        cov.clear();
        cov.extend((0..c.len()).map(|k| {
            if k == 0 {
                PoseCovariance::zeros()
            } else {
                PoseCovariance::identity()
            }
        }));
        Ok(())
    }
}

/// Standard normal draws from a fixed linear congruential sequence (Box-Muller).
fn normals(count: usize, seed: u64) -> Vec<f64> {
    let mut state = seed;
    let mut uniform = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..count)
        .map(|_| (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos())
        .collect()
}

/// Windows whose measured poses scatter around the start with standard deviations
/// `sd` (x, y) and `sd_yaw`, growing linearly along the window.
fn windows(count: usize, sd: f64, sd_yaw: f64, seed: u64) -> Vec<Window> {
    let z = normals(count * 3, seed);
    (0..count)
        .map(|i| {
            Window::new(
                i,
                i / 3,
                if i % 3 == 0 {
                    Phase::Transient
                } else {
                    Phase::Steady
                },
                vec![Input::zeros(); 40],
                vec![Input::zeros(); 40],
                (0..40)
                    .map(|k| {
                        let g = k as f64 / 39.0;
                        Pose::new(
                            g * sd * z[3 * i],
                            g * sd * z[3 * i + 1],
                            g * sd_yaw * z[3 * i + 2],
                        )
                    })
                    .collect(),
                vec![0.0; 40],
            )
        })
        .collect()
}

#[test]
fn scales_restore_the_level_on_new_windows_of_the_same_kind() {
    let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
    // Errors reach 3 m and 0.5 rad at the last step, under a unit covariance.
    let train = windows(600, 3.0, 0.5, 1);
    let set = WindowSet::new(&robot, &train);
    let model = Calibrator::default()
        .calibrate(Box::new(Still), &set, StartInfo::default(), |_| {
            Ok(Box::new(Still))
        })
        .unwrap();
    let test = windows(3000, 3.0, 0.5, 2);
    let (mut p, mut c) = (Vec::new(), Vec::new());
    let (mut inside, mut yaw_inside) = (0, 0);
    for w in &test {
        model
            .predict_with_covariance_into(
                &w.start_state(robot.vehicle.as_ref()),
                &w.command,
                &mut p,
                &mut c,
            )
            .unwrap();
        let e = pose_errors(&p, &w.pose);
        inside += usize::from(position_score(&e[39], &c[39]) <= chi2_2(0.95));
        yaw_inside += usize::from(e[39].z * e[39].z / c[39][(2, 2)] <= chi2_1(0.95));
        // The scale follows the spread: at the last step about 3^2 = 9 for position.
        assert!((6.0..13.0).contains(&c[39][(0, 0)]), "{}", c[39][(0, 0)]);
    }
    let (f, fy) = (inside as f64 / 3000.0, yaw_inside as f64 / 3000.0);
    assert!((0.93..=0.975).contains(&f), "position coverage {f}");
    assert!((0.93..=0.975).contains(&fy), "yaw coverage {fy}");
    assert_eq!(model.name(), "still");
    // Fewer intervals than folds: the model comes back as it was.
    let one = windows(3, 1.0, 1.0, 3);
    let back = Calibrator::default()
        .calibrate(
            Box::new(Still),
            &WindowSet::new(&robot, &one),
            StartInfo::default(),
            |_| Ok(Box::new(Still)),
        )
        .unwrap();
    let mut c1 = Vec::new();
    back.predict_with_covariance_into(
        &StartState::at_rest(Pose::zeros()),
        &[Input::zeros(); 3],
        &mut p,
        &mut c1,
    )
    .unwrap();
    assert_eq!(c1[2], PoseCovariance::identity());
}

/// Drives straight ahead at the first command's x (m/s), with a unit covariance on every
/// axis after the start.
#[derive(Debug, Serialize, Deserialize)]
struct Ahead;
#[typetag::serde(name = "ahead-calibration-test")]
impl MotionModel for Ahead {
    fn name(&self) -> String {
        "ahead".into()
    }
    fn dt(&self) -> f64 {
        0.05
    }
    fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) {
        let v = c.first().map_or(0.0, |u| u.x);
        p.clear();
        p.extend((0..c.len()).map(|k| s.pose + Pose::new(v * 0.05 * k as f64, 0.0, 0.0)));
    }
    fn predict_with_covariance_into(
        &self,
        s: &StartState,
        c: &[Input],
        p: &mut Vec<Pose>,
        cov: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        Still.predict_with_covariance_into(s, c, p, cov)?;
        self.predict_into(s, c, p);
        Ok(())
    }
}

/// Windows driven at 0.2 or 2 m/s (alternating by interval), whose errors around the
/// straight path grow with the speed: standard deviation 0.1 + speed / 2 (m, rad) at
/// the end, growing linearly along the window.
fn speed_windows(count: usize, seed: u64) -> Vec<Window> {
    let z = normals(count * 3, seed);
    (0..count)
        .map(|i| {
            let v = if (i / 3) % 2 == 0 { 0.2 } else { 2.0 };
            let sd = 0.1 + 0.5 * v;
            Window::new(
                i,
                i / 3,
                Phase::Steady,
                vec![Input::new(v, v, 0.0); 40],
                vec![Input::new(v, v, 0.0); 40],
                (0..40)
                    .map(|k| {
                        let g = k as f64 / 39.0;
                        Pose::new(
                            v * 0.05 * k as f64 + g * sd * z[3 * i],
                            g * sd * z[3 * i + 1],
                            g * sd * z[3 * i + 2],
                        )
                    })
                    .collect(),
                vec![0.0; 40],
            )
        })
        .collect()
}

#[test]
fn the_learned_difficulty_sizes_each_prediction_by_how_hard_it_is() {
    let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
    let train = speed_windows(1200, 4);
    let set = WindowSet::new(&robot, &train);
    let calibrate = |difficulty: bool| {
        Calibrator {
            difficulty,
            ..Calibrator::default()
        }
        .calibrate(Box::new(Ahead), &set, StartInfo::default(), |_| {
            Ok(Box::new(Ahead))
        })
        .unwrap()
    };
    let test = speed_windows(3000, 5);
    // Per speed: coverage of the position and the yaw at the last step, and the mean
    // ellipse area.
    let score = |model: &dyn MotionModel| {
        let (mut p, mut c) = (Vec::new(), Vec::new());
        let mut out = [[0.0; 3]; 2];
        for w in &test {
            model
                .predict_with_covariance_into(
                    &w.start_state(robot.vehicle.as_ref()),
                    &w.command,
                    &mut p,
                    &mut c,
                )
                .unwrap();
            let e = pose_errors(&p, &w.pose);
            let fast = usize::from(w.command[0].x > 1.0);
            out[fast][0] += f64::from(u8::from(position_score(&e[39], &c[39]) <= chi2_2(0.95)));
            out[fast][1] += f64::from(u8::from(e[39].z * e[39].z / c[39][(2, 2)] <= chi2_1(0.95)));
            out[fast][2] += c[39][(0, 0)];
        }
        out.map(|g| g.map(|v| v / 1500.0))
    };
    let [slow, fast] = score(calibrate(true).as_ref());
    let [slow_h, fast_h] = score(calibrate(false).as_ref());
    // One size per step covers the slow windows always and the fast ones too rarely.
    assert!(
        slow_h[0] > 0.99 && fast_h[0] < 0.92,
        "{slow_h:?} {fast_h:?}"
    );
    // With the difficulty, the slow windows' regions shrink towards their errors (0.2 /
    // 1.1 the fast ones'; by less, the ridge shrinks the difficulty towards one size)
    // while the fast windows keep at least their coverage, and the mean area falls.
    let ratio = (slow[2] / fast[2]).sqrt();
    assert!(ratio < 0.6, "radius ratio {ratio}");
    for (i, what) in ["position", "yaw"].iter().enumerate() {
        assert!(slow[i] >= 0.92, "slow {what} {}", slow[i]);
        assert!(
            fast[i] >= fast_h[i] - 0.005,
            "fast {what} {} against {}",
            fast[i],
            fast_h[i]
        );
    }
    assert!(slow[2] + fast[2] < slow_h[2] + fast_h[2]);
}

/// Windows started at headings spread over the circle, whose position errors at the end
/// have standard deviations 3 m along the start heading and 0.5 m across it (growing
/// linearly along the window), yaw error 0.2 rad.
fn heading_windows(count: usize, seed: u64) -> Vec<Window> {
    let z = normals(count * 3, seed);
    (0..count)
        .map(|i| {
            let heading = (i as f64 * 2.399_963) % std::f64::consts::TAU - std::f64::consts::PI;
            let (s, c) = heading.sin_cos();
            let (along, across) = (3.0 * z[3 * i], 0.5 * z[3 * i + 1]);
            Window::new(
                i,
                i / 3,
                Phase::Steady,
                vec![Input::zeros(); 40],
                vec![Input::zeros(); 40],
                (0..40)
                    .map(|k| {
                        let g = k as f64 / 39.0;
                        Pose::new(
                            g * (c * along - s * across),
                            g * (s * along + c * across),
                            heading + g * 0.2 * z[3 * i + 2],
                        )
                    })
                    .collect(),
                vec![0.0; 40],
            )
        })
        .collect()
}

#[test]
fn errors_longer_along_the_heading_get_regions_of_their_shape() {
    let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
    let train = heading_windows(900, 6);
    // `Still`'s unit covariance is round: the errors' own shape, turned with each
    // prediction's heading, gives smaller regions and is chosen.
    let model = Calibrator::default()
        .calibrate(
            Box::new(Still),
            &WindowSet::new(&robot, &train),
            StartInfo::default(),
            |_| Ok(Box::new(Still)),
        )
        .unwrap();
    let test = heading_windows(3000, 7);
    let (mut p, mut c) = (Vec::new(), Vec::new());
    let (mut inside, mut area, mut radius) = (0, 0.0, Vec::new());
    for w in &test {
        model
            .predict_with_covariance_into(
                &w.start_state(robot.vehicle.as_ref()),
                &w.command,
                &mut p,
                &mut c,
            )
            .unwrap();
        let e = pose_errors(&p, &w.pose);
        inside += usize::from(position_score(&e[39], &c[39]) <= chi2_2(0.95));
        let det = c[39][(0, 0)] * c[39][(1, 1)] - c[39][(0, 1)].powi(2);
        area += std::f64::consts::PI * chi2_2(0.95) * det.sqrt() / 3000.0;
        radius.push(e[39].x.hypot(e[39].y));
        // The long axis follows the heading: along it the variance is about 36 times
        // the one across it (3^2 / 0.5^2).
        let (s, co) = w.pose[0].z.sin_cos();
        let along = co * co * c[39][(0, 0)] + 2.0 * s * co * c[39][(0, 1)] + s * s * c[39][(1, 1)];
        let across = s * s * c[39][(0, 0)] - 2.0 * s * co * c[39][(0, 1)] + co * co * c[39][(1, 1)];
        assert!(
            (20.0..60.0).contains(&(along / across)),
            "{along} / {across}"
        );
    }
    let f = inside as f64 / 3000.0;
    assert!((0.93..=0.975).contains(&f), "position coverage {f}");
    // Against the smallest circle holding as many errors: the ellipse of these errors
    // has about a quarter of its area (pi 5.99 * 3 * 0.5 = 28 m^2 against pi 5.9^2).
    radius.sort_by(f64::total_cmp);
    let circle = std::f64::consts::PI * radius[inside.saturating_sub(1)].powi(2);
    assert!(area / circle < 0.4, "area ratio {}", area / circle);
}

#[test]
fn tylers_shape_ignores_the_errors_sizes() {
    // Directions on an ellipse of axes 2 and 0.5 turned by 30 degrees, each at a size
    // from 0.01 to 100: the shape is the ellipse's, of determinant 1.
    let (s, c) = (30f64.to_radians()).sin_cos();
    let u: Vec<[f64; 2]> = (0..400)
        .map(|i| {
            let t = i as f64 * 0.7;
            let size = 10f64.powf((i % 5) as f64 - 2.0);
            let (a, b) = (2.0 * t.cos() * size, 0.5 * t.sin() * size);
            [c * a - s * b, s * a + c * b]
        })
        .collect();
    let [a, b, d] = error_shape(u.iter(), 0.0).unwrap();
    // R diag(4, 0.25) R^T over its root determinant 1.
    let expected = [
        c * c * 4.0 + s * s * 0.25,
        c * s * (4.0 - 0.25),
        s * s * 4.0 + c * c * 0.25,
    ];
    for (got, want) in [a, b, d].iter().zip(expected) {
        assert!(
            (got - want).abs() < 0.05,
            "{:?} against {expected:?}",
            [a, b, d]
        );
    }
    // The floor rounds a line into a thin ellipse; too few errors give none.
    let line: Vec<[f64; 2]> = (1..10).map(|i| [i as f64, 0.0]).collect();
    assert_eq!(error_shape(line.iter(), 0.01), None);
    assert_eq!(error_shape([[1.0, 0.0], [0.0, 1.0]].iter(), 0.01), None);
    let near_line: Vec<[f64; 2]> = (1..10)
        .map(|i| [i as f64, 1e-3 * if i % 2 == 0 { 1.0 } else { -1.0 }])
        .collect();
    let thin = error_shape(near_line.iter(), 0.01).unwrap();
    // Raised to a hundredth of the larger eigenvalue before the lift (as `floored`).
    assert!((0.0098..0.0101).contains(&(thin[2] / thin[0])), "{thin:?}");
}

/// Two steps: the start, and a step scaled 2 (position) and 3 (yaw) whose region is four
/// times longer along the heading than across it.
fn heading_shaped() -> HorizonCalibration {
    HorizonCalibration {
        level: 0.95,
        shape_floor: 0.01,
        windows: 10,
        position_scale: vec![1.0, 2.0],
        yaw_scale: vec![1.0, 3.0],
        position_difficulty: vec![],
        yaw_difficulty: vec![],
        heading_shape: vec![UNIT_SHAPE, [4.0, 0.0, 0.25]],
    }
}

#[test]
fn a_heading_shape_turns_with_the_predicted_heading() {
    let calibration = heading_shaped();
    assert_eq!(calibration.check(), Ok(()));
    let c = PoseCovariance::identity();
    let x = [0.0; FEATURES];
    // Heading along y: the long axis (4, times the scale 2) is y.
    let turned = calibration.apply(1, &c, &x, std::f64::consts::FRAC_PI_2);
    assert!((turned[(1, 1)] - 8.0).abs() < 1e-12 && (turned[(0, 0)] - 0.5).abs() < 1e-12);
    assert!(turned[(0, 1)].abs() < 1e-12 && (turned[(2, 2)] - 3.0).abs() < 1e-12);
    let ahead = calibration.apply(1, &c, &x, 0.0);
    assert!((ahead[(0, 0)] - 8.0).abs() < 1e-12);
    // A shape not of determinant 1 is refused on load.
    let bad = HorizonCalibration {
        heading_shape: vec![UNIT_SHAPE, [4.0, 0.0, 1.0]],
        ..calibration
    };
    assert!(bad.check().unwrap_err().contains("determinant 1"));
}

/// An eleventh outside sweep: a heading-shaped position region was held at the last
/// calibrated step's size beyond the calibrated horizon (slip-ipem 10 s ahead: 1.3 m^2 while
/// its heading's variance reached 13.8 rad^2). Beyond it, the region grows as the model's own
/// position covariance does since that step; within it, nothing changes.
#[test]
fn a_heading_shaped_region_grows_beyond_the_calibrated_horizon_with_the_model() {
    let calibration = heading_shaped();
    let x = [0.0; FEATURES];
    let at_last = calibration.position_size(&PoseCovariance::identity());
    assert!((at_last - 1.0).abs() < 1e-12);
    // The model's own position covariance 9 times larger (size 9) at step 5.
    let grown = PoseCovariance::from_diagonal(&nalgebra::Vector3::new(9.0, 9.0, 1.0));
    let beyond = calibration.apply_beyond(5, &grown, &x, 0.0, at_last);
    assert!((beyond[(0, 0)] - 8.0 * 9.0).abs() < 1e-9, "{beyond}");
    // Held where the model's own shrank; unchanged within the horizon.
    let shrunk = PoseCovariance::identity() * 0.5;
    assert_eq!(
        calibration.apply_beyond(5, &shrunk, &x, 0.0, at_last),
        calibration.apply(5, &shrunk, &x, 0.0)
    );
    assert_eq!(
        calibration.apply_beyond(1, &grown, &x, 0.0, at_last),
        calibration.apply(1, &grown, &x, 0.0)
    );
}

#[test]
fn a_step_whose_fold_fits_lack_scores_has_no_difficulty() {
    // Scores that grow with the speed feature, 100 in fold 0 and 10 in fold 1: the fit
    // without fold 0 has too few, so the step has no difficulty at all (its fit on all
    // 110 would be applied to regions whose scale was set without it).
    let rows: Vec<Row> = (0..110)
        .map(|i| {
            let s = (i % 10) as f64;
            Row {
                x: [1.0, s, 0.0, 0.0, 0.0, 0.0],
                score: (0.3 * s).exp() * (1.0 + 0.1 * (i % 7) as f64),
                fold: usize::from(i >= 100),
            }
        })
        .collect();
    assert_ne!(
        crate::difficulty::fit_step(rows.iter(), None, 1.0),
        StepDifficulty::NONE
    );
    let steps = [Vec::new(), rows.clone()];
    let fit = fit_at_ridge(&Calibrator::default(), &steps, 1.0);
    assert!(fit.difficulty.is_empty());
    let raw: Vec<f64> = rows.iter().map(|r| r.score).collect();
    assert_eq!(fit.scores[1], raw);
    // With the folds balanced, the difficulty is learned.
    let balanced: Vec<Row> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| Row { fold: i % 2, ..*r })
        .collect();
    let steps = [Vec::new(), balanced];
    let fit = fit_at_ridge(&Calibrator::default(), &steps, 1.0);
    assert!(fit.difficulty[1].beta[1] > 0.0, "{:?}", fit.difficulty);
}

#[test]
fn steps_are_pooled_symmetrically() {
    assert_eq!(pooled_steps(20, 40), (18, 22));
    assert_eq!(pooled_steps(39, 40), (39, 39));
    assert_eq!(pooled_steps(38, 40), (37, 39));
    assert_eq!(pooled_steps(1, 40), (1, 1));
    assert_eq!(pooled_steps(3, 40), (2, 4));
}

#[test]
fn a_thin_covariance_is_widened_to_the_shape_floor() {
    let c = PoseCovariance::from_diagonal(&drive_traits::BodyVelocity::new(1.0, 0.0, 0.0));
    let f = floored(&c, 1e-2);
    assert!((f[(1, 1)] - 1e-2).abs() < 1e-12 && (f[(0, 0)] - 1.01).abs() < 1e-12);
    assert_eq!(f[(2, 2)], TINY_VARIANCE);
    // A round one is left alone.
    let round = PoseCovariance::identity();
    assert_eq!(floored(&round, 1e-2), round);
}

#[test]
fn chi_square_quantiles() {
    assert!((chi2_1(0.5) - 0.454_936_423_119_572_7).abs() < 1e-9);
    assert!((chi2_1(0.99) - 6.634_896_601_021_214).abs() < 1e-8);
    assert!((chi2_2(0.5) - 1.386_294_361_119_890_6).abs() < 1e-12);
}

/// [`Calibrator::difficulties_with`] on two folds' rows at one of the ridge strengths.
fn fit_at_ridge(c: &Calibrator, rows: &[Vec<Row>], ridge: f64) -> Difficulties {
    let logs = log_scores(rows);
    let index = RIDGES
        .iter()
        .position(|r| *r == ridge)
        .expect("one of RIDGES");
    c.difficulties_with(rows, &logs, &fit_steps(rows, &logs, 2), index)
}

#[test]
fn the_ridge_is_chosen_by_held_out_sharpness() {
    // Scores that follow the first feature exactly (ln score = 2 s, with a repeating
    // spread that does not depend on it): the weakest ridge keeps most of the slope, the
    // held-out regions are then the smallest at the same coverage, and it is chosen.
    let informative: Vec<Row> = (0..200)
        .map(|i| {
            let s = (i % 10) as f64 / 10.0;
            Row {
                x: [1.0, s, 0.0, 0.0, 0.0, 0.0],
                score: (2.0 * s).exp() * (1.0 + 0.05 * (i % 3) as f64),
                fold: i % 2,
            }
        })
        .collect();
    let rows = [Vec::new(), informative];
    let c = Calibrator::default();
    let chosen = c.difficulties(&rows, 2, chi2_2(0.95), Region::Area, |_| 1.0);
    let weakest = fit_at_ridge(&c, &rows, 0.1);
    assert_eq!(chosen.difficulty, weakest.difficulty);
    assert!(chosen.difficulty[1].beta[1] > fit_at_ridge(&c, &rows, 1.0).difficulty[1].beta[1]);
    // A feature that says nothing of the scores (a pattern of period 7 against one of
    // period 10 in the feature): the stronger ridges shrink its spurious coefficient, and
    // no weaker ridge than the default's is chosen.
    let noise: Vec<Row> = (0..200)
        .map(|i| Row {
            x: [1.0, (i % 10) as f64, 0.0, 0.0, 0.0, 0.0],
            score: 1.0 + (i % 7) as f64,
            fold: i % 2,
        })
        .collect();
    let rows = [Vec::new(), noise];
    let chosen = c.difficulties(&rows, 2, chi2_2(0.95), Region::Width, |_| 1.0);
    let default = fit_at_ridge(&c, &rows, 1.0);
    let slope = |d: &Difficulties| d.difficulty.get(1).map_or(0.0, |s| s.beta[1].abs());
    assert!(slope(&chosen) <= slope(&default), "{:?}", chosen.difficulty);
}

#[test]
fn pooled_quantiles_are_the_quantiles_of_the_pools() {
    // Steps of 0 to 39 scores, with ties, both zeros, infinities and NaN (left out), pooled
    // over 1 to 9 neighbouring steps, at levels from either end: the same order statistic
    // as selecting over the whole pool.
    let values = normals(4000, 7);
    let mut next = values.iter().copied().cycle();
    for case in 0..40 {
        let steps: Vec<Vec<f64>> = (0..12)
            .map(|i| {
                let len = (case * 7 + i * 13) % 40;
                (0..len)
                    .map(|j| match (case + i + j) % 13 {
                        0 => 0.0,
                        1 => -0.0,
                        2 => 1.0,
                        3 if case % 5 == 0 => f64::INFINITY,
                        4 if case % 3 == 0 => f64::NAN,
                        _ => next.next().unwrap_or(0.5),
                    })
                    .collect()
            })
            .collect();
        let pools: Vec<(usize, usize)> = (0..12usize)
            .map(|k| {
                let r = (case + k) % 5;
                (k.saturating_sub(r), (k + r).min(11))
            })
            .collect();
        for level in [0.0, 0.05, 0.3, 0.5, 0.68, 0.9, 0.95, 0.999, 1.0] {
            let pooled = pooled_conformal_quantiles(&steps, &pools, level);
            for (&(lo, hi), pooled) in pools.iter().zip(pooled) {
                let mut pool: Vec<f64> = steps[lo..=hi]
                    .iter()
                    .flatten()
                    .copied()
                    .filter(|s| !s.is_nan())
                    .collect();
                let whole = conformal_quantile(&mut pool, level);
                assert_eq!(
                    pooled.map(f64::to_bits),
                    whole.map(f64::to_bits),
                    "case {case}, pool {lo}..={hi}, level {level}"
                );
            }
        }
    }
}
