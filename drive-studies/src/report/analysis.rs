//! What the figures show, computed from a dataset and its fitted models.

use drive_traits::{
    BodyVelocity, BodyVelocityEstimator, CommandModel, Input, InputAxis, InputSpace, MotionModel,
    Phase, Pose, PoseCovariance, Powertrain, WindowSet,
};
use serde::Serialize;

/// The 95% quantile of the chi-square distribution with 2 degrees of freedom, `-2 ln 0.05`:
/// a position error `e` is inside the predicted 95% ellipse when `e^T S^-1 e <= CHI2_2_95`.
pub const CHI2_2_95: f64 = 5.991_464_547_107_979;

/// The outline of what a box of inputs commands in the (forward speed, yaw rate) plane,
/// counter-clockwise, as the vehicle maps it (eq. 4 for a differential drive).
///
/// Where the vehicle's map is affine on the box (a differential drive, an omnidirectional
/// base), the image is the polygon of the box's corners: a two-input box's four corners in
/// turn, for more axes their convex hull. Otherwise (a car, whose yaw rate is its speed
/// times its curvature; a four-wheel-steered rover) the corners' hull would draw turns the
/// vehicle cannot make (a car turning on the spot): the outline is then the upper and lower
/// envelope of the yaw rate over a dense grid of the box, in 64 bands of forward speed.
///
/// ```
/// use drive_studies::report::analysis::body_polygon;
/// use drive_traits::vehicles::Ackermann;
/// use drive_traits::{Input, InputSpace};
/// let car = Ackermann::new(2.5, 0.5);
/// let j = InputSpace::new(Input::new(-2.0, -0.5, 0.0), Input::new(5.0, 0.5, 0.0)).unwrap();
/// let outline = body_polygon(&car, &j);
/// // Standing still, a car does not turn: the outline is pinched at zero speed.
/// let near_rest = outline.iter().filter(|v| v.x.abs() < 0.1);
/// assert!(near_rest.clone().count() > 0 && near_rest.clone().all(|v| v.z.abs() < 0.05));
/// ```
pub fn body_polygon(vehicle: &dyn CommandModel, space: &InputSpace) -> Vec<BodyVelocity> {
    let (lo, hi) = (space.min, space.max);
    let dim = space.dim();
    let corner = |bits: usize| {
        Input::from_fn(|i, _| {
            if i >= dim {
                0.0
            } else if bits >> i & 1 == 0 {
                lo[i]
            } else {
                hi[i]
            }
        })
    };
    let corners: Vec<BodyVelocity> = (0..1usize << dim)
        .map(|bits| vehicle.body_velocity(&corner(bits)))
        .collect();
    if !is_affine(vehicle, space, &corners) {
        return envelope(vehicle, space);
    }
    if dim == 2 {
        return vec![corners[0], corners[1], corners[3], corners[2]];
    }
    convex_hull(corners)
}

/// Whether the vehicle's map is affine on the box: every corner is the first corner plus
/// the sum of its edges' steps, and the centre the corners' mean (to 1e-9 of their spread).
fn is_affine(vehicle: &dyn CommandModel, space: &InputSpace, corners: &[BodyVelocity]) -> bool {
    let spread = corners
        .iter()
        .map(|c| (c - corners[0]).amax())
        .fold(0.0, f64::max)
        .max(corners[0].amax())
        .max(f64::MIN_POSITIVE);
    let close = |a: &BodyVelocity, b: &BodyVelocity| (a - b).amax() <= 1e-9 * spread;
    let dim = space.dim();
    let predicted = |bits: usize| {
        (0..dim)
            .filter(|i| bits >> i & 1 == 1)
            .fold(corners[0], |acc, i| acc + (corners[1 << i] - corners[0]))
    };
    let mean = corners.iter().sum::<BodyVelocity>() / corners.len() as f64;
    corners.iter().all(|c| c.iter().all(|x| x.is_finite()))
        && (0..corners.len()).all(|bits| close(&corners[bits], &predicted(bits)))
        && close(&vehicle.body_velocity(&space.center()), &mean)
}

