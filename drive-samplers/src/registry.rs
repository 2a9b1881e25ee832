//! Samplers by name: [`builtin_samplers`] holds the project's; a researcher's own sampler is
//! one [`Registry::register`] call away from every experiment that takes the registry.

use crate::{
    AngularSampler, GridSampler, LinearSampler, RobotSpec, SamplerError, TargetedSampler,
    UniformSampler,
};
use drive_traits::{InputSampler, InputSpace, Registry, RegistryItem, SlipLeverage};
use std::sync::Arc;

/// What a sampler is built from.
#[derive(Debug, Clone)]
pub struct SamplerContext<'a> {
    /// The input space to sample (the characterized one during a protocol run).
    pub space: InputSpace,
    /// The robot (vehicle, rate, controller limits, acceleration limits).
    pub robot: &'a RobotSpec,
    /// Seed of the sampler.
    pub seed: u64,
}

impl<'a> SamplerContext<'a> {
    /// A context over the robot's input space.
    pub fn new(robot: &'a RobotSpec, seed: u64) -> Self {
        SamplerContext {
            space: robot.input_space(),
            robot,
            seed,
        }
    }

    /// The same context over another input space (the one the characterization found).
    pub fn over(mut self, space: InputSpace) -> Self {
        self.space = space;
        self
    }
}

/// Builds a seeded sampler from a context: what the sampler registry holds. Implemented for
/// every function or closure `Fn(&SamplerContext) -> Result<Box<dyn InputSampler>,
/// SamplerError>`.
///
/// ```
/// use drive_samplers::{builtin_robots, builtin_samplers, build_sampler, SamplerContext, UniformSampler};
/// use std::sync::Arc;
/// let mut samplers = builtin_samplers(Arc::new(drive_models::slip::SlipBlrLeverage::default()));
/// // A researcher's sampler: uniform over the forward half of the input space only.
/// samplers
///     .register("forward-half", "uniform over the forward half of J", Arc::new(|ctx: &SamplerContext<'_>| {
///         let mut space = ctx.space;
///         space.min.x = space.min.x.max(0.0);
///         space.min.y = space.min.y.max(0.0);
///         Ok(Box::new(UniformSampler::new(space, ctx.seed)?) as Box<dyn drive_traits::InputSampler>)
///     }))
///     .unwrap();
/// let husky = builtin_robots().get("husky").unwrap().part().as_ref().clone();
/// let mut sampler = build_sampler(&samplers, "forward-half", &SamplerContext::new(&husky, 1)).unwrap();
/// let u = sampler.next_input();
/// assert!(u.x >= 0.0 && u.y >= 0.0);
/// assert!(build_sampler(&samplers, "nope", &SamplerContext::new(&husky, 1)).is_err());
/// ```
pub trait MakeSampler: Send + Sync {
    /// A sampler for this context.
    fn make(&self, ctx: &SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError>;
}

impl<F> MakeSampler for F
where
    F: Fn(&SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError> + Send + Sync,
{
    fn make(&self, ctx: &SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError> {
        self(ctx)
    }
}

impl RegistryItem for dyn MakeSampler {}

/// Builds the sampler registered as `name` in `samplers`.
pub fn build_sampler(
    samplers: &Registry<dyn MakeSampler>,
    name: &str,
    ctx: &SamplerContext<'_>,
) -> Result<Box<dyn InputSampler>, SamplerError> {
    samplers.get(name)?.part().make(ctx)
}

/// The uniform sampler of DRIVE, with the controller's body-velocity limits when the robot
/// has them (draws beyond them are redrawn).
fn uniform(ctx: &SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError> {
    let s = UniformSampler::new(ctx.space, ctx.seed)?;
    Ok(match ctx.robot.body_limits() {
        None => Box::new(s),
        Some(limits) => Box::new(s.with_body_limits(limits)?),
    })
}

/// The project's samplers: `uniform` (DRIVE), `grid`, `linear`, `angular`, `targeted`
/// (largest uncertainty of the slip model `slip`; the project's is the paper's slip-BLR,
/// `drive_models::slip::SlipBlrLeverage`) and `targeted-coverage` (farthest from the inputs
/// held). Samplers fit no model themselves: `targeted` asks `slip`.
pub fn builtin_samplers(slip: Arc<dyn SlipLeverage>) -> Registry<dyn MakeSampler> {
    let mut r: Registry<dyn MakeSampler> = Registry::new("sampler");
    let parts: [(&str, &str, Arc<dyn MakeSampler>); 6] = [
        (
            "uniform",
            "DRIVE: uniform over the input space J, within the controller's limits (Sec. III-A)",
            Arc::new(uniform),
        ),
        (
            "grid",
            "a regular grid of 10 points per input axis over J, visited in a seeded random order",
            Arc::new(|c: &SamplerContext<'_>| {
                Ok(Box::new(GridSampler::new(c.space, 10, c.seed)?) as Box<dyn InputSampler>)
            }),
        ),
        (
            "linear",
            "human-like, linear-focused: mostly forward at 30-100% of the top speed, small turns",
            Arc::new(|c: &SamplerContext<'_>| {
                let sampler = LinearSampler::new(c.space, Arc::clone(&c.robot.vehicle), c.seed)
                    .with_body_limits(c.robot.body_limits());
                sampler.check()?;
                Ok(Box::new(sampler) as Box<dyn InputSampler>)
            }),
        ),
        (
            "angular",
            "human-like, angular-focused: half the top speed with a varying curvature",
            Arc::new(|c: &SamplerContext<'_>| {
                let sampler = AngularSampler::new(c.space, Arc::clone(&c.robot.vehicle), c.seed)
                    .with_body_limits(c.robot.body_limits());
                sampler.check()?;
                Ok(Box::new(sampler) as Box<dyn InputSampler>)
            }),
        ),
        (
            "targeted",
            "the input where the slip-BLR fitted so far is least sure of the slip, among 64 uniform candidates",
            Arc::new(move |c: &SamplerContext<'_>| {
                Ok(Box::new(TargetedSampler::slip_variance(
                    c.space,
                    uniform(c)?,
                    Arc::clone(&slip),
                )) as Box<dyn InputSampler>)
            }),
        ),
        (
            "targeted-coverage",
            "the uniform candidate farthest from every input held so far (maximin design over J)",
            Arc::new(|c: &SamplerContext<'_>| {
                Ok(Box::new(TargetedSampler::coverage(c.space, uniform(c)?)) as Box<dyn InputSampler>)
            }),
        ),
    ];
    for (name, description, part) in parts {
        // Distinct built-in names.
        r.register_trusted(name, description, part)
            .expect("distinct built-in samplers");
    }
    r
}
