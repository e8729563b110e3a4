#pragma once

#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace gpatlas_core {

// Factories by name, safe to use from several threads and from libraries loaded at run time: the
// one registry behind the surface models (surface_model_factory.h) and the strategies
// (strategy_registry.h).
template <typename Factory>
class NamedFactories {
 public:
  explicit NamedFactories(std::map<std::string, Factory> built_in) : factories_(std::move(built_in)) {}

  // False (and nothing changes) when the name is empty or taken, or the factory is empty.
  bool add(const std::string& name, Factory factory) {
    if (name.empty() || !factory) return false;
    std::lock_guard<std::mutex> lock(mutex_);
    return factories_.emplace(name, std::move(factory)).second;
  }

  // The factory of `name`; an empty one when there is none.
  Factory find(const std::string& name) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto found = factories_.find(name);
    return found == factories_.end() ? Factory() : found->second;
  }

  std::vector<std::string> names() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::string> names;
    for (const auto& entry : factories_) names.push_back(entry.first);
    return names;
  }

  // "a, b, c": for the error that names the known ones.
  std::string namesJoined() const {
    std::string joined;
    for (const std::string& n : names()) joined += (joined.empty() ? "" : ", ") + n;
    return joined;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, Factory> factories_;
};

}  // namespace gpatlas_core
