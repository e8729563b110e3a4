#include "gpatlas_core/model/surface_model_factory.h"

#include <map>
#include <mutex>
#include <stdexcept>

namespace gpatlas_core {

namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, SurfaceModelFactory> factories;

  Registry() {
    factories[GpisModel::kName] = [](const SurfaceModelConfig& c) { return std::make_unique<GpisModel>(c.gpis); };
    factories[MultiscaleGpisModel::kName] = [](const SurfaceModelConfig& c) {
      return std::make_unique<MultiscaleGpisModel>(c.multiscale, c.gpis);
    };
  }
};

Registry& registry() {
  static Registry instance;
  return instance;
}

}  // namespace

std::unique_ptr<SurfaceModel> makeSurfaceModel(const SurfaceModelConfig& config) {
  SurfaceModelFactory factory;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    const auto found = r.factories.find(config.type);
    if (found != r.factories.end()) factory = found->second;
  }
  if (!factory) {
    std::string known;
    for (const std::string& n : surfaceModelNames()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown surface model '" + config.type + "'; known: " + known);
  }
  return factory(config);
}

bool registerSurfaceModel(const std::string& name, SurfaceModelFactory factory) {
  if (name.empty() || !factory) return false;
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  return r.factories.emplace(name, std::move(factory)).second;
}

std::vector<std::string> surfaceModelNames() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<std::string> names;
  for (const auto& entry : r.factories) names.push_back(entry.first);
  return names;
}

}  // namespace gpatlas_core
