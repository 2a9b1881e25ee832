use drive_traits::limits::Short;
use drive_traits::{Dataset, WindowSet};
use thiserror::Error;

/// Why a split cannot be made.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SplitError {
    /// The fraction is not in (0, 1).
    #[error("split fraction {} is not between 0 and 1 (exclusive)", Short(*.0))]
    BadFraction(f64),
    /// One side of the split would be empty.
    #[error("split {} of {intervals} DRIVE intervals leaves {train} for training and {eval} for evaluation; both need at least one", Short(*.fraction))]
    EmptySide {
        /// fraction asked
        fraction: f64,
        /// intervals in the dataset
        intervals: usize,
        /// intervals for training
        train: usize,
        /// intervals for evaluation
        eval: usize,
    },
}

/// Splits a dataset by DRIVE interval in recording order: the first
/// `floor(fraction x intervals)` intervals train, the rest evaluate, so that no interval
/// is cut in two.
pub fn split_by_interval(
    data: &Dataset,
    fraction: f64,
) -> Result<(WindowSet<'_>, WindowSet<'_>), SplitError> {
    if !(fraction.is_finite() && fraction > 0.0 && fraction < 1.0) {
        return Err(SplitError::BadFraction(fraction));
    }
    let intervals = data.interval_count();
    let train_intervals = (fraction * intervals as f64).floor() as usize;
    if train_intervals == 0 || train_intervals >= intervals {
        return Err(SplitError::EmptySide {
            fraction,
            intervals,
            train: train_intervals,
            eval: intervals.saturating_sub(train_intervals),
        });
    }
    let cut = data
        .windows
        .partition_point(|w| w.interval < train_intervals);
    let (train, eval) = data.windows.split_at(cut);
    Ok((
        WindowSet::new(&data.robot, train),
        WindowSet::new(&data.robot, eval),
    ))
}
