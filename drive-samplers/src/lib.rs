//! Input-space samplers of the DRIVE protocol (Sec. III-A): each draws the input held for
//! the next 6 s training interval. All are seeded and deterministic: a seed gives the same
//! sequence on every platform (the generator is xoshiro256++, a fixed algorithm).

#![warn(missing_docs)]

mod uniform;

pub use uniform::{SamplerError, UniformSampler};
