// The ROS-free core of the Nav2 MPPI motion-model plug-in: a fitted DRIVE model (through the
// C library, drive.h) filling Nav2's velocity arrays from its sampled commands. Everything
// but the plug-in glue (drive_motion_model.hpp) is here, so that it is built and tested
// without ROS (test/test_core.cpp, run by the project's CI).
#ifndef DRIVE_NAV2_MPPI__DRIVE_MOTION_CORE_HPP_
#define DRIVE_NAV2_MPPI__DRIVE_MOTION_CORE_HPP_

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "drive.h"

namespace drive_nav2_mppi
{

/// A fitted DRIVE model as Nav2 MPPI's motion model. `predict` does what
/// `mppi::MotionModel::predict(models::State &)` must: fill `vx`, `vy`, `wz` (batch x time,
/// column 0 the measured speed, left as it is) from the sampled commands `cvx`, `cvy`,
/// `cwz` at Nav2's `model_dt`. Column j >= 1 is the body velocity the model predicts over
/// step j when command column k is sent at step k (the powertrain's dead time and lag, the
/// slip and its lagging velocity), from the measured speed at column 0 and the commands
/// already sent (Nav2's command history, oldest first).
class DriveMotionCore
{
public:
  /// Loads `model_file` (written by `drive train`); throws std::runtime_error when it cannot,
  /// or when `model_dt` (when not 0) is not the model's step (see checkStep).
  explicit DriveMotionCore(const std::string & model_file, float model_dt = 0.0f)
  {
    if (drive_model_load(model_file.c_str(), &model_) != DRIVE_OK) {
      throw std::runtime_error(std::string("drive: ") + drive_last_error());
    }
    dim_ = drive_model_input_count(model_);
    if (model_dt > 0.0f) {
      try {
        checkStep(model_dt);
      } catch (...) {
        drive_model_free(model_);
        throw;
      }
    }
    holonomic_ = std::string(drive_model_vehicle(model_)) == "omnidirectional";
    const std::string start = drive_model_fitted_start(model_);
    // What the model was fitted to start from (its file's fitted_with), "" for an older
    // file: the encoders and the IMU, as `drive eval` starts by default.
    imu_ = start.empty() || start.find("imu") != std::string::npos;
    localization_ = start.find("localization") != std::string::npos;
    if (drive_state_len(model_, 0, &state_len_) != DRIVE_OK) {
      throw std::runtime_error(std::string("drive: ") + drive_last_error());
    }
  }

  ~DriveMotionCore() {drive_model_free(model_);}
  DriveMotionCore(const DriveMotionCore &) = delete;
  DriveMotionCore & operator=(const DriveMotionCore &) = delete;

  /// Throws std::runtime_error unless `model_dt` is the model's step: Nav2's model_dt must
  /// be the model's command period (0.05 s for a model fitted at 20 Hz).
  void checkStep(float model_dt)
  {
    if (model_dt == checked_dt_) {
      return;
    }
    const double dt = drive_model_dt(model_);
    if (std::abs(dt - static_cast<double>(model_dt)) > 1e-6 * dt) {
      throw std::runtime_error(
              "drive: the model " + name() + " predicts in steps of " + std::to_string(dt) +
              " s and Nav2's model_dt is " + std::to_string(model_dt) +
              " s: set model_dt to the model's command period");
    }
    checked_dt_ = model_dt;
  }

  /// Whether the vehicle moves sideways (an omnidirectional base): Nav2's isHolonomic.
  bool holonomic() const {return holonomic_;}
  /// The model's name (`slip-blr+fopdt`).
  std::string name() const {return drive_model_name(model_);}
  /// Sampled commands (and history entries) of the last `predict` the vehicle had no input
  /// for (a yaw rate at zero speed for a car): each was given its nearest input.
  std::size_t unreachable() const {return unreachable_;}

