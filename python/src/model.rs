//! `drive.Model`: a fitted motion model, its predictions (one sequence, or a batch in
//! numpy's buffers), its scores on any dataset, its model file and its pickling.

use crate::args::{
    all_finite, all_finite_parallel, dataset_of, finite, float_array, number_of, numbers_of,
    path_of, type_name, within_readers,
};
use crate::err;
use crate::evaluate::start_info_of;
use drive::eval::split_by_interval;
use drive::models::model_file::{model_file_to_json, read_model_file, CommandRange, FitSettings};
use drive::traits::{
    Input, MotionError, MotionModel, Pose, RobotDescription, StartInfo, StartState,
};
use numpy::{
    IntoPyArray, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// A fitted motion model: predictions from commands, saved as the command line's model file.
#[pyclass(module = "drive._native", frozen)]
pub(crate) struct Model {
    pub(crate) model: std::sync::Arc<dyn MotionModel>,
    pub(crate) robot: RobotDescription,
    /// What the model was fitted to start from (`fit(..., start=)`; a loaded model file's
    /// `fitted_with`, the default for a file without it): what `score` gives it.
    pub(crate) start: StartInfo,
    /// The settings it was fitted with, written into its model file (`None` for a file
    /// written without them).
    pub(crate) settings: Option<FitSettings>,
}

/// Raises each of `notes` as a `UserWarning` (what the command line prints as a note).
pub(crate) fn warn_notes(py: Python<'_>, notes: impl IntoIterator<Item = String>) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for note in notes {
        // A note holds no NUL: numbers, units and the vehicle's column names.
        let message = std::ffi::CString::new(note).unwrap_or_default();
        PyErr::warn(py, &category, &message, 1)?;
    }
    Ok(())
}

impl Model {
    /// What the model knows of its inputs (the notes of a prediction beyond them).
    pub(crate) fn known(&self) -> Option<drive::models::known_inputs::KnownInputs> {
        drive::models::known_inputs::KnownInputs::of(
            self.model.as_ref(),
            self.settings.as_ref(),
            &self.robot,
        )
    }

    fn start(
        &self,
        pose: [f64; 3],
        wheels: Input,
        yaw_rate: Option<f64>,
        velocity: Option<[f64; 2]>,
    ) -> StartState {
        let start = StartState::measured(
            Pose::new(pose[0], pose[1], pose[2]),
            wheels,
            self.robot.vehicle.as_ref(),
        );
        let start = yaw_rate.map_or(start, |w| start.with_yaw_rate(w));
        velocity.map_or(start, |v| start.with_velocity(v))
    }
}

#[pymethods]
impl Model {
    /// The model's name.
    #[getter]
    fn name(&self) -> String {
        self.model.name()
    }

    /// The prediction step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// The vehicle's input axes, in the order of a command's columns (`left [rad/s]`,
    /// `right [rad/s]` for a differential drive).
    #[getter]
    fn inputs(&self) -> Vec<String> {
        self.robot
            .vehicle
            .axes()
            .iter()
            .map(|a| format!("{} [{}]", a.name, a.unit))
            .collect()
    }

    /// The number of input axes D (the width of a command).
    #[getter]
    fn n_inputs(&self) -> usize {
        self.robot.vehicle.input_dim()
    }

