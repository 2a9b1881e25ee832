/*
 * drive.h: the C library of fitted DRIVE models (libdrive_capi, the crate drive-capi).
 *
 * Load a model file written by `drive train`, ask what it is (vehicle, input axes, rate),
 * predict batches of rollouts with and without their covariance, and step batches of
 * states one command at a time: the model's whole state (pose, the powertrain's wheels and
 * the commands inside its dead time, the slip model's own state, the pose covariance) in
 * one row of doubles per state, for a controller that calls dynamics(state, action).
 *
 * Errors: a function returns DRIVE_OK (0) or a negative DRIVE_ERROR_*; drive_last_error()
 * then gives the message (per thread). Nothing panics or aborts across this boundary.
 *
 * Threads: a drive_model is immutable once loaded; every function taking a
 * `const drive_model *` may run on several threads at once. A state buffer or a
 * drive_states must not be used by two threads at once. Batch functions run on the
 * library's thread pool (RAYON_NUM_THREADS sets its size).
 *
 * Build: cargo build --release -p drive-capi, then link target/release/libdrive_capi.so
 * (or the static libdrive_capi.a with -lpthread -ldl -lm). Checked against the Rust
 * functions by .ci/check-capi-header. See docs/deploying.md.
 */
#ifndef DRIVE_H
#define DRIVE_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Status codes. */
#define DRIVE_OK 0
/* An argument is wrong: NULL, a size that does not match, a value not finite. */
#define DRIVE_ERROR_ARGUMENT (-1)
/* The model file cannot be read or is not one `drive train` writes. */
#define DRIVE_ERROR_FILE (-2)
/* The model cannot do it: no covariance, a history for a model stepped by replay, a
 * prediction that is not finite. */
#define DRIVE_ERROR_MODEL (-3)
/* An internal error (a panic inside the library, caught): a bug to report. */
#define DRIVE_ERROR_INTERNAL (-4)

/* Where a state's values are (in doubles from the start of the state): the pose x, y, yaw;
 * the body velocity of its last step v_x, v_y, w; its pose covariance (row-major 3 x 3,
 * zero unless the states carry it); its step count. The model's own state follows. */
#define DRIVE_STATE_POSE 0
#define DRIVE_STATE_VELOCITY 3
#define DRIVE_STATE_COVARIANCE 6
#define DRIVE_STATE_STEPS 15

/* A fitted model (opaque). */
typedef struct drive_model drive_model;

/* A batch of states owned by the library (opaque). */
typedef struct drive_states drive_states;

/* What is known at the start: the pose (x, y, yaw), the measured inputs (the first
 * drive_model_input_count: the encoders' wheel velocities of a differential drive), and,
 * when measured, the IMU's yaw rate and the localization's body velocity just before. */
typedef struct drive_start {
    double pose[3];
    double inputs[3];
    int has_yaw_rate;
    double yaw_rate;
    int has_velocity;
    double velocity[2];
} drive_start;

/* The message of the last failing call on this thread ("" if none). */
const char *drive_last_error(void);
/* The library's version ("0.1.0"). */
const char *drive_version(void);

/* Loading. */
int drive_model_load(const char *path, drive_model **out);
int drive_model_from_json(const char *text, size_t len, drive_model **out);
void drive_model_free(drive_model *model);

/* What the model is. Strings are owned by the model; NULL on error. */
const char *drive_model_name(const drive_model *model);
const char *drive_model_vehicle(const drive_model *model);
const char *drive_model_fitted_start(const drive_model *model);
double drive_model_dt(const drive_model *model);
size_t drive_model_input_count(const drive_model *model);
const char *drive_model_input_name(const drive_model *model, size_t axis);
const char *drive_model_input_unit(const drive_model *model, size_t axis);
const char *drive_model_command_column(const drive_model *model, size_t axis);
int drive_model_has_uncertainty(const drive_model *model);
/* The vehicle's inputs for a body velocity (v_x, v_y, w), and the body velocity of inputs. */
int drive_model_inputs_for(const drive_model *model, const double *body, double *inputs);
int drive_model_body_velocity(const drive_model *model, const double *inputs, double *body);
/* n body velocities (n x 3) to inputs (n x input_count): one without an input of its own gets
 * the nearest (the sideways velocity dropped, then the yaw rate), counted in *unreachable. */
int drive_model_inputs_for_batch(const drive_model *model, const double *body, size_t n,
                                 double *inputs, size_t *unreachable);

/* A start at rest at the origin, nothing measured. */
void drive_start_rest(drive_start *start);

/* States in caller-provided buffers: batch x state_len doubles. `covariance` nonzero for
 * states that carry the pose covariance; use the same value for every call on them. */
int drive_state_len(const drive_model *model, int covariance, size_t *len);
int drive_state_init(const drive_model *model, int covariance, const drive_start *starts,
                     size_t n_starts, const double *history, size_t history_len, double *states,
                     size_t batch);
int drive_state_step(const drive_model *model, int covariance, double *states, size_t batch,
                     const double *commands);
int drive_state_rollout(const drive_model *model, int covariance, double *states, size_t batch,
                        const double *commands, size_t horizon, double *poses, double *velocities,
                        double *covariances);

/* drive_state_rollout with the commands as body velocities (batch x horizon x 3: v_x, v_y,
 * w), each turned into the vehicle's inputs as drive_model_inputs_for_batch does. */
int drive_state_rollout_body(const drive_model *model, int covariance, double *states,
                             size_t batch, const double *body, size_t horizon, double *poses,
                             double *velocities, size_t *unreachable);

/* States owned by the library (they hold the model: freeing the model first is allowed). */
int drive_states_new(const drive_model *model, size_t batch, int covariance, drive_states **out);
void drive_states_free(drive_states *states);
double *drive_states_data(drive_states *states);
size_t drive_states_state_len(const drive_states *states);
size_t drive_states_batch(const drive_states *states);
int drive_states_init(drive_states *states, const drive_start *starts, size_t n_starts,
                      const double *history, size_t history_len);
int drive_states_step(drive_states *states, const double *commands);
int drive_states_rollout(drive_states *states, const double *commands, size_t horizon,
                         double *poses, double *velocities, double *covariances);

/* Predictions, as `drive predict`: horizon rows of poses (row 0 the start), with their
 * covariances when `covariances` is not NULL. */
int drive_predict(const drive_model *model, const drive_start *start, const double *commands,
                  size_t horizon, double *poses, double *covariances);
int drive_predict_batch(const drive_model *model, const drive_start *starts, size_t batch,
                        const double *commands, size_t horizon, double *poses,
                        double *covariances);

#ifdef __cplusplus
}
#endif

#endif /* DRIVE_H */