  /// Fills columns 1.. of `vx`, `vy` (holonomic only), `wz` (batch x time) from `cvx`,
  /// `cvy`, `cwz` (the same shape), column 0 the measured speed; `history` the body
  /// commands already sent (vx, vy, wz), oldest first (empty: none known). Throws
  /// std::runtime_error on a library error (its message).
  void predict(
    Eigen::ArrayXXf & vx, Eigen::ArrayXXf & vy, Eigen::ArrayXXf & wz,
    const Eigen::ArrayXXf & cvx, const Eigen::ArrayXXf & cvy, const Eigen::ArrayXXf & cwz,
    const std::vector<std::array<float, 3>> & history)
  {
    const std::size_t b = static_cast<std::size_t>(vx.rows());
    const std::size_t t = static_cast<std::size_t>(vx.cols());
    if (b == 0 || t < 2) {
      return;
    }
    unreachable_ = 0;
    // The commands state by state (Nav2's arrays are column-major, time by time): in
    // tiles of rows, so that neither side strides across the whole arrays.
    body_.resize(b * t * 3);
    for (std::size_t i0 = 0; i0 < b; i0 += kTile) {
      const std::size_t i1 = std::min(b, i0 + kTile);
      for (std::size_t j = 0; j < t; ++j) {
        for (std::size_t i = i0; i < i1; ++i) {
          double * v = &body_[(i * t + j) * 3];
          v[0] = cvx(i, j);
          v[1] = holonomic_ ? static_cast<double>(cvy(i, j)) : 0.0;
          v[2] = cwz(i, j);
        }
      }
    }
    std::size_t missed = 0;
    // The commands already sent, as inputs.
    history_body_.resize(history.size() * 3);
    for (std::size_t k = 0; k < history.size(); ++k) {
      history_body_[3 * k] = history[k][0];
      history_body_[3 * k + 1] = holonomic_ ? history[k][1] : 0.0f;
      history_body_[3 * k + 2] = history[k][2];
    }
    history_.resize(history.size() * dim_);
    if (!history.empty()) {
      check(drive_model_inputs_for_batch(
          model_, history_body_.data(), history.size(), history_.data(), &missed));
      unreachable_ += missed;
    }
    // One start per state, from its measured speed (column 0): the inputs that command it,
    // the yaw rate (the IMU's, for a model fitted with it) and the velocity (the
    // localization's, for a model fitted with it).
    starts_.resize(b);
    start_body_.resize(b * 3);
    start_inputs_.resize(b * dim_);
    for (std::size_t i = 0; i < b; ++i) {
      start_body_[3 * i] = vx(i, 0);
      start_body_[3 * i + 1] = holonomic_ ? static_cast<double>(vy(i, 0)) : 0.0;
      start_body_[3 * i + 2] = wz(i, 0);
    }
    check(drive_model_inputs_for_batch(
        model_, start_body_.data(), b, start_inputs_.data(), &missed));
    unreachable_ += missed;
    for (std::size_t i = 0; i < b; ++i) {
      drive_start & s = starts_[i];
      drive_start_rest(&s);
      for (std::size_t d = 0; d < dim_; ++d) {
        s.inputs[d] = start_inputs_[i * dim_ + d];
      }
      s.has_yaw_rate = imu_ ? 1 : 0;
      s.yaw_rate = start_body_[3 * i + 2];
      s.has_velocity = localization_ ? 1 : 0;
      s.velocity[0] = start_body_[3 * i];
      s.velocity[1] = start_body_[3 * i + 1];
    }
    // Nav2 measures one speed for every sampled sequence: one start then, made once.
    bool same = true;
    for (std::size_t i = 1; i < b && same; ++i) {
      same = start_body_[3 * i] == start_body_[0] && start_body_[3 * i + 1] == start_body_[1] &&
        start_body_[3 * i + 2] == start_body_[2];
    }
    states_.resize(b * state_len_);
    check(drive_state_init(
        model_, 0, starts_.data(), same ? 1 : b, history_.empty() ? nullptr : history_.data(),
        history.size(), states_.data(), b));
    // Every state through its t commands (turned into the vehicle's inputs on the way);
    // the velocity over step j fills column j.
    velocities_.resize(b * t * 3);
    check(drive_state_rollout_body(
        model_, 0, states_.data(), b, body_.data(), t, nullptr, velocities_.data(), &missed));
    unreachable_ += missed;
    for (std::size_t i0 = 0; i0 < b; i0 += kTile) {
      const std::size_t i1 = std::min(b, i0 + kTile);
      for (std::size_t j = 1; j < t; ++j) {
        for (std::size_t i = i0; i < i1; ++i) {
          const double * v = &velocities_[(i * t + j) * 3];
          vx(i, j) = static_cast<float>(v[0]);
          if (holonomic_) {
            vy(i, j) = static_cast<float>(v[1]);
          }
          wz(i, j) = static_cast<float>(v[2]);
        }
      }
    }
  }

private:
  /// Rows per tile of the transposition between Nav2's arrays and the library's buffers.
  static constexpr std::size_t kTile = 64;

  static void check(int status)
  {
    if (status != DRIVE_OK) {
      throw std::runtime_error(std::string("drive: ") + drive_last_error());
    }
  }

  drive_model * model_{nullptr};
  std::size_t dim_{0};
  std::size_t state_len_{0};
  bool holonomic_{false};
  bool imu_{true};
  bool localization_{false};
  std::size_t unreachable_{0};
  float checked_dt_{0.0f};
  std::vector<double> body_, history_body_, history_, start_body_, start_inputs_;
  std::vector<double> states_, velocities_;
  std::vector<drive_start> starts_;
};

}  // namespace drive_nav2_mppi

#endif  // DRIVE_NAV2_MPPI__DRIVE_MOTION_CORE_HPP_
