use super::*;

fn ols(x: &[f64], k: usize, g: &[f64]) -> DVector<f64> {
    let n = g.len();
    let xm = DMatrix::from_row_slice(n, k, x);
    let gv = DVector::from_column_slice(g);
    (xm.transpose() * &xm).try_inverse().unwrap() * xm.transpose() * gv
}

#[test]
fn hand_computed_single_input() {
    // x = [1, 2], g = [1, 3]: OLS gamma = (1 + 6) / (1 + 4) = 1.4; RSS = (1-1.4)^2 + (3-2.8)^2 = 0.2.
    let post = BlrPosterior::fit(
        &[1.0, 2.0],
        1,
        &[1.0, 3.0],
        &Prior::Uninformative { phi: 1.0 },
        "t",
    )
    .unwrap();
    assert!((post.mean[0] - 0.7).abs() < 1e-12); // phi / (1 + phi) = 1/2
    assert!((post.covariance[0] - 0.5 / 5.0).abs() < 1e-12);
    assert_eq!(post.a, 1.0);
    // b = 1/2 (RSS + |X gamma_ls|^2 / 2) = 1/2 (0.2 + 1.4^2 * 5 / 2)
    assert!((post.b - 0.5 * (0.2 + 1.96 * 5.0 / 2.0)).abs() < 1e-12);
}

#[test]
fn a_posterior_read_from_a_file_holds_what_a_fit_writes() {
    let fitted = BlrPosterior::fit(
        &[1.0, 2.0, 3.0],
        1,
        &[1.0, 3.0, 2.0],
        &Prior::Uninformative { phi: 1.0 },
        "t",
    )
    .unwrap();
    assert_eq!(fitted.a, 1.5);
    assert!(fitted.check(1, "slip_x").is_ok());
    let refused = |edit: &dyn Fn(&mut BlrPosterior), says: &str| {
        let mut p = fitted.clone();
        edit(&mut p);
        let e = p.check(1, "slip_x").unwrap_err();
        assert!(e.contains("slip_x") && e.contains(says), "{e}");
    };
    refused(&|p| p.a = 1e300, "noise shape a = 1e300");
    refused(&|p| p.b = 1e300, "noise variance");
    // A shape of 1 or less: a predictive of infinite variance (acc-BLR's covariances
    // collapsed to zero with a = 0.5).
    refused(&|p| p.a = 1.0, "noise shape a = 1 must be above 1");
    refused(&|p| p.a = 0.5, "must be above 1");
    refused(&|p| p.mean[0] = 1e300, "weight 1e300");
    refused(&|p| p.covariance[0] = 1e300, "covariance entry 1e300");
    refused(&|p| p.covariance[0] = -1.0, "not positive definite");
}

#[test]
fn fixed_prior_hand_computed() {
    // One input, prior mean 1, precision 1, a0 = 1, b0 = 1; data x = [1, 0], g = [3, 0].
    // K = 1 / (1 + 1) = 0.5; gamma = 0.5 (1 + 3) = 2; a = 1 + 2/2 = 2;
    // b = 1 + 1/2 (1 + 9 - 2 * 2 * 2) = 2.
    let prior = Prior::Fixed {
        mean: vec![1.0],
        precision: vec![1.0],
        a: 1.0,
        b: 1.0,
    };
    // A second row with x = 0, g = 0 adds nothing to the statistics but one to n.
    let post = BlrPosterior::fit(&[1.0, 0.0], 1, &[3.0, 0.0], &prior, "t").unwrap();
    assert!((post.mean[0] - 2.0).abs() < 1e-12);
    assert!((post.covariance[0] - 0.5).abs() < 1e-12);
    assert_eq!(post.a, 2.0);
    assert!((post.b - 2.0).abs() < 1e-12);
}

#[test]
fn degenerate_inputs_are_refused() {
    let zero = BlrPosterior::fit(
        &[0.0, 1.0, 0.0, 2.0, 0.0, 3.0],
        2,
        &[1.0, 2.0, 3.0],
        &Prior::default(),
        "t",
    );
    assert!(matches!(zero, Err(FitError::DegenerateInputs { .. })));
    let collinear = BlrPosterior::fit(
        &[1.0, 2.0, 2.0, 4.0, 3.0, 6.0],
        2,
        &[1.0, 2.0, 3.0],
        &Prior::default(),
        "t",
    );
    assert!(matches!(collinear, Err(FitError::DegenerateInputs { .. })));
    let few = BlrPosterior::fit(&[1.0], 1, &[1.0], &Prior::default(), "t");
    assert!(matches!(few, Err(FitError::TooFewSamples { .. })));
    let bad_phi = BlrPosterior::fit(
        &[1.0, 2.0],
        1,
        &[1.0, 2.0],
        &Prior::Uninformative { phi: -1.0 },
        "t",
    );
    assert!(matches!(
        bad_phi,
        Err(FitError::InvalidHyperparameter { .. })
    ));
}

