//! The step API from Python: `Model.initial_state`, `Model.step` and `drive.State`, a batch
//! of stepped states in one numpy array (see `drive::traits::step`), and `Model.step_array`
//! on raw arrays (what the pytorch_mppi adapter `drive.MppiDynamics` calls).

use crate::args::{finite, float_array, number_of, short_repr, type_name};
use crate::err;
use crate::model::Model;
use drive::models::batch::step_batch_parallel;
use drive::traits::step::{layout, StepOptions, Stepper, DEFAULT_REPLAY_STEPS};
use drive::traits::{Input, MotionModel, StartState};
use numpy::{PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods, ToPyArray};
use pyo3::prelude::*;
use std::sync::Arc;

/// States per parallel task: below this many, one thread steps them all (a parallel call
/// costs more than it saves on a small batch).
const CHUNK: usize = 512;

/// A batch of stepped states of a fitted model: one row of `state_len` numbers per state in
/// `array` (B, state_len), the pose first (see `drive.State` in the docs).
#[pyclass(module = "drive._native")]
pub(crate) struct State {
    pub(crate) model: Arc<dyn MotionModel>,
    pub(crate) dim: usize,
    pub(crate) options: StepOptions,
    pub(crate) array: Py<PyArray2<f64>>,
}

impl State {
    fn view<'py>(&self, py: Python<'py>, from: usize, to: usize) -> PyResult<Bound<'py, PyAny>> {
        let slice = pyo3::types::PySlice::new(py, from as isize, to as isize, 1);
        let all = pyo3::types::PySlice::full(py);
        self.array.bind(py).as_any().get_item((all, slice))
    }
}

#[pymethods]
impl State {
    /// The states themselves, (B, state_len) float64: row b is state b, numbers 0-2 its pose
    /// (x, y, yaw), 3-5 the body velocity of its last step (v_x, v_y, w), 6-14 its pose
    /// covariance (row-major, when carried), 15 its steps taken, then the model's own state
    /// (the powertrain's wheels and the commands inside its dead time, the slip model's
    /// lagging velocity, ...). A view: changing it changes the states.
    #[getter]
    fn array<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.array.bind(py).clone()
    }

    /// The poses (B, 3): x, y, yaw (a view of `array`).
    #[getter]
    fn poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.view(py, layout::POSE, layout::POSE + 3)
    }

    /// The body velocities over the last step (B, 3): v_x, v_y, w in the body frame (at
    /// the start, the start's); a view of `array`.
    #[getter]
    fn body_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.view(py, layout::VELOCITY, layout::VELOCITY + 3)
    }

    /// The pose covariances (B, 3, 3) (a copy), for states that carry them
    /// (`initial_state(..., covariance=True)`); a `DriveError` otherwise.
    #[getter]
    fn covariances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        if !self.options.covariance {
            return Err(err(
                "these states do not carry the covariance: make them with initial_state(..., covariance=True)",
            ));
        }
        let v = self.view(py, layout::COVARIANCE, layout::COVARIANCE + 9)?;
        v.call_method1("reshape", ((-1, 3, 3),))?
            .call_method0("copy")
    }

    /// The steps each state has taken (B,) (a copy).
    #[getter]
    fn steps<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.view(py, layout::STEPS, layout::STEPS + 1)?
            .call_method1("reshape", (-1,))?
            .call_method1("astype", ("int64",))
    }

    /// The number of states B.
    #[getter]
    fn batch(&self, py: Python<'_>) -> usize {
        self.array.bind(py).shape()[0]
    }

    /// Whether the states carry the pose covariance.
    #[getter]
    fn with_covariance(&self) -> bool {
        self.options.covariance
    }

    /// A copy of the states (a new array): stepping one leaves the other as it was.
    fn copy(&self, py: Python<'_>) -> PyResult<State> {
        let array = self
            .array
            .bind(py)
            .call_method0("copy")?
            .cast_into::<PyArray2<f64>>()?
            .unbind();
        Ok(State {
            model: Arc::clone(&self.model),
            dim: self.dim,
            options: self.options,
            array,
        })
    }

    fn __len__(&self, py: Python<'_>) -> usize {
        self.batch(py)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let shape = self.array.bind(py).shape().to_vec();
        format!(
            "State({:?}, batch={}, state_len={}, covariance={})",
            self.model.name(),
            shape[0],
            shape[1],
            if self.options.covariance {
                "True"
            } else {
                "False"
            }
        )
    }
}

/// The stepper of `model`, its errors in the command line's words.
fn stepper_of(model: &dyn MotionModel, options: StepOptions) -> PyResult<Box<dyn Stepper + '_>> {
    model.stepper(options).map_err(err)
}

