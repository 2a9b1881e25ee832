//! The C library of fitted DRIVE models: load a model file written by `drive train`, ask
//! what it is (vehicle, input axes, rate), predict batches of rollouts with and without
//! their covariance, and step batches of states one command at a time
//! ([`drive_traits::step`]) for a controller written in C or C++ (Nav2's MPPI,
//! `examples/nav2_mppi`). The header is `include/drive.h`.
//!
//! Every function returns a status (`DRIVE_OK`, or a negative `DRIVE_ERROR_*` whose message
//! [`drive_last_error`] gives on the same thread) or a value that says failure itself (a
//! null pointer, 0); none panics or aborts across the boundary: a panic inside is caught
//! and returned as `DRIVE_ERROR_INTERNAL`.
//!
//! Threads: a `drive_model` is immutable once loaded, so every function that takes a
//! `const drive_model *` may run on several threads at once; a state buffer or a
//! `drive_states` must not be used by two threads at once. The batch functions run on the
//! library's own thread pool (rayon: `RAYON_NUM_THREADS` sets its size).
//!
//! ```
//! use drive_capi::*;
//! // A model file from the project's tests; in C: drive_model_load("model.json", &model).
//! # let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/naive.json")).unwrap();
//! let mut model = std::ptr::null_mut();
//! let status = unsafe { drive_model_from_json(text.as_ptr().cast(), text.len(), &mut model) };
//! assert_eq!(status, DRIVE_OK);
//! let mut start = drive_start::default();
//! unsafe { drive_start_rest(&mut start) };
//! let commands = [10.0, 10.0, 10.0, 10.0, 10.0, 10.0]; // 3 steps of (left, right) rad/s
//! let mut poses = [0.0; 9];
//! let status = unsafe {
//!     drive_predict(model, &start, commands.as_ptr(), 3, poses.as_mut_ptr(), std::ptr::null_mut())
//! };
//! assert_eq!(status, DRIVE_OK);
//! assert!(poses[6] > 0.0); // moved forward by the third pose
//! unsafe { drive_model_free(model) };
//! ```

#![allow(non_camel_case_types)]

use drive_models::batch::{predict_batch_parallel, rollout_states, step_batch_parallel};
use drive_models::model_file::read_model_file;
use drive_traits::limits::{Short, MAX_ABS_MEASUREMENT};
use drive_traits::step::{StepOptions, StepOutputs, Stepper};
use drive_traits::{
    BodyVelocity, Input, MotionError, MotionModel, Pose, PoseCovariance, RobotDescription,
    StartState,
};
// (nalgebra's vectors are plain arrays of doubles: bytemuck checks the casts.)
use nalgebra as _;
// The facade is a dependency for its features only (Cargo.toml).
use drive as _;
use std::cell::RefCell;
use std::ffi::{c_char, c_int, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

/// Success.
pub const DRIVE_OK: c_int = 0;
/// An argument is wrong: a null pointer, a size that does not match, a value that is not a
/// finite number within the limits.
pub const DRIVE_ERROR_ARGUMENT: c_int = -1;
/// The model file cannot be read or is not a model file `drive train` writes.
pub const DRIVE_ERROR_FILE: c_int = -2;
/// The model cannot do what is asked: a covariance of a model without one, a command
/// history of a model stepped by replay, a prediction that is not finite.
pub const DRIVE_ERROR_MODEL: c_int = -3;
/// An internal error (a panic inside the library, caught): a bug to report.
pub const DRIVE_ERROR_INTERNAL: c_int = -4;

/// The numbers of a state before the model's own (see `drive_traits::step::layout`).
pub const DRIVE_STATE_POSE: usize = drive_traits::step::layout::POSE;
/// Where a state's body velocity over its last step starts.
pub const DRIVE_STATE_VELOCITY: usize = drive_traits::step::layout::VELOCITY;
/// Where a state's pose covariance (row-major 3 x 3) starts.
pub const DRIVE_STATE_COVARIANCE: usize = drive_traits::step::layout::COVARIANCE;
/// Where a state's step count is.
pub const DRIVE_STATE_STEPS: usize = drive_traits::step::layout::STEPS;

/// States stepped on one thread when a batch has at most this many (a parallel call
/// costs more than it saves on a small batch).
const SERIAL_STATES: usize = 512;

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// A failed call: its status and message.
struct Failure(c_int, String);

impl Failure {
    fn argument(message: impl Into<String>) -> Self {
        Failure(DRIVE_ERROR_ARGUMENT, message.into())
    }
    fn model(e: impl std::fmt::Display) -> Self {
        Failure(DRIVE_ERROR_MODEL, e.to_string())
    }
}

fn set_error(message: &str) {
    // A message never holds a NUL byte (it would end the C string early).
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = text);
}

/// Runs `f`, its failure or panic turned into a status and the thread's message.
fn guard(f: impl FnOnce() -> Result<(), Failure>) -> c_int {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => DRIVE_OK,
        Ok(Err(Failure(code, message))) => {
            set_error(&message);
            code
        }
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            set_error(&format!("internal error (please report it): {what}"));
            DRIVE_ERROR_INTERNAL
        }
    }
}

/// The message of the last call that failed on this thread ("" if none did): valid until
/// the next failing call on the same thread.
#[unsafe(no_mangle)]
pub extern "C" fn drive_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// The library's version ("0.1.0"), a static string.
#[unsafe(no_mangle)]
pub extern "C" fn drive_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

/// What a model holds besides the model: its robot and the C strings the queries return.
struct Inner {
    model: Box<dyn MotionModel>,
    robot: RobotDescription,
    name: CString,
    vehicle: CString,
    fitted_start: CString,
    input_names: Vec<CString>,
    input_units: Vec<CString>,
    command_columns: Vec<CString>,
    uncertainty: bool,
}

/// A fitted model loaded from a model file (opaque to C).
pub struct drive_model {
    inner: Arc<Inner>,
}

fn cstring(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).unwrap_or_default()
}

