#include "gpatlas_core/model/surface_model_factory.h"

#include "gpatlas_core/common/named_factories.h"

#include <stdexcept>

namespace gpatlas_core {

namespace {

NamedFactories<SurfaceModelFactory>& registry() {
  static NamedFactories<SurfaceModelFactory> instance({
      {GpisModel::kName, [](const SurfaceModelConfig& c) { return std::make_unique<GpisModel>(c.gpis); }},
      {MultiscaleGpisModel::kName,
       [](const SurfaceModelConfig& c) { return std::make_unique<MultiscaleGpisModel>(c.multiscale, c.gpis); }},
  });
  return instance;
}

}  // namespace

std::unique_ptr<SurfaceModel> makeSurfaceModel(const SurfaceModelConfig& config) {
  const SurfaceModelFactory factory = registry().find(config.type);
  if (!factory)
    throw std::invalid_argument("unknown surface model '" + config.type + "'; known: " + registry().namesJoined());
  return factory(config);
}

bool registerSurfaceModel(const std::string& name, SurfaceModelFactory factory) {
  return registry().add(name, std::move(factory));
}

std::vector<std::string> surfaceModelNames() { return registry().names(); }

}  // namespace gpatlas_core
