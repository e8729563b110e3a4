#pragma once

#include <gpatlas_motion/approach_config.h>
#include <gpatlas_motion/arm.h>

#include <ros/node_handle.h>

#include <memory>
#include <string>

namespace gpatlas_ros {

// The arm the approach is planned for when approach/use_arm is set: the chain from
// arm_base_link to arm_tip_link of the URDF in `robot_description` (looked up from nh's
// namespace upwards, as robot_state_publisher does), with arm_link_radius_m. Null when use_arm
// is off; null with *error set when the URDF is missing or has no such chain.
std::shared_ptr<const gpatlas_motion::Arm> loadApproachArm(const ros::NodeHandle& nh,
                                                           const gpatlas_motion::ApproachConfig& config,
                                                           std::string* error);

}  // namespace gpatlas_ros