/// A small deterministic generator so that the property tests need no extra crate.
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// Online BLR: observations added chunk by chunk (or as merged statistics) give the
/// batch posterior to 1e-9, for both priors, every chunking.
#[test]
fn property_recursive_statistics_equal_the_batch_fit() {
    let mut seed = 23;
    for case in 0..300 {
        let k = 1 + case % 3;
        let n = k + 2 + (case * 7) % 60;
        let scale = [1e-3, 1.0, 30.0][case % 3];
        let x: Vec<f64> = (0..n * k).map(|_| lcg(&mut seed) * scale).collect();
        let g: Vec<f64> = (0..n).map(|_| lcg(&mut seed) * 2.0).collect();
        let prior = if case % 4 == 3 {
            Prior::Fixed {
                mean: (0..k).map(|j| 0.1 * j as f64).collect(),
                precision: (0..k * k)
                    .map(|i| if i % (k + 1) == 0 { 0.5 } else { 0.0 })
                    .collect(),
                a: 1.0,
                b: 0.5,
            }
        } else {
            Prior::Uninformative {
                phi: [1.0, 10.0, 1e12][case % 3],
            }
        };
        let batch = BlrPosterior::fit(&x, k, &g, &prior, "t").unwrap();
        // Random chunks, as intervals arrive.
        let mut online = BlrStatistics::new(k);
        let mut merged = BlrStatistics::new(k);
        let mut i = 0;
        while i < n {
            let m = 1 + ((lcg(&mut seed) + 1.0) * 4.0) as usize;
            let end = (i + m).min(n);
            online.add_rows(&x[i * k..end * k], &g[i..end]);
            let mut part = BlrStatistics::new(k);
            part.add_rows(&x[i * k..end * k], &g[i..end]);
            merged.merge(&part);
            i = end;
        }
        for stats in [&online, &merged] {
            assert_eq!(stats.observations(), n);
            let p = stats.posterior(&prior, "t").unwrap();
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()));
            for (a, b) in batch
                .mean
                .iter()
                .chain(&batch.covariance)
                .zip(p.mean.iter().chain(&p.covariance))
            {
                assert!(close(*a, *b), "case {case}: {a} vs {b}");
            }
            assert!(
                close(batch.a, p.a) && close(batch.b, p.b),
                "case {case}: {batch:?} vs {p:?}"
            );
        }
    }
}

#[test]
fn recursive_statistics_refuse_what_the_batch_fit_refuses() {
    let mut s = BlrStatistics::new(2);
    s.add_rows(&[1.0, 0.0, 2.0, 0.0, 3.0, 0.0], &[1.0, 2.0, 3.0]);
    let err = s.posterior(&Prior::default(), "t").unwrap_err().to_string();
    assert!(err.contains("input 1 is zero on every row"), "{err}");
    let mut c = BlrStatistics::new(2);
    c.add_rows(&[1.0, 2.0, 2.0, 4.0, 3.0, 6.0], &[1.0, 2.0, 3.0]);
    let err = c.posterior(&Prior::default(), "t").unwrap_err().to_string();
    assert!(err.contains("collinear"), "{err}");
    let mut few = BlrStatistics::new(2);
    few.add_rows(&[1.0, 2.0, 2.0, 1.0], &[1.0, 2.0]);
    assert!(matches!(
        few.posterior(&Prior::default(), "t"),
        Err(FitError::TooFewSamples { .. })
    ));
    let mut nan = BlrStatistics::new(1);
    nan.add_rows(&[1.0, f64::NAN, 2.0], &[1.0, 2.0, 3.0]);
    assert!(matches!(
        nan.posterior(&Prior::default(), "t"),
        Err(FitError::NonFinite { .. })
    ));
}

