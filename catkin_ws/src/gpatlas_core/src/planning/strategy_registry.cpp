#include "gpatlas_core/planning/strategy_registry.h"

#include "gpatlas_core/common/named_factories.h"
#include "gpatlas_core/planning/atlas_strategy.h"
#include "gpatlas_core/planning/baseline_strategies.h"

#include <stdexcept>

namespace gpatlas_core {

namespace {

// atlas_poke's planner, also atlas_frontier's: a poke touches the first chart that needs one.
AtlasPlanner::Config pokeAtlas(const StrategyConfig& c) {
  AtlasPlanner::Config atlas = c.atlas;
  atlas.extend_path_charts = 0;
  atlas.evidence = c.evidence;
  return atlas;
}

NamedFactories<StrategyFactory>& registry() {
  static NamedFactories<StrategyFactory> instance({
      {"atlas_poke",
       [](const StrategyConfig& c) {
         return std::make_unique<AtlasStrategy>(AtlasStrategy::Mode::kPoke, pokeAtlas(c), c.seed);
       }},
      {"atlas_slide",
       [](const StrategyConfig& c) {
         AtlasPlanner::Config atlas = c.atlas;
         atlas.evidence = c.evidence;
         return std::make_unique<AtlasStrategy>(AtlasStrategy::Mode::kSlide, atlas, c.seed);
       }},
      {"atlas_frontier",
       [](const StrategyConfig& c) {
         FrontierStrategy::Config frontier = c.frontier;
         frontier.atlas = pokeAtlas(c);
         return std::make_unique<FrontierStrategy>(frontier, c.seed);
       }},
      {"random",
       [](const StrategyConfig& c) { return std::make_unique<RandomStrategy>(c.sampler, c.evidence, c.seed); }},
      {"max_variance",
       [](const StrategyConfig& c) { return std::make_unique<MaxVarianceStrategy>(c.sampler, c.evidence, c.seed); }},
  });
  return instance;
}

}  // namespace

std::unique_ptr<ExplorationStrategy> makeStrategy(const std::string& name, const StrategyConfig& config) {
  const StrategyFactory factory = registry().find(name);
  if (!factory)
    throw std::invalid_argument("unknown exploration strategy '" + name + "'; known: " + registry().namesJoined());
  return factory(config);
}

bool registerStrategy(const std::string& name, StrategyFactory factory) { return registry().add(name, std::move(factory)); }

std::vector<std::string> strategyNames() { return registry().names(); }

}  // namespace gpatlas_core
