//! Properties that must hold for any input: the BLR posterior (eq. 6) under a fixed prior
//! is the same fitted at once or one batch after the other, its predictive variance (eq. 7)
//! is positive; a rollout with zero input stays put, and a rollout from any start yaw is
//! the rotated rollout from yaw zero.

use drive::models::blr::{BlrPosterior, Prior};
use drive::traits::{wrap_angle, Input, Pose, StartState};
use proptest::prelude::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

/// Rows of `k` inputs away from zero (a zero column is refused as degenerate), and one
/// observation per row.
fn regression(k: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (2 * k + 2..40).prop_flat_map(move |n| {
        let input = prop_oneof![-3.0..-0.1f64, 0.1..3.0f64];
        (
            proptest::collection::vec(input, n * k),
            proptest::collection::vec(-2.0..2.0f64, n),
        )
    })
}

fn fixed_prior(k: usize, precision: f64) -> Prior {
    let mut p = vec![0.0; k * k];
    for i in 0..k {
        p[i * k + i] = precision;
    }
    Prior::Fixed {
        mean: vec![0.1; k],
        precision: p,
        a: 2.0,
        b: 0.5,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn blr_batch_equals_sequential_under_a_fixed_prior(
        (k, (x, g), cut, precision) in (1usize..=3).prop_flat_map(|k| {
            (Just(k), regression(k), 0.2..0.8f64, 0.01..10.0f64)
        })
    ) {
        let n = g.len();
        let m = ((n as f64 * cut) as usize).clamp(1, n - 1);
        let prior = fixed_prior(k, precision);
        let all = BlrPosterior::fit(&x, k, &g, &prior, "all").unwrap();
        let first = BlrPosterior::fit(&x[..m * k], k, &g[..m], &prior, "first");
        // A first batch smaller than the inputs is refused; then there is nothing to chain.
        prop_assume!(first.is_ok());
        let first = first.unwrap();
        let then = BlrPosterior::fit(&x[m * k..], k, &g[m..], &first.as_prior(), "then");
        prop_assume!(then.is_ok());
        let then = then.unwrap();
        for (a, b) in all.mean.iter().zip(&then.mean) {
            prop_assert!(close(*a, *b, 1e-7), "mean {:?} vs {:?}", all.mean, then.mean);
        }
        for (a, b) in all.covariance.iter().zip(&then.covariance) {
            prop_assert!(close(*a, *b, 1e-7), "covariance {:?} vs {:?}", all.covariance, then.covariance);
        }
        prop_assert!(close(all.a, then.a, 1e-12));
        prop_assert!(close(all.b, then.b, 1e-7), "b {} vs {}", all.b, then.b);
    }

    #[test]
    fn blr_predictive_variance_is_positive(
        (k, (x, g), at) in (1usize..=3).prop_flat_map(|k| {
            (Just(k), regression(k), proptest::collection::vec(-100.0..100.0f64, k))
        })
    ) {
        for prior in [fixed_prior(k, 1.0), Prior::Uninformative { phi: 1e12 }] {
            let post = BlrPosterior::fit(&x, k, &g, &prior, "p").unwrap();
            let v = post.predictive_variance(&at);
            prop_assert!(v > 0.0 && v.is_finite(), "variance {v} at {at:?}");
            prop_assert!(post.leverage(&at) >= -1e-12);
        }
    }
}

fn pose() -> impl Strategy<Value = Pose> {
    (
        -50.0..50.0f64,
        -50.0..50.0f64,
        -std::f64::consts::PI..std::f64::consts::PI,
    )
        .prop_map(|(x, y, t)| Pose::new(x, y, t))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn a_robot_at_rest_given_zero_input_stays_put(start in pose(), steps in 1usize..80) {
        let commands = vec![Input::zeros(); steps];
        for (_, model) in crate::common::husky_half_models() {
            let s = StartState::at_rest(start);
            let poses = model.predict(&s, &commands);
            prop_assert_eq!(poses.len(), steps);
            for p in &poses {
                prop_assert!((p - start).norm() < 1e-9, "{} moved to {p} from {start}", model.name());
            }
        }
    }

    #[test]
    fn a_rollout_from_any_yaw_is_the_rotated_rollout_from_yaw_zero(
        start in pose(),
        wheels in (-6.0..6.0f64, -6.0..6.0f64),
        imu in proptest::option::of(-2.0..2.0f64),
        commands in proptest::collection::vec((-8.0..8.0f64, -8.0..8.0f64), 1..60),
    ) {
        let commands: Vec<Input> = commands.into_iter().map(|(l, r)| Input::new(l, r, 0.0)).collect();
        let (s, c) = start.z.sin_cos();
        for (_, model) in crate::common::husky_half_models() {
            // With the IMU's yaw rate or without: what slip-ipem's disturbance reads.
            let at = |pose| {
                let s = StartState { input: Input::new(wheels.0, wheels.1, 0.0), ..StartState::at_rest(pose) };
                imu.map_or(s, |w| s.with_yaw_rate(w))
            };
            let local = model.predict(&at(Pose::zeros()), &commands);
            let moved = model.predict(&at(start), &commands);
            for (l, m) in local.iter().zip(&moved) {
                let expected = Pose::new(
                    start.x + c * l.x - s * l.y,
                    start.y + s * l.x + c * l.y,
                    start.z + l.z,
                );
                prop_assert!(
                    (m.xy() - expected.xy()).norm() < 1e-9 && wrap_angle(m.z - expected.z).abs() < 1e-9,
                    "{}: {m} vs {expected}", model.name()
                );
            }
        }
    }
}
