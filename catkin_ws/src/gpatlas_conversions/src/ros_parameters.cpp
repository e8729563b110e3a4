#include "gpatlas_conversions/ros_parameters.h"

#include <xmlrpcpp/XmlRpcValue.h>

namespace gpatlas_conversions {

bool RosParameterSource::exists(const std::string& name) const { return nh_.hasParam(name); }

std::optional<double> RosParameterSource::number(const std::string& name) const {
  double value = 0.0;
  if (nh_.getParam(name, value)) return value;
  int as_int = 0;
  if (nh_.getParam(name, as_int)) return static_cast<double>(as_int);
  return std::nullopt;
}

std::optional<int> RosParameterSource::integer(const std::string& name) const {
  int value = 0;
  if (nh_.getParam(name, value)) return value;
  return std::nullopt;
}

std::optional<bool> RosParameterSource::flag(const std::string& name) const {
  bool value = false;
  if (nh_.getParam(name, value)) return value;
  return std::nullopt;
}

std::optional<std::string> RosParameterSource::text(const std::string& name) const {
  std::string value;
  if (nh_.getParam(name, value)) return value;
  return std::nullopt;
}

std::optional<std::vector<double>> RosParameterSource::numbers(const std::string& name) const {
  XmlRpc::XmlRpcValue raw;
  if (!nh_.getParam(name, raw) || raw.getType() != XmlRpc::XmlRpcValue::TypeArray) return std::nullopt;
  std::vector<double> values;
  for (int i = 0; i < raw.size(); ++i) {
    if (raw[i].getType() == XmlRpc::XmlRpcValue::TypeDouble) values.push_back(static_cast<double>(raw[i]));
    else if (raw[i].getType() == XmlRpc::XmlRpcValue::TypeInt) values.push_back(static_cast<int>(raw[i]));
    else return std::nullopt;
  }
  return values;
}

std::optional<std::vector<std::string>> RosParameterSource::texts(const std::string& name) const {
  std::vector<std::string> value;
  if (nh_.getParam(name, value)) return value;
  return std::nullopt;
}

}  // namespace gpatlas_conversions
