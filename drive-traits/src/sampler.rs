use crate::Input;

/// A sampler of protocol inputs: each call draws the input held for the next DRIVE
/// interval. Implementations are seeded at construction and deterministic.
pub trait InputSampler {
    /// The next input to hold.
    fn next_input(&mut self) -> Input;
}