/// `obj` as rows of `width` numbers: `(n, width)`, or `(width,)` for every row when
/// `broadcast` (n rows); `None` for None.
fn rows_of(
    py: Python<'_>,
    what: &str,
    obj: Option<&Bound<'_, PyAny>>,
    n: usize,
    width: usize,
) -> PyResult<Option<Vec<f64>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    // A single number (width 1) is one for every state, as a row of `width` is; a width
    // of 1 also takes one number per state (n,).
    let expected = if width == 1 {
        format!("a number or a ({n},) array")
    } else {
        format!("a ({width},) or ({n}, {width}) array")
    };
    let a = (0..=2)
        .find_map(|ndim| float_array(py, what, &expected, obj, ndim).ok())
        .ok_or_else(|| {
            err(format!(
                "{what} must be {expected} of numbers, got {}",
                short_repr(obj)
            ))
        })?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    let values: Vec<f64> = a.call_method1("reshape", (-1,))?.extract()?;
    finite(what, &values)?;
    match (shape.as_slice(), width) {
        ([], 1) => Ok(Some(values.repeat(n))),
        ([w], _) if *w == width => Ok(Some(values.repeat(n))),
        ([b], 1) if *b == n => Ok(Some(values)),
        ([b, w], _) if *b == n && *w == width => Ok(Some(values)),
        _ => Err(err(format!(
            "{what} must be {expected}, got shape {shape:?}"
        ))),
    }
}

/// A (B, D) float64 array's numbers, fast for a C-contiguous float64 array (no conversion).
fn actions_of<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    b: usize,
    dim: usize,
) -> PyResult<Vec<Input>> {
    let shape_error = |shape: &[usize]| {
        err(format!(
            "actions must be a ({b}, {dim}) array (one row per state, one column per input axis), got shape {shape:?}"
        ))
    };
    let direct: Option<PyReadonlyArray2<'py, f64>> = obj.extract().ok();
    let read = |a: &PyReadonlyArray2<'py, f64>| -> PyResult<Vec<Input>> {
        if a.shape() != [b, dim] {
            return Err(shape_error(a.shape()));
        }
        let v = a.as_array();
        let mut out = Vec::with_capacity(b);
        for row in v.rows() {
            let mut u = Input::zeros();
            for (i, x) in row.iter().enumerate() {
                u[i] = *x;
            }
            out.push(u);
        }
        Ok(out)
    };
    let out = match direct {
        Some(a) => read(&a)?,
        None => {
            let a = float_array(py, "actions", &format!("({b}, {dim})"), obj, 2).or_else(|e| {
                // One action for a batch of one.
                if b == 1 {
                    float_array(py, "actions", &format!("({b}, {dim})"), obj, 1)?
                        .call_method1("reshape", ((1, -1),))
                } else {
                    Err(e)
                }
            })?;
            read(&a.extract()?)?
        }
    };
    // Finite, and within what the command line reads (1e9: an action of 1e300 stepped to
    // states of 1e299 without a word).
    let limit = drive::traits::limits::MAX_ABS_MEASUREMENT;
    if let Some(i) = out
        .iter()
        .position(|u| !u.iter().take(dim).all(|x| x.abs() <= limit))
    {
        let what = if out[i].iter().take(dim).all(|x| x.is_finite()) {
            format!(
                "beyond {} (what the command line reads): in the robot's units?",
                drive::traits::limits::Short(limit)
            )
        } else {
            "not finite numbers".to_string()
        };
        return Err(err(format!("actions: row {i} is {what}")));
    }
    Ok(out)
}

/// `Err` naming the first value of `states` (rows of `len`) that is not finite or beyond
/// what the command line reads (1e9): not a state the step API makes (a state edited to
/// 1e12 stepped to a pose of 8e19 m without a word).
fn states_within_limits(states: &[f64], len: usize) -> PyResult<()> {
    let limit = drive::traits::limits::MAX_ABS_MEASUREMENT;
    match states
        .iter()
        .position(|x| !x.is_finite() || x.abs() > limit)
    {
        Some(i) => Err(err(format!(
            "states: row {}, entry {} is {}: not a state the step API makes (finite, within {})",
            i / len.max(1),
            i % len.max(1),
            drive::traits::limits::Short(states[i]),
            drive::traits::limits::Short(limit)
        ))),
        None => Ok(()),
    }
}

