//! The terrain's unpredictability: the properties the metric is defined by.

use drive_eval::{unpredictability, Unpredictability, UnpredictabilityConfig};
use drive_models::DifferentialDrive;
use drive_samplers::BodySize;
use drive_traits::{CommandModel, Dataset, Input, Phase, Pose, RobotDescription, Window};

const DT: f64 = 0.05;
const HUSKY_BODY: BodySize = BodySize {
    length_m: 0.8382,
    width_m: 0.6604,
};

fn vehicle() -> DifferentialDrive {
    DifferentialDrive::new(0.165, 0.55)
}

/// A dataset of `commands.len()` windows of 40 samples, each holding one command; `motion`
/// gives the body velocity the robot makes for a command (its poses integrate it exactly,
/// along arcs), the encoders follow the commands.
fn dataset(commands: &[Input], motion: impl Fn(&Input) -> [f64; 3]) -> Dataset {
    let windows = commands
        .iter()
        .enumerate()
        .map(|(i, u)| {
            let [vx, vy, w] = motion(u);
            let mut pose = vec![Pose::zeros()];
            for _ in 1..40 {
                let q = *pose.last().unwrap();
                // Exact integration of a constant body velocity over one step.
                let (dx, dy) = if w.abs() < 1e-12 {
                    (vx * DT, vy * DT)
                } else {
                    let a = w * DT;
                    (
                        (vx * a.sin() - vy * (1.0 - a.cos())) / w,
                        (vx * (1.0 - a.cos()) + vy * a.sin()) / w,
                    )
                };
                let (s, c) = q.z.sin_cos();
                pose.push(Pose::new(
                    q.x + c * dx - s * dy,
                    q.y + s * dx + c * dy,
                    q.z + w * DT,
                ));
            }
            Window::new(
                i,
                i / 3,
                if i % 3 == 0 {
                    Phase::Transient
                } else {
                    Phase::Steady
                },
                vec![*u; 40],
                vec![*u; 40],
                pose,
                vec![w; 40],
            )
        })
        .collect();
    Dataset {
        robot: RobotDescription::new("toy", "toy", 20.0, 40, vehicle()),
        windows,
    }
}

/// Commands spread over the input space, some of them turning on the spot, two of them
/// turning two full turns in a second (12 rad/s) or more.
fn commands() -> Vec<Input> {
    let mut c: Vec<Input> = (0..30)
        .map(|i| {
            let a = i as f64 * 0.7;
            Input::new(5.0 * a.sin(), 5.0 * (1.3 * a + 0.4).cos(), 0.0)
        })
        .collect();
    c.extend([
        Input::new(-20.0, 20.0, 0.0),
        Input::new(10.0, 30.0, 0.0),
        Input::new(-20.0, 20.0, 0.0),
    ]);
    c
}

fn as_commanded(u: &Input) -> [f64; 3] {
    let f = vehicle().body_velocity(u);
    [f.x, f.y, f.z]
}

fn all_values(u: &Unpredictability) -> Vec<f64> {
    let mut v: Vec<f64> = u
        .windows
        .iter()
        .flat_map(|w| [w.translational, w.rotational, w.total])
        .flatten()
        .collect();
    for s in [u.translational, u.rotational, u.total].iter().flatten() {
        v.extend([s.median, s.iqr[0], s.iqr[1], s.mean]);
    }
    v
}

#[test]
fn a_robot_that_moves_as_commanded_is_predictable() {
    let data = dataset(&commands(), as_commanded);
    let u = unpredictability(&data, Some(HUSKY_BODY), &UnpredictabilityConfig::default());
    for (kind, s) in [
        ("translational", u.translational),
        ("rotational", u.rotational),
        ("total", u.total),
    ] {
        let s = s.unwrap_or_else(|| panic!("{kind}: no sample"));
        assert!(s.median < 1e-9, "{kind}: median {}", s.median);
        assert!(s.iqr[1] < 1e-9, "{kind}: third quartile {}", s.iqr[1]);
        assert!(s.samples >= 250, "{kind}: {} samples", s.samples);
    }
    // Transient windows too, here: the motion follows the command at once.
    for w in &u.windows {
        for v in [w.translational, w.rotational, w.total].iter().flatten() {
            assert!(*v < 1e-9, "window {}: {v}", w.window);
        }
    }
}

#[test]
fn a_robot_that_does_not_move_while_commanded_is_fully_unpredictable() {
    // Wheels turning, body still (a robot on a bench, or stuck).
    let data = dataset(&commands(), |_| [0.0; 3]);
    let u = unpredictability(&data, Some(HUSKY_BODY), &UnpredictabilityConfig::default());
    for s in [u.translational, u.rotational, u.total] {
        let s = s.unwrap();
        assert_eq!((s.median, s.iqr[0], s.mean), (1.0, 1.0, 1.0));
    }
    // Encoders at zero as well (dead motors): still the command that was not obeyed.
    let mut dead = data.clone();
    for w in &mut dead.windows {
        w.measured.iter_mut().for_each(|m| *m = Input::zeros());
    }
    let u = unpredictability(&dead, Some(HUSKY_BODY), &UnpredictabilityConfig::default());
    assert_eq!(u.total.unwrap().median, 1.0);
}

