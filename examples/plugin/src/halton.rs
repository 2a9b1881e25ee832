//! A sampler: the Halton sequence (bases 2 and 3) over the input space, a low-discrepancy
//! design; the seed skips into the sequence.

use drive::samplers::{SamplerContext, SamplerError};
use drive::traits::{Input, InputSampler, InputSpace};

/// The `index`-th element of the van der Corput sequence in `base`.
fn radical_inverse(mut index: u64, base: u64) -> f64 {
    let (mut value, mut scale) = (0.0, 1.0 / base as f64);
    while index > 0 {
        value += (index % base) as f64 * scale;
        index /= base;
        scale /= base as f64;
    }
    value
}

/// Halton points over J.
#[derive(Debug)]
pub struct Halton {
    space: InputSpace,
    index: u64,
}

impl InputSampler for Halton {
    fn next_input(&mut self) -> Input {
        self.index += 1;
        let (a, b) = (
            radical_inverse(self.index, 2),
            radical_inverse(self.index, 3),
        );
        self.space.min + (self.space.max - self.space.min).component_mul(&Input::new(a, b, 0.0))
    }
}

/// What the sampler registry holds.
pub fn make(ctx: &SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError> {
    Ok(Box::new(Halton {
        space: ctx.space,
        index: ctx.seed % 1_000_003,
    }))
}
