//! Pooled summaries per scenario and model, and the paired bootstrap of the improvements
//! over the baseline.

use super::BootstrapConfig;
use super::{Improvement, Matrix, MatrixCell, Scenario, SummaryRow};
use drive_eval::{paired_bootstrap, Mrmse, PairedErrors, Summary};
use drive_models::ModelSpec;
use rayon::prelude::*;

/// `learner/powertrain` (or the learner alone).
fn stream_label(m: &ModelSpec) -> String {
    match &m.powertrain {
        Some(p) => format!("{}/{p}", m.learner),
        None => m.learner.clone(),
    }
}

/// Pooled summaries per scenario and model, with improvements over the baseline.
pub(super) fn summarize(
    matrix: &Matrix,
    cells: &[MatrixCell],
    tick: &(dyn Fn() + Sync),
) -> Vec<SummaryRow> {
    let mut scenarios: Vec<&Scenario> = Vec::new();
    for c in cells {
        if !scenarios.contains(&&c.scenario) {
            scenarios.push(&c.scenario);
        }
    }
    let jobs: Vec<(&Scenario, &ModelSpec)> = scenarios
        .iter()
        .flat_map(|s| matrix.models.iter().map(move |m| (*s, m)))
        .collect();
    jobs.par_iter()
        .map(|&(scenario, model)| {
            // Each row's resampling stream depends on what it compares only, so a row's
            // interval is the same in any sweep that holds it.
            // The model part of the key keeps the sweep's earlier `learner/powertrain` form.
            let index = fnv1a(&format!(
                "{}|{:?}|{}",
                scenario.label(),
                scenario.split,
                stream_label(model)
            ));
            let of = |m: &ModelSpec| -> Vec<&MatrixCell> {
                cells
                    .iter()
                    .filter(|c| &c.scenario == scenario && &c.model == m)
                    .collect()
            };
            let mine = of(model);
            let base = of(&matrix.baseline);
            let ok: Vec<&MatrixCell> = mine
                .iter()
                .copied()
                .filter(|c| c.failure.is_none())
                .collect();
            let pooled = |pick: fn(&Mrmse) -> f64| {
                Summary::of(ok.iter().flat_map(|c| c.errors.iter().map(pick)))
            };
            // Pairs of (model, baseline) runs scored on the same evaluation windows.
            let pairs: Vec<(&MatrixCell, &MatrixCell)> = ok
                .iter()
                .filter_map(|c| {
                    base.iter()
                        .find(|b| b.seed == c.seed && b.failure.is_none())
                        .map(|b| (*c, *b))
                })
                .collect();
            let complete = !pairs.is_empty() && pairs.len() == mine.len();
            let improvement = |pick: fn(&Mrmse) -> f64, salt: u64| {
                complete
                    .then(|| bootstrap_improvement(&pairs, pick, &matrix.bootstrap, index, salt))
            };
            let row = SummaryRow {
                scenario: scenario.clone(),
                model: model.clone(),
                runs: mine.len(),
                windows: ok.iter().map(|c| c.errors.len()).sum(),
                translational: pooled(|e| e.translational),
                rotational: pooled(|e| e.rotational),
                translational_improvement: improvement(|e| e.translational, 0),
                rotational_improvement: improvement(|e| e.rotational, 1),
                failed: mine.len() - ok.len(),
            };
            tick();
            row
        })
        .collect()
}

/// FNV-1a of a text: a fixed, platform-independent hash.
fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The improvement of the pooled median over the baseline's, and its bootstrap percentile
/// interval: each run's evaluation intervals (their windows together) resampled with
/// replacement, the same draw for the model and the baseline (a paired bootstrap, see
/// [`paired_bootstrap`]).
pub(super) fn bootstrap_improvement(
    pairs: &[(&MatrixCell, &MatrixCell)],
    pick: fn(&Mrmse) -> f64,
    config: &BootstrapConfig,
    index: u64,
    salt: u64,
) -> Improvement {
    let picked: Vec<(Vec<f64>, Vec<f64>)> = pairs
        .iter()
        .map(|(m, b)| {
            (
                m.errors.iter().map(pick).collect(),
                b.errors.iter().map(pick).collect(),
            )
        })
        .collect();
    let runs: Vec<PairedErrors<'_>> = picked
        .iter()
        .zip(pairs)
        .map(|((m, b), (cell, _))| PairedErrors {
            model: m,
            reference: b,
            blocks: Some(&cell.intervals),
        })
        .collect();
    paired_bootstrap(
        &runs,
        config,
        config.seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (salt << 63),
    )
}

#[cfg(test)]
mod tests {
    use super::super::Scenario;
    use super::*;
    use drive_eval::quantile;
    use drive_traits::median as median_of;

    fn cell(seed: u64, errors: &[f64]) -> MatrixCell {
        MatrixCell {
            scenario: Scenario {
                dataset: "d".into(),
                robot: "r".into(),
                terrain: None,
                sampler: None,
                duration_s: None,
                split: Some(0.5),
            },
            seed: Some(seed),
            model: crate::Registries::builtin().model("naive").unwrap(),
            train_windows: 1,
            eval_windows: errors.len(),
            fit_seconds: 0.0,
            translational: Summary::of(errors.iter().copied()),
            rotational: Summary::of(errors.iter().copied()),
            failure: None,
            errors: errors
                .iter()
                .map(|&e| Mrmse {
                    translational: e,
                    rotational: 2.0 * e,
                })
                .collect(),
            // One interval per window.
            intervals: (0..errors.len()).collect(),
        }
    }

    #[test]
    fn median_by_selection_equals_the_interpolated_quantile() {
        for n in 1..12 {
            let mut v: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 * 0.5).collect();
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            assert_eq!(
                median_of(&mut v),
                quantile(&sorted, 0.5).unwrap(),
                "n = {n}"
            );
        }
        assert!(median_of(&mut []).is_nan());
    }

    #[test]
    fn a_model_with_half_the_baseline_errors_improves_by_exactly_fifty_percent() {
        let base = cell(1, &[0.2, 0.4, 0.6, 0.8, 1.0]);
        let half = cell(1, &[0.1, 0.2, 0.3, 0.4, 0.5]);
        let config = BootstrapConfig::default();
        let i = bootstrap_improvement(&[(&half, &base)], |e| e.translational, &config, 0, 0);
        // Paired resampling keeps the ratio of every draw at 1/2, so the interval is a point.
        assert!((i.percent - 50.0).abs() < 1e-9);
        assert!((i.ci[0] - 50.0).abs() < 1e-9 && (i.ci[1] - 50.0).abs() < 1e-9);
        let same = bootstrap_improvement(&[(&base, &base)], |e| e.rotational, &config, 0, 1);
        assert_eq!((same.percent, same.ci), (0.0, [0.0, 0.0]));
    }

    #[test]
    fn the_interval_widens_with_noisy_pairs_and_brackets_the_estimate() {
        let base = cell(1, &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        let model = cell(1, &[0.2, 0.9, 0.4, 1.2, 0.6, 0.3, 1.1, 0.5]);
        let config = BootstrapConfig::default();
        let i = bootstrap_improvement(&[(&model, &base)], |e| e.translational, &config, 3, 0);
        // Median of the model: (0.5 + 0.6) / 2 = 0.55, so 45% better than 1.0.
        assert!((i.percent - 45.0).abs() < 1e-9);
        assert!(i.ci[0] < 45.0 && i.ci[1] > 45.0, "{:?}", i.ci);
        // Same seed, same interval.
        let again = bootstrap_improvement(&[(&model, &base)], |e| e.translational, &config, 3, 0);
        assert_eq!(i, again);
    }
}