/// Steps `states` (B rows of the stepper's length) by `actions` without the GIL.
fn step_rows(
    py: Python<'_>,
    stepper: &dyn Stepper,
    states: &mut [f64],
    actions: &[Input],
) -> PyResult<()> {
    py.detach(|| {
        if actions.len() <= CHUNK {
            stepper.step_batch(states, actions)
        } else {
            let chunk = actions
                .len()
                .div_ceil(rayon::current_num_threads())
                .max(CHUNK / 4);
            step_batch_parallel(stepper, states, actions, chunk)
        }
    })
    .map_err(err)
}

fn options_of(covariance: bool, max_steps: Option<&Bound<'_, PyAny>>) -> PyResult<StepOptions> {
    let max_steps = match max_steps.filter(|m| !m.is_none()) {
        None => DEFAULT_REPLAY_STEPS,
        Some(m) => {
            let n = number_of("max_steps", "a whole number of steps, at least 1", m)?;
            if !(n >= 1.0 && n.fract() == 0.0 && n <= 1e7) {
                return Err(err(format!(
                    "max_steps must be a whole number of steps from 1 to 10,000,000, got {}",
                    short_repr(m)
                )));
            }
            n as usize
        }
    };
    Ok(StepOptions {
        covariance,
        max_steps,
    })
}

fn bool_of(what: &str, obj: Option<&Bound<'_, PyAny>>) -> PyResult<bool> {
    match obj.filter(|o| !o.is_none()) {
        None => Ok(false),
        Some(o) if matches!(type_name(o).as_str(), "bool" | "bool_") => o.is_truthy(),
        Some(o) => Err(err(format!(
            "{what} must be True or False, got {}",
            short_repr(o)
        ))),
    }
}