/// The outline of a box's image as the upper and lower envelope of the yaw rate over a
/// grid of the box (65 points per axis for two inputs), in 64 bands of forward speed: the
/// upper envelope left to right, then the lower one back. With three inputs, one grid per
/// axis, 257 levels along it and 17 along the others (each grid holds the box's faces):
/// one grid of 17 levels left bands of forward speed that only a four-wheel-steered
/// rover's crabbing inputs reached (its outline came out a sawtooth, most of its turns
/// missing).
fn envelope(vehicle: &dyn CommandModel, space: &InputSpace) -> Vec<BodyVelocity> {
    const BANDS: usize = 64;
    let dim = space.dim();
    let level = |i: usize, k: usize, n: usize| {
        if i >= dim {
            0.0
        } else if k + 1 == n {
            space.max[i]
        } else {
            space.min[i] + (space.max[i] - space.min[i]) * k as f64 / (n - 1) as f64
        }
    };
    // (the axis refined, its levels, the others' levels)
    let grids: Vec<(usize, usize, usize)> = if dim == 2 {
        vec![(0, 65, 65)]
    } else {
        (0..dim).map(|axis| (axis, 257, 17)).collect()
    };
    let mut points = Vec::new();
    for (fine, n_fine, n) in grids {
        let count: usize = (0..dim)
            .map(|i| if i == fine { n_fine } else { n })
            .product();
        for mut index in 0..count {
            let mut u = Input::zeros();
            for i in 0..dim {
                let levels = if i == fine { n_fine } else { n };
                u[i] = level(i, index % levels, levels);
                index /= levels;
            }
            let v = vehicle.body_velocity(&u);
            if v.x.is_finite() && v.z.is_finite() {
                points.push(v);
            }
        }
    }
    let (x0, x1) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v.x), b.max(v.x))
        });
    if points.len() < 3 || x1 <= x0 {
        return convex_hull(points);
    }
    let mut top: Vec<Option<BodyVelocity>> = vec![None; BANDS];
    let mut bottom: Vec<Option<BodyVelocity>> = vec![None; BANDS];
    for v in &points {
        let band = (((v.x - x0) / (x1 - x0)) * BANDS as f64).floor() as usize;
        let band = band.min(BANDS - 1);
        if top[band].is_none_or(|t| v.z > t.z) {
            top[band] = Some(*v);
        }
        if bottom[band].is_none_or(|b| v.z < b.z) {
            bottom[band] = Some(*v);
        }
    }
    let mut outline: Vec<BodyVelocity> = bottom.into_iter().flatten().collect();
    outline.extend(top.into_iter().rev().flatten());
    outline
}

/// The convex hull of points in the (x, z) plane (monotone chain), counter-clockwise.
fn convex_hull(mut points: Vec<BodyVelocity>) -> Vec<BodyVelocity> {
    points.retain(|p| p.x.is_finite() && p.z.is_finite());
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.z.total_cmp(&b.z)));
    if points.len() < 3 {
        return points;
    }
    let cross = |o: &BodyVelocity, a: &BodyVelocity, b: &BodyVelocity| {
        (a.x - o.x) * (b.z - o.z) - (a.z - o.z) * (b.x - o.x)
    };
    let mut hull: Vec<BodyVelocity> = Vec::with_capacity(2 * points.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &BodyVelocity>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for p in iter {
            while hull.len() >= start + 2
                && cross(&hull[hull.len() - 2], &hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(*p);
        }
        hull.pop();
    }
    hull
}

/// The box spanned by a set of inputs; `None` when there are none.
pub fn bounding_box<'a>(inputs: impl IntoIterator<Item = &'a Input>) -> Option<InputSpace> {
    let mut it = inputs.into_iter();
    let first = *it.next()?;
    let (lo, hi) = it.fold((first, first), |(lo, hi), u| (lo.inf(u), hi.sup(u)));
    InputSpace::new(lo, hi)
}

