#include "gpatlas_core/common/parameters.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <sstream>

namespace gpatlas_core {

// ---------------------------------------------------------------- ParamReader

ParamReader::Scope::Scope(ParamReader& reader, const std::string& ns) : reader_(reader), previous_(reader.ns_) {
  if (!ns.empty()) reader.ns_ += ns.back() == '/' ? ns : ns + "/";
}

void ParamReader::problem(const std::string& full_name, const std::string& why) {
  // A section two components read (gpis/: the global model's and the multiscale model's coarse
  // level) is reported once.
  const std::string error = source_.fullName(full_name) + ": " + why;
  if (std::find(errors_.begin(), errors_.end(), error) == errors_.end()) errors_.push_back(error);
}

bool ParamReader::present(const std::string& name) {
  read_.push_back(name);
  if (source_.exists(name)) return true;
  if (std::find(defaulted_.begin(), defaulted_.end(), name) == defaulted_.end()) defaulted_.push_back(name);
  return false;
}

namespace {
std::string formatted(double v) {
  std::ostringstream out;
  out << std::setprecision(17) << v;
  return out.str();
}
template <typename T, typename Format>
std::string formattedList(const std::vector<T>& values, Format format) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + format(values[i]);
  return out + "]";
}
std::string joined(const std::vector<std::string>& items, const char* separator) {
  std::ostringstream out;
  for (std::size_t i = 0; i < items.size(); ++i) out << (i ? separator : "") << items[i];
  return out.str();
}
}  // namespace

std::string ParamReader::errors() const { return joined(errors_, "; "); }
std::string ParamReader::defaulted() const { return joined(defaulted_, ", "); }

double ParamReader::number(const std::string& key, double fallback, double min, double max) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, formatted(fallback));
  if (!present(name)) return fallback;
  const std::optional<double> value = source_.number(name);
  if (!value) {
    problem(name, "is not a number");
    return fallback;
  }
  if (!std::isfinite(*value) || *value < min || *value > max) {
    std::ostringstream why;
    why << "= " << *value << " is outside [" << min << ", " << max << "]";
    problem(name, why.str());
    return fallback;
  }
  return *value;
}

int ParamReader::integer(const std::string& key, int fallback, int min, int max) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, std::to_string(fallback));
  if (!present(name)) return fallback;
  const std::optional<int> value = source_.integer(name);
  if (!value) {
    problem(name, "is not an integer");
    return fallback;
  }
  if (*value < min || *value > max) {
    problem(name, "= " + std::to_string(*value) + " is outside [" + std::to_string(min) + ", " + std::to_string(max) + "]");
    return fallback;
  }
  return *value;
}

bool ParamReader::flag(const std::string& key, bool fallback) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, std::string(fallback ? "true" : "false"));
  if (!present(name)) return fallback;
  const std::optional<bool> value = source_.flag(name);
  if (!value) {
    problem(name, "is not a boolean");
    return fallback;
  }
  return *value;
}

std::string ParamReader::text(const std::string& key, const std::string& fallback) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, fallback);
  if (!present(name)) return fallback;
  const std::optional<std::string> value = source_.text(name);
  if (!value) {
    problem(name, "is not a string");
    return fallback;
  }
  return *value;
}

std::vector<std::string> ParamReader::texts(const std::string& key, const std::vector<std::string>& fallback) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, formattedList(fallback, [](const std::string& t) { return t; }));
  if (!present(name)) return fallback;
  if (auto value = source_.texts(name)) return *value;
  if (auto single = source_.text(name)) return {*single};  // one item given without brackets
  problem(name, "is not a list of strings");
  return fallback;
}

std::vector<double> ParamReader::numbers(const std::string& key, const std::vector<double>& fallback) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, formattedList(fallback, formatted));
  if (!present(name)) return fallback;
  const auto value = source_.numbers(name);
  if (!value) {
    problem(name, "is not a list of numbers");
    return fallback;
  }
  for (double v : *value)
    if (!std::isfinite(v)) {
      problem(name, "must be finite");
      return fallback;
    }
  return *value;
}

