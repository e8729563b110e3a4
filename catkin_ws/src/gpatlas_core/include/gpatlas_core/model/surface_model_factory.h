#pragma once

#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/model/surface_model.h"

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// Builds fresh models of one kind with the settings its factory read.
using SurfaceModelMaker = std::function<std::unique_ptr<SurfaceModel>()>;
// Reads a model's settings from `settings`, already in its namespace (surfaceModelMaker's `ns`),
// with the readers of its Configs, as a strategy reads its own (strategy_registry.h): a refused
// value is reported through `settings` and its default applies. Returns the maker.
using SurfaceModelFactory = std::function<SurfaceModelMaker(ParamReader& settings)>;

// Which surface model a node fits (the YAML's model/type), and how every registered model is
// built with its settings: a replica is rebuilt by the name its training set carries.
struct SurfaceModelConfig {
  std::string type{MultiscaleGpisModel::kName};
  // By model name (readSurfaceModel); a model absent here is built with its defaults.
  std::map<std::string, SurfaceModelMaker> makers;
};

// The maker of the model `name`, a built-in one or one added with registerSurfaceModel, reading
// its settings under `ns` of `settings`. Throws std::invalid_argument for an unknown name (the
// message lists the known ones).
SurfaceModelMaker surfaceModelMaker(const std::string& name, ParamReader& settings, const std::string& ns = "");
// Builds the model named config.type (see surfaceModelMaker). Throws std::invalid_argument for
// an unknown name.
std::unique_ptr<SurfaceModel> makeSurfaceModel(const SurfaceModelConfig& config);
// Adds a model (from a plugin library's static initialiser, see strategy_library.h); false when
// the name is empty or taken.
bool registerSurfaceModel(const std::string& name, SurfaceModelFactory factory);
std::vector<std::string> surfaceModelNames();

// The built-in models' readers: gpis/ (the global GPIS, also the multiscale model's coarse level)
// and multiscale/. What no single parameter can check is checked by the model; a refused
// section falls back to its defaults whole, so every node's replicas stay exact.
void readGpis(ParamReader& r, GpisModelConfig* c);
void readMultiscale(ParamReader& r, MultiscaleGpisConfig* c);

}  // namespace gpatlas_core

#define GPATLAS_SURFACE_MODEL_CONCAT_INNER(a, b) a##b
#define GPATLAS_SURFACE_MODEL_CONCAT(a, b) GPATLAS_SURFACE_MODEL_CONCAT_INNER(a, b)
// Registers a surface model factory when the translation unit (or the plugin library holding it,
// loaded as a strategy library is: strategy_library.h) is loaded. The model's name() must be the
// registered name, which replicas are rebuilt by.
#define GPATLAS_REGISTER_SURFACE_MODEL(name, ...)                                                            \
  static const bool GPATLAS_SURFACE_MODEL_CONCAT(gpatlas_surface_model_registered_, __COUNTER__) [[maybe_unused]] = \
      ::gpatlas_core::registerSurfaceModel(name, __VA_ARGS__)