/// Paper Fig. 1 in the body-velocity plane.
#[derive(Debug, Clone, Serialize)]
pub struct InputSpaceFigure {
    /// The manufacturer's (naive) input space and where it comes from; `None` without a
    /// robot description.
    pub naive: Option<(String, InputSpace)>,
    /// The space the commands spanned.
    pub commanded: InputSpace,
    /// The true input space: the inputs the measurements reached.
    pub reached: InputSpace,
    /// The commanded body velocity each steady window held (the vehicle's eq. 4 on its last
    /// command).
    pub commands: Vec<BodyVelocity>,
    /// The measured body velocity of each steady window (mean over the window).
    pub measured: Vec<BodyVelocity>,
}

/// Builds the input-space figure's data from every window of a dataset.
pub fn input_space(
    all: &WindowSet<'_>,
    naive: Option<(String, InputSpace)>,
) -> Option<InputSpaceFigure> {
    let vehicle = all.robot.vehicle.as_ref();
    let commanded = bounding_box(all.windows.iter().flat_map(|w| w.command.iter()))?;
    let reached = bounding_box(all.windows.iter().flat_map(|w| w.measured.iter()))?;
    let mut commands = Vec::new();
    let mut measured = Vec::new();
    let estimator = BodyVelocityEstimator::default();
    let mut v = Vec::new();
    for w in &all.windows {
        if w.phase == Phase::Transient {
            continue;
        }
        if let Some(u) = w.command.last() {
            commands.push(vehicle.body_velocity(u));
        }
        estimator.estimate(w, all.robot.dt(), &mut v);
        let known: Vec<&BodyVelocity> = v.iter().flatten().collect();
        if !known.is_empty() {
            measured.push(known.iter().copied().sum::<BodyVelocity>() / known.len() as f64);
        }
    }
    Some(InputSpaceFigure {
        naive,
        commanded,
        reached,
        commands,
        measured,
    })
}

/// Paper Fig. 3: the vehicle's inputs over consecutive windows.
#[derive(Debug, Clone, Serialize)]
pub struct PowertrainTrace {
    /// The vehicle's input axes.
    pub axes: Vec<InputAxis>,
    /// The powertrain's name.
    pub powertrain: String,
    /// Time of each sample (s) from the first window's start.
    pub t: Vec<f64>,
    /// Commanded inputs.
    pub commanded: Vec<Input>,
    /// Measured inputs.
    pub measured: Vec<Input>,
    /// The powertrain model's prediction, started at each window from the measured velocity.
    pub modeled: Vec<Input>,
    /// Each window's time span and phase.
    pub windows: Vec<(f64, f64, Phase)>,
}

/// The first `intervals` whole intervals of `eval` predicted by `powertrain`, window by
/// window as a motion model uses it.
pub fn powertrain_trace(
    eval: &WindowSet<'_>,
    name: &str,
    powertrain: &dyn Powertrain,
    intervals: usize,
) -> PowertrainTrace {
    let dt = eval.robot.dt();
    let mut trace = PowertrainTrace {
        axes: eval.robot.vehicle.axes(),
        powertrain: name.to_string(),
        t: Vec::new(),
        commanded: Vec::new(),
        measured: Vec::new(),
        modeled: Vec::new(),
        windows: Vec::new(),
    };
    // Start at the first transient window, so that the trace opens on a new command.
    let first = eval
        .windows
        .iter()
        .position(|w| w.phase == Phase::Transient)
        .unwrap_or(0);
    let Some(w0) = eval.windows.get(first) else {
        return trace;
    };
    let last_interval = w0.interval + intervals;
    let mut t0 = 0.0;
    for w in eval.windows[first..]
        .iter()
        .take_while(|w| w.interval < last_interval)
    {
        let modeled = powertrain.predict(&w.measured[0], &w.command);
        for (k, ((c, e), m)) in w.command.iter().zip(&w.measured).zip(&modeled).enumerate() {
            trace.t.push(t0 + k as f64 * dt);
            trace.commanded.push(*c);
            trace.measured.push(*e);
            trace.modeled.push(*m);
        }
        let t1 = t0 + w.len() as f64 * dt;
        trace.windows.push((t0, t1, w.phase));
        t0 = t1;
    }
    trace
}

