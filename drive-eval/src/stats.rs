use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};
use std::ops::Range;

pub use drive_traits::quantile;

/// Median and interquartile range of a set of errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Number of values.
    pub count: usize,
    /// Median.
    pub median: f64,
    /// First quartile.
    pub q1: f64,
    /// Third quartile.
    pub q3: f64,
}

impl Summary {
    /// Summary of `values` (NaN-free); `None` when empty.
    ///
    /// ```
    /// let s = drive_eval::Summary::of([4.0, 1.0, 3.0, 2.0]).unwrap();
    /// assert_eq!((s.q1, s.median, s.q3), (1.75, 2.5, 3.25));
    /// ```
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Summary> {
        let mut v: Vec<f64> = values.into_iter().collect();
        v.sort_by(f64::total_cmp);
        Some(Summary {
            count: v.len(),
            median: quantile(&v, 0.5)?,
            q1: quantile(&v, 0.25)?,
            q3: quantile(&v, 0.75)?,
        })
    }
}

/// The bootstrap of the improvement confidence intervals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BootstrapConfig {
    /// Resamples of the evaluation windows.
    pub resamples: usize,
    /// Confidence level of the interval.
    pub level: f64,
    /// Seed of the resampling.
    pub seed: u64,
}

impl Default for BootstrapConfig {
    fn default() -> Self {
        BootstrapConfig {
            resamples: 1000,
            level: 0.95,
            seed: 0,
        }
    }
}

/// Improvement of `value` over `baseline` in percent: `100 (baseline - value) / baseline`;
/// 0 when both are zero (a perfect baseline matched), not NaN.
///
/// ```
/// assert_eq!(drive_eval::improvement_percent(0.5, 2.0), 75.0);
/// assert_eq!(drive_eval::improvement_percent(0.0, 0.0), 0.0);
/// ```
pub fn improvement_percent(value: f64, baseline: f64) -> f64 {
    if value == baseline {
        return 0.0;
    }
    100.0 * (baseline - value) / baseline
}

/// The median of `values` (reordered in place; NaN-free), as [`quantile`] at 0.5 gives it;
/// NaN when empty. Linear time (selection, no sort): the bootstrap calls it for every draw.
pub(crate) use drive_traits::median as median_of;

/// An improvement over a reference model with its bootstrap confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Improvement {
    /// `100 (reference median - median) / reference median`.
    pub percent: f64,
    /// Bootstrap percentile interval of the same figure.
    pub ci: [f64; 2],
}

/// The errors of a model and of its reference on the same evaluation windows, in the same
/// order: one run of a [`paired_bootstrap`].
#[derive(Debug, Clone, Copy)]
pub struct PairedErrors<'a> {
    /// The model's error per window.
    pub model: &'a [f64],
    /// The reference's error on the same windows.
    pub reference: &'a [f64],
    /// The block (e.g. the DRIVE interval) of each window, non-decreasing: whole blocks
    /// are resampled, keeping the windows of one command together. `None`: windows are
    /// resampled one by one.
    pub blocks: Option<&'a [usize]>,
}