fn load(name: &str, text: &str) -> Result<drive_model, Failure> {
    let file = read_model_file(name, text).map_err(|e| Failure(DRIVE_ERROR_FILE, e.to_string()))?;
    let axes = file.robot.vehicle.axes();
    let uncertainty = file
        .model
        .predict_with_covariance_into(
            &StartState::at_rest(Pose::zeros()),
            &[Input::zeros(); 2],
            &mut Vec::new(),
            &mut Vec::new(),
        )
        .is_ok();
    let inner = Inner {
        name: cstring(&file.model.name()),
        vehicle: cstring(
            &drive_traits::vehicle_tag(file.robot.vehicle.as_ref()).unwrap_or_default(),
        ),
        fitted_start: cstring(file.fitted_with.as_ref().map_or("", |f| f.start.as_str())),
        input_names: axes.iter().map(|a| cstring(a.name)).collect(),
        input_units: axes.iter().map(|a| cstring(a.unit)).collect(),
        command_columns: axes.iter().map(|a| cstring(a.command_column)).collect(),
        uncertainty,
        model: file.model,
        robot: file.robot,
    };
    Ok(drive_model {
        inner: Arc::new(inner),
    })
}

/// Reads the model file at `path` (a NUL-terminated path) into `*out`; free it with
/// [`drive_model_free`]. `DRIVE_ERROR_FILE` when the file cannot be read or is not a model
/// file `drive train` writes (the message says where).
///
/// # Safety
/// `path` is a NUL-terminated string and `out` a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_load(
    path: *const c_char,
    out: *mut *mut drive_model,
) -> c_int {
    guard(|| {
        if path.is_null() || out.is_null() {
            return Err(Failure::argument(
                "drive_model_load: path and out must not be NULL",
            ));
        }
        // SAFETY: a NUL-terminated string, as the caller promises.
        let path = unsafe { CStr::from_ptr(path) }
            .to_str()
            .map_err(|_| Failure::argument("drive_model_load: the path is not UTF-8"))?;
        let text = drive_traits::files::read_text(
            std::path::Path::new(path),
            drive_models::model_file::MAX_MODEL_FILE_BYTES,
        )
        .map_err(|e| Failure(DRIVE_ERROR_FILE, format!("reading {path}: {e}")))?;
        let model = load(path, &text)?;
        // SAFETY: `out` is a valid pointer, as the caller promises.
        unsafe { *out = Box::into_raw(Box::new(model)) };
        Ok(())
    })
}

/// Reads a model file's text (`len` bytes of UTF-8 at `text`) into `*out`; free it with
/// [`drive_model_free`].
///
/// # Safety
/// `text` points to `len` readable bytes and `out` is a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_from_json(
    text: *const c_char,
    len: usize,
    out: *mut *mut drive_model,
) -> c_int {
    guard(|| {
        if text.is_null() || out.is_null() {
            return Err(Failure::argument(
                "drive_model_from_json: text and out must not be NULL",
            ));
        }
        if len as u64 > drive_models::model_file::MAX_MODEL_FILE_BYTES {
            return Err(Failure(
                DRIVE_ERROR_FILE,
                format!("the model text is {len} bytes, more than a model file holds"),
            ));
        }
        // SAFETY: `len` readable bytes at `text`, as the caller promises.
        let bytes = unsafe { std::slice::from_raw_parts(text.cast::<u8>(), len) };
        let text = std::str::from_utf8(bytes)
            .map_err(|_| Failure(DRIVE_ERROR_FILE, "the model text is not UTF-8".into()))?;
        let model = load("model text", text)?;
        // SAFETY: `out` is a valid pointer, as the caller promises.
        unsafe { *out = Box::into_raw(Box::new(model)) };
        Ok(())
    })
}

/// Frees a model (NULL is ignored). States made from it stay usable: they hold the model.
///
/// # Safety
/// `model` is NULL or a model from `drive_model_load` / `drive_model_from_json` not freed
/// before.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_free(model: *mut drive_model) {
    if !model.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: a model this library allocated, freed once.
            drop(unsafe { Box::from_raw(model) });
        }));
    }
}

/// The model, or an argument error for NULL.
///
/// # Safety
/// `model` is NULL or a live model.
unsafe fn model_ref<'a>(model: *const drive_model) -> Result<&'a Inner, Failure> {
    // SAFETY: NULL or a live model, as the caller promises.
    match unsafe { model.as_ref() } {
        Some(m) => Ok(&m.inner),
        None => Err(Failure::argument("the model is NULL")),
    }
}

/// A string of the model, or NULL (with the error set) for a NULL model.
///
/// # Safety
/// `model` is NULL or a live model.
unsafe fn model_str(model: *const drive_model, f: impl Fn(&Inner) -> &CString) -> *const c_char {
    // SAFETY: as the caller promises.
    match unsafe { model_ref(model) } {
        Ok(m) => f(m).as_ptr(),
        Err(Failure(_, message)) => {
            set_error(&message);
            std::ptr::null()
        }
    }
}

/// The model's name (`slip-blr+fopdt`), owned by the model. NULL for a NULL model.
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_name(model: *const drive_model) -> *const c_char {
    // SAFETY: as the caller promises.
    unsafe { model_str(model, |m| &m.name) }
}

/// The model's vehicle type (`differential`, `ackermann`, `omnidirectional`, or a
/// plug-in's), owned by the model.
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_vehicle(model: *const drive_model) -> *const c_char {
    // SAFETY: as the caller promises.
    unsafe { model_str(model, |m| &m.vehicle) }
}

/// What the model's predictions were fitted to start from (`encoders`, `encoders+imu`,
/// `encoders+imu+localization`; its file's `fitted_with`), or "" for a file without it.
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_fitted_start(model: *const drive_model) -> *const c_char {
    // SAFETY: as the caller promises.
    unsafe { model_str(model, |m| &m.fitted_start) }
}

/// The model's step (s): the period of its commands. 0 for a NULL model.
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_dt(model: *const drive_model) -> f64 {
    // SAFETY: as the caller promises.
    unsafe { model_ref(model) }.map_or(0.0, |m| m.model.dt())
}

/// The number of input axes of the model's vehicle (the width of a command): 2 for a
/// differential drive (left, right) and a car (speed, steering), 3 for an
/// omnidirectional base. 0 for a NULL model.
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_input_count(model: *const drive_model) -> usize {
    // SAFETY: as the caller promises.
    unsafe { model_ref(model) }.map_or(0, |m| m.robot.vehicle.input_dim())
}

/// The name of input axis `axis` (`left`), its unit (`rad/s`) and the command column of a
/// command file (`cmd_left`), owned by the model; NULL beyond the axes.
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_input_name(
    model: *const drive_model,
    axis: usize,
) -> *const c_char {
    // SAFETY: as the caller promises.
    unsafe { model_axis(model, axis, |m| &m.input_names) }
}

