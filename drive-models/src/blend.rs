//! A mixture of motion models: models of one robot fitted on different grounds, weighted
//! (a terrain library's blend, issue 61: each model weighed by how likely it made the
//! windows just driven).

use drive_traits::{
    wrap_angle, Input, InvalidPart, MotionError, MotionModel, Pose, PoseCovariance, StartState,
};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Weights below this share of the largest are left out of a prediction (their models are
/// not rolled out).
const NEGLIGIBLE_WEIGHT: f64 = 1e-6;

/// Models of one robot blended by weights: the prediction is the mixture's mean (the
/// weighted mean of the models' poses, the headings averaged as their differences from the
/// first model's), its covariance the mixture's (each model's covariance plus its mean's
/// spread around the blend's, weighted).
///
/// ```
/// use drive_models::{BlendedModel, ComposedModel, DifferentialDrive};
/// use drive_models::powertrain::CommandedPowertrain;
/// use drive_models::slip::NoSlipModel;
/// use drive_traits::{Input, MotionModel, Pose, StartState};
/// let naive = |label: &str, radius: f64| -> std::sync::Arc<dyn MotionModel> {
///     std::sync::Arc::new(ComposedModel {
///         label: label.into(),
///         vehicle: std::sync::Arc::new(DifferentialDrive::new(radius, 0.5)),
///         powertrain: Box::new(CommandedPowertrain),
///         slip: Box::new(NoSlipModel),
///         dt: 0.05,
///     })
/// };
/// // Wheels of 0.1 m and 0.3 m: 1 rad/s moves one 0.1 m/s, the other 0.3 m/s.
/// let blend = BlendedModel::new(vec![naive("small", 0.1), naive("large", 0.3)], vec![3.0, 1.0]).unwrap();
/// let poses = blend.predict(&StartState::at_rest(Pose::zeros()), &[Input::new(1.0, 1.0, 0.0); 21]);
/// // A second at 0.75 x 0.1 + 0.25 x 0.3 = 0.15 m/s.
/// assert!((poses[20].x - 0.15).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BlendedModel {
    /// The models, of one step.
    #[serde(with = "shared_models")]
    pub models: Vec<Arc<dyn MotionModel>>,
    /// Their weights, summing to 1.
    pub weights: Vec<f64>,
}

/// Shared models saved as the models themselves.
mod shared_models {
    use drive_traits::MotionModel;
    use serde::ser::SerializeSeq;
    use serde::{Deserialize, Deserializer, Serializer};
    use std::sync::Arc;

    pub(super) fn serialize<S: Serializer>(
        models: &[Arc<dyn MotionModel>],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(models.len()))?;
        for m in models {
            seq.serialize_element(&**m)?;
        }
        seq.end()
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Vec<Arc<dyn MotionModel>>, D::Error> {
        let models: Vec<Box<dyn MotionModel>> = Vec::deserialize(d)?;
        Ok(models.into_iter().map(Arc::from).collect())
    }
}

impl BlendedModel {
    /// `models` blended by `weights` (non-negative, not all zero; normalised to sum to 1).
    /// `Err` says why not: no model, a weight per model missing, a negative or non-finite
    /// weight, models of different steps.
    pub fn new(models: Vec<Arc<dyn MotionModel>>, weights: Vec<f64>) -> Result<Self, InvalidPart> {
        let mut blend = BlendedModel { models, weights };
        let total: f64 = blend.weights.iter().sum();
        if total.is_finite() && total > 0.0 {
            blend.weights.iter_mut().for_each(|w| *w /= total);
        }
        blend.check()?;
        Ok(blend)
    }

    /// The models taking part in a prediction (weight not negligible) with their weights.
    fn active(&self) -> impl Iterator<Item = (&dyn MotionModel, f64)> {
        let largest = self.weights.iter().copied().fold(0.0, f64::max);
        self.models
            .iter()
            .zip(&self.weights)
            .filter(move |(_, w)| **w > NEGLIGIBLE_WEIGHT * largest)
            .map(|(m, w)| (m.as_ref(), *w))
    }
}

