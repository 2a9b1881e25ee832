//! Reading files strictly: fixed-length arrays (`#[serde(deserialize_with = ...)]`, a list
//! with more numbers than the field holds is refused, not cut short) and one-line parse
//! errors ([`parse_message`]).
//!
//! ```
//! #[derive(serde::Deserialize)]
//! struct Mount {
//!     #[serde(deserialize_with = "drive_traits::exact::array")]
//!     at: [f64; 3],
//! }
//! assert!(serde_json::from_str::<Mount>(r#"{"at": [1, 2, 3]}"#).is_ok());
//! let e = serde_json::from_str::<Mount>(r#"{"at": [1, 2, 3, 4]}"#).err().unwrap();
//! assert!(e.to_string().contains("invalid length 4, expected 3 numbers"));
//! ```

use serde::de::{Deserialize, Deserializer, Error};

struct Count(usize);

impl serde::de::Expected for Count {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} numbers", self.0)
    }
}

struct Pairs;

impl serde::de::Expected for Pairs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "one [min, max] pair per input axis (2 or 3)")
    }
}

fn exact<E: Error, const N: usize>(v: Vec<f64>) -> Result<[f64; N], E> {
    let n = v.len();
    <[f64; N]>::try_from(v).map_err(|_| E::invalid_length(n, &Count(N)))
}

fn pairs<E: Error>(v: Vec<Vec<f64>>) -> Result<Vec<[f64; 2]>, E> {
    let n = v.len();
    if !(2..=crate::MAX_INPUTS).contains(&n) {
        return Err(E::invalid_length(n, &Pairs));
    }
    v.into_iter().map(exact::<E, 2>).collect()
}

struct Axes;

impl serde::de::Expected for Axes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "one number per input axis (2 or 3)")
    }
}

fn axes<E: Error>(v: Vec<f64>) -> Result<Vec<f64>, E> {
    if !(2..=crate::MAX_INPUTS).contains(&v.len()) {
        return Err(E::invalid_length(v.len(), &Axes));
    }
    Ok(v)
}

/// Exactly `N` numbers.
pub fn array<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
    exact(Vec::<f64>::deserialize(d)?)
}

/// Exactly `N` numbers, for an optional field (give it `#[serde(default)]` too).
pub fn option_array<'de, D: Deserializer<'de>, const N: usize>(
    d: D,
) -> Result<Option<[f64; N]>, D::Error> {
    Option::<Vec<f64>>::deserialize(d)?.map(exact).transpose()
}

/// One `[min, max]` pair per input axis: two or three ([`MAX_INPUTS`](crate::MAX_INPUTS)).
///
/// ```
/// #[derive(serde::Deserialize)]
/// struct Limits {
///     #[serde(deserialize_with = "drive_traits::exact::min_max_pairs")]
///     input_limits: Vec<[f64; 2]>,
/// }
/// assert!(serde_json::from_str::<Limits>(r#"{"input_limits": [[-1, 1], [-2, 2], [-3, 3]]}"#).is_ok());
/// assert!(serde_json::from_str::<Limits>(r#"{"input_limits": [[-1, 1]]}"#).is_err());
/// assert!(serde_json::from_str::<Limits>(r#"{"input_limits": [[-1, 1, 0], [-2, 2]]}"#).is_err());
/// ```
pub fn min_max_pairs<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<[f64; 2]>, D::Error> {
    pairs(Vec::<Vec<f64>>::deserialize(d)?)
}

/// One `[min, max]` pair per input axis, for an optional field (give it
/// `#[serde(default)]` too).
pub fn option_min_max_pairs<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<Vec<[f64; 2]>>, D::Error> {
    Option::<Vec<Vec<f64>>>::deserialize(d)?
        .map(pairs)
        .transpose()
}

/// One number per input axis (two or three), for an optional field (give it
/// `#[serde(default)]` too).
pub fn option_axes<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<f64>>, D::Error> {
    Option::<Vec<f64>>::deserialize(d)?.map(axes).transpose()
}

/// A parser's `message` about `text` as one line, with the line of the byte `offset` it
/// points at: `message (line N)`.
///
/// ```
/// use drive_traits::exact::parse_message;
/// assert_eq!(parse_message("a = 1\nb = x\n", "invalid string", Some(10)), "invalid string (line 2)");
/// assert_eq!(parse_message("", "empty\n", None), "empty");
/// ```
pub fn parse_message(text: &str, message: &str, offset: Option<usize>) -> String {
    let message = message.trim().replace('\n', " ");
    match offset {
        Some(o) => {
            let line = text[..o.min(text.len())].lines().count().max(1);
            format!("{message} (line {line})")
        }
        None => message,
    }
}
