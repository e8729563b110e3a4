#pragma once

// The strategies by name: the built-in ones and those a library registers (strategy_library.h).

#include "gpatlas_core/planning/atlas_planner.h"
#include "gpatlas_core/planning/exploration_strategy.h"
#include "gpatlas_core/planning/frontier_strategy.h"
#include "gpatlas_core/planning/surface_sampler.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

inline AtlasPlanner::Config atlasStrategyDefaults() {
  AtlasPlanner::Config config;
  config.extend_path_charts = 20;
  return config;
}

// Everything a built-in strategy may need; each uses the parts that concern it.
struct StrategyConfig {
  // atlas_poke, atlas_slide; atlas_poke does not extend its path (extend_path_charts): a poke
  // touches the first chart above V_max.
  // Its evidence rule is `evidence` below (the atlas strategies set atlas.evidence from it).
  AtlasPlanner::Config atlas{atlasStrategyDefaults()};
  SurfaceSampler::Config sampler;   // random, max_variance
  // atlas_frontier: its pokes into unobserved space; its atlas is atlas_poke's (`atlas` above).
  FrontierStrategy::Config frontier;
  // Every strategy's evidence test (config/pipeline.yaml's evidence/).
  EvidenceRule evidence;
  std::uint64_t seed{0};
};

using StrategyFactory = std::function<std::unique_ptr<ExplorationStrategy>(const StrategyConfig&)>;

// Creates a strategy by name: "atlas_poke", "atlas_slide", "atlas_frontier", "random",
// "max_variance", or one added with registerStrategy. Throws std::invalid_argument listing the known names.
std::unique_ptr<ExplorationStrategy> makeStrategy(const std::string& name,
                                                  const StrategyConfig& config = StrategyConfig());
// Returns false (and changes nothing) if the name is taken or the factory is empty.
bool registerStrategy(const std::string& name, StrategyFactory factory);
std::vector<std::string> strategyNames();

}  // namespace gpatlas_core
