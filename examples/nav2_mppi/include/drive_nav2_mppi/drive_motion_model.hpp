// The Nav2 MPPI motion-model plug-in: `drive_nav2_mppi::DriveMotionModel`, a fitted DRIVE
// model (a model file written by `drive train`) as `mppi::MotionModel` (navigation2
// PR #6076). The work is in DriveMotionCore (drive_motion_core.hpp, ROS-free and tested by
// the project's CI); this is the glue, built on a ROS 2 machine with Nav2.
#ifndef DRIVE_NAV2_MPPI__DRIVE_MOTION_MODEL_HPP_
#define DRIVE_NAV2_MPPI__DRIVE_MOTION_MODEL_HPP_

#include <memory>
#include <string>

#include "nav2_mppi_controller/motion_models.hpp"
#include "drive_nav2_mppi/drive_motion_core.hpp"

namespace drive_nav2_mppi
{

class DriveMotionModel : public mppi::MotionModel
{
public:
  DriveMotionModel() = default;

  /// Reads the parameter `model_file` (under the plug-in's namespace) and loads it.
  void initialize(mppi::ParametersHandler * param_handler, const std::string & plugin_name) override;

  /// True for an omnidirectional base.
  bool isHolonomic() const override;

  /// vx, vy, wz from cvx, cvy, cwz through the fitted model, from the measured speed at
  /// column 0 and the commands Nav2 keeps (model_delay_vx, model_delay_wz: set them to at
  /// least the model's dead time).
  void predict(mppi::models::State & state) override;

private:
  std::string model_file_;
  std::unique_ptr<DriveMotionCore> core_;
  std::vector<std::array<float, 3>> history_;
};

}  // namespace drive_nav2_mppi

#endif  // DRIVE_NAV2_MPPI__DRIVE_MOTION_MODEL_HPP_
