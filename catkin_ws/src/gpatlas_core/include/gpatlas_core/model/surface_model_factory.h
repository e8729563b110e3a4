#pragma once

#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/model/surface_model.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// Which surface model to build (the YAML's model/type), and the settings of the built-in ones.
struct SurfaceModelConfig {
  std::string type{MultiscaleGpisModel::kName};
  GpisModelConfig gpis;  // the global GPIS (the paper's model); also the multiscale model's coarse level
  MultiscaleGpisConfig multiscale;  // "multiscale": coarse GPIS + local GPs of its residual
};

using SurfaceModelFactory = std::function<std::unique_ptr<SurfaceModel>(const SurfaceModelConfig&)>;

// Builds the model named config.type: a built-in one or one added with registerSurfaceModel.
// Throws std::invalid_argument for an unknown name (the message lists the known ones) or an
// invalid config.
std::unique_ptr<SurfaceModel> makeSurfaceModel(const SurfaceModelConfig& config);
// Adds a model (from a plugin library's static initialiser, see strategy_library.h); false when
// the name is empty or taken.
bool registerSurfaceModel(const std::string& name, SurfaceModelFactory factory);
std::vector<std::string> surfaceModelNames();

}  // namespace gpatlas_core

#define GPATLAS_SURFACE_MODEL_CONCAT_INNER(a, b) a##b
#define GPATLAS_SURFACE_MODEL_CONCAT(a, b) GPATLAS_SURFACE_MODEL_CONCAT_INNER(a, b)
// Registers a surface model factory when the translation unit (or the plugin library holding it,
// loaded as a strategy library is: strategy_library.h) is loaded. The model's name() must be the
// registered name, which replicas are rebuilt by.
#define GPATLAS_REGISTER_SURFACE_MODEL(name, ...)                                                            \
  static const bool GPATLAS_SURFACE_MODEL_CONCAT(gpatlas_surface_model_registered_, __COUNTER__) [[maybe_unused]] = \
      ::gpatlas_core::registerSurfaceModel(name, __VA_ARGS__)
