// Tests the plug-in's ROS-free core (DriveMotionCore) at Nav2's default shape (batch 2000,
// 56 time steps, model_dt 0.05) against the Rust rollouts of the C library's prediction
// (drive_predict_batch: the model's own `predict`, not the step API the core uses):
//
//     test_core MODEL_FILE...
//
// For each model file: the velocities the core fills (columns 1..55) are the body
// velocities of the predicted poses, column 0 is left as measured; commands already sent
// that equal the measured speed change nothing, others do; a wrong model_dt is refused.
// Prints the core's time per call. Exits 1 on the first failure.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "drive_nav2_mppi/drive_motion_core.hpp"

using drive_nav2_mppi::DriveMotionCore;

namespace
{

int failures = 0;

void expect(bool ok, const std::string & what)
{
  if (!ok) {
    std::fprintf(stderr, "FAILED: %s\n", what.c_str());
    ++failures;
  }
}

// A reproducible uniform number in [lo, hi).
double uniform(unsigned long long & s, double lo, double hi)
{
  s = s * 6364136223846793005ULL + 1442695040888963407ULL;
  return lo + (hi - lo) * static_cast<double>(s >> 11) / 9007199254740992.0;
}

struct Nav2State
{
  Eigen::ArrayXXf vx, vy, wz, cvx, cvy, cwz;
};

// Nav2's state: commands sampled around a plan, the measured speed in column 0 (the same
// for every row when `same_start`).
Nav2State sample(std::size_t b, std::size_t t, bool holonomic, bool car, bool same_start)
{
  Nav2State s;
  for (auto * a : {&s.vx, &s.vy, &s.wz, &s.cvx, &s.cvy, &s.cwz}) {
    a->setZero(b, t);
  }
  unsigned long long seed = 42;
  for (std::size_t i = 0; i < b; ++i) {
    const double v0 = same_start ? 0.4 : uniform(seed, -0.8, 0.8);
    s.vx(i, 0) = static_cast<float>(v0);
    s.wz(i, 0) = static_cast<float>(car ? 0.3 * v0 : (same_start ? 0.2 : uniform(seed, -0.6, 0.6)));
    if (holonomic) {
      s.vy(i, 0) = static_cast<float>(same_start ? 0.1 : uniform(seed, -0.3, 0.3));
    }
    double v = uniform(seed, -1.0, 1.0), w = uniform(seed, -1.0, 1.0), y = uniform(seed, -0.4, 0.4);
    for (std::size_t j = 0; j < t; ++j) {
      if (j % 8 == 0) {  // a new command held for 8 steps, as noise around a plan
        v = uniform(seed, -1.0, 1.0);
        w = car ? v * uniform(seed, -0.5, 0.5) : uniform(seed, -1.0, 1.0);
        y = uniform(seed, -0.4, 0.4);
      }
      s.cvx(i, j) = static_cast<float>(v);
      s.cwz(i, j) = static_cast<float>(w);
      s.cvy(i, j) = holonomic ? static_cast<float>(y) : 0.0f;
    }
  }
  return s;
}

bool check(int status)
{
  if (status != DRIVE_OK) {
    std::fprintf(stderr, "drive: %s\n", drive_last_error());
  }
  return status == DRIVE_OK;
}

void test_model(const char * path)
{
  const std::size_t b = 2000, t = 56;
  const float model_dt = 0.05f;
  drive_model * model = nullptr;
  if (!check(drive_model_load(path, &model))) {
    ++failures;
    return;
  }
  const std::string vehicle = drive_model_vehicle(model);
  const bool holonomic = vehicle == "omnidirectional", car = vehicle == "ackermann";
  const std::size_t dim = drive_model_input_count(model);
  const std::string start = drive_model_fitted_start(model);
  const bool imu = start.empty() || start.find("imu") != std::string::npos;
  const bool localization = start.find("localization") != std::string::npos;
  std::printf("%s: %s, vehicle %s (%zu inputs), fitted from %s\n", path,
    drive_model_name(model), vehicle.c_str(), dim, start.c_str());

  // A model_dt that is not the model's step is refused.
  bool refused = false;
  try {
    DriveMotionCore wrong(path, 0.1f);
  } catch (const std::runtime_error &) {
    refused = true;
  }
  expect(refused, "a model_dt of 0.1 s refused");

  DriveMotionCore core(path, model_dt);
  expect(core.holonomic() == holonomic, "isHolonomic for " + vehicle);
  Nav2State s = sample(b, t, holonomic, car, false);
  const Eigen::ArrayXXf measured_vx = s.vx.col(0), measured_wz = s.wz.col(0);
  core.predict(s.vx, s.vy, s.wz, s.cvx, s.cvy, s.cwz, {});
  expect(core.unreachable() == 0, "every sampled command has an input");
  expect((s.vx.col(0) == measured_vx).all() && (s.wz.col(0) == measured_wz).all(),
    "column 0 left as measured");

  // The reference: the model's prediction from the same starts through the same commands
  // (one more command, for the velocity over the last step).
  std::vector<double> body((t + 1) * b * 3), inputs((t + 1) * b * dim);
  for (std::size_t i = 0; i < b; ++i) {
    for (std::size_t j = 0; j <= t; ++j) {
      const std::size_t k = std::min(j, t - 1);
      double * v = &body[(i * (t + 1) + j) * 3];
      v[0] = s.cvx(i, k);
      v[1] = holonomic ? s.cvy(i, k) : 0.0f;
      v[2] = s.cwz(i, k);
    }
  }
  std::size_t missed = 0;
  expect(check(drive_model_inputs_for_batch(model, body.data(), (t + 1) * b, inputs.data(), &missed)), "inputs");
  std::vector<drive_start> starts(b);
  for (std::size_t i = 0; i < b; ++i) {
    drive_start_rest(&starts[i]);
    const double m[3] = {measured_vx(i), holonomic ? s.vy(i, 0) : 0.0f, measured_wz(i)};
    double u[3] = {0, 0, 0};
    expect(check(drive_model_inputs_for(model, m, u)), "start inputs");
    for (std::size_t d = 0; d < dim; ++d) {
      starts[i].inputs[d] = u[d];
    }
    starts[i].has_yaw_rate = imu;
    starts[i].yaw_rate = m[2];
    starts[i].has_velocity = localization;
    starts[i].velocity[0] = m[0];
    starts[i].velocity[1] = m[1];
  }
  std::vector<double> poses(b * (t + 1) * 3);
  expect(check(drive_predict_batch(model, starts.data(), b, inputs.data(), t + 1, poses.data(), nullptr)), "predict");
  double worst = 0.0;
  const double dt = drive_model_dt(model);
  for (std::size_t i = 0; i < b; ++i) {
    for (std::size_t j = 1; j < t; ++j) {
      const double * q = &poses[(i * (t + 1) + j) * 3];
      const double * r = q + 3;
      const double c = std::cos(q[2]), sn = std::sin(q[2]);
      const double dx = r[0] - q[0], dy = r[1] - q[1];
      const double v[3] = {(c * dx + sn * dy) / dt, (c * dy - sn * dx) / dt, (r[2] - q[2]) / dt};
      const double got[3] = {s.vx(i, j), holonomic ? s.vy(i, j) : 0.0f, s.wz(i, j)};
      for (int d = 0; d < 3; ++d) {
        if (!holonomic && d == 1) {
          continue;
        }
        worst = std::max(worst, std::abs(got[d] - v[d]) / std::max(1.0, std::abs(v[d])));
      }
    }
  }
  std::printf("  the core's velocities against the predicted poses: largest difference %.2e\n", worst);
  expect(worst < 1e-5, "velocities equal the prediction's (float precision)");

  // The commands already sent: the measured speed held changes nothing; others act
  // inside the dead time.
  Nav2State a = sample(b, t, holonomic, car, true), h = a, other = a;
  core.predict(a.vx, a.vy, a.wz, a.cvx, a.cvy, a.cwz, {});
  const std::vector<std::array<float, 3>> held(12, {h.vx(0, 0), h.vy(0, 0), h.wz(0, 0)});
  core.predict(h.vx, h.vy, h.wz, h.cvx, h.cvy, h.cwz, held);
  expect((a.vx == h.vx).all() && (a.wz == h.wz).all(), "a history of the measured speed held changes nothing");
  const std::vector<std::array<float, 3>> sent(12, {-0.5f, 0.0f, car ? -0.1f : 0.8f});
  core.predict(other.vx, other.vy, other.wz, other.cvx, other.cvy, other.cwz, sent);
  expect(!(a.vx == other.vx).all() || !(a.wz == other.wz).all(), "commands sent change the first steps");

  // The time of one call (Nav2 calls it once per iteration).
  std::vector<double> times;
  for (int r = 0; r < 7; ++r) {
    Nav2State x = sample(b, t, holonomic, car, false);
    const auto t0 = std::chrono::steady_clock::now();
    core.predict(x.vx, x.vy, x.wz, x.cvx, x.cvy, x.cwz, {});
    times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  std::printf("  predict at 2000 x 56: median %.2f ms (fastest %.2f ms)\n", times[3], times[0]);
  drive_model_free(model);
}

}  // namespace

int main(int argc, char ** argv)
{
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODEL_FILE...\n", argv[0]);
    return 2;
  }
  for (int i = 1; i < argc; ++i) {
    test_model(argv[i]);
  }
  if (failures) {
    std::fprintf(stderr, "%d failure(s)\n", failures);
    return 1;
  }
  std::printf("all passed\n");
  return 0;
}