/// See [`drive_model_input_name`].
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_input_unit(
    model: *const drive_model,
    axis: usize,
) -> *const c_char {
    // SAFETY: as the caller promises.
    unsafe { model_axis(model, axis, |m| &m.input_units) }
}

/// See [`drive_model_input_name`].
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_command_column(
    model: *const drive_model,
    axis: usize,
) -> *const c_char {
    // SAFETY: as the caller promises.
    unsafe { model_axis(model, axis, |m| &m.command_columns) }
}

/// # Safety
/// `model` is NULL or a live model.
unsafe fn model_axis(
    model: *const drive_model,
    axis: usize,
    f: impl Fn(&Inner) -> &Vec<CString>,
) -> *const c_char {
    // SAFETY: as the caller promises.
    match unsafe { model_ref(model) } {
        Ok(m) => match f(m).get(axis) {
            Some(s) => s.as_ptr(),
            None => {
                set_error(&format!(
                    "axis {axis}: the vehicle has {} input axes",
                    f(m).len()
                ));
                std::ptr::null()
            }
        },
        Err(Failure(_, message)) => {
            set_error(&message);
            std::ptr::null()
        }
    }
}

/// 1 when the model predicts a pose covariance (slip-BLR, acc-BLR, slip-ipem, calibrated
/// or not), 0 when it does not (the naive and powertrain models), -1 for a NULL model.
///
/// # Safety
/// `model` is NULL or a live model.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_has_uncertainty(model: *const drive_model) -> c_int {
    // SAFETY: as the caller promises.
    unsafe { model_ref(model) }.map_or(-1, |m| c_int::from(m.uncertainty))
}

/// The vehicle's inputs (`drive_model_input_count` numbers into `inputs`) that command the
/// body velocity `body` (v_x, v_y, w: m/s, m/s, rad/s), as a Twist on cmd_vel asks:
/// `DRIVE_ERROR_MODEL` when the vehicle has none (a sideways velocity of a differential
/// drive).
///
/// # Safety
/// `model` is NULL or a live model; `body` holds 3 numbers, `inputs` room for the axes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_inputs_for(
    model: *const drive_model,
    body: *const f64,
    inputs: *mut f64,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let body = unsafe { slice(body, 3, "body") }?;
        let out = unsafe { slice_mut(inputs, m.robot.vehicle.input_dim(), "inputs") }?;
        finite("body", body)?;
        let v = BodyVelocity::new(body[0], body[1], body[2]);
        let u = m.robot.vehicle.input_for(&v).ok_or_else(|| {
            Failure::model(format!(
                "the {} vehicle has no input for the body velocity ({}, {}, {})",
                m.vehicle.to_string_lossy(),
                Short(v.x),
                Short(v.y),
                Short(v.z)
            ))
        })?;
        out.copy_from_slice(&u.as_slice()[..out.len()]);
        Ok(())
    })
}

thread_local! {
    /// The body velocities and their inputs of a conversion on this thread, reused.
    static CONVERSION: RefCell<(Vec<BodyVelocity>, Vec<Option<Input>>)> =
        const { RefCell::new((Vec::new(), Vec::new())) };
}

/// The nearest inputs of `vehicle` to the body velocities `body` (three numbers each) into
/// `out` (cleared first); the number without an input of their own.
fn nearest_inputs(
    vehicle: &dyn drive_traits::CommandModel,
    body: &[f64],
    out: &mut Vec<Input>,
) -> usize {
    let mut run = |(copy, own): &mut (Vec<BodyVelocity>, Vec<Option<Input>>)| {
        // The caller's numbers seen as body velocities, without a copy where they can be.
        let v: &[BodyVelocity] = match bytemuck::try_cast_slice(body) {
            Ok(v) => v,
            Err(_) => {
                copy.clear();
                copy.extend(
                    body.chunks_exact(3)
                        .map(|b| BodyVelocity::new(b[0], b[1], b[2])),
                );
                copy
            }
        };
        vehicle.inputs_for_into(v, own);
        let mut missed = 0;
        out.clear();
        out.extend(own.iter().zip(v).map(|(u, v)| match u {
            Some(u) => *u,
            None => {
                missed += 1;
                nearest_input(vehicle, v).0
            }
        }));
        missed
    };
    CONVERSION.with(|cell| match cell.try_borrow_mut() {
        Ok(mut buffers) => run(&mut buffers),
        Err(_) => run(&mut (Vec::new(), Vec::new())),
    })
}

/// The nearest input of `vehicle` to the body velocity `v`: its own when it has one, else
/// the same without the sideways velocity, else without the yaw rate either, else at rest;
/// `true` when it had its own.
fn nearest_input(vehicle: &dyn drive_traits::CommandModel, v: &BodyVelocity) -> (Input, bool) {
    if let Some(u) = vehicle.input_for(v) {
        return (u, true);
    }
    let u = vehicle
        .input_for(&BodyVelocity::new(v.x, 0.0, v.z))
        .or_else(|| vehicle.input_for(&BodyVelocity::new(v.x, 0.0, 0.0)))
        .unwrap_or_else(Input::zeros);
    (u, false)
}

/// [`drive_model_inputs_for`] for `n` body velocities at once (`body` n x 3, `inputs` n x
/// `drive_model_input_count`), for a controller that samples body velocities (Nav2's
/// cvx, cvy, cwz): a body velocity the vehicle has no input for (a yaw rate at zero speed
/// for a car, a sideways velocity for a differential drive) gets the nearest it has, the
/// sideways velocity dropped, then the yaw rate, and `*unreachable` (when not NULL) counts
/// them.
///
/// # Safety
/// `model` is NULL or a live model; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_inputs_for_batch(
    model: *const drive_model,
    body: *const f64,
    n: usize,
    inputs: *mut f64,
    unreachable: *mut usize,
) -> c_int {
    guard(|| {
        use rayon::prelude::*;
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let dim = m.robot.vehicle.input_dim();
        let body = unsafe { slice(body, size(n, 3, "body")?, "body") }?;
        let out = unsafe { slice_mut(inputs, size(n, dim, "inputs")?, "inputs") }?;
        if let Some(i) = body.iter().position(|v| !v.is_finite()) {
            return Err(Failure::argument(format!(
                "body: value {i} is not a finite number"
            )));
        }
        let vehicle = m.robot.vehicle.as_ref();
        const CHUNK: usize = 4096;
        let missed: usize = out
            .par_chunks_mut(CHUNK * dim.max(1))
            .zip(body.par_chunks(CHUNK * 3))
            .map(|(out, body)| {
                let mut inputs = Vec::new();
                let missed = nearest_inputs(vehicle, body, &mut inputs);
                for (o, u) in out.chunks_exact_mut(dim.max(1)).zip(&inputs) {
                    o.copy_from_slice(&u.as_slice()[..o.len()]);
                }
                missed
            })
            .sum();
        // SAFETY: NULL or valid, as the caller promises.
        if let Some(u) = unsafe { unreachable.as_mut() } {
            *u = missed;
        }
        Ok(())
    })
}

