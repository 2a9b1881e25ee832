//! The C library's functions called as C calls them: statuses and messages for every kind of
//! wrong argument (never a panic across the boundary), the queries, stepping and rollouts
//! against the prediction, library-owned states outliving their model.

use drive_capi::*;
use std::ffi::{CStr, CString};
use std::ptr::{null, null_mut};

/// The naive model of the bundled Husky (a model file written by `drive train`).
fn naive() -> *mut drive_model {
    let path = CString::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/naive.json")).unwrap();
    let mut model = null_mut();
    assert_eq!(
        unsafe { drive_model_load(path.as_ptr(), &mut model) },
        DRIVE_OK
    );
    model
}

fn last_error() -> String {
    unsafe { CStr::from_ptr(drive_last_error()) }
        .to_string_lossy()
        .into_owned()
}

fn text(p: *const std::ffi::c_char) -> String {
    assert!(!p.is_null());
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

#[test]
fn queries_describe_the_model_and_its_vehicle() {
    let m = naive();
    unsafe {
        assert_eq!(text(drive_model_name(m)), "no-slip+commanded");
        assert_eq!(text(drive_model_vehicle(m)), "differential");
        assert_eq!(text(drive_model_fitted_start(m)), "encoders+imu");
        assert_eq!(drive_model_dt(m), 0.05);
        assert_eq!(drive_model_input_count(m), 2);
        assert_eq!(text(drive_model_input_name(m, 1)), "right");
        assert_eq!(text(drive_model_input_unit(m, 0)), "rad/s");
        assert_eq!(text(drive_model_command_column(m, 0)), "cmd_left");
        assert!(drive_model_input_name(m, 2).is_null());
        assert!(last_error().contains("2 input axes"));
        assert_eq!(drive_model_has_uncertainty(m), 0);
        // Eq. 4 both ways: r = 0.165 m, b = 0.55 m.
        let mut u = [0.0; 2];
        assert_eq!(
            drive_model_inputs_for(m, [1.0, 0.0, 0.0].as_ptr(), u.as_mut_ptr()),
            DRIVE_OK
        );
        assert!((u[0] - 1.0 / 0.165).abs() < 1e-12 && (u[1] - u[0]).abs() < 1e-12);
        let mut v = [0.0; 3];
        assert_eq!(
            drive_model_body_velocity(m, u.as_ptr(), v.as_mut_ptr()),
            DRIVE_OK
        );
        assert!((v[0] - 1.0).abs() < 1e-12);
        // A sideways velocity has no input: an error; the batch gives the nearest and counts it.
        assert_eq!(
            drive_model_inputs_for(m, [1.0, 0.5, 0.0].as_ptr(), u.as_mut_ptr()),
            DRIVE_ERROR_MODEL
        );
        let body = [1.0, 0.5, 0.0, 1.0, 0.0, 0.0];
        let mut inputs = [0.0; 4];
        let mut unreachable = 0;
        assert_eq!(
            drive_model_inputs_for_batch(
                m,
                body.as_ptr(),
                2,
                inputs.as_mut_ptr(),
                &mut unreachable
            ),
            DRIVE_OK
        );
        assert_eq!(unreachable, 1);
        assert_eq!(inputs[..2], inputs[2..]);
        drive_model_free(m);
    }
}

#[test]
fn wrong_arguments_are_statuses_with_messages() {
    let m = naive();
    unsafe {
        let mut out = null_mut();
        assert_eq!(drive_model_load(null(), &mut out), DRIVE_ERROR_ARGUMENT);
        let missing = CString::new("/nonexistent/model.json").unwrap();
        assert_eq!(
            drive_model_load(missing.as_ptr(), &mut out),
            DRIVE_ERROR_FILE
        );
        assert!(last_error().contains("/nonexistent/model.json"));
        let junk = "{\"format_version\": 2}";
        assert_eq!(
            drive_model_from_json(junk.as_ptr().cast(), junk.len(), &mut out),
            DRIVE_ERROR_FILE
        );
        assert!(last_error().contains("'format'"), "{}", last_error());
        let junk = "{\"format\": \"drive-motion-model\", \"format_version\": 2}";
        assert_eq!(
            drive_model_from_json(junk.as_ptr().cast(), junk.len(), &mut out),
            DRIVE_ERROR_FILE
        );
        assert!(last_error().contains("robot"), "{}", last_error());
        assert!(out.is_null());
        // NULL models.
        assert!(drive_model_name(null()).is_null());
        assert_eq!(drive_model_input_count(null()), 0);
        assert_eq!(drive_model_has_uncertainty(null()), -1);
        let mut start = drive_start::default();
        drive_start_rest(&mut start);
        let commands = [1.0; 6];
        let mut poses = [0.0; 9];
        assert_eq!(
            drive_predict(
                null(),
                &start,
                commands.as_ptr(),
                3,
                poses.as_mut_ptr(),
                null_mut()
            ),
            DRIVE_ERROR_ARGUMENT
        );
        // No output buffer; a command that is not a number; a covariance of a model without one.
        assert_eq!(
            drive_predict(m, &start, commands.as_ptr(), 3, null_mut(), null_mut()),
            DRIVE_ERROR_ARGUMENT
        );
        let nan = [f64::NAN, 1.0];
        assert_eq!(
            drive_predict(m, &start, nan.as_ptr(), 1, poses.as_mut_ptr(), null_mut()),
            DRIVE_ERROR_ARGUMENT
        );
        assert!(last_error().contains("commands"));
        let mut cov = [0.0; 27];
        assert_eq!(
            drive_predict(
                m,
                &start,
                commands.as_ptr(),
                3,
                poses.as_mut_ptr(),
                cov.as_mut_ptr()
            ),
            DRIVE_ERROR_MODEL
        );
        assert!(last_error().contains("uncertainty"));
        let mut len = 0;
        assert_eq!(drive_state_len(m, 1, &mut len), DRIVE_ERROR_MODEL);
        // A start beyond 1e9.
        start.pose[0] = 1e300;
        assert_eq!(
            drive_predict(
                m,
                &start,
                commands.as_ptr(),
                3,
                poses.as_mut_ptr(),
                null_mut()
            ),
            DRIVE_ERROR_ARGUMENT
        );
        // One start for three states is fine, two are not.
        drive_start_rest(&mut start);
        assert_eq!(drive_state_len(m, 0, &mut len), DRIVE_OK);
        let mut states = vec![0.0; 3 * len];
        let two = [start, start];
        assert_eq!(
            drive_state_init(m, 0, two.as_ptr(), 2, null(), 0, states.as_mut_ptr(), 3),
            DRIVE_ERROR_ARGUMENT
        );
        assert_eq!(
            drive_state_init(m, 0, two.as_ptr(), 1, null(), 0, states.as_mut_ptr(), 3),
            DRIVE_OK
        );
        drive_model_free(m);
        drive_model_free(null_mut());
        drive_states_free(null_mut());
    }
}

#[test]
fn stepping_and_rollouts_equal_the_prediction() {
    let m = naive();
    unsafe {
        let mut start = drive_start::default();
        drive_start_rest(&mut start);
        start.pose = [1.0, 2.0, 0.5];
        start.inputs = [2.0, 4.0, 0.0];
        let horizon = 30;
        let commands: Vec<f64> = (0..horizon)
            .flat_map(|k| [3.0 + k as f64 * 0.1, 5.0 - k as f64 * 0.2])
            .collect();
        let mut poses = vec![0.0; horizon * 3];
        assert_eq!(
            drive_predict(
                m,
                &start,
                commands.as_ptr(),
                horizon,
                poses.as_mut_ptr(),
                null_mut()
            ),
            DRIVE_OK
        );
        // Library-owned states, stepped one command at a time.
        let mut states = null_mut();
        assert_eq!(drive_states_new(m, 4, 0, &mut states), DRIVE_OK);
        assert_eq!(drive_states_init(states, &start, 1, null(), 0), DRIVE_OK);
        let len = drive_states_state_len(states);
        assert_eq!(drive_states_batch(states), 4);
        // The model may be freed first: the states hold it.
        drive_model_free(m);
        for k in 0..horizon - 1 {
            let step: Vec<f64> = (0..4)
                .flat_map(|_| [commands[2 * k], commands[2 * k + 1]])
                .collect();
            assert_eq!(drive_states_step(states, step.as_ptr()), DRIVE_OK);
            let data = std::slice::from_raw_parts(drive_states_data(states), 4 * len);
            for b in 0..4 {
                let pose = &data[b * len + DRIVE_STATE_POSE..b * len + DRIVE_STATE_POSE + 3];
                for d in 0..3 {
                    assert!((pose[d] - poses[3 * (k + 1) + d]).abs() < 1e-12, "step {k}");
                }
                assert_eq!(data[b * len + DRIVE_STATE_STEPS], (k + 1) as f64);
            }
        }
        // A rollout of the same commands from a fresh start writes the same poses.
        assert_eq!(drive_states_init(states, &start, 1, null(), 0), DRIVE_OK);
        let all: Vec<f64> = (0..4).flat_map(|_| commands.clone()).collect();
        let mut rolled = vec![0.0; 4 * horizon * 3];
        let mut velocities = vec![0.0; 4 * horizon * 3];
        assert_eq!(
            drive_states_rollout(
                states,
                all.as_ptr(),
                horizon,
                rolled.as_mut_ptr(),
                velocities.as_mut_ptr(),
                null_mut()
            ),
            DRIVE_OK
        );
        for b in 0..4 {
            for k in 0..horizon - 1 {
                for d in 0..3 {
                    assert!(
                        (rolled[(b * horizon + k) * 3 + d] - poses[3 * (k + 1) + d]).abs() < 1e-12
                    );
                }
            }
        }
        // The naive model: the velocity over a step is eq. 4 of its command.
        assert!((velocities[0] - 0.165 * (3.0 + 5.0) / 2.0).abs() < 1e-12);
        // Covariances of states made without: refused.
        let mut cov = vec![0.0; 4 * horizon * 9];
        assert_eq!(
            drive_states_rollout(
                states,
                all.as_ptr(),
                horizon,
                null_mut(),
                null_mut(),
                cov.as_mut_ptr()
            ),
            DRIVE_ERROR_ARGUMENT
        );
        drive_states_free(states);
    }
}

#[test]
fn version_and_empty_messages() {
    assert_eq!(text(drive_version()), env!("CARGO_PKG_VERSION"));
    // A thread that never failed has an empty message.
    std::thread::spawn(|| assert_eq!(last_error(), ""))
        .join()
        .unwrap();
}