Vector3 ParamReader::vector3(const std::string& key, const Vector3& fallback) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, formattedList(std::vector<double>{fallback.x(), fallback.y(), fallback.z()}, formatted));
  if (!present(name)) return fallback;
  const auto value = source_.numbers(name);
  if (!value || value->size() != 3) {
    problem(name, "must be a list of 3 numbers");
    return fallback;
  }
  const Vector3 v((*value)[0], (*value)[1], (*value)[2]);
  if (!v.allFinite()) {
    problem(name, "must be finite");
    return fallback;
  }
  return v;
}

bool ParamReader::isOff(const std::string& name) const {
  if (source_.text(name) == std::optional<std::string>("off")) return true;
  const std::optional<bool> value = source_.flag(name);  // rosparam's false for a bare off
  return value && !*value;
}

void ParamReader::refuseNonPositive(const std::string& name, const std::string& value) {
  problem(name, "= " + value + " is not a limit (it must be > 0): write off for none");
}

std::optional<double> ParamReader::optionalNumber(const std::string& key, std::optional<double> fallback,
                                                  double max) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, fallback ? formatted(*fallback) : std::string("off"));
  if (!present(name)) return fallback;
  if (isOff(name)) return std::nullopt;
  const std::optional<double> value = source_.number(name);
  if (!value || !std::isfinite(*value)) {
    problem(name, "is neither a finite number nor off");
    return fallback;
  }
  if (*value <= 0.0) {
    refuseNonPositive(name, formatted(*value));
    return fallback;
  }
  if (*value > max) {
    problem(name, "= " + formatted(*value) + " is outside (0, " + formatted(max) + "]");
    return fallback;
  }
  return *value;
}

std::optional<int> ParamReader::optionalInteger(const std::string& key, std::optional<int> fallback, int max) {
  const std::string name = ns_ + key;
  defaults_.emplace_back(name, fallback ? std::to_string(*fallback) : std::string("off"));
  if (!present(name)) return fallback;
  if (isOff(name)) return std::nullopt;
  const std::optional<int> value = source_.integer(name);
  if (!value) {
    problem(name, "is neither an integer nor off");
    return fallback;
  }
  if (*value <= 0) {
    refuseNonPositive(name, std::to_string(*value));
    return fallback;
  }
  if (*value > max) {
    problem(name, "= " + std::to_string(*value) + " is outside [1, " + std::to_string(max) + "]");
    return fallback;
  }
  return *value;
}

// ---------------------------------------------------------------- YamlParameters

struct YamlParameters::Impl {
  YAML::Node root;

  // The node at a '/'-separated name, or an undefined node.
  YAML::Node find(const std::string& name) const {
    // Read-only: a const node's operator[] never inserts, and reset() rebinds the handle
    // (assignment would overwrite the node it refers to).
    YAML::Node node;
    node.reset(root);
    std::stringstream parts(name);
    std::string part;
    while (std::getline(parts, part, '/')) {
      if (part.empty()) continue;
      if (!node.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
      const YAML::Node child = static_cast<const YAML::Node&>(node)[part];
      if (!child.IsDefined()) return YAML::Node(YAML::NodeType::Undefined);
      node.reset(child);
    }
    return node;
  }

  // The node at `name` as a T, when it is of `kind` and converts.
  template <typename T>
  std::optional<T> as(const std::string& name, YAML::NodeType::value kind) const {
    const YAML::Node node = find(name);
    if (node.Type() != kind) return std::nullopt;
    try {
      return node.as<T>();
    } catch (const YAML::Exception&) {
      return std::nullopt;
    }
  }
};

YamlParameters::YamlParameters() : impl_(std::make_unique<Impl>()) {}
YamlParameters::~YamlParameters() = default;

std::unique_ptr<YamlParameters> YamlParameters::fromString(const std::string& yaml, std::string* error) {
  std::unique_ptr<YamlParameters> params(new YamlParameters());
  try {
    params->impl_->root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    if (error) *error = std::string("not valid YAML: ") + e.what();
    return nullptr;
  }
  if (params->impl_->root.IsNull()) params->impl_->root = YAML::Node(YAML::NodeType::Map);
  if (!params->impl_->root.IsMap()) {
    if (error) *error = "the YAML's top level must be a map of parameters";
    return nullptr;
  }
  return params;
}

std::unique_ptr<YamlParameters> YamlParameters::fromFile(const std::string& path, std::string* error) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    if (error) *error = "cannot read " + path;
    return nullptr;
  } catch (const YAML::Exception& e) {
    if (error) *error = path + " is not valid YAML: " + e.what();
    return nullptr;
  }
  std::unique_ptr<YamlParameters> params(new YamlParameters());
  params->impl_->root = root.IsNull() ? YAML::Node(YAML::NodeType::Map) : root;
  if (!params->impl_->root.IsMap()) {
    if (error) *error = path + ": the top level must be a map of parameters";
    return nullptr;
  }
  return params;
}

