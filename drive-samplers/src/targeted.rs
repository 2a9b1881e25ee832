//! The targeted sampler: the paper's future work (Sec. V) made a sampler. It draws the
//! next input from what the protocol has measured so far instead of blindly.

use std::sync::Arc;

use drive_traits::{
    Input, InputSampler, InputSpace, RobotDescription, SlipLeverage, Window, WindowSet,
    WINDOWS_PER_INTERVAL,
};

/// What a [`TargetedSampler`] aims at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// The input where the slip model fitted on the intervals so far is least sure of the
    /// slip: the largest weight-uncertainty share of eq. 7's predictive variance (a
    /// [`SlipLeverage`]; the paper's slip-BLR is `drive_models::slip::SlipBlrLeverage`).
    SlipVariance,
    /// The least-covered input: the candidate farthest from every input already held,
    /// distances measured in J scaled to a unit square (a maximin space-filling design).
    Coverage,
}

/// A sampler that picks, among `candidates` inputs drawn from a base sampler (uniform over
/// J, with the controller limits), the one that best serves its [`Target`].
///
/// Aiming at the slip's variance ([`TargetedSampler::slip_variance`]), the first `warmup`
/// intervals are the base sampler's draws (there is no model yet); afterwards the slip model
/// is refitted on every interval seen (the runner passes them through
/// [`InputSampler::observe`]) before each draw. When the fit fails (too little or
/// degenerate data), that draw falls back to [`Target::Coverage`].
///
/// ```
/// use drive_samplers::{Target, TargetedSampler, UniformSampler};
/// use drive_traits::{Input, InputSampler, InputSpace};
/// let j = InputSpace::new(Input::new(-1.0, -1.0, 0.0), Input::new(1.0, 1.0, 0.0)).unwrap();
/// let base = Box::new(UniformSampler::new(j, 7).unwrap());
/// let mut s = TargetedSampler::coverage(j, base);
/// assert_eq!(s.target(), Target::Coverage);
/// let inputs: Vec<Input> = (0..4).map(|_| s.next_input()).collect();
/// // Every new input keeps its distance from the earlier ones.
/// for (i, a) in inputs.iter().enumerate() {
///     for b in &inputs[..i] {
///         assert!((a - b).norm() > 0.3);
///     }
/// }
/// ```
pub struct TargetedSampler {
    space: InputSpace,
    base: Box<dyn InputSampler>,
    target: Target,
    /// The slip model's uncertainty, aiming at [`Target::SlipVariance`].
    leverage: Option<Arc<dyn SlipLeverage>>,
    candidates: usize,
    warmup: usize,
    robot: Option<RobotDescription>,
    seen: Vec<Window>,
    held: Vec<Input>,
}

impl std::fmt::Debug for TargetedSampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TargetedSampler")
            .field("target", &self.target)
            .field("candidates", &self.candidates)
            .field("warmup", &self.warmup)
            .field("held", &self.held.len())
            .finish()
    }
}

impl TargetedSampler {
    /// Aiming at [`Target::SlipVariance`] with the slip model `leverage` over J = `space`,
    /// choosing among 64 candidates from `base` per draw, after 2 warm-up intervals.
    pub fn slip_variance(
        space: InputSpace,
        base: Box<dyn InputSampler>,
        leverage: Arc<dyn SlipLeverage>,
    ) -> Self {
        Self::new(space, base, Target::SlipVariance, Some(leverage))
    }

    /// Aiming at [`Target::Coverage`] over J = `space`, choosing among 64 candidates from
    /// `base` per draw.
    pub fn coverage(space: InputSpace, base: Box<dyn InputSampler>) -> Self {
        Self::new(space, base, Target::Coverage, None)
    }

    fn new(
        space: InputSpace,
        base: Box<dyn InputSampler>,
        target: Target,
        leverage: Option<Arc<dyn SlipLeverage>>,
    ) -> Self {
        TargetedSampler {
            space,
            base,
            target,
            leverage,
            candidates: 64,
            warmup: 2,
            robot: None,
            seen: Vec::new(),
            held: Vec::new(),
        }
    }

    /// What it aims at.
    pub fn target(&self) -> Target {
        self.target
    }

    /// The number of candidates per draw (at least 1).
    pub fn with_candidates(mut self, n: usize) -> Self {
        self.candidates = n.max(1);
        self
    }

    /// The number of intervals drawn from the base sampler before the model steers.
    pub fn with_warmup(mut self, intervals: usize) -> Self {
        self.warmup = intervals;
        self
    }

    /// Distance in J scaled to the unit square from `u` to the nearest input held so far.
    fn gap(&self, u: &Input) -> f64 {
        let extent = self.space.scale();
        self.held
            .iter()
            .map(|h| (u - h).component_div(&extent).norm())
            .fold(f64::INFINITY, f64::min)
    }

    /// Scores of the candidates under the slip model fitted so far, or `None` when there is
    /// no model yet.
    fn slip_scores(&self, candidates: &[Input]) -> Option<Vec<f64>> {
        let robot = self.robot.as_ref()?;
        let leverage = self.leverage.as_ref()?;
        let set = WindowSet {
            robot,
            windows: self.seen.iter().collect(),
        };
        // The slip inputs of a candidate held steadily are those of its commanded body
        // velocity.
        let at: Vec<_> = candidates
            .iter()
            .map(|u| robot.vehicle.body_velocity(u))
            .collect();
        let scores = leverage.leverage(&set, &at)?;
        (scores.len() == candidates.len() && scores.iter().all(|s| s.is_finite())).then_some(scores)
    }
}

impl InputSampler for TargetedSampler {
    fn learns_from_windows(&self) -> bool {
        self.target == Target::SlipVariance
    }

    fn next_input(&mut self) -> Input {
        let warming_up = match self.target {
            Target::SlipVariance => self.seen.len() < WINDOWS_PER_INTERVAL * self.warmup,
            Target::Coverage => self.held.is_empty(),
        };
        // While warming up, exactly the base sampler's sequence.
        let n = if warming_up { 1 } else { self.candidates };
        let candidates: Vec<Input> = (0..n).map(|_| self.base.next_input()).collect();
        let best = if warming_up {
            0
        } else {
            let scores = match self.target {
                Target::SlipVariance => self.slip_scores(&candidates),
                Target::Coverage => None,
            }
            .unwrap_or_else(|| candidates.iter().map(|u| self.gap(u)).collect());
            // The first of the best scores: deterministic for a seed.
            (0..candidates.len()).fold(0, |best, i| if scores[i] > scores[best] { i } else { best })
        };
        let u = candidates[best];
        self.held.push(u);
        u
    }

    fn observe(&mut self, robot: &RobotDescription, interval: &[Window]) {
        if self.robot.is_none() {
            self.robot = Some(robot.clone());
        }
        self.seen.extend_from_slice(interval);
    }
}
