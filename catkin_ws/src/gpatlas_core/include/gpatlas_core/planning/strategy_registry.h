#pragma once

// The strategies by name: the built-in ones and those a library registers (strategy_library.h).

#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/planning/exploration_strategy.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// Makes a strategy, as MoveIt initialises its planner plugins: the strategy reads its own
// settings from `settings`, already in its namespace (makeStrategy's `ns`), with the readers of
// its Configs; a value they refuse is reported there (its default is used). `seed` is the run's:
// the strategy derives its own streams from it and from each plan's PlanRequest::seed.
using StrategyFactory = std::function<std::unique_ptr<ExplorationStrategy>(ParamReader& settings, std::uint64_t seed)>;

// Creates a strategy by name: "atlas_poke", "atlas_slide", "atlas_frontier", "random",
// "max_variance", or one added with registerStrategy, with its settings under `ns` of `settings`
// ("": the top level, as config/pipeline.yaml and the nodelets' parameters hold the built-in
// ones' planner/, score/, evidence/ and frontier/). Throws std::invalid_argument listing the
// known names.
std::unique_ptr<ExplorationStrategy> makeStrategy(const std::string& name, ParamReader& settings, std::uint64_t seed,
                                                  const std::string& ns = "");
// The same with every setting at its default.
std::unique_ptr<ExplorationStrategy> makeStrategy(const std::string& name, std::uint64_t seed = 0);
// Returns false (and changes nothing) if the name is taken or the factory is empty.
bool registerStrategy(const std::string& name, StrategyFactory factory);
std::vector<std::string> strategyNames();

}  // namespace gpatlas_core
