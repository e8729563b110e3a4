#include "gpatlas_ros/ros_params.h"

#include <ros/console.h>

namespace gpatlas_ros {

void ParamReader::report(const std::string& who) const {
  if (!ok()) ROS_ERROR_STREAM(who << ": invalid parameters, defaults used instead: " << errors());
  if (!defaultedNames().empty())
    ROS_INFO_STREAM(who << ": parameters not set in " << ns() << ", defaults used: " << defaulted());
}

}  // namespace gpatlas_ros
