#pragma once

// The ROS parameter server as a gpatlas_core::ParameterSource: the core's Config readers
// (gpatlas_core/config/config_readers.h, probe_sim's readSimulation) read the nodes' parameters with
// the same code that reads config/pipeline.yaml in gpatlas_bench.

#include <gpatlas_core/common/parameters.h>

#include <ros/node_handle.h>

#include <optional>
#include <string>
#include <vector>

namespace gpatlas_conversions {

// The parameter server under a node handle's namespace.
class RosParameterSource : public gpatlas_core::ParameterSource {
 public:
  explicit RosParameterSource(const ros::NodeHandle& nh) : nh_(nh) {}
  bool exists(const std::string& name) const override;
  std::optional<double> number(const std::string& name) const override;
  std::optional<int> integer(const std::string& name) const override;
  std::optional<bool> flag(const std::string& name) const override;
  std::optional<std::string> text(const std::string& name) const override;
  std::optional<std::vector<double>> numbers(const std::string& name) const override;
  std::optional<std::vector<std::string>> texts(const std::string& name) const override;
  std::string fullName(const std::string& name) const override { return nh_.resolveName(name); }
  const std::string& ns() const { return nh_.getNamespace(); }

 private:
  ros::NodeHandle nh_;
};

}  // namespace gpatlas_conversions