/// One evaluation window's measured path and the models' predictions.
#[derive(Debug, Clone)]
pub struct Trajectory {
    /// Window index in the dataset.
    pub window: usize,
    /// Measured poses.
    pub measured: Vec<Pose>,
    /// Per model: name, predicted poses, and the pose covariances when the model has them.
    pub predicted: Vec<(String, Vec<Pose>, Option<Vec<PoseCovariance>>)>,
}

/// `count` evaluation windows with distinct motions: steady windows ordered by how much the
/// robot turned, taken at evenly spaced ranks.
pub fn trajectories(
    eval: &WindowSet<'_>,
    models: &[(&str, &dyn MotionModel)],
    count: usize,
) -> Vec<Trajectory> {
    let vehicle = eval.robot.vehicle.as_ref();
    let mut steady: Vec<_> = eval
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && w.len() >= 2)
        .collect();
    let turn = |w: &drive_traits::Window| w.pose[w.len() - 1].z.abs();
    steady.sort_by(|a, b| turn(a).total_cmp(&turn(b)));
    if steady.is_empty() || count == 0 {
        return Vec::new();
    }
    let picks: Vec<usize> = (0..count)
        .map(|i| ((i as f64 + 0.5) / count as f64 * steady.len() as f64) as usize)
        .map(|i| i.min(steady.len() - 1))
        .collect();
    let mut out: Vec<Trajectory> = Vec::new();
    for i in picks {
        let w = steady[i];
        if out.iter().any(|t| t.window == w.index) {
            continue;
        }
        let start = w.start_state(vehicle);
        let predicted = models
            .iter()
            .map(|(name, m)| {
                let (mut poses, mut covs) = (Vec::new(), Vec::new());
                let cov = m
                    .predict_with_covariance_into(&start, &w.command, &mut poses, &mut covs)
                    .is_ok();
                if !cov {
                    m.predict_into(&start, &w.command, &mut poses);
                }
                (name.to_string(), poses, cov.then_some(covs))
            })
            .collect();
        out.push(Trajectory {
            window: w.index,
            measured: w.pose.clone(),
            predicted,
        });
    }
    out
}

/// How well a model's predicted uncertainty matches its errors on the evaluation windows.
#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    /// Model name.
    pub model: String,
    /// Per horizon step k (k = 1 .. n-1; k = 0 is the known start): the fraction of
    /// evaluation windows whose measured position lies inside the predicted 95% ellipse.
    pub inside_fraction: Vec<f64>,
    /// The same over every step and window.
    pub inside_overall: f64,
    /// Mean negative log-likelihood of the measured position under the predicted Gaussian
    /// (nats, over every step and window with a positive-definite covariance).
    pub mean_nll: f64,
    /// Steps whose predicted position covariance was not positive definite (counted as
    /// outside, left out of the NLL).
    pub degenerate: usize,
    /// Fraction of the measured positions inside the 95% ellipse at 0.5, 1 and 2 s.
    pub coverage95: std::collections::BTreeMap<String, f64>,
    /// Fraction of the measured yaws inside the 95% interval at 0.5, 1 and 2 s.
    pub yaw_coverage95: std::collections::BTreeMap<String, f64>,
    /// Nominal against observed coverage (position and yaw), 50% to 99%: the reliability
    /// diagram.
    pub reliability: Vec<drive_eval::ReliabilityPoint>,
    /// The reliability diagram of the transient and of the steady windows.
    pub reliability_by_phase: std::collections::BTreeMap<String, Vec<drive_eval::ReliabilityPoint>>,
    /// Position coverage at 0.5, 1 and 2 s per phase (`"transient"`, `"steady"`).
    pub coverage95_by_phase: drive_eval::GroupCoverage,
    /// Position coverage per third of the commanded speed (`"low"`, `"mid"`, `"high"`).
    pub coverage95_by_speed: drive_eval::GroupCoverage,
    /// Mean 95% region area at 2 s over the constant circle of the same coverage.
    pub area_ratio_to_constant: f64,
    /// Rank correlation at 2 s of the predicted spread with the error (`"position"`, `"yaw"`).
    pub error_rank_correlation: std::collections::BTreeMap<String, f64>,
}