#[test]
fn property_uninformative_mean_is_shrunk_ols() {
    let mut seed = 7;
    for case in 0..200 {
        let k = 1 + case % 3;
        let n = k + 2 + case % 17;
        let x: Vec<f64> = (0..n * k).map(|_| lcg(&mut seed) * 3.0).collect();
        let g: Vec<f64> = (0..n).map(|_| lcg(&mut seed)).collect();
        let phi = [1e-3, 0.5, 1.0, 10.0, 1e12][case % 5];
        let post = BlrPosterior::fit(&x, k, &g, &Prior::Uninformative { phi }, "t").unwrap();
        let ls = ols(&x, k, &g);
        for j in 0..k {
            let expected = phi / (1.0 + phi) * ls[j];
            assert!(
                (post.mean[j] - expected).abs() <= 1e-8 * (1.0 + expected.abs()),
                "case {case}: {} vs {expected}",
                post.mean[j]
            );
        }
    }
}

#[test]
fn property_fixed_prior_matches_eq6_and_uninformative_limit() {
    let mut seed = 11;
    for case in 0..200 {
        let k = 1 + case % 3;
        let n = k + 1 + case % 13;
        let x: Vec<f64> = (0..n * k).map(|_| lcg(&mut seed) * 2.0).collect();
        let g: Vec<f64> = (0..n).map(|_| lcg(&mut seed)).collect();
        let xm = DMatrix::from_row_slice(n, k, &x);
        let gv = DVector::from_column_slice(&g);
        // A random SPD prior precision.
        let a = DMatrix::from_fn(k, k, |_, _| lcg(&mut seed));
        let prec0 = &a * a.transpose() + DMatrix::identity(k, k) * 0.5;
        let mean0 = DVector::from_fn(k, |_, _| lcg(&mut seed));
        let (a0, b0) = (0.5 + lcg(&mut seed).abs(), 0.1 + lcg(&mut seed).abs());
        let prior = Prior::Fixed {
            mean: mean0.iter().copied().collect(),
            precision: row_major(&prec0),
            a: a0,
            b: b0,
        };
        let post = BlrPosterior::fit(&x, k, &g, &prior, "t").unwrap();
        // Eq. 6 written out independently.
        let kk = (&prec0 + xm.transpose() * &xm).try_inverse().unwrap();
        let gamma = &kk * (&prec0 * &mean0 + xm.transpose() * &gv);
        let b = b0
            + 0.5
                * (mean0.dot(&(&prec0 * &mean0)) + gv.dot(&gv)
                    - gamma.dot(&(kk.clone().try_inverse().unwrap() * &gamma)));
        for j in 0..k {
            assert!((post.mean[j] - gamma[j]).abs() < 1e-9 * (1.0 + gamma[j].abs()));
        }
        for (p, e) in post.covariance.iter().zip(row_major(&kk)) {
            assert!((p - e).abs() < 1e-9 * (1.0 + e.abs()));
        }
        assert!((post.a - (a0 + n as f64 / 2.0)).abs() < 1e-12);
        assert!((post.b - b).abs() < 1e-8 * (1.0 + b.abs()));
        // The paper's prior is the fixed prior K0 = phi (X^T X)^-1: both paths agree.
        if n > k {
            let phi = 3.0;
            let un = BlrPosterior::fit(&x, k, &g, &Prior::Uninformative { phi }, "t").unwrap();
            let xtx = xm.transpose() * &xm;
            let as_fixed = Prior::Fixed {
                mean: vec![0.0; k],
                precision: row_major(&(xtx / phi)),
                a: 0.0,
                b: 0.0,
            };
            let fx = BlrPosterior::fit(&x, k, &g, &as_fixed, "t").unwrap();
            for j in 0..k {
                assert!((un.mean[j] - fx.mean[j]).abs() < 1e-7 * (1.0 + fx.mean[j].abs()));
            }
            assert!((un.b - fx.b).abs() < 1e-7 * (1.0 + fx.b.abs()));
        }
    }
}

#[test]
fn predictive_variance_follows_eq7() {
    let post = BlrPosterior {
        mean: vec![1.0],
        covariance: vec![0.25],
        a: 3.0,
        b: 1.5,
    };
    // scale^2 = b/a (1 + x K x) = 0.5 (1 + 4 * 0.25) = 1; variance = 1 * 6 / 4.
    assert!((post.predictive_scale2(&[2.0]) - 1.0).abs() < 1e-15);
    assert!((post.predictive_variance(&[2.0]) - 1.5).abs() < 1e-15);
}
