//! The commands of a recorded run, held again in their order: a simulated run driven exactly
//! as a real one was (the twin check of `drive sim-fit` compares a twin with its real run on
//! the same commands).

use drive_traits::{Input, InputSampler, Window};

/// Holds recorded commands in their order, one per interval, then again from the first.
///
/// ```
/// use drive_samplers::ReplaySampler;
/// use drive_traits::{Input, InputSampler};
/// let mut s = ReplaySampler::new(vec![Input::new(1.0, 2.0, 0.0), Input::new(-3.0, 3.0, 0.0)]).unwrap();
/// assert_eq!(s.next_input(), Input::new(1.0, 2.0, 0.0));
/// assert_eq!(s.next_input(), Input::new(-3.0, 3.0, 0.0));
/// assert_eq!(s.next_input(), Input::new(1.0, 2.0, 0.0)); // from the first again
/// assert!(ReplaySampler::new(Vec::new()).is_none());
/// ```
#[derive(Debug, Clone)]
pub struct ReplaySampler {
    commands: Vec<Input>,
    next: usize,
}

impl ReplaySampler {
    /// A sampler holding `commands` in turn; `None` when there is none to hold.
    pub fn new(commands: Vec<Input>) -> Option<Self> {
        (!commands.is_empty()).then_some(ReplaySampler { commands, next: 0 })
    }

    /// The command each DRIVE interval of `windows` held, in their order: the last command
    /// of the interval's last window (the input held once a ramp is over).
    ///
    /// ```
    /// use drive_samplers::ReplaySampler;
    /// use drive_traits::{Input, Phase, Pose, Window};
    /// // Two intervals: a ramp to (1, 2) held in a steady window, then a step to (3, 3).
    /// let window = |index, interval, phase, command: Vec<Input>| {
    ///     let n = command.len();
    ///     Window::new(index, interval, phase, command, vec![Input::zeros(); n], vec![Pose::zeros(); n], vec![0.0; n])
    /// };
    /// let (a, b) = (Input::new(1.0, 2.0, 0.0), Input::new(3.0, 3.0, 0.0));
    /// let windows = [
    ///     window(0, 0, Phase::Transient, vec![Input::new(0.5, 1.0, 0.0), a]),
    ///     window(1, 0, Phase::Steady, vec![a, a]),
    ///     window(2, 1, Phase::Transient, vec![b, b]),
    /// ];
    /// assert_eq!(ReplaySampler::interval_commands(&windows), vec![a, b]);
    /// ```
    pub fn interval_commands(windows: &[Window]) -> Vec<Input> {
        let mut out: Vec<(usize, Input)> = Vec::new();
        for w in windows {
            let Some(u) = w.command.last() else { continue };
            match out.last_mut() {
                Some((interval, held)) if *interval == w.interval => *held = *u,
                _ => out.push((w.interval, *u)),
            }
        }
        out.into_iter().map(|(_, u)| u).collect()
    }
}

impl InputSampler for ReplaySampler {
    fn next_input(&mut self) -> Input {
        // `commands` is not empty (`new`).
        let u = self.commands[self.next % self.commands.len()];
        self.next += 1;
        u
    }
}
