//! The commands still inside a powertrain's dead time (eq. 3), kept in a stepped state: a
//! ring of the last `M` commands, `M` the longest whole-sample delay of the axes.

use drive_traits::step::index_of;
use drive_traits::{Input, MAX_INPUTS};

/// The delay line of the axes' whole-sample delays `lags` (one per axis): its state is the
/// ring's head, then the last `M = max(lags)` commands (saturated), three numbers each.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DelayLine {
    lags: [usize; MAX_INPUTS],
    axes: usize,
    len: usize,
}

impl DelayLine {
    /// The delay line of whole-sample delays `lags` (at most [`MAX_INPUTS`] axes).
    pub(crate) fn new(lags: &[usize]) -> Self {
        let mut l = [0; MAX_INPUTS];
        let axes = lags.len().min(MAX_INPUTS);
        l[..axes].copy_from_slice(&lags[..axes]);
        DelayLine {
            lags: l,
            axes,
            len: l.iter().copied().max().unwrap_or(0),
        }
    }

    /// The numbers of its state.
    pub(crate) fn state_len(&self) -> usize {
        1 + MAX_INPUTS * self.len
    }

    /// Writes the state before the first step and returns, per axis, the command delayed by
    /// its lag + 1 samples at step 0 (the powertrain's `older`). The command at sample
    /// `i < 0` is `history[len + i]` saturated by `saturate` where the history reaches,
    /// `initial` before (as a prediction takes every command before the window).
    pub(crate) fn init(
        &self,
        initial: &Input,
        history: &[Input],
        saturate: impl Fn(usize, f64) -> f64,
        state: &mut [f64],
    ) -> [f64; MAX_INPUTS] {
        let reach = history.len() as isize;
        let value = |axis: usize, i: isize| {
            if i >= -reach {
                saturate(axis, history[(reach + i) as usize][axis])
            } else {
                initial[axis]
            }
        };
        state[0] = 0.0;
        let m = self.len as isize;
        for e in 0..self.len {
            for axis in 0..self.axes {
                state[1 + MAX_INPUTS * e + axis] = value(axis, e as isize - m);
            }
        }
        std::array::from_fn(|axis| {
            if axis < self.axes {
                value(axis, -(self.lags[axis] as isize) - 1)
            } else {
                0.0
            }
        })
    }

    /// The longest whole-sample delay (the ring's length) and the lags of axes 0 and 1.
    #[inline]
    pub(crate) fn two_lags(&self) -> (usize, usize, usize) {
        (self.len, self.lags[0], self.lags[1])
    }

    /// [`DelayLine::step`] for two axes (a differential drive's sides, a car's speed and
    /// steering): the delayed commands of axes 0 and 1, `(a, b)` pushed.
    #[inline]
    pub(crate) fn step_two(&self, state: &mut [f64], a: f64, b: f64) -> (f64, f64) {
        let len = self.len;
        if len == 0 {
            return (a, b);
        }
        let head = index_of(state[0], len);
        let delayed = |lag: usize, axis: usize, now: f64, state: &[f64]| {
            if lag == 0 {
                now
            } else {
                // (head - lag) mod len, head < len and 0 < lag <= len: no division.
                let slot = if head >= lag {
                    head - lag
                } else {
                    head + len - lag
                };
                state[1 + MAX_INPUTS * slot + axis]
            }
        };
        let out = (
            delayed(self.lags[0], 0, a, state),
            delayed(self.lags[1], 1, b, state),
        );
        let at = 1 + MAX_INPUTS * head;
        state[at..at + MAX_INPUTS].copy_from_slice(&[a, b, 0.0]);
        state[0] = if head + 1 == len {
            0.0
        } else {
            (head + 1) as f64
        };
        out
    }

    /// Per axis, the command delayed by its lag at this step (`saturated` itself for a lag
    /// of 0), then `saturated` pushed into the line.
    #[inline]
    pub(crate) fn step(
        &self,
        state: &mut [f64],
        saturated: &[f64; MAX_INPUTS],
    ) -> [f64; MAX_INPUTS] {
        if self.len == 0 {
            return *saturated;
        }
        let head = index_of(state[0], self.len);
        let mut newer = *saturated;
        for (axis, v) in newer.iter_mut().enumerate().take(self.axes) {
            let lag = self.lags[axis];
            if lag > 0 {
                // (head - lag) mod len, head < len and 0 < lag <= len: no division.
                let slot = if head >= lag {
                    head - lag
                } else {
                    head + self.len - lag
                };
                *v = state[1 + MAX_INPUTS * slot + axis];
            }
        }
        let at = 1 + MAX_INPUTS * head;
        state[at..at + MAX_INPUTS].copy_from_slice(saturated);
        state[0] = if head + 1 == self.len {
            0.0
        } else {
            (head + 1) as f64
        };
        newer
    }
}