    /// Predicted poses (H, 3) for the (H, D) commands (the vehicle's D inputs, one row per
    /// step of `dt` s; D = 2 for a differential drive or a car, 3 for an omnidirectional
    /// base): row k is the pose (x, y, yaw) at time k * dt, so row 0 is the start pose
    /// itself and row k the pose after commands 0..k-1; the last command never changes the
    /// output (for the pose after all H commands, append one more command). The same rows as
    /// the windows' poses in a dataset and as `drive predict`.
    ///
    /// The start: `start` (x, y, yaw; the origin by default), the measured inputs
    /// `start_wheels` (zero by default), the yaw rate the IMU measured, `start_yaw_rate`
    /// (none by default), and the body velocity (x, y; m/s) the localization measured just
    /// before, `start_velocity` (none by default).
    ///
    /// With `return_cov=True`, a pair (poses, covariances): covariances (H, 3, 3) of x, y,
    /// yaw at each row (zero at row 0), for a model with an uncertainty (slip-BLR,
    /// acc-BLR, slip-ipem, calibrated by default); a `DriveError` for one without.
    #[pyo3(signature = (commands, start=None, start_wheels=None, start_yaw_rate=None, start_velocity=None, return_cov=None))]
    #[allow(clippy::too_many_arguments)]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        commands: &Bound<'py, PyAny>,
        start: Option<&Bound<'py, PyAny>>,
        start_wheels: Option<&Bound<'py, PyAny>>,
        start_yaw_rate: Option<&Bound<'py, PyAny>>,
        start_velocity: Option<&Bound<'py, PyAny>>,
        return_cov: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let return_cov = match return_cov.filter(|r| !r.is_none()) {
            None => false,
            // Python's and numpy's booleans.
            Some(r) if matches!(type_name(r).as_str(), "bool" | "bool_") => r.is_truthy()?,
            Some(r) => {
                return Err(err(format!(
                    "return_cov must be True or False, got {}",
                    crate::args::short_repr(r)
                )))
            }
        };
        let velocity: Option<[f64; 2]> = start_velocity
            .filter(|v| !v.is_none())
            .map(|v| numbers_of("start_velocity", Some(v)))
            .transpose()?;
        if let Some(v) = velocity {
            finite("start_velocity", &v)?;
        }
        let start: [f64; 3] = numbers_of("start", start)?;
        let dim = self.robot.vehicle.input_dim();
        let start_wheels = crate::args::input_of("start_wheels", start_wheels, dim)?;
        finite("start_wheels", &start_wheels.as_slice()[..dim])?;
        let yaw_rate = start_yaw_rate
            .filter(|w| !w.is_none())
            .map(|w| number_of("start_yaw_rate", "a number (rad/s)", w))
            .transpose()?;
        let commands = float_array(py, "commands", &format!("(H, {dim})"), commands, 2)?;
        let commands: PyReadonlyArray2<'py, f64> = commands.extract()?;
        let shape = commands.shape();
        if shape.len() != 2 || shape[1] != dim {
            return Err(err(format!(
                "commands must be an (H, {dim}) array (one column per input axis), got shape {shape:?}"
            )));
        }
        let flat: Vec<f64> = commands.as_array().iter().copied().collect();
        finite("commands", &flat)?;
        within_readers("commands", &flat)?;
        finite("start", &start)?;
        within_readers("start", &start)?;
        within_readers("start_wheels", &start_wheels.as_slice()[..dim])?;
        if let Some(w) = yaw_rate {
            finite("start_yaw_rate", &[w])?;
            within_readers("start_yaw_rate", &[w])?;
        }
        if let Some(v) = velocity {
            within_readers("start_velocity", &v)?;
        }
        let start = self.start(start, start_wheels, yaw_rate, velocity);
        let cmds: Vec<Input> = flat.chunks_exact(dim).map(input_of_row).collect();
        // The command line's notes, as warnings: commands or a start beyond what the model
        // knows.
        let known = self.known();
        if let Some(k) = &known {
            let notes = k
                .command_note(&self.robot, cmds.iter().copied())
                .into_iter()
                .chain(k.start_notes(
                    &self.robot,
                    start_wheels,
                    velocity,
                    "start_wheels",
                    "start_velocity",
                ))
                .chain(yaw_rate.and_then(|w| k.yaw_rate_note(&self.robot, w, "start_yaw_rate")));
            warn_notes(py, notes)?;
        }
        let mut poses = Vec::with_capacity(cmds.len());
        let mut covariances = Vec::new();
        if return_cov {
            self.model
                .predict_with_covariance_into(&start, &cmds, &mut poses, &mut covariances)
                .map_err(err)?;
        } else {
            self.model.predict_into(&start, &cmds, &mut poses);
        }
        // Never a non-finite pose or covariance: the command line's refusal.
        if let Some(e) =
            MotionError::not_finite(&self.model.name(), self.model.dt(), &poses, &covariances)
        {
            return Err(err(e));
        }
        if let Some(k) = &known {
            warn_notes(py, k.speed_note(&self.robot, self.model.dt(), &poses))?;
        }
        let out: Vec<f64> = poses.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let poses_array = numpy::ndarray::Array2::from_shape_vec((poses.len(), 3), out)
            .map(|a| a.into_pyarray(py))
            .map_err(err)?;
        if !return_cov {
            return Ok(poses_array.into_any());
        }
        // Row-major 3 x 3 per step (nalgebra stores columns: transpose on the way out).
        let cov: Vec<f64> = covariances
            .iter()
            .flat_map(|c| (0..3).flat_map(move |i| (0..3).map(move |j| c[(i, j)])))
            .collect();
        let cov_array = numpy::ndarray::Array3::from_shape_vec((covariances.len(), 3, 3), cov)
            .map(|a| a.into_pyarray(py))
            .map_err(err)?;
        Ok((poses_array, cov_array).into_pyobject(py)?.into_any())
    }

    /// Poses (B, H, 3) of B command sequences (B, H, D; D inputs per command), each from its
    /// row of `starts` (B, 3; the origin by default), `start_wheels` (B, D; zero by default) and
    /// `start_yaw_rates` (B,; none by default) and `start_velocities` (B, 2; none by
    /// default); computed in parallel without the GIL, read from and written into numpy's
    /// buffers without copies. Row b equals `predict(commands[b], starts[b], ...)`: its
    /// pose k is at time k * dt, pose 0 the start, and each sequence's last command changes
    /// nothing.
    #[pyo3(signature = (commands, starts=None, start_wheels=None, start_yaw_rates=None, start_velocities=None))]
    fn predict_batch<'py>(
        &self,
        py: Python<'py>,
        commands: &Bound<'py, PyAny>,
        starts: Option<&Bound<'py, PyAny>>,
        start_wheels: Option<&Bound<'py, PyAny>>,
        start_yaw_rates: Option<&Bound<'py, PyAny>>,
        start_velocities: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let dim = self.robot.vehicle.input_dim();
        let commands = float_array(py, "commands", &format!("(B, H, {dim})"), commands, 3)?;
        let commands: PyReadonlyArray3<'py, f64> = commands.extract()?;
        let starts = match starts {
            Some(a) => Some(float_array(py, "starts", "(B, 3)", a, 2)?.extract()?),
            None => None,
        };
        let start_wheels = match start_wheels {
            Some(a) => {
                Some(float_array(py, "start_wheels", &format!("(B, {dim})"), a, 2)?.extract()?)
            }
            None => None,
        };
        let start_velocities = match start_velocities.filter(|a| !a.is_none()) {
            Some(a) => Some(float_array(py, "start_velocities", "(B, 2)", a, 2)?.extract()?),
            None => None,
        };
        let shape = commands.shape().to_vec();
        if shape[2] != dim {
            return Err(err(format!(
                "commands must be a (B, H, {dim}) array (one column per input axis), got shape {shape:?}"
            )));
        }
        let (b, h) = (shape[0], shape[1]);
        // The commands in numpy's own buffer (C-contiguous float64, made so by float_array),
        // seen as inputs without a copy: a copy of a large batch costs more in page faults
        // than the rollouts themselves.
        let flat: &[f64] = commands.as_slice().map_err(err)?;
        if !py.detach(|| all_finite_parallel(flat)) {
            finite("commands", flat)?;
        }
        let limit = drive::traits::limits::MAX_ABS_MEASUREMENT;
        if py.detach(|| flat.iter().any(|x| x.abs() > limit)) {
            within_readers("commands", flat)?;
        }
        // The command line's note, as a warning: a command beyond what the model knows (its
        // index counts the commands of every sequence, row by row).
        let known = self.known();
        if let Some(k) = &known {
            let commands = flat.chunks_exact(dim).map(input_of_row);
            warn_notes(py, k.command_note(&self.robot, commands))?;
        }
        let rows = |a: Option<PyReadonlyArray2<'py, f64>>,
                    width: usize,
                    what: &str|
         -> PyResult<Vec<f64>> {
            match a {
                None => Ok(vec![0.0; b * width]),
                Some(a) => {
                    if a.shape() != [b, width] {
                        return Err(err(format!(
                            "{what} must be a ({b}, {width}) array, got shape {:?}",
                            a.shape()
                        )));
                    }
                    let v: Vec<f64> = a.as_array().iter().copied().collect();
                    finite(what, &v)?;
                    within_readers(what, &v)?;
                    Ok(v)
                }
            }
        };
        let poses0 = rows(starts, 3, "starts")?;
        let wheels = rows(start_wheels, dim, "start_wheels")?;
        // A start beyond what the model knows: the first row's note.
        if let Some(k) = &known {
            let beyond = wheels
                .chunks_exact(dim.max(1))
                .position(|w| k.range.beyond(w).is_some());
            if let Some(i) = beyond {
                let w = input_of_row(&wheels[dim * i..dim * (i + 1)]);
                let flag = format!("start_wheels[{i}]");
                warn_notes(py, k.start_notes(&self.robot, w, None, &flag, ""))?;
            }
        }
        let velocities = start_velocities
            .is_some()
            .then(|| rows(start_velocities, 2, "start_velocities"))
            .transpose()?;
        let yaw_rates: Option<Vec<f64>> = match start_yaw_rates.filter(|w| !w.is_none()) {
            None => None,
            Some(a) => {
                let a: PyReadonlyArray1<'py, f64> =
                    float_array(py, "start_yaw_rates", "(B,)", a, 1)?.extract()?;
                if a.shape() != [b] {
                    return Err(err(format!(
                        "start_yaw_rates must be a ({b},) array, got shape {:?}",
                        a.shape()
                    )));
                }
                let v: Vec<f64> = a.as_array().iter().copied().collect();
                finite("start_yaw_rates", &v)?;
                within_readers("start_yaw_rates", &v)?;
                // A yaw rate no data showed: the first row's note.
                if let Some(k) = &known {
                    let flag = |i: usize| format!("start_yaw_rates[{i}]");
                    let note = v
                        .iter()
                        .enumerate()
                        .find_map(|(i, w)| k.yaw_rate_note(&self.robot, *w, &flag(i)));
                    warn_notes(py, note)?;
                }
                Some(v)
            }
        };
        // `Input` is nalgebra's Vector3<f64>: three f64 side by side (bytemuck checks it).
        // A vehicle of three inputs reads numpy's buffer as inputs without a copy; one of
        // two copies each task's rows into inputs (a third axis of zero).
        let whole: Option<&[Input]> = if dim == drive::traits::MAX_INPUTS {
            Some(bytemuck::try_cast_slice(flat).map_err(err)?)
        } else {
            None
        };
        // The poses are written straight into the returned array, allocated without numpy's
        // zeroing (a fresh zeroed block of this size is mapped page by page as it is first
        // written, which costs more than the rollouts): each parallel task zeroes its own
        // rows, builds their starts, rolls them out and checks them.
        let out = unsafe { PyArray3::<f64>::new(py, [b, h, 3], false) };
        let base = out.data() as usize;
        let model = self.model.as_ref();
        let start_of = |i: usize| {
            self.start(
                [poses0[3 * i], poses0[3 * i + 1], poses0[3 * i + 2]],
                input_of_row(&wheels[dim * i..dim * (i + 1)]),
                yaw_rates.as_ref().map(|w| w[i]),
                velocities.as_ref().map(|v| [v[2 * i], v[2 * i + 1]]),
            )
        };
        const CHUNK: usize = 256;
        let all = py
            .detach(|| {
                use rayon::prelude::*;
                (0..b.div_ceil(CHUNK))
                    .into_par_iter()
                    .map(|c| {
                        let rows = c * CHUNK..((c + 1) * CHUNK).min(b);
                        let values = rows.len() * h * 3;
                        // SAFETY: rows `rows` of the new (B, H, 3) float64 array, disjoint from
                        // every other task's, zeroed through a raw pointer before the slice
                        // over them is made; the array is not reachable from Python yet.
                        let buffer: &mut [f64] = unsafe {
                            let ptr = (base as *mut f64).add(rows.start * h * 3);
                            std::ptr::write_bytes(ptr, 0, values);
                            std::slice::from_raw_parts_mut(ptr, values)
                        };
                        let poses: &mut [Pose] =
                            bytemuck::try_cast_slice_mut(buffer).map_err(|e| e.to_string())?;
                        let starts: Vec<StartState> = rows.clone().map(start_of).collect();
                        if h > 0 {
                            let copied: Vec<Input>;
                            let cmds = match whole {
                                Some(all) => &all[rows.start * h..rows.end * h],
                                None => {
                                    copied = flat[rows.start * h * dim..rows.end * h * dim]
                                        .chunks_exact(dim)
                                        .map(input_of_row)
                                        .collect();
                                    &copied
                                }
                            };
                            model
                                .predict_batch_into(&starts, cmds, h, poses)
                                .map_err(|e| e.to_string())?;
                        }
                        Ok(all_finite(bytemuck::cast_slice(poses)))
                    })
                    .try_reduce(|| true, |x, y| Ok(x && y))
            })
            .map_err(|e: String| err(e))?;
        if !all {
            // Never a non-finite pose: the command line's refusal, naming the sequence.
            let view = out.try_readonly().map_err(err)?;
            let poses: &[Pose] =
                bytemuck::try_cast_slice(view.as_slice().map_err(err)?).map_err(err)?;
            if let Some(i) = poses.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
                let row = &poses[(i / h) * h..(i / h + 1) * h];
                if let Some(e) = MotionError::not_finite(&model.name(), model.dt(), row, &[]) {
                    return Err(err(format!("sequence {}: {e}", i / h)));
                }
            }
        }
        Ok(out)
    }

    /// The numbers of one stepped state of this model (the width of `State.array`), with
    /// or without the covariance; `max_steps` bounds a model stepped by replay only.
    #[pyo3(signature = (covariance=None, max_steps=None))]
    fn state_len(
        &self,
        covariance: Option<&Bound<'_, PyAny>>,
        max_steps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        self.state_len_impl(covariance, max_steps)
    }

    /// `batch` states at a start, for stepping one command at a time (`step`): the start
    /// as `predict` takes it (`start` x, y, yaw; `start_wheels` the measured inputs;
    /// `start_yaw_rate`; `start_velocity`), each either one for every state or one row per
    /// state ((B, 3), (B, D), (B,), (B, 2)), and `history` the commands already sent,
    /// oldest first ((L, D)): those still inside the powertrain's dead time act in the
    /// first steps. With `covariance=True` the states carry the pose covariance (a model
    /// with an uncertainty). Stepping k times gives row k of `predict` from the same start
    /// and commands. `max_steps` bounds the states of a model stepped by replay (a plug-in
    /// model without a stepper of its own) only.
    #[pyo3(signature = (start=None, start_wheels=None, start_yaw_rate=None, start_velocity=None, history=None, batch=None, covariance=None, max_steps=None))]
    #[allow(clippy::too_many_arguments)]
    fn initial_state(
        &self,
        py: Python<'_>,
        start: Option<&Bound<'_, PyAny>>,
        start_wheels: Option<&Bound<'_, PyAny>>,
        start_yaw_rate: Option<&Bound<'_, PyAny>>,
        start_velocity: Option<&Bound<'_, PyAny>>,
        history: Option<&Bound<'_, PyAny>>,
        batch: Option<&Bound<'_, PyAny>>,
        covariance: Option<&Bound<'_, PyAny>>,
        max_steps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<crate::step::State> {
        self.initial_state_impl(
            py,
            start,
            start_wheels,
            start_yaw_rate,
            start_velocity,
            history,
            batch,
            covariance,
            max_steps,
        )
    }

    /// The states after one step of `dt` under `actions` (B, D): one command per state, one
    /// column per input axis. A new `State` (the one given is left as it was), or the same
    /// one stepped with `inplace=True`. Stepped in parallel without the GIL.
    #[pyo3(signature = (state, actions, inplace=None))]
    fn step(
        &self,
        py: Python<'_>,
        state: &Bound<'_, crate::step::State>,
        actions: &Bound<'_, PyAny>,
        inplace: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<crate::step::State>> {
        self.step_impl(py, state, actions, inplace)
    }

    /// `states` (K, state_len) after one step under `actions` (K, D), as a new array: the
    /// pytorch_mppi signature `dynamics(state, action) -> next_state` on numpy arrays (see
    /// `drive.MppiDynamics`). `covariance` and `max_steps` as the states were made with.
    #[pyo3(signature = (states, actions, covariance=None, max_steps=None))]
    fn step_array<'py>(
        &self,
        py: Python<'py>,
        states: &Bound<'py, PyAny>,
        actions: &Bound<'py, PyAny>,
        covariance: Option<&Bound<'py, PyAny>>,
        max_steps: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        self.step_array_impl(py, states, actions, covariance, max_steps)
    }

    /// The settings the model was fitted with (its model file's `fitted_with`: model,
    /// canonical, start, uncertainty, split, training_windows) as a dict; None for a file
    /// written without them.
    #[getter]
    fn fitted_with<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.settings {
            None => Ok(py.None().into_bound(py)),
            Some(s) => py
                .import("json")?
                .call_method1("loads", (serde_json::to_string(s).map_err(err)?,)),
        }
    }

    /// Saves the model as the command line's model file (`drive predict --model`). A model
    /// the loader would refuse (a fit of useless data, allowed) is not written: a
    /// `DriveError` says why, as `drive train` does.
    fn save(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = path_of("path", path)?;
        // Never under a dataset's, a recording's or an array's name, nor over a dataset's
        // sidecar or CSV (the command line's rule for train --out).
        drive::data::output_names::refused_name(
            &path,
            "a model file (JSON)",
            drive::data::output_names::DATA_NAMES,
            false,
        )
        .map_err(err)?;
        let text = self.to_json()?;
        if let Err(e) =
            drive::models::model_file::read_model_file(&path.display().to_string(), &text)
        {
            return Err(err(format!(
                "the model is not one the loader accepts, so it is not written: {e}"
            )));
        }
        std::fs::write(&path, text)
            .map_err(|e| err(format!("{}: cannot write: {e}", path.display())))
    }

    /// The vehicle's inputs (a differential drive's left and right wheel velocities, rad/s)
    /// that command the body velocity `linear` (m/s, forward) and `angular` (rad/s): what a
    /// Twist on cmd_vel asks of the robot, in the model's inputs. A `DriveError` when the
    /// vehicle has no input for it.
    fn input_for<'py>(
        &self,
        py: Python<'py>,
        linear: f64,
        angular: f64,
    ) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        finite("linear, angular", &[linear, angular])?;
        let v = drive::traits::BodyVelocity::new(linear, 0.0, angular);
        match self.robot.vehicle.input_for(&v) {
            Some(u) => crate::args::input_tuple(py, &u, self.robot.vehicle.input_dim()),
            None => Err(err(format!(
                "the vehicle has no input for the body velocity ({linear} m/s, {angular} rad/s)"
            ))),
        }
    }

    /// The model file's JSON text (what `save` writes), with the settings the model was
    /// fitted with (`fitted_with`: its start among them).
    fn to_json(&self) -> PyResult<String> {
        model_file_to_json(self.model.as_ref(), &self.robot, self.settings.as_ref()).map_err(err)
    }

    /// The start information the model was fitted for ("encoders", "encoders+imu" or
    /// "encoders+imu+localization"): what `score` predicts from.
    #[getter(start)]
    fn fitted_start(&self) -> &'static str {
        self.start.as_str()
    }

    /// Pickling (multiprocessing, joblib, copy.deepcopy) through the model file's text.
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (String, &'static str))> {
        let rebuild = py.import("drive._native")?.getattr("_model_from_json")?;
        Ok((rebuild, (self.to_json()?, self.start.as_str())))
    }

    /// The fitted model's parameters as a dict: the `model` part of its model file (the
    /// powertrain's, the slip learner's posterior, the calibration's scales, ...).
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?
            .call_method1("loads", (self.to_json()?,))?
            .get_item("model")
    }

    /// The model's eq. 8 errors on every window of `dataset` (transfer: another run,
    /// another terrain of the same vehicle), predicting from `start` (the start it was
    /// fitted for when None), as a dict: `translational_m` and `rotational_rad`
    /// ({"all", "transient", "steady"}: windows, median, iqr), `per_window` (window,
    /// interval, phase, error) and `uncertainty` (the 95% regions' calibration, for a
    /// model with a covariance), and `notes`. A dataset of another geometry of the same
    /// vehicle type (another calibration of the robot's wheels or baseline) is refused
    /// unless `allow_other_geometry`, which scores it with the difference as a UserWarning
    /// and in `notes`. A dataset the data checks call useless is refused unless
    /// `allow_useless`.
    #[pyo3(signature = (dataset, start=None, allow_other_geometry=false, allow_useless=false))]
    fn score<'py>(
        &self,
        py: Python<'py>,
        dataset: &Bound<'py, PyAny>,
        start: Option<&Bound<'py, PyAny>>,
        allow_other_geometry: bool,
        allow_useless: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let text = self.score_json(py, dataset, start, allow_other_geometry, allow_useless)?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// The model's eq. 8 errors on every window of `dataset` (any dataset of the same
    /// vehicle: another run, another terrain), predicting from `start` (the start it was
    /// fitted for when None), as JSON text: the medians and quartiles (all windows and per
    /// phase), the per-window errors, and the 95% regions' calibration for a model with a
    /// covariance; with `allow_other_geometry` and `allow_useless`, as [`Self::score`].
    #[pyo3(signature = (dataset, start=None, allow_other_geometry=false, allow_useless=false))]
    fn score_json(
        &self,
        py: Python<'_>,
        dataset: &Bound<'_, PyAny>,
        start: Option<&Bound<'_, PyAny>>,
        allow_other_geometry: bool,
        allow_useless: bool,
    ) -> PyResult<String> {
        let dataset = dataset_of(dataset)?;
        crate::dataset::refuse_useless(&dataset.inner, "the dataset", allow_useless)?;
        let start = match start.filter(|s| !s.is_none()) {
            Some(s) => start_info_of(Some(s))?,
            None => self.start,
        };
        let data = &dataset.inner;
        let model = self.model.as_ref();
        let robot = &self.robot;
        let score = py
            .detach(|| {
                drive::studies::score_model(
                    model,
                    robot,
                    data,
                    start,
                    allow_other_geometry,
                    "allow_other_geometry=True",
                )
            })
            .map_err(err)?;
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        for note in &score.notes {
            // The note holds no NUL: the numbers and field names are JSON's, the dataset's
            // name a sidecar's (checked on load).
            let message = std::ffi::CString::new(note.clone()).unwrap_or_default();
            PyErr::warn(py, &category, &message, 1)?;
        }
        let value = serde_json::to_value(&score).map_err(err)?;
        Ok(value.to_string())
    }

    fn __repr__(&self) -> String {
        format!("Model({:?}, dt={} s)", self.model.name(), self.model.dt())
    }
}