#[typetag::serde(name = "blended")]
impl MotionModel for BlendedModel {
    fn name(&self) -> String {
        let names: Vec<String> = self.models.iter().map(|m| m.name()).collect();
        format!("blend of {}", names.join(", "))
    }

    fn dt(&self) -> f64 {
        self.models.first().map_or(f64::NAN, |m| m.dt())
    }

    fn check(&self) -> Result<(), InvalidPart> {
        let Some(first) = self.models.first() else {
            return Err(InvalidPart::from("a blend of no model".to_string()));
        };
        if self.weights.len() != self.models.len() {
            return Err(InvalidPart::from(format!(
                "{} weights for {} models",
                self.weights.len(),
                self.models.len()
            )));
        }
        if self.weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
            || (self.weights.iter().sum::<f64>() - 1.0).abs() > 1e-9
        {
            return Err(InvalidPart::from(format!(
                "weights {:?} are not non-negative shares summing to 1",
                self.weights
            )));
        }
        for m in &self.models {
            m.check()?;
            if (m.dt() - first.dt()).abs() > 1e-12 * first.dt() {
                return Err(InvalidPart::from(format!(
                    "{} steps {} s, {} {} s: a blend is of models of one step",
                    m.name(),
                    m.dt(),
                    first.name(),
                    first.dt()
                )));
            }
        }
        Ok(())
    }

    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        poses.clear();
        let mut one = Vec::with_capacity(commands.len() + 1);
        let mut reference = Vec::new();
        for (model, w) in self.active() {
            model.predict_into(start, commands, &mut one);
            add_weighted(poses, &mut reference, &one, w);
        }
    }

    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        let mut each = Vec::new();
        for (model, w) in self.active() {
            let (mut p, mut c) = (Vec::new(), Vec::new());
            model.predict_with_covariance_into(start, commands, &mut p, &mut c)?;
            each.push((p, c, w));
        }
        poses.clear();
        let mut reference = Vec::new();
        for (p, _, w) in &each {
            add_weighted(poses, &mut reference, p, *w);
        }
        covariances.clear();
        covariances.resize(poses.len(), PoseCovariance::zeros());
        for (p, c, w) in &each {
            for (k, out) in covariances.iter_mut().enumerate() {
                let d = drive_traits::nalgebra::Vector3::new(
                    p[k].x - poses[k].x,
                    p[k].y - poses[k].y,
                    wrap_angle(p[k].z - poses[k].z),
                );
                *out += *w * (c[k] + d * d.transpose());
            }
        }
        Ok(())
    }
}