/// The body velocity (v_x, v_y, w into `body`) the vehicle's inputs `inputs` command (eq. 4
/// for a differential drive).
///
/// # Safety
/// `model` is NULL or a live model; `inputs` holds the axes, `body` room for 3 numbers.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_model_body_velocity(
    model: *const drive_model,
    inputs: *const f64,
    body: *mut f64,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let u = unsafe { slice(inputs, m.robot.vehicle.input_dim(), "inputs") }?;
        let out = unsafe { slice_mut(body, 3, "body") }?;
        finite("inputs", u)?;
        let v = m.robot.vehicle.body_velocity(&input_of(u));
        out.copy_from_slice(v.as_slice());
        Ok(())
    })
}

/// What is known at the start of a prediction or of a state: the pose, the measured inputs
/// (the first `drive_model_input_count`; the encoders' wheel velocities of a differential
/// drive), and, when measured, the IMU's yaw rate (rad/s) and the localization's body
/// velocity just before (v_x, v_y in m/s, body frame). `drive_start_rest` makes one at rest
/// at the origin with nothing else measured.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct drive_start {
    /// x, y, yaw (m, m, rad).
    pub pose: [f64; 3],
    /// The measured inputs, one per input axis (the rest ignored).
    pub inputs: [f64; 3],
    /// Nonzero when `yaw_rate` was measured.
    pub has_yaw_rate: c_int,
    /// The IMU's yaw rate at the start (rad/s).
    pub yaw_rate: f64,
    /// Nonzero when `velocity` was measured.
    pub has_velocity: c_int,
    /// The localization's body velocity just before the start (m/s, forward and left).
    pub velocity: [f64; 2],
}

/// Sets `*start` at rest at the origin, nothing measured but the inputs (zero).
///
/// # Safety
/// `start` is NULL (ignored) or a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_start_rest(start: *mut drive_start) {
    // SAFETY: NULL or valid, as the caller promises.
    if let Some(s) = unsafe { start.as_mut() } {
        *s = drive_start::default();
    }
}

fn start_of(m: &Inner, s: &drive_start) -> Result<StartState, Failure> {
    let dim = m.robot.vehicle.input_dim();
    finite("the start's pose", &s.pose)?;
    finite("the start's inputs", &s.inputs[..dim])?;
    if s.has_yaw_rate != 0 {
        finite("the start's yaw rate", &[s.yaw_rate])?;
    }
    if s.has_velocity != 0 {
        finite("the start's velocity", &s.velocity)?;
    }
    let start = StartState::measured(
        Pose::new(s.pose[0], s.pose[1], s.pose[2]),
        input_of(&s.inputs[..dim]),
        m.robot.vehicle.as_ref(),
    );
    let start = if s.has_yaw_rate != 0 {
        start.with_yaw_rate(s.yaw_rate)
    } else {
        start
    };
    Ok(if s.has_velocity != 0 {
        start.with_velocity(s.velocity)
    } else {
        start
    })
}

fn input_of(values: &[f64]) -> Input {
    let mut u = Input::zeros();
    for (i, v) in values.iter().enumerate().take(drive_traits::MAX_INPUTS) {
        u[i] = *v;
    }
    u
}

/// Every value finite and within the readers' 1e9.
fn finite(what: &str, values: &[f64]) -> Result<(), Failure> {
    match values
        .iter()
        .position(|v| !(v.is_finite() && v.abs() <= MAX_ABS_MEASUREMENT))
    {
        Some(i) => Err(Failure::argument(format!(
            "{what}: value {i} ({}) is not a finite number within +-{}",
            Short(values[i]),
            Short(MAX_ABS_MEASUREMENT)
        ))),
        None => Ok(()),
    }
}

/// `len` numbers at `ptr` (NULL an error unless `len` is 0).
///
/// # Safety
/// `ptr` points to `len` readable numbers, or is NULL.
unsafe fn slice<'a>(ptr: *const f64, len: usize, what: &str) -> Result<&'a [f64], Failure> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Failure::argument(format!("{what} must not be NULL")));
    }
    // SAFETY: `len` readable numbers at `ptr`, as the caller promises.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// # Safety
/// `ptr` points to `len` writable numbers, or is NULL.
unsafe fn slice_mut<'a>(ptr: *mut f64, len: usize, what: &str) -> Result<&'a mut [f64], Failure> {
    if len == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(Failure::argument(format!("{what} must not be NULL")));
    }
    // SAFETY: `len` writable numbers at `ptr`, as the caller promises.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, len) })
}

fn size(a: usize, b: usize, what: &str) -> Result<usize, Failure> {
    a.checked_mul(b)
        .ok_or_else(|| Failure::argument(format!("{what}: {a} x {b} overflows")))
}

/// The commands of `n` steps (`dim` numbers each), checked.
fn commands_of(values: &[f64], dim: usize) -> Result<Vec<Input>, Failure> {
    finite("commands", values)?;
    Ok(values.chunks_exact(dim.max(1)).map(input_of).collect())
}

thread_local! {
    /// The commands of the last batch call on this thread, reused: a fresh buffer of a
    /// large batch costs more in page faults than the steps themselves.
    static COMMANDS: RefCell<Vec<Input>> = const { RefCell::new(Vec::new()) };
}

/// Runs `f` with the commands in `values` (`dim` numbers each, checked): the caller's own
/// buffer for a vehicle of three inputs, otherwise this thread's buffer.
fn with_commands<R>(
    values: &[f64],
    dim: usize,
    f: impl FnOnce(&[Input]) -> Result<R, Failure>,
) -> Result<R, Failure> {
    finite("commands", values)?;
    if dim == drive_traits::MAX_INPUTS {
        if let Ok(inputs) = bytemuck::try_cast_slice::<f64, Input>(values) {
            return f(inputs);
        }
    }
    COMMANDS.with(|cell| match cell.try_borrow_mut() {
        Ok(mut buffer) => {
            buffer.clear();
            buffer.extend(values.chunks_exact(dim.max(1)).map(input_of));
            f(&buffer)
        }
        Err(_) => f(&commands_of(values, dim)?),
    })
}

