#include "drive_nav2_mppi/drive_motion_model.hpp"

#include <algorithm>

#include "rclcpp/rclcpp.hpp"

namespace drive_nav2_mppi
{

void DriveMotionModel::initialize(
  mppi::ParametersHandler * param_handler, const std::string & plugin_name)
{
  auto getParam = param_handler->getParamGetter(plugin_name);
  getParam(model_file_, "model_file", std::string(""), mppi::ParameterType::Static);
  if (model_file_.empty()) {
    throw std::runtime_error(
            "drive_nav2_mppi: set " + plugin_name + ".model_file to a model file written by "
            "`drive train`");
  }
  // The step is checked against Nav2's model_dt at the first prediction (setConstraints
  // comes after initialize); 0 here: no check yet.
  core_ = std::make_unique<DriveMotionCore>(model_file_, 0.0f);
  RCLCPP_INFO(
    rclcpp::get_logger("drive_nav2_mppi"), "Loaded the DRIVE model %s from %s",
    core_->name().c_str(), model_file_.c_str());
}

bool DriveMotionModel::isHolonomic() const
{
  return core_ && core_->holonomic();
}

void DriveMotionModel::predict(mppi::models::State & state)
{
  core_->checkStep(model_dt_);
  // The commands Nav2 published and keeps (oldest first, each axis's buffer as long as its
  // model_delay): the tail common to the axes the vehicle uses.
  std::size_t n = std::min(cmd_history_vx_.size(), cmd_history_wz_.size());
  if (isHolonomic()) {
    n = std::min(n, cmd_history_vy_.size());
  }
  history_.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const auto at = [k, n](const std::vector<float> & h) {return h[h.size() - n + k];};
    history_[k] = {at(cmd_history_vx_), isHolonomic() ? at(cmd_history_vy_) : 0.0f,
      at(cmd_history_wz_)};
  }
  core_->predict(state.vx, state.vy, state.wz, state.cvx, state.cvy, state.cwz, history_);
  if (core_->unreachable() > 0) {
    static rclcpp::Clock clock(RCL_STEADY_TIME);
    RCLCPP_WARN_THROTTLE(
      rclcpp::get_logger("drive_nav2_mppi"), clock, 5000,
      "%zu sampled commands had no input of the vehicle (a yaw rate at zero speed of a car?): "
      "each was given its nearest", core_->unreachable());
  }
}

}  // namespace drive_nav2_mppi

#include <pluginlib/class_list_macros.hpp>
PLUGINLIB_EXPORT_CLASS(drive_nav2_mppi::DriveMotionModel, mppi::MotionModel)