/// The calibration of a model with pose covariances; `None` for a model without them. The
/// scores are [`drive_eval::score_uncertainty`]'s (the same as `drive eval`'s).
pub fn calibration(
    name: &str,
    model: &dyn MotionModel,
    eval: &WindowSet<'_>,
    start: drive_traits::StartInfo,
) -> Option<Calibration> {
    let u = drive_eval::score_uncertainty(model, eval, start)?;
    Some(Calibration {
        coverage95: u.coverage95,
        yaw_coverage95: u.yaw_coverage95,
        reliability: u.reliability,
        reliability_by_phase: u.reliability_by_phase,
        coverage95_by_phase: u.coverage95_by_phase,
        coverage95_by_speed: u.coverage95_by_speed,
        area_ratio_to_constant: u.area_ratio_to_constant,
        error_rank_correlation: u.error_rank_correlation,
        model: name.to_string(),
        inside_fraction: u.coverage95_per_step,
        inside_overall: u.coverage95_overall,
        mean_nll: u.nll,
        degenerate: u.degenerate,
    })
}

/// The 95% ellipse of a 2x2 position covariance as a closed polygon around `center`.
pub fn ellipse(center: (f64, f64), cov: &PoseCovariance, points: usize) -> Vec<(f64, f64)> {
    let (a, b, d) = (cov[(0, 0)], cov[(0, 1)], cov[(1, 1)]);
    // Eigen-decomposition of [[a, b], [b, d]].
    let mean = 0.5 * (a + d);
    let diff = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let (l1, l2) = ((mean + diff).max(0.0), (mean - diff).max(0.0));
    let angle = 0.5 * (2.0 * b).atan2(a - d);
    let (r1, r2) = ((CHI2_2_95 * l1).sqrt(), (CHI2_2_95 * l2).sqrt());
    let (ca, sa) = (angle.cos(), angle.sin());
    (0..=points)
        .map(|i| {
            let t = i as f64 / points as f64 * std::f64::consts::TAU;
            let (u, v) = (r1 * t.cos(), r2 * t.sin());
            (center.0 + ca * u - sa * v, center.1 + sa * u + ca * v)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ellipse_of_an_axis_aligned_covariance_has_the_chi2_radii() {
        let cov = PoseCovariance::from_diagonal(&drive_traits::Pose::new(4.0, 1.0, 0.0));
        let pts = ellipse((1.0, 2.0), &cov, 4);
        // t = 0: along the larger axis (x), radius sqrt(5.991 x 4).
        assert!((pts[0].0 - (1.0 + (CHI2_2_95 * 4.0).sqrt())).abs() < 1e-12);
        assert!((pts[0].1 - 2.0).abs() < 1e-12);
        // t = pi/2: along y, radius sqrt(5.991).
        assert!((pts[1].1 - (2.0 + CHI2_2_95.sqrt())).abs() < 1e-12);
    }

    #[test]
    fn chi2_quantile_is_minus_two_ln_005() {
        assert!((CHI2_2_95 + 2.0 * 0.05f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn bounding_box_and_polygon() {
        let inputs = [Input::new(-1.0, 2.0, 0.0), Input::new(3.0, -4.0, 0.0)];
        let b = bounding_box(&inputs).unwrap();
        assert_eq!(
            (b.min, b.max),
            (Input::new(-1.0, -4.0, 0.0), Input::new(3.0, 2.0, 0.0))
        );
        let vehicle = drive_models::DifferentialDrive::new(0.5, 1.0);
        let p = body_polygon(&vehicle, &b);
        // (left 3, right -4): forward 0.5 x 0.5 x (3 - 4) = -0.25 m/s, yaw 0.5 (-4 - 3) = -3.5.
        assert!((p[1].x + 0.25).abs() < 1e-12 && (p[1].z + 3.5).abs() < 1e-12);
        assert!(bounding_box(&[]).is_none());
    }
}
