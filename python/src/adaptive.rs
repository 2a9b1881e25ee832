//! `drive.AdaptiveModel`: a fitted model that keeps learning from the windows the robot
//! drives (issue 61; `drive_studies::AdaptiveFit`, docs/adaptation.md).

use crate::args::{dataset_of, type_name};
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
    prior: Py<Model>,
    windows: usize,
}

#[pymethods]
impl AdaptiveModel {
    /// Adapts `prior` (a fitted `drive.Model` composed of a powertrain and a slip model); its
    /// refits are the same model, fitted as `drive adapt` fits them.
    #[new]
    fn new(py: Python<'_>, prior: &Bound<'_, PyAny>) -> PyResult<Self> {
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
        let prior = Py::new(
            py,
            Model {
                model: std::sync::Arc::clone(&model.model),
                robot: model.robot.clone(),
                start: model.start,
                settings: model.settings.clone(),
            },
        )?;
        Ok(AdaptiveModel {
            fit,
            prior,
            windows: 0,
        })
    }

    /// Learns from `data`'s windows (a `drive.Dataset` of the prior's robot: its rate,
    /// window length and vehicle), in their order: each interval is predicted by every
    /// candidate before it is learned from. Data checks are not run here (they need a run's
    /// worth of windows: see `drive.Dataset` and `drive check`).
    fn add(&mut self, py: Python<'_>, data: &Bound<'_, PyAny>) -> PyResult<()> {
        let data = dataset_of(data)?;
        let prior = self.prior.borrow(py);
        let (a, b) = (&prior.robot, &data.inner.robot);
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
        drop(prior);
        for w in &data.inner.windows {
            self.fit.add(w);
            self.windows += 1;
        }
        Ok(())
    }

    /// The adapted model now: the prior itself until a correction or a refit predicts the
    /// windows driven better.
    fn model(&self, py: Python<'_>) -> PyResult<Model> {
        let prior = self.prior.borrow(py);
        let adapted = self.fit.model();
        Ok(Model {
            model: std::sync::Arc::new(adapted) as std::sync::Arc<dyn MotionModel>,
            robot: prior.robot.clone(),
            start: prior.start,
            settings: None,
        })
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
        self.windows
    }

    /// The prior, as given.
    #[getter]
    fn prior(&self, py: Python<'_>) -> Py<Model> {
        self.prior.clone_ref(py)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "AdaptiveModel(prior={}, windows={}, changed={})",
            self.prior.borrow(py).model.name(),
            self.windows,
            if self.fit.changed() { "True" } else { "False" }
        )
    }
}