fn options(covariance: c_int) -> StepOptions {
    StepOptions::with_covariance(covariance != 0)
}

/// The numbers of one state of the model (with its covariance when `covariance` is
/// nonzero) into `*len`: a batch of B states is B x len doubles.
///
/// # Safety
/// `model` is NULL or a live model; `len` a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_state_len(
    model: *const drive_model,
    covariance: c_int,
    len: *mut usize,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let stepper = m
            .model
            .stepper(options(covariance))
            .map_err(Failure::model)?;
        // SAFETY: as the caller promises.
        match unsafe { len.as_mut() } {
            Some(l) => *l = stepper.state_len(),
            None => return Err(Failure::argument("len must not be NULL")),
        }
        Ok(())
    })
}

fn init_states(
    m: &Inner,
    stepper: &dyn Stepper,
    starts: &[drive_start],
    history: &[f64],
    states: &mut [f64],
    batch: usize,
) -> Result<(), Failure> {
    let dim = m.robot.vehicle.input_dim();
    if history.len() % dim != 0 {
        return Err(Failure::argument("history: not a whole number of commands"));
    }
    let history = commands_of(history, dim)?;
    let len = stepper.state_len();
    if starts.len() != 1 && starts.len() != batch {
        return Err(Failure::argument(format!(
            "{} starts for {batch} states: give one start, or one per state",
            starts.len()
        )));
    }
    let one = if starts.len() == 1 {
        Some(start_of(m, &starts[0])?)
    } else {
        None
    };
    // One start for every state: made once, copied (a state is plain numbers).
    if let (Some(start), true) = (one, len > 0) {
        let (first, rest) = states.split_at_mut(len.min(states.len()));
        if first.is_empty() {
            return Ok(());
        }
        stepper
            .init(&start, &history, first)
            .map_err(Failure::model)?;
        for s in rest.chunks_exact_mut(len) {
            s.copy_from_slice(first);
        }
        return Ok(());
    }
    let init = |(i, s): (usize, &mut [f64])| -> Result<(), Failure> {
        let start = match one {
            Some(s) => s,
            None => start_of(m, &starts[i])?,
        };
        stepper.init(&start, &history, s).map_err(Failure::model)
    };
    if batch <= SERIAL_STATES || len == 0 {
        states
            .chunks_exact_mut(len.max(1))
            .enumerate()
            .try_for_each(init)
    } else {
        use rayon::prelude::*;
        states
            .par_chunks_exact_mut(len)
            .enumerate()
            .try_for_each(init)
    }
}

/// Writes `batch` states (each `drive_state_len` numbers, consecutive in `states`) at their
/// start: `starts` holds one start for every state (`n_starts` 1) or one per state
/// (`n_starts` = `batch`); `history` the `history_len` commands already sent before the
/// start (oldest first, `drive_model_input_count` numbers each; NULL with 0): those still
/// inside the powertrain's dead time act in the first steps.
///
/// # Safety
/// `model` is NULL or a live model; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_state_init(
    model: *const drive_model,
    covariance: c_int,
    starts: *const drive_start,
    n_starts: usize,
    history: *const f64,
    history_len: usize,
    states: *mut f64,
    batch: usize,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let stepper = m
            .model
            .stepper(options(covariance))
            .map_err(Failure::model)?;
        let dim = m.robot.vehicle.input_dim();
        if starts.is_null() || n_starts == 0 {
            return Err(Failure::argument(
                "starts must not be NULL, n_starts at least 1",
            ));
        }
        // SAFETY: `n_starts` starts, as the caller promises.
        let starts = unsafe { std::slice::from_raw_parts(starts, n_starts) };
        let history = unsafe { slice(history, size(history_len, dim, "history")?, "history") }?;
        let states = unsafe {
            slice_mut(
                states,
                size(batch, stepper.state_len(), "states")?,
                "states",
            )
        }?;
        init_states(m, stepper.as_ref(), starts, history, states, batch)
    })
}

fn step_states(
    stepper: &dyn Stepper,
    states: &mut [f64],
    commands: &[Input],
) -> Result<(), Failure> {
    if commands.len() <= SERIAL_STATES {
        stepper.step_batch(states, commands)
    } else {
        let chunk = commands
            .len()
            .div_ceil(rayon::current_num_threads())
            .max(SERIAL_STATES / 4);
        step_batch_parallel(stepper, states, commands, chunk)
    }
    .map_err(Failure::model)
}

/// Steps `batch` states (made by `drive_state_init` with the same `covariance`) one step
/// of `drive_model_dt` under `commands` (one command per state, `drive_model_input_count`
/// numbers each), in place, on the library's threads for a large batch.
///
/// # Safety
/// `model` is NULL or a live model; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_state_step(
    model: *const drive_model,
    covariance: c_int,
    states: *mut f64,
    batch: usize,
    commands: *const f64,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let stepper = m
            .model
            .stepper(options(covariance))
            .map_err(Failure::model)?;
        let dim = m.robot.vehicle.input_dim();
        let states = unsafe {
            slice_mut(
                states,
                size(batch, stepper.state_len(), "states")?,
                "states",
            )
        }?;
        let commands = unsafe { slice(commands, size(batch, dim, "commands")?, "commands") }?;
        with_commands(commands, dim, |commands| {
            step_states(stepper.as_ref(), states, commands)
        })
    })
}

/// A pointer, or `None` for NULL.
///
/// # Safety
/// `ptr` is NULL or points to `len` writable numbers.
unsafe fn optional_mut<'a>(ptr: *mut f64, len: usize) -> Option<&'a mut [f64]> {
    // SAFETY: as the caller promises.
    (!ptr.is_null()).then(|| unsafe { std::slice::from_raw_parts_mut(ptr, len) })
}