/// The improvement of the pooled median error over the reference's, with its paired
/// bootstrap percentile interval: every run's windows (or blocks of windows) are resampled
/// with replacement, the same draw for the model and the reference. Deterministic for a
/// `seed`. Draws where the improvement is not a number are left out.
///
/// ```
/// use drive_eval::{paired_bootstrap, BootstrapConfig, PairedErrors};
/// let reference: Vec<f64> = (1..=40).map(|i| i as f64 / 10.0).collect();
/// let model: Vec<f64> = reference.iter().map(|e| e / 2.0).collect();
/// let blocks: Vec<usize> = (0..40).map(|i| i / 3).collect();
/// let run = PairedErrors { model: &model, reference: &reference, blocks: Some(&blocks) };
/// let imp = paired_bootstrap(&[run], &BootstrapConfig::default(), 7);
/// // Half the error on every window: 50% on every draw.
/// assert!((imp.percent - 50.0).abs() < 1e-12);
/// assert!((imp.ci[0] - 50.0).abs() < 1e-9 && (imp.ci[1] - 50.0).abs() < 1e-9);
/// ```
pub fn paired_bootstrap(
    runs: &[PairedErrors<'_>],
    config: &BootstrapConfig,
    seed: u64,
) -> Improvement {
    let mut mine: Vec<f64> = Vec::new();
    let mut base: Vec<f64> = Vec::new();
    for r in runs {
        mine.extend_from_slice(r.model);
        base.extend_from_slice(r.reference);
    }
    let percent = improvement_percent(median_of(&mut mine), median_of(&mut base));
    // Each run's blocks as ranges of windows (each window alone without blocks).
    let ranges: Vec<Vec<Range<usize>>> = runs
        .iter()
        .map(|r| block_ranges(r.model.len().min(r.reference.len()), r.blocks))
        .collect();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut draws = Vec::with_capacity(config.resamples);
    for _ in 0..config.resamples {
        mine.clear();
        base.clear();
        for (r, blocks) in runs.iter().zip(&ranges) {
            for _ in 0..blocks.len() {
                let b = &blocks[rng.random_range(0..blocks.len())];
                mine.extend_from_slice(&r.model[b.clone()]);
                base.extend_from_slice(&r.reference[b.clone()]);
            }
        }
        let p = improvement_percent(median_of(&mut mine), median_of(&mut base));
        if p.is_finite() {
            draws.push(p);
        }
    }
    Improvement {
        percent,
        ci: percentile_interval(&mut draws, config.level),
    }
}

/// The blocks a bootstrap resamples whole among `n` windows, as ranges of indices: the runs
/// of equal consecutive `ids` (windows beyond `ids` left out), or each window alone without
/// them.
fn block_ranges(n: usize, ids: Option<&[usize]>) -> Vec<Range<usize>> {
    let Some(ids) = ids else {
        return (0..n).map(|i| i..i + 1).collect();
    };
    let ids = &ids[..ids.len().min(n)];
    let mut out: Vec<Range<usize>> = Vec::new();
    for (i, id) in ids.iter().enumerate() {
        match out.last_mut() {
            Some(last) if *id == ids[last.start] => last.end = i + 1,
            _ => out.push(i..i + 1),
        }
    }
    out
}

/// The percentile interval at `level` of bootstrap `draws` (sorted here); NaN bounds without
/// draws.
fn percentile_interval(draws: &mut [f64], level: f64) -> [f64; 2] {
    draws.sort_unstable_by(f64::total_cmp);
    let tail = (1.0 - level) / 2.0;
    [
        quantile(draws, tail).unwrap_or(f64::NAN),
        quantile(draws, 1.0 - tail).unwrap_or(f64::NAN),
    ]
}

/// The bootstrap percentile interval of the median of `errors`: the blocks of windows
/// (`blocks[i]` the block of window `i`, e.g. its DRIVE interval, non-decreasing; `None`:
/// each window alone) resampled whole with replacement `config.resamples` times, seeded by
/// `seed` (not `config.seed`, as [`paired_bootstrap`]). How far the median of one run's
/// evaluation windows could have fallen with other commands drawn; NaN bounds when there is
/// no window to draw (`errors` or `blocks` empty). Windows beyond `blocks` are left out.
///
/// ```
/// use drive_eval::{median_interval, BootstrapConfig};
/// // Ten intervals of three windows: 0.1, 0.2, ..., 1.0 m.
/// let errors: Vec<f64> = (0..30).map(|i| (i / 3 + 1) as f64 / 10.0).collect();
/// let blocks: Vec<usize> = (0..30).map(|i| i / 3).collect();
/// let [lo, hi] = median_interval(&errors, Some(&blocks), &BootstrapConfig::default(), 0);
/// assert!(lo < 0.55 && 0.55 < hi && lo >= 0.1 && hi <= 1.0);
/// // One value everywhere: no spread.
/// assert_eq!(median_interval(&[0.2; 12], None, &BootstrapConfig::default(), 0), [0.2, 0.2]);
/// ```
pub fn median_interval(
    errors: &[f64],
    blocks: Option<&[usize]>,
    config: &BootstrapConfig,
    seed: u64,
) -> [f64; 2] {
    let ranges = block_ranges(errors.len(), blocks);
    if ranges.is_empty() {
        return [f64::NAN; 2];
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut draw = Vec::with_capacity(errors.len());
    let mut medians = Vec::with_capacity(config.resamples);
    for _ in 0..config.resamples {
        draw.clear();
        for _ in 0..ranges.len() {
            draw.extend_from_slice(&errors[ranges[rng.random_range(0..ranges.len())].clone()]);
        }
        let m = median_of(&mut draw);
        if m.is_finite() {
            medians.push(m);
        }
    }
    percentile_interval(&mut medians, config.level)
}

/// The ranks of `values` (1 = smallest), ties sharing their mean rank.
///
/// ```
/// assert_eq!(drive_eval::average_ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
/// ```
pub fn average_ranks(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut r = vec![0.0; n];
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && values[order[j + 1]] == values[order[i]] {
            j += 1;
        }
        // Ranks i + 1 ..= j + 1 share their mean.
        let mean = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            r[k] = mean;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation of paired values (ties get their average rank); `None` for
/// fewer than 3 pairs or when either side is constant.
///
/// ```
/// use drive_eval::spearman;
/// assert_eq!(spearman(&[1.0, 2.0, 3.0, 4.0], &[10.0, 20.0, 25.0, 100.0]), Some(1.0));
/// assert_eq!(spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]), Some(-1.0));
/// assert_eq!(spearman(&[1.0, 1.0, 1.0], &[3.0, 2.0, 1.0]), None);
/// ```
pub fn spearman(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len().min(y.len());
    if n < 3 {
        return None;
    }
    let (rx, ry) = (average_ranks(&x[..n]), average_ranks(&y[..n]));
    let mean = (n as f64 + 1.0) / 2.0;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in rx.iter().zip(&ry) {
        sxy += (a - mean) * (b - mean);
        sxx += (a - mean) * (a - mean);
        syy += (b - mean) * (b - mean);
    }
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Errors constant within blocks of three (one DRIVE interval's windows move
    /// together): resampling whole blocks gives a wider interval than resampling windows
    /// as if they were independent, and the same seed gives the same interval.
    #[test]
    fn block_resampling_widens_the_interval_of_correlated_windows_and_is_seeded() {
        let blocks: Vec<usize> = (0..90).map(|i| i / 3).collect();
        // A reference error per block, and a model better by a block-dependent amount.
        let reference: Vec<f64> = blocks.iter().map(|b| 1.0 + (b % 7) as f64 * 0.3).collect();
        let model: Vec<f64> = blocks
            .iter()
            .zip(&reference)
            .map(|(b, r)| r * (0.4 + 0.5 * ((b * 13) % 10) as f64 / 10.0))
            .collect();
        let config = BootstrapConfig::default();
        let run = |blocks| PairedErrors {
            model: &model,
            reference: &reference,
            blocks,
        };
        let by_block = paired_bootstrap(&[run(Some(&blocks))], &config, 3);
        let by_window = paired_bootstrap(&[run(None)], &config, 3);
        assert_eq!(by_block.percent, by_window.percent);
        let width = |i: &Improvement| i.ci[1] - i.ci[0];
        assert!(
            width(&by_block) > width(&by_window),
            "{by_block:?} {by_window:?}"
        );
        assert!(by_block.ci[0] <= by_block.percent && by_block.percent <= by_block.ci[1]);
        assert_eq!(
            by_block,
            paired_bootstrap(&[run(Some(&blocks))], &config, 3)
        );
        assert_ne!(
            by_block,
            paired_bootstrap(&[run(Some(&blocks))], &config, 4)
        );
    }
}
