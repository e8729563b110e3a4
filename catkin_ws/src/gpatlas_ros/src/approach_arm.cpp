#include "gpatlas_ros/approach_arm.h"

#include <exception>

namespace gpatlas_ros {

std::shared_ptr<const gpatlas_motion::Arm> loadApproachArm(const ros::NodeHandle& nh,
                                                           const gpatlas_motion::ApproachConfig& config,
                                                           std::string* error) {
  error->clear();
  if (!config.use_arm) return nullptr;
  std::string key, urdf;
  if (!nh.searchParam("robot_description", key) || !nh.getParam(key, urdf) || urdf.empty()) {
    *error = "no robot_description parameter (from " + nh.getNamespace() +
             " upwards): load the robot's URDF, or set approach/use_arm false";
    return nullptr;
  }
  gpatlas_motion::Arm::Config arm_config;
  arm_config.base_link = config.arm_base_link;
  arm_config.tip_link = config.arm_tip_link;
  arm_config.link_radius_m = config.arm_link_radius_m;
  try {
    return std::make_shared<const gpatlas_motion::Arm>(gpatlas_motion::Arm::fromUrdfString(urdf, arm_config));
  } catch (const std::exception& e) {
    *error = std::string("robot_description (") + key + "): " + e.what();
    return nullptr;
  }
}

}  // namespace gpatlas_ros