/// Fits `model` (a model name, as `drive train --model`) on the dataset's first `split` of
/// the intervals (all of them when None), for predictions that start from `start`
/// (`drive train --start`). Data the data checks call useless is refused unless
/// `allow_useless` (`drive train --allow-useless`).
#[pyfunction]
#[pyo3(signature = (dataset, model, split=None, start=None, allow_useless=false))]
pub(crate) fn fit(
    py: Python<'_>,
    dataset: &Bound<'_, PyAny>,
    model: &Bound<'_, PyAny>,
    split: Option<&Bound<'_, PyAny>>,
    start: Option<&Bound<'_, PyAny>>,
    allow_useless: bool,
) -> PyResult<Model> {
    let dataset = dataset_of(dataset)?;
    crate::dataset::refuse_useless(&dataset.inner, "the dataset", allow_useless)?;
    let start = start_info_of(start)?;
    let model: String = model.extract().map_err(|_| {
        err(format!(
            "model must be a model name such as 'slip-blr' (see drive list), got {}",
            type_name(model)
        ))
    })?;
    let model = model.as_str();
    let split = split
        .filter(|s| !s.is_none())
        .map(|s| number_of("split", "a number between 0 and 1", s))
        .transpose()?;
    let registries = crate::registries();
    let spec = registries.model(model).map_err(err)?.clone();
    let spec = spec.clone().with_uncertainty(spec.uncertainty, start);
    let data = &dataset.inner;
    // The work's thread has its own copy of the data and the spec (a Ctrl-C returns at once,
    // while the fit under way finishes there).
    let (owned, fit_spec, name) = (data.clone(), spec.clone(), model.to_string());
    let fitted = crate::interrupt::interruptible(py, None, move |_| {
        let train = match split {
            Some(f) => split_by_interval(&owned, f).map_err(|e| e.to_string())?.0,
            None => owned.all(),
        };
        fit_spec
            .fit(&train)
            .map_err(|e| format!("fitting {name}: {e}"))
    })?;
    let fitted = fitted.map_err(err)?;
    let (training_windows, commanded) = match split {
        Some(f) => {
            let train = split_by_interval(data, f).map_err(err)?.0;
            (train.len(), CommandRange::of(&train))
        }
        None => (data.windows.len(), CommandRange::of(&data.all())),
    };
    Ok(Model {
        model: fitted.into(),
        robot: data.robot.clone(),
        start,
        settings: Some(FitSettings {
            split,
            training_windows,
            commanded,
            ..FitSettings::of(&spec)
        }),
    })
}