#[allow(clippy::too_many_arguments)]
fn rollout(
    m: &Inner,
    stepper: &dyn Stepper,
    states: &mut [f64],
    batch: usize,
    commands: &[f64],
    horizon: usize,
    poses: Option<&mut [f64]>,
    velocities: Option<&mut [f64]>,
    covariances: Option<&mut [f64]>,
) -> Result<(), Failure> {
    let dim = m.robot.vehicle.input_dim();
    finite("commands", commands)?;
    let convert = |values: &[f64], out: &mut Vec<Input>| {
        out.clear();
        out.extend(values.chunks_exact(dim.max(1)).map(input_of));
        0
    };
    chunked_rollout(
        stepper,
        states,
        batch,
        horizon,
        (commands, dim),
        &convert,
        [poses, velocities],
        covariances,
    )
    .map(|_| ())
}

/// Rolls `batch` states through `horizon` commands each, in parallel over chunks of states,
/// each chunk turning its own commands (`commands.0`, `commands.1` numbers a command) into
/// inputs with `convert` (which returns how many it could not give exactly): the
/// conversion runs on the chunk's thread, into its reused buffer. Writes `outputs`' poses
/// and velocities (three doubles a row) and `covariances` (nine, row-major) when given;
/// returns the conversions' count.
#[allow(clippy::too_many_arguments)]
fn chunked_rollout(
    stepper: &dyn Stepper,
    states: &mut [f64],
    batch: usize,
    horizon: usize,
    commands: (&[f64], usize),
    convert: &(dyn Fn(&[f64], &mut Vec<Input>) -> usize + Sync),
    outputs: [Option<&mut [f64]>; 2],
    covariances: Option<&mut [f64]>,
) -> Result<usize, Failure> {
    use rayon::prelude::*;
    let len = stepper.state_len();
    if covariances.is_some() && !stepper.with_covariance() {
        return Err(Failure::argument(
            "covariances asked of states made without the covariance (covariance = 0)",
        ));
    }
    let [poses, velocities] = outputs;
    let (poses, velocities) = (as_vectors(poses)?, as_vectors(velocities)?);
    if batch == 0 || horizon == 0 || len == 0 {
        return Ok(0);
    }
    let chunk = batch.div_ceil(2 * rayon::current_num_threads()).max(32);
    let count = batch.div_ceil(chunk);
    let (poses, velocities, covariances) = (
        split(poses, chunk * horizon, count),
        split(velocities, chunk * horizon, count),
        split(covariances, chunk * horizon * 9, count),
    );
    let (values, width) = commands;
    states
        .par_chunks_mut(chunk * len)
        .zip(values.par_chunks(chunk * horizon * width))
        .zip(poses.into_par_iter())
        .zip(velocities.into_par_iter())
        .zip(covariances.into_par_iter())
        .map(|((((s, c), p), v), cv)| -> Result<usize, Failure> {
            let states_here = s.len() / len;
            let run = |inputs: &mut Vec<Input>| -> Result<usize, Failure> {
                let missed = convert(c, inputs);
                let mut local = cv
                    .as_ref()
                    .map(|_| vec![PoseCovariance::zeros(); states_here * horizon]);
                rollout_states(
                    stepper,
                    s,
                    inputs,
                    horizon,
                    StepOutputs {
                        poses: p,
                        velocities: v,
                        covariances: local.as_deref_mut(),
                    },
                    states_here,
                )
                .map_err(Failure::model)?;
                if let (Some(out), Some(local)) = (cv, local) {
                    for (o, c) in out.chunks_exact_mut(9).zip(&local) {
                        for r in 0..3 {
                            for k in 0..3 {
                                o[3 * r + k] = c[(r, k)];
                            }
                        }
                    }
                }
                Ok(missed)
            };
            // This thread's buffer of inputs, reused from call to call.
            COMMANDS.with(|cell| match cell.try_borrow_mut() {
                Ok(mut buffer) => run(&mut buffer),
                Err(_) => run(&mut Vec::new()),
            })
        })
        .try_reduce(|| 0, |a, b| Ok(a + b))
}

/// A caller's buffer of doubles as vectors of three (poses, body velocities).
fn as_vectors(b: Option<&mut [f64]>) -> Result<Option<&mut [Pose]>, Failure> {
    b.map(|b| {
        bytemuck::try_cast_slice_mut::<f64, Pose>(b).map_err(|e| {
            Failure(
                DRIVE_ERROR_INTERNAL,
                format!("a buffer of doubles as vectors: {e}"),
            )
        })
    })
    .transpose()
}

/// Steps every one of `batch` states through its `horizon` commands (`commands` holds
/// batch x horizon x `drive_model_input_count` numbers, state by state), in parallel,
/// writing after every step what is asked (each NULL or batch x horizon rows): `poses`
/// (x, y, yaw), `velocities` (the body velocity of the step, v_x, v_y, w) and
/// `covariances` (row-major 3 x 3, of states made with the covariance). The states are
/// left after their last step. What a controller that samples many command sequences from
/// the robot's state (Nav2's MPPI) calls once per cycle.
///
/// # Safety
/// `model` is NULL or a live model; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_state_rollout(
    model: *const drive_model,
    covariance: c_int,
    states: *mut f64,
    batch: usize,
    commands: *const f64,
    horizon: usize,
    poses: *mut f64,
    velocities: *mut f64,
    covariances: *mut f64,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let stepper = m
            .model
            .stepper(options(covariance))
            .map_err(Failure::model)?;
        let dim = m.robot.vehicle.input_dim();
        let n = size(batch, horizon, "batch x horizon")?;
        let states = unsafe {
            slice_mut(
                states,
                size(batch, stepper.state_len(), "states")?,
                "states",
            )
        }?;
        let commands = unsafe { slice(commands, size(n, dim, "commands")?, "commands") }?;
        let (poses, velocities, covariances) = unsafe {
            (
                optional_mut(poses, size(n, 3, "poses")?),
                optional_mut(velocities, size(n, 3, "velocities")?),
                optional_mut(covariances, size(n, 9, "covariances")?),
            )
        };
        rollout(
            m,
            stepper.as_ref(),
            states,
            batch,
            commands,
            horizon,
            poses,
            velocities,
            covariances,
        )
    })
}