/// The step API's methods of `Model` (their Python signatures and docs are in model.rs).
impl Model {
    pub(crate) fn state_len_impl(
        &self,
        covariance: Option<&Bound<'_, PyAny>>,
        max_steps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        let options = options_of(bool_of("covariance", covariance)?, max_steps)?;
        Ok(stepper_of(self.model.as_ref(), options)?.state_len())
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn initial_state_impl(
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
    ) -> PyResult<State> {
        let b = match batch {
            None => 1,
            Some(o) => {
                let n = number_of("batch", "a whole number of states, at least 1", o)?;
                if !(n >= 1.0 && n.fract() == 0.0 && n <= 1e8)
                    || o.is_instance_of::<pyo3::types::PyBool>()
                {
                    return Err(err(format!(
                        "batch must be a whole number of states, at least 1, got {}",
                        short_repr(o)
                    )));
                }
                n as usize
            }
        };
        let options = options_of(bool_of("covariance", covariance)?, max_steps)?;
        let dim = self.robot.vehicle.input_dim();
        let poses = rows_of(py, "start", start, b, 3)?.unwrap_or_else(|| vec![0.0; 3 * b]);
        let wheels = rows_of(py, "start_wheels", start_wheels, b, dim)?
            .unwrap_or_else(|| vec![0.0; dim * b]);
        let yaw_rates = rows_of(py, "start_yaw_rate", start_yaw_rate, b, 1)?;
        let velocities = rows_of(py, "start_velocity", start_velocity, b, 2)?;
        for v in poses
            .iter()
            .chain(&wheels)
            .chain(yaw_rates.iter().flatten())
            .chain(velocities.iter().flatten())
        {
            drive::traits::limits::at_most(
                "the start",
                v.abs(),
                drive::traits::limits::MAX_ABS_MEASUREMENT,
                "",
            )
            .map_err(err)?;
        }
        // A start no data showed, as Model.predict warns of it: the first row's notes.
        if let Some(k) = self.known() {
            let mut notes = Vec::new();
            if let Some(i) = wheels
                .chunks_exact(dim.max(1))
                .position(|w| k.range.beyond(w).is_some())
            {
                let w = crate::model::input_of_row(&wheels[dim * i..dim * (i + 1)]);
                notes.extend(k.start_notes(
                    &self.robot,
                    w,
                    None,
                    &format!("start_wheels[{i}]"),
                    "",
                ));
            }
            notes.extend(yaw_rates.iter().flatten().enumerate().find_map(|(i, w)| {
                k.yaw_rate_note(&self.robot, *w, &format!("start_yaw_rate[{i}]"))
            }));
            notes.extend(
                velocities
                    .iter()
                    .flat_map(|v| v.chunks_exact(2))
                    .enumerate()
                    .find_map(|(i, v)| {
                        let flag = format!("start_velocity[{i}]");
                        k.start_notes(&self.robot, Input::zeros(), Some([v[0], v[1]]), "", &flag)
                            .into_iter()
                            .find(|n| n.starts_with(&flag))
                    }),
            );
            crate::model::warn_notes(py, notes)?;
        }
        let history: Vec<Input> = match history.filter(|h| !h.is_none()) {
            None => Vec::new(),
            Some(h) => {
                let a = float_array(py, "history", &format!("(L, {dim})"), h, 2)?;
                let shape: Vec<usize> = a.getattr("shape")?.extract()?;
                if shape[1] != dim {
                    return Err(err(format!(
                        "history must be an (L, {dim}) array of the commands already sent (oldest first), got shape {shape:?}"
                    )));
                }
                let values: Vec<f64> = a.call_method1("reshape", (-1,))?.extract()?;
                finite("history", &values)?;
                crate::args::within_readers("history", &values)?;
                values
                    .chunks_exact(dim)
                    .map(|r| {
                        let mut u = Input::zeros();
                        u.as_mut_slice()[..dim].copy_from_slice(r);
                        u
                    })
                    .collect()
            }
        };
        let stepper = stepper_of(self.model.as_ref(), options)?;
        let len = stepper.state_len();
        let mut data = vec![0.0; b * len];
        for (i, row) in data.chunks_exact_mut(len).enumerate() {
            let mut u = Input::zeros();
            u.as_mut_slice()[..dim].copy_from_slice(&wheels[dim * i..dim * (i + 1)]);
            let s = StartState::measured(
                drive::traits::Pose::new(poses[3 * i], poses[3 * i + 1], poses[3 * i + 2]),
                u,
                self.robot.vehicle.as_ref(),
            );
            let s = match &yaw_rates {
                Some(w) => s.with_yaw_rate(w[i]),
                None => s,
            };
            let s = match &velocities {
                Some(v) => s.with_velocity([v[2 * i], v[2 * i + 1]]),
                None => s,
            };
            stepper.init(&s, &history, row).map_err(err)?;
        }
        let array = numpy::ndarray::Array2::from_shape_vec((b, len), data)
            .map_err(err)?
            .to_pyarray(py)
            .unbind();
        Ok(State {
            model: Arc::clone(&self.model),
            dim,
            options,
            array,
        })
    }

    pub(crate) fn step_impl(
        &self,
        py: Python<'_>,
        state: &Bound<'_, State>,
        actions: &Bound<'_, PyAny>,
        inplace: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<State>> {
        let inplace = bool_of("inplace", inplace)?;
        let (options, array) = {
            let s = state.borrow();
            if !Arc::ptr_eq(&s.model, &self.model) {
                return Err(err(format!(
                    "these states are of another model ({}): step them with the model that made them",
                    s.model.name()
                )));
            }
            (s.options, s.array.clone_ref(py))
        };
        let target = if inplace {
            state.clone().unbind()
        } else {
            Py::new(py, state.borrow().copy(py)?)?
        };
        let array = if inplace {
            array
        } else {
            target.borrow(py).array.clone_ref(py)
        };
        let bound = array.bind(py);
        let b = bound.shape()[0];
        let actions = actions_of(py, actions, b, self.robot.vehicle.input_dim())?;
        let stepper = stepper_of(self.model.as_ref(), options)?;
        let mut rw = bound.try_readwrite().map_err(err)?;
        let states = rw.as_slice_mut().map_err(err)?;
        drive::traits::step::check_states(stepper.state_len(), states.len(), b).map_err(err)?;
        states_within_limits(states, stepper.state_len())?;
        step_rows(py, stepper.as_ref(), states, &actions)?;
        Ok(target)
    }

    pub(crate) fn step_array_impl<'py>(
        &self,
        py: Python<'py>,
        states: &Bound<'py, PyAny>,
        actions: &Bound<'py, PyAny>,
        covariance: Option<&Bound<'py, PyAny>>,
        max_steps: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let options = options_of(bool_of("covariance", covariance)?, max_steps)?;
        let stepper = stepper_of(self.model.as_ref(), options)?;
        let len = stepper.state_len();
        let a = float_array(py, "states", &format!("(K, {len})"), states, 2)?;
        let shape: Vec<usize> = a.getattr("shape")?.extract()?;
        if shape[1] != len {
            return Err(err(format!(
                "states must be a (K, {len}) array (this model's states hold {len} numbers), got shape {shape:?}"
            )));
        }
        let k = shape[0];
        let actions = actions_of(py, actions, k, self.robot.vehicle.input_dim())?;
        let a: PyReadonlyArray2<'py, f64> = a.extract()?;
        let mut data = a.as_slice().map_err(err)?.to_vec();
        states_within_limits(&data, len)?;
        step_rows(py, stepper.as_ref(), &mut data, &actions)?;
        Ok(numpy::ndarray::Array2::from_shape_vec((k, len), data)
            .map_err(err)?
            .to_pyarray(py))
    }
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<State>()
}
