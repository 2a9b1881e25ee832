//! The one place where sampler names map to samplers. [`SamplerRegistry::builtin`] holds the
//! project's samplers; a researcher's own sampler is one [`SamplerRegistry::register`] call
//! away from every simulated experiment that takes a registry.

use crate::{
    AngularSampler, BodyLimits, GridSampler, LinearSampler, RobotSpec, SamplerError, Target,
    TargetedSampler, UniformSampler,
};
use drive_traits::{CommandModel, InputSampler, InputSpace};
use std::sync::Arc;

/// What a sampler is built from.
pub struct SamplerContext<'a> {
    /// The input space to sample (the characterized one during a protocol run).
    pub space: InputSpace,
    /// The robot (rate, controller limits, acceleration limits).
    pub robot: &'a RobotSpec,
    /// Makes the vehicle's command model (inputs to body velocities and back).
    pub vehicle: &'a dyn Fn() -> Box<dyn CommandModel>,
    /// Seed of the sampler.
    pub seed: u64,
}

type MakeFn =
    dyn Fn(&SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError> + Send + Sync;

/// Samplers by name, in registration order.
///
/// ```
/// use drive_samplers::{RobotSpec, SamplerContext, SamplerRegistry, UniformSampler};
/// use drive_models::DifferentialDrive;
/// use drive_traits::CommandModel;
/// let mut registry = SamplerRegistry::builtin();
/// // A researcher's sampler: uniform over the forward half of the input space only.
/// registry
///     .register("forward-half", |ctx: &SamplerContext<'_>| {
///         let mut space = ctx.space;
///         space.min.x = space.min.x.max(0.0);
///         space.min.y = space.min.y.max(0.0);
///         Ok(Box::new(UniformSampler::new(space, ctx.seed)?))
///     })
///     .unwrap();
/// let robot = RobotSpec::preset("husky").unwrap();
/// let vehicle = || Box::new(DifferentialDrive::new(0.165, 0.555)) as Box<dyn CommandModel>;
/// let ctx = SamplerContext { space: robot.input_space(), robot: &robot, vehicle: &vehicle, seed: 1 };
/// let mut sampler = registry.build("forward-half", &ctx).unwrap();
/// let u = sampler.next_input();
/// assert!(u.x >= 0.0 && u.y >= 0.0);
/// assert!(registry.build("nope", &ctx).is_err());
/// ```
#[derive(Clone, Default)]
pub struct SamplerRegistry {
    entries: Vec<(String, Arc<MakeFn>)>,
}

impl std::fmt::Debug for SamplerRegistry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.names()).finish()
    }
}

/// The uniform sampler of DRIVE, with the controller's body-velocity limits when the robot
/// has them (draws beyond them are redrawn).
fn uniform(ctx: &SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError> {
    let s = UniformSampler::new(ctx.space, ctx.seed)?;
    let robot = ctx.robot;
    Ok(
        match (robot.controller_max_linear, robot.controller_max_angular) {
            (None, None) => Box::new(s),
            (lin, ang) => Box::new(s.with_body_limits(BodyLimits {
                vehicle: (ctx.vehicle)(),
                max_linear: lin.unwrap_or(f64::INFINITY),
                max_angular: ang.unwrap_or(f64::INFINITY),
            })?),
        },
    )
}

impl SamplerRegistry {
    /// A registry with no sampler.
    pub fn empty() -> Self {
        Self::default()
    }

    /// The project's samplers ([`crate::SAMPLER_NAMES`]): `uniform` (DRIVE), `grid`,
    /// `linear`, `angular`, `targeted` (largest slip-BLR uncertainty) and
    /// `targeted-coverage` (farthest from the inputs held).
    pub fn builtin() -> Self {
        let mut r = Self::empty();
        let fresh = "the built-in names are distinct";
        r.register("uniform", uniform).expect(fresh);
        r.register("grid", |c: &SamplerContext<'_>| {
            Ok(Box::new(GridSampler::new(c.space, 10, c.seed)?))
        })
        .expect(fresh);
        r.register("linear", |c: &SamplerContext<'_>| {
            Ok(Box::new(LinearSampler::new(c.space, (c.vehicle)(), c.seed)))
        })
        .expect(fresh);
        r.register("angular", |c: &SamplerContext<'_>| {
            Ok(Box::new(AngularSampler::new(
                c.space,
                (c.vehicle)(),
                c.seed,
            )))
        })
        .expect(fresh);
        r.register("targeted", |c: &SamplerContext<'_>| {
            Ok(Box::new(TargetedSampler::new(
                c.space,
                uniform(c)?,
                Target::SlipVariance,
            )))
        })
        .expect(fresh);
        r.register("targeted-coverage", |c: &SamplerContext<'_>| {
            Ok(Box::new(TargetedSampler::new(
                c.space,
                uniform(c)?,
                Target::Coverage,
            )))
        })
        .expect(fresh);
        r
    }

    /// Registers a sampler under `name`; refused (with the name back) when the name is
    /// empty or taken.
    pub fn register<F>(&mut self, name: &str, make: F) -> Result<&mut Self, String>
    where
        F: Fn(&SamplerContext<'_>) -> Result<Box<dyn InputSampler>, SamplerError>
            + Send
            + Sync
            + 'static,
    {
        if name.is_empty() || self.contains(name) {
            return Err(name.to_string());
        }
        self.entries.push((name.to_string(), Arc::new(make)));
        Ok(self)
    }

    /// Whether `name` is registered.
    pub fn contains(&self, name: &str) -> bool {
        self.entries.iter().any(|(n, _)| n == name)
    }

    /// The registered names, in registration order.
    pub fn names(&self) -> Vec<&str> {
        self.entries.iter().map(|(n, _)| n.as_str()).collect()
    }

    /// Builds the sampler registered under `name`.
    pub fn build(
        &self,
        name: &str,
        ctx: &SamplerContext<'_>,
    ) -> Result<Box<dyn InputSampler>, SamplerError> {
        let (_, make) = self
            .entries
            .iter()
            .find(|(n, _)| n == name)
            .ok_or_else(|| SamplerError::Unknown {
                name: name.to_string(),
                known: self.names().join(", "),
            })?;
        make(ctx)
    }
}