/// [`drive_state_rollout`] with the commands given as body velocities (`body`: batch x
/// horizon x 3 numbers, v_x, v_y, w, state by state), each turned into the vehicle's
/// inputs as [`drive_model_inputs_for_batch`] turns it (the nearest input where the
/// vehicle has none, counted in `*unreachable` when not NULL): for a controller that
/// samples body velocities (Nav2's MPPI samples vx, vy, wz), without a buffer of inputs.
///
/// # Safety
/// `model` is NULL or a live model; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_state_rollout_body(
    model: *const drive_model,
    covariance: c_int,
    states: *mut f64,
    batch: usize,
    body: *const f64,
    horizon: usize,
    poses: *mut f64,
    velocities: *mut f64,
    unreachable: *mut usize,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let stepper = m
            .model
            .stepper(options(covariance))
            .map_err(Failure::model)?;
        let len = stepper.state_len();
        let n = size(batch, horizon, "batch x horizon")?;
        let states = unsafe { slice_mut(states, size(batch, len, "states")?, "states") }?;
        let body = unsafe { slice(body, size(n, 3, "body")?, "body") }?;
        finite("body", body)?;
        let (poses, velocities) = unsafe {
            (
                optional_mut(poses, size(n, 3, "poses")?),
                optional_mut(velocities, size(n, 3, "velocities")?),
            )
        };
        let vehicle = m.robot.vehicle.as_ref();
        let convert = |values: &[f64], out: &mut Vec<Input>| nearest_inputs(vehicle, values, out);
        let missed = chunked_rollout(
            stepper.as_ref(),
            states,
            batch,
            horizon,
            (body, 3),
            &convert,
            [poses, velocities],
            None,
        )?;
        // SAFETY: NULL or valid, as the caller promises.
        if let Some(u) = unsafe { unreachable.as_mut() } {
            *u = missed;
        }
        Ok(())
    })
}

/// `v` in chunks of `size` (`count` of them), or `count` times `None`.
fn split<T>(v: Option<&mut [T]>, size: usize, count: usize) -> Vec<Option<&mut [T]>> {
    match v {
        Some(v) => v.chunks_mut(size).map(Some).collect(),
        None => (0..count).map(|_| None).collect(),
    }
}

/// A batch of states owned by the library (opaque to C): the model's, its states' numbers,
/// and whether they carry the covariance.
pub struct drive_states {
    inner: Arc<Inner>,
    covariance: bool,
    batch: usize,
    len: usize,
    data: Vec<f64>,
}

/// Makes `batch` states of `model` (with the covariance when `covariance` is nonzero) into
/// `*out`, at rest at the origin; free them with [`drive_states_free`]. They hold the
/// model: freeing the model first is allowed.
///
/// # Safety
/// `model` is NULL or a live model; `out` a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_new(
    model: *const drive_model,
    batch: usize,
    covariance: c_int,
    out: *mut *mut drive_states,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model.as_ref() }.ok_or_else(|| Failure::argument("the model is NULL"))?;
        if out.is_null() {
            return Err(Failure::argument("out must not be NULL"));
        }
        let inner = Arc::clone(&m.inner);
        let len = inner
            .model
            .stepper(options(covariance))
            .map_err(Failure::model)?
            .state_len();
        let numbers = size(batch, len, "states")?;
        let mut data = Vec::new();
        data.try_reserve_exact(numbers).map_err(|_| {
            Failure::argument(format!(
                "{batch} states of {len} numbers do not fit in memory"
            ))
        })?;
        data.resize(numbers, 0.0);
        let mut states = drive_states {
            inner,
            covariance: covariance != 0,
            batch,
            len,
            data,
        };
        let rest = drive_start::default();
        {
            let stepper = states
                .inner
                .model
                .stepper(options(covariance))
                .map_err(Failure::model)?;
            init_states(
                &states.inner,
                stepper.as_ref(),
                &[rest],
                &[],
                &mut states.data,
                batch,
            )?;
        }
        // SAFETY: `out` is a valid pointer, as the caller promises.
        unsafe { *out = Box::into_raw(Box::new(states)) };
        Ok(())
    })
}

/// Frees states (NULL is ignored).
///
/// # Safety
/// `states` is NULL or states from `drive_states_new` not freed before.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_free(states: *mut drive_states) {
    if !states.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: states this library allocated, freed once.
            drop(unsafe { Box::from_raw(states) });
        }));
    }
}

/// The states' numbers (batch x `drive_states_state_len`), writable: state `i`'s pose is
/// at `i * state_len + DRIVE_STATE_POSE`. NULL for NULL states.
///
/// # Safety
/// `states` is NULL or live states.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_data(states: *mut drive_states) -> *mut f64 {
    // SAFETY: as the caller promises.
    unsafe { states.as_mut() }.map_or(std::ptr::null_mut(), |s| s.data.as_mut_ptr())
}

/// The numbers of one state (0 for NULL states).
///
/// # Safety
/// `states` is NULL or live states.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_state_len(states: *const drive_states) -> usize {
    // SAFETY: as the caller promises.
    unsafe { states.as_ref() }.map_or(0, |s| s.len)
}

/// The number of states (0 for NULL states).
///
/// # Safety
/// `states` is NULL or live states.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_batch(states: *const drive_states) -> usize {
    // SAFETY: as the caller promises.
    unsafe { states.as_ref() }.map_or(0, |s| s.batch)
}

/// # Safety
/// `states` is NULL or live states.
unsafe fn states_mut<'a>(states: *mut drive_states) -> Result<&'a mut drive_states, Failure> {
    // SAFETY: as the caller promises.
    unsafe { states.as_mut() }.ok_or_else(|| Failure::argument("the states are NULL"))
}

/// Sets the states at their starts (see [`drive_state_init`]).
///
/// # Safety
/// `states` is NULL or live states; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_init(
    states: *mut drive_states,
    starts: *const drive_start,
    n_starts: usize,
    history: *const f64,
    history_len: usize,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let s = unsafe { states_mut(states) }?;
        if starts.is_null() || n_starts == 0 {
            return Err(Failure::argument(
                "starts must not be NULL, n_starts at least 1",
            ));
        }
        let dim = s.inner.robot.vehicle.input_dim();
        // SAFETY: as the caller promises.
        let starts = unsafe { std::slice::from_raw_parts(starts, n_starts) };
        let history = unsafe { slice(history, size(history_len, dim, "history")?, "history") }?;
        let stepper = s
            .inner
            .model
            .stepper(options(c_int::from(s.covariance)))
            .map_err(Failure::model)?;
        init_states(
            &s.inner,
            stepper.as_ref(),
            starts,
            history,
            &mut s.data,
            s.batch,
        )
    })
}

