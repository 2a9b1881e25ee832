//! `drive.AdaptiveModel`: a fitted model that keeps learning from the windows the robot
//! drives (issue 61; `drive_studies::AdaptiveFit`, docs/adaptation.md).

use crate::args::{dataset_of, path_of, type_name};
use crate::err;
use crate::model::Model;
use drive::models::adapt::{composed_of, AdapterConfig};
use drive::models::calibration::Uncertainty;
use drive::studies::AdaptiveFit;
use drive::traits::MotionModel;
use pyo3::prelude::*;

/// A fitted model adapting to the ground it drives on: `add` the windows just driven (a
/// `drive.Dataset`, in time order); `model()` is the adapted model (a `drive.Model` that
/// predicts, steps and saves like any), the prior itself until the windows driven show a
/// correction of its slip, or a refit of the same model on them, predicts better
/// (`changed`). The prior is a composed model (`drive.fit`, `drive.load_model`: slip-BLR,
/// slip-ipem, the powertrain model, a plug-in's learner) of the same robot as the data.
/// `save(path)` writes the whole adaptive state, `AdaptiveModel.load(path)` reads it back to
/// adapt on.
///
/// ```python
/// prior = drive.fit(drive.load_dataset("bundled:warthog_asphalt_a"), "slip-blr")
/// adaptive = drive.AdaptiveModel(prior)
/// adaptive.add(windows_just_driven)   # a drive.Dataset of the same robot
/// adaptive.model().predict(...)
/// ```
#[pyclass(module = "drive._native", unsendable)]
pub(crate) struct AdaptiveModel {
    fit: AdaptiveFit,
}

impl AdaptiveModel {
    fn model_of(&self, model: std::sync::Arc<dyn MotionModel>) -> Model {
        Model {
            model,
            robot: self.fit.robot().clone(),
            start: self.fit.start(),
            settings: None,
        }
    }
}

#[pymethods]
impl AdaptiveModel {
    /// Adapts `prior` (a fitted `drive.Model` composed of a powertrain and a slip model); its
    /// refits are the same model, fitted as `drive adapt` fits them.
    #[new]
    fn new(prior: &Bound<'_, PyAny>) -> PyResult<Self> {
        let model: PyRef<'_, Model> = prior.extract().map_err(|_| {
            err(format!(
                "prior must be a fitted drive.Model (drive.fit, drive.load_model), got {}",
                type_name(prior)
            ))
        })?;
        let composed = composed_of(model.model.as_ref()).ok_or_else(|| {
            err(format!(
                "{}: only a model composed of a powertrain and a slip model adapts",
                model.model.name()
            ))
        })?;
        let spec = crate::registries()
            .models()
            .resolve(&model.model.name())
            .map_err(|e| err(format!("refitting {}: {e}", model.model.name())))?;
        let spec = spec.with_uncertainty(Uncertainty::Paper, model.start);
        let fit = AdaptiveFit::new(
            composed,
            &spec,
            &model.robot,
            AdapterConfig {
                start: model.start,
                ..AdapterConfig::default()
            },
        );
        Ok(AdaptiveModel { fit })
    }

    /// Learns from `data`'s windows (a `drive.Dataset` of the prior's robot: its rate,
    /// window length and vehicle), in their order: each interval is predicted by every
    /// candidate before it is learned from. Data checks are not run here (they need a run's
    /// worth of windows: see `drive.Dataset` and `drive check`).
    fn add(&mut self, data: &Bound<'_, PyAny>) -> PyResult<()> {
        let data = dataset_of(data)?;
        let (a, b) = (self.fit.robot(), &data.inner.robot);
        if a.rate_hz != b.rate_hz || a.window_len != b.window_len {
            return Err(err(format!(
                "the data is {} Hz x {} samples per window, the prior's model {} Hz x {}",
                b.rate_hz, b.window_len, a.rate_hz, a.window_len
            )));
        }
        let json =
            |v: &dyn drive::traits::CommandModel| serde_json::to_string(v).unwrap_or_default();
        if json(a.vehicle.as_ref()) != json(b.vehicle.as_ref()) {
            return Err(err(format!(
                "the data's vehicle ({}) is not the prior's ({}): adaptation follows a change of ground, not of vehicle",
                json(b.vehicle.as_ref()),
                json(a.vehicle.as_ref())
            )));
        }
        for w in &data.inner.windows {
            self.fit.add(w);
        }
        Ok(())
    }

    /// The adapted model now: the prior itself until a correction or a refit predicts the
    /// windows driven better.
    fn model(&self) -> Model {
        self.model_of(std::sync::Arc::new(self.fit.model()))
    }

    /// The detector of a change of ground: whether a correction of the prior's slip, or a
    /// refit, predicts the windows driven better than the prior (`drive adapt`'s
    /// `ground_changed`).
    #[getter]
    fn changed(&self) -> bool {
        self.fit.changed()
    }

    /// The windows added so far.
    #[getter]
    fn windows(&self) -> usize {
        self.fit.windows()
    }

    /// The prior, as given (its composed model: a calibrated prior's calibration is not
    /// kept).
    #[getter]
    fn prior(&self) -> Model {
        self.model_of(std::sync::Arc::new(self.fit.prior().clone()))
    }

    /// Writes the whole adaptive state (JSON, format `drive-adaptive-state`): the prior, the
    /// correction's sums, the windows kept for the refits and the refit.
    fn save(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = path_of("path", path)?;
        drive::data::output_names::refused_name(
            &path,
            "an adaptive state (JSON)",
            drive::data::output_names::DATA_NAMES,
            false,
        )
        .map_err(err)?;
        let text = self.fit.save().map_err(err)?;
        std::fs::write(&path, text)
            .map_err(|e| err(format!("{}: cannot write: {e}", path.display())))
    }

    /// An adaptive model from its saved state (`save`), to adapt on as the one saved.
    #[staticmethod]
    fn load(path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let path = path_of("path", path)?;
        let name = path.display().to_string();
        let text = drive::traits::files::read_text(&path, drive::studies::MAX_ADAPTIVE_STATE_BYTES)
            .map_err(|e| err(format!("reading {name}: {e}")))?;
        let fit = AdaptiveFit::load(&text, crate::registries())
            .map_err(|e| err(format!("{name}: {e}")))?;
        Ok(AdaptiveModel { fit })
    }

    fn __repr__(&self) -> String {
        format!(
            "AdaptiveModel(prior={}, windows={}, changed={})",
            self.fit.prior().name(),
            self.fit.windows(),
            if self.fit.changed() { "True" } else { "False" }
        )
    }
}
