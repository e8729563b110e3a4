#pragma once

#include <ros/ros.h>

#include <functional>
#include <string>

namespace gpatlas_ros {

// How long a wait may stay silent (issue 51: an exploration waited 600 s for a topic without a
// publisher and said nothing until it failed): past it, a wait says what it waits for, and
// again after each further period.
constexpr double kWaitReportPeriodS = 10.0;

// Says, while a wait lasts, what it waits for: after each period a warning "<owner>: waiting
// <seconds> s for <describe()>". describe() is asked only then, so it may say what is known at
// that moment (publishers, the last status). Call poll() in the wait's loop.
class WaitReport {
 public:
  WaitReport(std::string owner, std::function<std::string()> describe, double period_s = kWaitReportPeriodS);
  // True when it logged.
  bool poll();

 private:
  std::string owner_;
  std::function<std::string()> describe_;
  double period_s_;
  ros::WallTime started_;
  ros::WallTime next_;
};

// A duration as a wait's line gives it: "25 s", "0.5 s".
std::string seconds(double s);

// A topic or service name as a user needs it to fix a wait: the resolved name and how to change
// it, "/ns/name (remapped from `name`)" or "/ns/name (remap name:=... to change it)".
std::string remapHint(const ros::NodeHandle& nh, const std::string& name);

}  // namespace gpatlas_ros
