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
        write!(f, "two [min, max] pairs")
    }
}

fn exact<E: Error, const N: usize>(v: Vec<f64>) -> Result<[f64; N], E> {
    let n = v.len();
    <[f64; N]>::try_from(v).map_err(|_| E::invalid_length(n, &Count(N)))
}

fn pairs<E: Error>(v: Vec<Vec<f64>>) -> Result<[[f64; 2]; 2], E> {
    let n = v.len();
    let rows: Vec<[f64; 2]> = v.into_iter().map(exact::<E, 2>).collect::<Result<_, _>>()?;
    <[[f64; 2]; 2]>::try_from(rows).map_err(|_| E::invalid_length(n, &Pairs))
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

/// Exactly two `[min, max]` pairs.
pub fn min_max_pairs<'de, D: Deserializer<'de>>(d: D) -> Result<[[f64; 2]; 2], D::Error> {
    pairs(Vec::<Vec<f64>>::deserialize(d)?)
}

/// Exactly two `[min, max]` pairs, for an optional field (give it `#[serde(default)]`
/// too).
pub fn option_min_max_pairs<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<[[f64; 2]; 2]>, D::Error> {
    Option::<Vec<Vec<f64>>>::deserialize(d)?
        .map(pairs)
        .transpose()
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
