#pragma once

// Named parameters ("gpis/kernel") from the ROS parameter server or a YAML file, read by the one
// reader of each Config (config/config_readers.h, and the strategies' own): the nodelets and
// gpatlas_bench fill their Configs with the same code from the same config/pipeline.yaml.

#include "gpatlas_core/common/types.h"

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace gpatlas_core {

// A tree of parameters addressed by '/'-separated names relative to the source's namespace.
// Each getter returns nullopt when the parameter is absent or not of that type; exists()
// tells which.
class ParameterSource {
 public:
  virtual ~ParameterSource() = default;
  virtual bool exists(const std::string& name) const = 0;
  virtual std::optional<double> number(const std::string& name) const = 0;  // an integer is a number
  virtual std::optional<int> integer(const std::string& name) const = 0;
  virtual std::optional<bool> flag(const std::string& name) const = 0;
  virtual std::optional<std::string> text(const std::string& name) const = 0;
  virtual std::optional<std::vector<double>> numbers(const std::string& name) const = 0;
  virtual std::optional<std::vector<std::string>> texts(const std::string& name) const = 0;
  // The full name of a parameter, for messages.
  virtual std::string fullName(const std::string& name) const { return name; }
};

// Reads typed, range-checked values with defaults. Collects every invalid value (with its full
// name) instead of stopping at the first, and records which names were read and which were
// not set (their defaults apply).
class ParamReader {
 public:
  explicit ParamReader(const ParameterSource& source) : source_(source) {}

  // While it lives, every name is read under `ns` (appended to the current namespace; "" keeps
  // it): a component reads its own section with its Configs' readers, wherever the section lies
  // (a strategy made by the registry, as MoveIt's planner plugins read theirs).
  class Scope {
   public:
    Scope(ParamReader& reader, const std::string& ns);
    ~Scope() { reader_.ns_ = previous_; }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    ParamReader& reader_;
    std::string previous_;
  };
  // The current namespace: "" or ending in '/'.
  const std::string& scope() const { return ns_; }

  double number(const std::string& name, double fallback, double min, double max);
  int integer(const std::string& name, int fallback, int min, int max);
  bool flag(const std::string& name, bool fallback);
  std::string text(const std::string& name, const std::string& fallback);
  std::vector<std::string> texts(const std::string& name, const std::vector<std::string>& fallback);
  std::vector<double> numbers(const std::string& name, const std::vector<double>& fallback);
  Vector3 vector3(const std::string& name, const Vector3& fallback);
  // An optional limit: a value in (0, max], or `off` (empty: no limit, the feature off). 0 and
  // negatives are refused, so that no number means "off" for one key and itself for another.
  // rosparam reads a bare `off` as YAML 1.1's false, which is taken as off too.
  std::optional<double> optionalNumber(const std::string& name, std::optional<double> fallback, double max);
  std::optional<int> optionalInteger(const std::string& name, std::optional<int> fallback, int max);

  // Records a problem found by the caller's own check (e.g. an unknown plugin name).
  void invalid(const std::string& name, const std::string& why) { problem(ns_ + name, why); }

  bool ok() const { return errors_.empty(); }
  std::string errors() const;
  // The parameters that were not set, so their defaults apply. Names here and in readNames(),
  // defaults() and defaultedNames() are full: with the namespace they were read under.
  std::string defaulted() const;
  const std::vector<std::string>& readNames() const { return read_; }
  // The code's default of every parameter read, as YAML text ("0.1", "true", "[1, 2]", "x"):
  // what a node gets without the file.
  const std::vector<std::pair<std::string, std::string>>& defaults() const { return defaults_; }
  const std::vector<std::string>& defaultedNames() const { return defaulted_; }

 private:
  void problem(const std::string& full_name, const std::string& why);
  bool present(const std::string& name);
  bool isOff(const std::string& name) const;
  void refuseNonPositive(const std::string& name, const std::string& value);

  const ParameterSource& source_;
  std::string ns_;
  std::vector<std::string> errors_;
  std::vector<std::string> read_;
  std::vector<std::string> defaulted_;
  std::vector<std::pair<std::string, std::string>> defaults_;
};

// No settings: every reader keeps its Config's defaults.
class NoParameters : public ParameterSource {
 public:
  bool exists(const std::string&) const override { return false; }
  std::optional<double> number(const std::string&) const override { return std::nullopt; }
  std::optional<int> integer(const std::string&) const override { return std::nullopt; }
  std::optional<bool> flag(const std::string&) const override { return std::nullopt; }
  std::optional<std::string> text(const std::string&) const override { return std::nullopt; }
  std::optional<std::vector<double>> numbers(const std::string&) const override { return std::nullopt; }
  std::optional<std::vector<std::string>> texts(const std::string&) const override { return std::nullopt; }
};

// Parameters from a YAML file (yaml-cpp), with overrides "key/sub=value" (the value parsed as
// YAML: 0.2, true, [1, 2, 3], text).
class YamlParameters : public ParameterSource {
 public:
  // nullptr with the reason when the file cannot be read or parsed.
  static std::unique_ptr<YamlParameters> fromFile(const std::string& path, std::string* error);
  static std::unique_ptr<YamlParameters> fromString(const std::string& yaml, std::string* error);
  ~YamlParameters() override;
  // false with the reason for a malformed "key=value".
  bool set(const std::string& assignment, std::string* error);
  // Every leaf (scalar or sequence) name in the file, sorted.
  std::vector<std::string> leafNames() const;
  // Sets every leaf of `overlay` here (a partial file over a full one); false with the reason
  // if one cannot be set.
  bool overlay(const YamlParameters& overlay, std::string* error);

  bool exists(const std::string& name) const override;
  std::optional<double> number(const std::string& name) const override;
  std::optional<int> integer(const std::string& name) const override;
  std::optional<bool> flag(const std::string& name) const override;
  std::optional<std::string> text(const std::string& name) const override;
  std::optional<std::vector<double>> numbers(const std::string& name) const override;
  std::optional<std::vector<std::string>> texts(const std::string& name) const override;

 private:
  YamlParameters();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gpatlas_core
