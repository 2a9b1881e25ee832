//! Documented bounds on every size that drives memory or run time (rates, window lengths,
//! run lengths, repetitions, resamples, sweep sizes), checked before the work starts, so
//! that a mistyped number is an error naming the flag or field instead of an abort on an
//! impossible allocation or a run that never ends.
//!
//! Each bound is far beyond what the DRIVE protocol needs (20 Hz, 40-sample windows, a
//! 20-minute run); the one a long study could reach, [`MAX_RUN_SAMPLES`], can be raised
//! (`--max-samples`).
//!
//! ```
//! use drive_traits::limits::{at_most, MAX_SEEDS};
//! assert!(at_most("--seeds", 5.0, MAX_SEEDS as f64, "").is_ok());
//! let e = at_most("--seeds", 1e9, MAX_SEEDS as f64, "").unwrap_err();
//! assert_eq!(e.to_string(), "--seeds = 1e9 is more than the limit of 1000");
//! let e = at_most("--max-samples", 20_000_001.0, 2e7, "").unwrap_err();
//! assert_eq!(e.to_string(), "--max-samples = 20000001 is more than the limit of 20000000");
//! ```

use std::fmt;
use thiserror::Error;

/// Highest command and logging rate (Hz) of a robot or a dataset.
pub const MAX_RATE_HZ: f64 = 1000.0;
/// Lowest rate (Hz): a 2 s DRIVE window needs at least two samples.
pub const MIN_RATE_HZ: f64 = 1.0;
/// Most samples in one window (a 2 s window at 50 kHz).
pub const MAX_WINDOW_LEN: usize = 100_000;
/// Most samples (commands or measurements) in one run or schedule: 55 h at 20 Hz, about
/// 2 GB of memory for a simulation (0.5 kB per sample). Raise it with `--max-samples`.
pub const MAX_RUN_SAMPLES: usize = 4_000_000;
/// The most `--max-samples` may raise [`MAX_RUN_SAMPLES`] to: 2 x 10^7 samples (278 h at
/// 20 Hz), about 10 GB of memory and several minutes for a simulation.
pub const MAX_RUN_SAMPLES_CEILING: usize = 20_000_000;
/// Most repetitions (seeds) of a simulated study.
pub const MAX_SEEDS: usize = 1000;
/// Most random draws per region of a study on recorded data.
pub const MAX_DRAWS: usize = 10_000;
/// Most bootstrap resamples.
pub const MAX_RESAMPLES: usize = 1_000_000;
/// Most combinations in one evaluation sweep (`drive matrix`).
pub const MAX_COMBINATIONS: usize = 100_000;

/// Largest magnitude of a measured or commanded value in a dataset or log (m, rad, rad/s,
/// m/s): nothing a ground robot measures comes near it (map coordinates in UTM are below
/// 10^7 m), and squares of values within it stay finite, so that a corrupted number is
/// refused where it is instead of turning an error metric into infinity.
pub const MAX_ABS_MEASUREMENT: f64 = 1e9;

/// Largest magnitude of a time in seconds (a command file's `t`): Unix epoch times (a ROS
/// clock's, 1.7e9 s in 2024) up to the year 2286, where a double still resolves 2 us, a
/// fiftieth of a period at the highest rate ([`MAX_RATE_HZ`]).
pub const MAX_ABS_TIME_S: f64 = 1e10;

/// A size beyond its documented limit.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{what} = {} is more than the limit of {}{hint}", distinct(*.value, *.limit).0, distinct(*.value, *.limit).1)]
pub struct TooLarge {
    /// The flag or field, as the user wrote it (`--seeds`, `rate_hz`).
    pub what: String,
    /// The value asked for.
    pub value: f64,
    /// The limit.
    pub limit: f64,
    /// What to do about it (starts with "; " or is empty).
    pub hint: String,
}

/// The value and the limit as short numbers, or in full when the short forms would look
/// the same (`20000001` against `20000000`, not `2e7` against `2e7`).
fn distinct(value: f64, limit: f64) -> (String, String) {
    let (v, l) = (Short(value).to_string(), Short(limit).to_string());
    if v != l {
        (v, l)
    } else {
        (format!("{value}"), format!("{limit}"))
    }
}

/// `Ok` when `value <= limit`; else an error naming `what` and the limit, with `hint`
/// (e.g. "raise it with --max-samples") after a semicolon.
pub fn at_most(what: &str, value: f64, limit: f64, hint: &str) -> Result<(), TooLarge> {
    if value <= limit {
        return Ok(());
    }
    Err(TooLarge {
        what: what.to_string(),
        value,
        limit,
        hint: if hint.is_empty() {
            String::new()
        } else {
            format!("; {hint}")
        },
    })
}

/// A number at the precision it has (the shortest text that reads back to it), in
/// scientific notation when tiny or huge: for a value refused at a bound, where rounding
/// would hide why (`1.0000001` is not `1`).
///
/// ```
/// use drive_traits::limits::Exact;
/// assert_eq!(Exact(1.0000001).to_string(), "1.0000001");
/// assert_eq!(Exact(1e308).to_string(), "1e308");
/// assert_eq!(Exact(3.5e-5).to_string(), "3.5e-5");
/// assert_eq!(Exact(0.0).to_string(), "0");
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Exact(pub f64);

impl fmt::Display for Exact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v != 0.0 && v.is_finite() && (v.abs() < 1e-4 || v.abs() >= 1e16) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// A number for a message: at most six significant digits, in scientific notation when
/// very large or very small (a mistyped `1e308` is not echoed as 309 digits).
///
/// ```
/// use drive_traits::limits::Short;
/// assert_eq!(Short(1e308).to_string(), "1e308");
/// assert_eq!(Short(0.1 + 0.2).to_string(), "0.3");
/// assert_eq!(Short(-20.0).to_string(), "-20");
/// assert_eq!(Short(123456789.0).to_string(), "1.23457e8");
/// assert_eq!(Short(2.5e-7).to_string(), "2.5e-7");
/// assert_eq!(Short(f64::NAN).to_string(), "NaN");
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Short(pub f64);

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if !x.is_finite() || x == 0.0 {
            return write!(f, "{x}");
        }
        let magnitude = x.abs().log10().floor() as i32;
        if (-4..6).contains(&magnitude) {
            let decimals = (5 - magnitude).max(0) as usize;
            let s = format!("{x:.decimals$}");
            let s = if s.contains('.') {
                s.trim_end_matches('0').trim_end_matches('.')
            } else {
                &s
            };
            write!(f, "{s}")
        } else {
            let s = format!("{x:.5e}");
            let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            write!(f, "{mantissa}e{exponent}")
        }
    }
}

/// Whether a free-text field (a robot's, a terrain's or a dataset's name) holds a character
/// no field of a sidecar, robot or model file may: a control character, or a line or
/// paragraph separator (U+2028, U+2029), which break a table's line as a newline does. One
/// rule for every file the tool writes and reads, so that what one command writes the others
/// read.
///
/// ```
/// use drive_traits::limits::breaks_text;
/// assert!(breaks_text("wet\tgrass"));
/// assert!(breaks_text("grav\u{2028}el"));
/// assert!(!breaks_text("gravel (wet), 2024-08-06"));
/// ```
pub fn breaks_text(text: &str) -> bool {
    text.chars()
        .any(|c| c.is_control() || matches!(c, '\u{2028}' | '\u{2029}'))
}