#[test]
fn the_total_weights_direction_and_turning_sense() {
    // Driving backward when commanded forward: the same translational energy (0), but the
    // total counts none of it.
    let straight: Vec<Input> = (1..=12)
        .map(|i| Input::new(0.4 * i as f64, 0.4 * i as f64, 0.0))
        .collect();
    let backward = dataset(&straight, |u| {
        let [vx, vy, w] = as_commanded(u);
        [-vx, vy, w]
    });
    let u = unpredictability(
        &backward,
        Some(HUSKY_BODY),
        &UnpredictabilityConfig::default(),
    );
    assert!(u.translational.unwrap().median < 1e-9);
    assert!(u.total.unwrap().median > 0.999);
    // Turning the other way: rotational energy as commanded, total of none.
    let spins: Vec<Input> = (1..=12)
        .map(|i| Input::new(-0.4 * i as f64, 0.4 * i as f64, 0.0))
        .collect();
    let wrong_way = dataset(&spins, |u| {
        let [vx, vy, w] = as_commanded(u);
        [vx, vy, -w]
    });
    let u = unpredictability(
        &wrong_way,
        Some(HUSKY_BODY),
        &UnpredictabilityConfig::default(),
    );
    assert!(u.rotational.unwrap().median < 1e-9);
    assert!(u.total.unwrap().median > 0.999);
    // Half the commanded speed: between the two.
    let slow = dataset(&straight, |u| as_commanded(u).map(|v| 0.5 * v));
    let m = unpredictability(&slow, Some(HUSKY_BODY), &UnpredictabilityConfig::default())
        .translational
        .unwrap()
        .median;
    // atan2(1/4, 1): the energy goes with the square of the speed.
    let expected = 4.0 / std::f64::consts::PI * (std::f64::consts::FRAC_PI_4 - 0.25f64.atan());
    assert!((m - expected).abs() < 1e-3, "{m} vs {expected}");
}

#[test]
fn the_unpredictability_always_lies_in_zero_one() {
    // Real data of two robots, a simulated run and arbitrary motion.
    let mut sets = vec![
        drive_data::bundled::load("husky_drive").unwrap(),
        drive_data::bundled::load("warthog_grass_2024-08-08").unwrap(),
    ];
    sets.push(dataset(&commands(), |u| {
        let [vx, _, w] = as_commanded(u);
        [0.3 * w - vx, 0.7 * vx, 2.0 * vx - w]
    }));
    for data in &sets {
        let u = unpredictability(data, Some(HUSKY_BODY), &UnpredictabilityConfig::default());
        let values = all_values(&u);
        assert!(!values.is_empty());
        assert!(
            values.iter().all(|v| (0.0..=1.0).contains(v)),
            "{}: {:?}",
            data.robot.name,
            values.iter().find(|v| !(0.0..=1.0).contains(*v))
        );
    }
}

#[test]
fn a_rotation_of_the_world_frame_changes_nothing() {
    for name in ["warthog_asphalt_a", "husky_drive"] {
        let data = drive_data::bundled::load(name).unwrap();
        let config = UnpredictabilityConfig::default();
        let before = unpredictability(&data, Some(HUSKY_BODY), &config);
        for angle in [0.7f64, -2.9] {
            let mut turned = data.clone();
            let (s, c) = angle.sin_cos();
            for w in &mut turned.windows {
                for q in &mut w.pose {
                    *q = Pose::new(c * q.x - s * q.y, s * q.x + c * q.y, q.z + angle);
                }
            }
            let after = unpredictability(&turned, Some(HUSKY_BODY), &config);
            let (a, b) = (all_values(&before), all_values(&after));
            assert_eq!(a.len(), b.len(), "{name}");
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-9, "{name} turned by {angle}: {x} vs {y}");
            }
        }
    }
}

#[test]
fn the_total_needs_the_body_and_the_mass_cancels() {
    let data = dataset(&commands(), |u| as_commanded(u).map(|v| 0.8 * v));
    let without = unpredictability(&data, None, &UnpredictabilityConfig::default());
    assert!(without.total.is_none() && without.translational.is_some());
    assert!(without.windows.iter().all(|w| w.total.is_none()));
    // The body enters the total only: the translational and rotational figures are ratios
    // of one kind of energy each, which neither the mass nor the inertia changes.
    let with = unpredictability(&data, Some(HUSKY_BODY), &UnpredictabilityConfig::default());
    assert_eq!(with.translational, without.translational);
    assert_eq!(with.rotational, without.rotational);
    let total = with.total.unwrap().median;
    // 80% of the commanded speed: atan2(0.64, 1) mapped.
    let expected = 4.0 / std::f64::consts::PI * (std::f64::consts::FRAC_PI_4 - 0.64f64.atan());
    assert!((total - expected).abs() < 2e-3, "{total} vs {expected}");
}

#[test]
fn localization_noise_keeps_it_near_zero() {
    // Centimetre-level ICP noise on poses that follow the commands.
    let mut data = dataset(&commands(), as_commanded);
    let mut state = 12345u64;
    let mut noise = |scale: f64| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        scale * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
    };
    for w in &mut data.windows {
        for q in &mut w.pose {
            *q = Pose::new(q.x + noise(0.004), q.y + noise(0.004), q.z + noise(0.002));
        }
    }
    let u = unpredictability(&data, Some(HUSKY_BODY), &UnpredictabilityConfig::default());
    for s in [u.translational, u.rotational, u.total] {
        assert!(s.unwrap().median < 0.05, "{:?}", s);
    }
}
