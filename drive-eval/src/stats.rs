use serde::Serialize;

/// The `p`-quantile of sorted values by linear interpolation between order statistics
/// (position `(n - 1) p`, as numpy's default). `None` for no values.
///
/// ```
/// use drive_eval::quantile;
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), Some(2.5));
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.25), Some(1.75));
/// ```
pub fn quantile(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let pos = (sorted.len() - 1) as f64 * p.clamp(0.0, 1.0);
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    Some(sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64))
}

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
