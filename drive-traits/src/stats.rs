//! Small statistics the crates share.

/// The median of `values` (reordered in place): the middle value, or the mean of the two
/// middle values; NaN when empty. Linear time (selection, no sort).
///
/// ```
/// use drive_traits::median;
/// assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
/// assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
/// assert!(median(&mut []).is_nan());
/// ```
pub fn median(values: &mut [f64]) -> f64 {
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    let (left, mid, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
    let upper = *mid;
    if n % 2 == 1 {
        return upper;
    }
    // The lower middle value is the largest of the left part.
    let lower = left.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    lower + (upper - lower) * 0.5
}

/// An integer key ordered as [`f64::total_cmp`] orders the floats (the same transform of
/// the bits): sorting or selecting on keys gives the same order statistics with integer
/// comparisons. [`from_total_order_key`] takes a key back to its float, bit for bit.
///
/// ```
/// use drive_traits::{from_total_order_key, total_order_key};
/// let x = [-1.5, -0.0, 0.0, 2.0, f64::INFINITY];
/// assert!(x.windows(2).all(|w| total_order_key(w[0]) < total_order_key(w[1])));
/// assert_eq!(from_total_order_key(total_order_key(-0.0)).to_bits(), (-0.0f64).to_bits());
/// ```
pub fn total_order_key(x: f64) -> i64 {
    let bits = x.to_bits() as i64;
    bits ^ ((((bits >> 63) as u64) >> 1) as i64)
}

/// The float whose [`total_order_key`] is `key`.
pub fn from_total_order_key(key: i64) -> f64 {
    // The transform flips the low 63 bits of negative numbers only, and keeps the sign
    // bit: it is its own inverse.
    f64::from_bits(total_order_key(f64::from_bits(key as u64)) as u64)
}

/// The `p`-quantile of sorted values by linear interpolation between order statistics
/// (position `(n - 1) p`, as numpy's default). `None` for no values.
///
/// ```
/// use drive_traits::quantile;
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), Some(2.5));
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.25), Some(1.75));
/// assert_eq!(quantile(&[], 0.5), None);
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