/// Steps the states by one command each (see [`drive_state_step`]).
///
/// # Safety
/// `states` is NULL or live states; `commands` holds batch x input_count numbers.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_step(
    states: *mut drive_states,
    commands: *const f64,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let s = unsafe { states_mut(states) }?;
        let dim = s.inner.robot.vehicle.input_dim();
        let commands = unsafe { slice(commands, size(s.batch, dim, "commands")?, "commands") }?;
        let stepper = s
            .inner
            .model
            .stepper(options(c_int::from(s.covariance)))
            .map_err(Failure::model)?;
        let data = &mut s.data;
        with_commands(commands, dim, |commands| {
            step_states(stepper.as_ref(), data, commands)
        })
    })
}

/// Steps the states through `horizon` commands each (see [`drive_state_rollout`]).
///
/// # Safety
/// `states` is NULL or live states; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_states_rollout(
    states: *mut drive_states,
    commands: *const f64,
    horizon: usize,
    poses: *mut f64,
    velocities: *mut f64,
    covariances: *mut f64,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let s = unsafe { states_mut(states) }?;
        let dim = s.inner.robot.vehicle.input_dim();
        let n = size(s.batch, horizon, "batch x horizon")?;
        let commands = unsafe { slice(commands, size(n, dim, "commands")?, "commands") }?;
        let (poses, velocities, covariances) = unsafe {
            (
                optional_mut(poses, size(n, 3, "poses")?),
                optional_mut(velocities, size(n, 3, "velocities")?),
                optional_mut(covariances, size(n, 9, "covariances")?),
            )
        };
        let stepper = s
            .inner
            .model
            .stepper(options(c_int::from(s.covariance)))
            .map_err(Failure::model)?;
        let batch = s.batch;
        rollout(
            &s.inner,
            stepper.as_ref(),
            &mut s.data,
            batch,
            commands,
            horizon,
            poses,
            velocities,
            covariances,
        )
    })
}

/// One rollout's poses and pose covariances.
type Rollout = (Vec<Pose>, Vec<PoseCovariance>);

/// The predicted poses of one command sequence from `start`, as `drive predict` prints
/// them: `commands` holds `horizon` commands (`drive_model_input_count` numbers each),
/// `poses` gets `horizon` rows of x, y, yaw (row k at time k * dt: row 0 the start, the
/// last command moves nothing). With `covariances` (NULL for none) `horizon` row-major
/// 3 x 3 pose covariances too, for a model with an uncertainty (`DRIVE_ERROR_MODEL`
/// otherwise). A prediction that is not finite is `DRIVE_ERROR_MODEL`, nothing written.
///
/// # Safety
/// `model` is NULL or a live model; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_predict(
    model: *const drive_model,
    start: *const drive_start,
    commands: *const f64,
    horizon: usize,
    poses: *mut f64,
    covariances: *mut f64,
) -> c_int {
    // SAFETY: as the caller promises (one start for a batch of one).
    unsafe { drive_predict_batch(model, start, 1, commands, horizon, poses, covariances) }
}

/// [`drive_predict`] for `batch` sequences at once, in parallel: `starts` one per sequence,
/// `commands` batch x horizon commands (sequence by sequence), `poses` batch x horizon rows
/// and `covariances` (NULL for none) batch x horizon 3 x 3 matrices.
///
/// # Safety
/// `model` is NULL or a live model; the buffers hold what their sizes say.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn drive_predict_batch(
    model: *const drive_model,
    starts: *const drive_start,
    batch: usize,
    commands: *const f64,
    horizon: usize,
    poses: *mut f64,
    covariances: *mut f64,
) -> c_int {
    guard(|| {
        // SAFETY: as the caller promises.
        let m = unsafe { model_ref(model) }?;
        let dim = m.robot.vehicle.input_dim();
        if starts.is_null() && batch > 0 {
            return Err(Failure::argument("starts must not be NULL"));
        }
        let starts: &[drive_start] = if batch == 0 {
            &[]
        } else {
            // SAFETY: `batch` starts, as the caller promises.
            unsafe { std::slice::from_raw_parts(starts, batch) }
        };
        let n = size(batch, horizon, "batch x horizon")?;
        let commands = commands_of(
            unsafe { slice(commands, size(n, dim, "commands")?, "commands") }?,
            dim,
        )?;
        let out = unsafe { slice_mut(poses, size(n, 3, "poses")?, "poses") }?;
        let cov_out = unsafe { optional_mut(covariances, size(n, 9, "covariances")?) };
        let starts: Vec<StartState> = starts
            .iter()
            .map(|s| start_of(m, s))
            .collect::<Result<_, _>>()?;
        let model = m.model.as_ref();
        let mut p = vec![Pose::zeros(); n];
        let mut c = Vec::new();
        if cov_out.is_some() {
            use rayon::prelude::*;
            let rows: Vec<Result<Rollout, MotionError>> = starts
                .par_iter()
                .enumerate()
                .map(|(i, s)| {
                    let (mut poses, mut covs) = (Vec::new(), Vec::new());
                    model.predict_with_covariance_into(
                        s,
                        &commands[i * horizon..(i + 1) * horizon],
                        &mut poses,
                        &mut covs,
                    )?;
                    Ok((poses, covs))
                })
                .collect();
            for (i, r) in rows.into_iter().enumerate() {
                let (poses, covs) = r.map_err(Failure::model)?;
                p[i * horizon..(i + 1) * horizon].copy_from_slice(&poses);
                c.extend(covs);
            }
        } else {
            predict_batch_parallel(model, &starts, &commands, horizon, &mut p, 64)
                .map_err(Failure::model)?;
        }
        for i in 0..batch {
            let rows = i * horizon..(i + 1) * horizon;
            let covs: &[PoseCovariance] = if c.is_empty() { &[] } else { &c[rows.clone()] };
            if let Some(e) = MotionError::not_finite(&model.name(), model.dt(), &p[rows], covs) {
                return Err(Failure::model(if batch > 1 {
                    format!("sequence {i}: {e}")
                } else {
                    e.to_string()
                }));
            }
        }
        for (o, p) in out.chunks_exact_mut(3).zip(&p) {
            o.copy_from_slice(p.as_slice());
        }
        if let Some(cov_out) = cov_out {
            for (o, c) in cov_out.chunks_exact_mut(9).zip(&c) {
                for r in 0..3 {
                    for k in 0..3 {
                        o[3 * r + k] = c[(r, k)];
                    }
                }
            }
        }
        Ok(())
    })
}