/// Loads a model file written by `drive train` or `Model.save`.
#[pyfunction]
pub(crate) fn load_model(path: &Bound<'_, PyAny>) -> PyResult<Model> {
    let path = path_of("path", path)?;
    let name = path.display().to_string();
    // The command line's words (drive predict --model).
    let text =
        drive::traits::files::read_text(&path, drive::models::model_file::MAX_MODEL_FILE_BYTES)
            .map_err(|e| err(format!("reading {name}: {e}")))?;
    model_of_text(&name, &text, None)
}

/// A model from a model file's text: the start it was fitted for is the file's
/// (`fitted_with`); for a file without it, `start` (the default when None).
pub(crate) fn model_of_text(name: &str, text: &str, start: Option<&str>) -> PyResult<Model> {
    let file = read_model_file(name, text).map_err(err)?;
    let start = match (&file.fitted_with, start) {
        (Some(f), _) => f.start,
        (None, Some(s)) => StartInfo::parse(s).map_err(err)?,
        (None, None) => StartInfo::default(),
    };
    Ok(Model {
        model: file.model.into(),
        robot: file.robot,
        start,
        settings: file.fitted_with,
    })
}

/// A model from its model file's text and its start's name: what unpickling calls.
#[pyfunction]
pub(crate) fn _model_from_json(text: &str, start: &str) -> PyResult<Model> {
    model_of_text("pickled model", text, Some(start))
}

/// One row of numbers (one per input axis) as an input, the axes beyond it zero.
pub(crate) fn input_of_row(row: &[f64]) -> Input {
    let mut u = Input::zeros();
    for (i, v) in row.iter().enumerate().take(drive::traits::MAX_INPUTS) {
        u[i] = *v;
    }
    u
}