/// Adds the poses `one` of a model of weight `w` to the blend `poses` (empty before the
/// first model). Headings are averaged as differences from the first model's, kept in
/// `reference`.
fn add_weighted(poses: &mut Vec<Pose>, reference: &mut Vec<f64>, one: &[Pose], w: f64) {
    if reference.is_empty() {
        *reference = one.iter().map(|q| q.z).collect();
        poses.clear();
        poses.extend(reference.iter().map(|&z| Pose::new(0.0, 0.0, z)));
    }
    for ((p, q), r) in poses.iter_mut().zip(one).zip(reference.iter()) {
        p.x += w * q.x;
        p.y += w * q.y;
        p.z += w * wrap_angle(q.z - r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straight ahead at `speed` with the heading `yaw` held, its position variance growing
    /// by `var` per step.
    #[derive(Debug, Serialize, Deserialize)]
    struct Straight {
        speed: f64,
        yaw: f64,
        var: f64,
        dt: f64,
    }

    #[typetag::serde(name = "blend-test-straight")]
    impl MotionModel for Straight {
        fn name(&self) -> String {
            format!("straight at {}", self.speed)
        }
        fn dt(&self) -> f64 {
            self.dt
        }
        fn predict_into(&self, _start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
            poses.clear();
            poses.extend(
                (0..commands.len())
                    .map(|k| Pose::new(self.speed * self.dt * k as f64, 0.0, self.yaw)),
            );
        }
        fn predict_with_covariance_into(
            &self,
            start: &StartState,
            commands: &[Input],
            poses: &mut Vec<Pose>,
            covariances: &mut Vec<PoseCovariance>,
        ) -> Result<(), MotionError> {
            self.predict_into(start, commands, poses);
            covariances.clear();
            covariances
                .extend((0..poses.len()).map(|k| PoseCovariance::identity() * self.var * k as f64));
            Ok(())
        }
    }

    fn straight(speed: f64, yaw: f64) -> Arc<dyn MotionModel> {
        Arc::new(Straight {
            speed,
            yaw,
            var: 0.01,
            dt: 0.05,
        })
    }

    #[test]
    fn the_blend_is_the_mixture_mean_and_covariance_across_the_heading_wrap() {
        let blend = BlendedModel::new(
            vec![straight(1.0, 3.1), straight(3.0, -3.1)],
            vec![1.0, 1.0],
        )
        .unwrap();
        let start = StartState::at_rest(Pose::zeros());
        let (mut poses, mut covs) = (Vec::new(), Vec::new());
        blend
            .predict_with_covariance_into(&start, &[Input::zeros(); 21], &mut poses, &mut covs)
            .unwrap();
        // One second: 1 m and 3 m, blended to 2 m; headings 3.1 and -3.1 meet at pi.
        assert!((poses[20].x - 2.0).abs() < 1e-12);
        assert!(
            (wrap_angle(poses[20].z - std::f64::consts::PI)).abs() < 1e-12,
            "{}",
            poses[20].z
        );
        // Each model's variance (0.2) plus its mean's spread (1 m either way).
        assert!((covs[20][(0, 0)] - 1.2).abs() < 1e-12, "{}", covs[20]);
        assert!((covs[20][(1, 1)] - 0.2).abs() < 1e-12);
        // The headings' spread is 0.0416 rad either way of pi.
        let d = std::f64::consts::PI - 3.1;
        assert!((covs[20][(2, 2)] - (0.2 + d * d)).abs() < 1e-12);
    }

    #[test]
    fn a_blend_serialises_with_its_models() {
        let blend = BlendedModel::new(
            vec![straight(1.0, 0.3), straight(3.0, -1.0)],
            vec![1.0, 3.0],
        )
        .unwrap();
        let text = serde_json::to_string(&blend as &dyn MotionModel).unwrap();
        let back: Box<dyn MotionModel> = serde_json::from_str(&text).unwrap();
        let start = StartState::at_rest(Pose::zeros());
        let commands = [Input::zeros(); 5];
        assert_eq!(
            back.predict(&start, &commands),
            blend.predict(&start, &commands)
        );
        assert!(text.contains("\"type\":\"blended\""), "{text}");
    }

    #[test]
    fn a_model_of_all_the_weight_is_predicted_alone() {
        let (a, b) = (straight(1.0, 0.3), straight(3.0, -1.0));
        let blend = BlendedModel::new(vec![a.clone(), b], vec![1.0, 0.0]).unwrap();
        let start = StartState::at_rest(Pose::zeros());
        let commands = [Input::zeros(); 7];
        assert_eq!(
            blend.predict(&start, &commands),
            a.predict(&start, &commands)
        );
    }

    #[test]
    fn a_blend_that_cannot_be_is_refused_with_the_reason() {
        let no = |models: Vec<Arc<dyn MotionModel>>, weights: Vec<f64>| {
            BlendedModel::new(models, weights).unwrap_err().to_string()
        };
        assert!(no(vec![], vec![]).contains("no model"));
        assert!(no(vec![straight(1.0, 0.0)], vec![1.0, 1.0]).contains("2 weights for 1 models"));
        assert!(no(
            vec![straight(1.0, 0.0), straight(2.0, 0.0)],
            vec![2.0, -1.0]
        )
        .contains("not non-negative"));
        assert!(no(vec![straight(1.0, 0.0)], vec![0.0]).contains("not non-negative"));
        let slow: Arc<dyn MotionModel> = Arc::new(Straight {
            speed: 1.0,
            yaw: 0.0,
            var: 0.0,
            dt: 0.1,
        });
        assert!(no(vec![straight(1.0, 0.0), slow], vec![1.0, 1.0])
            .contains("a blend is of models of one step"));
    }
}