bool YamlParameters::overlay(const YamlParameters& overlay, std::string* error) {
  for (const std::string& name : overlay.leafNames()) {
    YAML::Emitter value;
    value << YAML::Flow << overlay.impl_->find(name);
    if (!set(name + "=" + value.c_str(), error)) return false;
  }
  return true;
}

bool YamlParameters::set(const std::string& assignment, std::string* error) {
  const std::size_t equals = assignment.find('=');
  if (equals == std::string::npos || equals == 0) {
    if (error) *error = "'" + assignment + "' is not of the form key=value";
    return false;
  }
  const std::string key = assignment.substr(0, equals);
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(equals + 1));
  } catch (const YAML::Exception& e) {
    if (error) *error = "'" + assignment + "': the value is not valid YAML: " + e.what();
    return false;
  }
  std::vector<std::string> parts;
  std::stringstream stream(key);
  for (std::string part; std::getline(stream, part, '/');)
    if (!part.empty()) parts.push_back(part);
  if (parts.empty()) {
    if (error) *error = "'" + assignment + "' has no key";
    return false;
  }
  // yaml-cpp's operator[] returns proxies into the tree, so a walk by value reassigns nodes:
  // build the path recursively instead.
  std::function<void(YAML::Node, std::size_t)> assign = [&](YAML::Node node, std::size_t depth) {
    if (depth + 1 == parts.size()) {
      node[parts[depth]] = value;
      return;
    }
    YAML::Node child = node[parts[depth]];
    if (!child.IsMap()) {
      node[parts[depth]] = YAML::Node(YAML::NodeType::Map);
      child = node[parts[depth]];
    }
    assign(child, depth + 1);
  };
  assign(impl_->root, 0);
  return true;
}

std::vector<std::string> YamlParameters::leafNames() const {
  std::vector<std::string> names;
  std::function<void(const YAML::Node&, const std::string&)> walk = [&](const YAML::Node& node,
                                                                        const std::string& prefix) {
    if (node.IsMap()) {
      for (const auto& entry : node) walk(entry.second, prefix + (prefix.empty() ? "" : "/") + entry.first.as<std::string>());
      return;
    }
    names.push_back(prefix);
  };
  walk(impl_->root, "");
  std::sort(names.begin(), names.end());
  return names;
}

bool YamlParameters::exists(const std::string& name) const { return impl_->find(name).IsDefined(); }

std::optional<double> YamlParameters::number(const std::string& name) const {
  return impl_->as<double>(name, YAML::NodeType::Scalar);
}

std::optional<int> YamlParameters::integer(const std::string& name) const {
  return impl_->as<int>(name, YAML::NodeType::Scalar);
}

std::optional<bool> YamlParameters::flag(const std::string& name) const {
  return impl_->as<bool>(name, YAML::NodeType::Scalar);
}

std::optional<std::string> YamlParameters::text(const std::string& name) const {
  if (impl_->find(name).IsNull()) return std::string();
  return impl_->as<std::string>(name, YAML::NodeType::Scalar);
}

std::optional<std::vector<double>> YamlParameters::numbers(const std::string& name) const {
  return impl_->as<std::vector<double>>(name, YAML::NodeType::Sequence);
}

std::optional<std::vector<std::string>> YamlParameters::texts(const std::string& name) const {
  return impl_->as<std::vector<std::string>>(name, YAML::NodeType::Sequence);
}

}  // namespace gpatlas_core
