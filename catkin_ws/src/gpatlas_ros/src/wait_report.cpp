#include "gpatlas_ros/wait_report.h"

#include <sstream>

namespace gpatlas_ros {

WaitReport::WaitReport(std::string owner, std::function<std::string()> describe, double period_s)
    : owner_(std::move(owner)),
      describe_(std::move(describe)),
      period_s_(period_s),
      started_(ros::WallTime::now()),
      next_(started_ + ros::WallDuration(period_s)) {}

bool WaitReport::poll() {
  const ros::WallTime now = ros::WallTime::now();
  if (now < next_) return false;
  next_ = now + ros::WallDuration(period_s_);
  std::ostringstream line;
  line.precision(3);
  line << owner_ << ": waiting " << (now - started_).toSec() << " s for " << describe_();
  ROS_WARN_STREAM(line.str());
  return true;
}

std::string seconds(double s) {
  std::ostringstream text;
  text << s << " s";
  return text.str();
}

std::string remapHint(const ros::NodeHandle& nh, const std::string& name) {
  const std::string resolved = nh.resolveName(name);
  if (resolved != nh.resolveName(name, false)) return resolved + " (remapped from `" + name + "`)";
  return resolved + " (remap " + name + ":=... to change it)";
}

}  // namespace gpatlas_ros
