#pragma once

#include "gpatlas_core/planning/strategy_registry.h"

#include <string>
#include <vector>

namespace gpatlas_core {

// Your own exploration strategy, compared with the built-in ones by the tools that run them
// (gpatlas_bench --strategy-library) without rebuilding them: compile the strategy into a shared
// library that registers it when it is loaded,
//
//   GPATLAS_REGISTER_STRATEGY("my_strategy", [](gpatlas_core::ParamReader& settings, std::uint64_t seed) {
//     return std::make_unique<MyStrategy>(settings, seed);
//   });
//
// link it against gpatlas_core, and load it by path (examples/farthest_from_evidence_strategy.cpp).
// The factory gets the tool's settings (config/pipeline.yaml, or the AtlasPlanner nodelet's
// parameters) in the namespace the tool gives (the root, for gpatlas_bench and the nodelet):
// MyStrategy reads its own keys under a prefix of its own ("my_strategy/..."), and shared
// sections such as evidence/ with their readers (readEvidence); a value it refuses (ParamReader's
// range checks, or invalid()) is reported by the tool. `seed` is the run's; each plan's PlanRequest::seed varies it.
struct StrategyLibraryLoad {
  bool ok{false};
  std::string message;             // what went wrong, when !ok
  std::vector<std::string> added;  // the strategy names the library registered
  // The surface models it registered (GPATLAS_REGISTER_SURFACE_MODEL, surface_model_factory.h):
  // a library may add strategies, models or both.
  std::vector<std::string> added_models;
};

// Loads the library once: later calls with the same file, under any name, give the names of the
// first load. Fails with a message when the file cannot be loaded (dlerror's reason) or registers
// no new strategy nor surface model (no GPATLAS_REGISTER_STRATEGY, only names that are already taken, or a library
// the program already holds). The library stays loaded for the life of the process: the factories
// it registered live in it. Its static initialisers run in the caller's process (a nodelet
// manager, for the AtlasPlanner): a library that throws or crashes there takes the process down.
StrategyLibraryLoad loadStrategyLibrary(const std::string& path);

}  // namespace gpatlas_core

#define GPATLAS_STRATEGY_CONCAT_INNER(a, b) a##b
#define GPATLAS_STRATEGY_CONCAT(a, b) GPATLAS_STRATEGY_CONCAT_INNER(a, b)
// Registers a strategy factory when the translation unit (or the library holding it) is loaded;
// usable several times in one file. The factory may contain commas (a lambda's captures).
#define GPATLAS_REGISTER_STRATEGY(name, ...)                                                          \
  static const bool GPATLAS_STRATEGY_CONCAT(gpatlas_strategy_registered_, __COUNTER__) [[maybe_unused]] = \
      ::gpatlas_core::registerStrategy(name, __VA_ARGS__)
