#include "gpatlas_core/planning/strategy_registry.h"

#include "gpatlas_core/common/named_factories.h"
#include "gpatlas_core/planning/atlas_strategy.h"
#include "gpatlas_core/planning/baseline_strategies.h"
#include "gpatlas_core/planning/frontier_strategy.h"

#include <stdexcept>

namespace gpatlas_core {

namespace {

AtlasPlanner::Config atlasPlannerSettings(ParamReader& settings) {
  AtlasPlanner::Config atlas;
  readAtlasPlanner(settings, &atlas);
  return atlas;
}

StrategyFactory atlasFactory(AtlasStrategy::Mode mode) {
  return [mode](ParamReader& settings, std::uint64_t seed) {
    return std::make_unique<AtlasStrategy>(mode, atlasPlannerSettings(settings), seed);
  };
}

template <typename Baseline>
StrategyFactory baselineFactory() {
  return [](ParamReader& settings, std::uint64_t seed) {
    SurfaceSampler::Config sampler;
    readSurfaceSampler(settings, &sampler);
    EvidenceRule evidence;
    readEvidence(settings, &evidence);
    return std::make_unique<Baseline>(sampler, evidence, seed);
  };
}

NamedFactories<StrategyFactory>& registry() {
  static NamedFactories<StrategyFactory> instance({
      {"atlas_poke", atlasFactory(AtlasStrategy::Mode::kPoke)},
      {"atlas_slide", atlasFactory(AtlasStrategy::Mode::kSlide)},
      {"atlas_frontier",
       [](ParamReader& settings, std::uint64_t seed) {
         FrontierStrategy::Config frontier;
         readFrontier(settings, &frontier);
         return std::make_unique<FrontierStrategy>(frontier, atlasPlannerSettings(settings), seed);
       }},
      {"random", baselineFactory<RandomStrategy>()},
      {"max_variance", baselineFactory<MaxVarianceStrategy>()},
  });
  return instance;
}

}  // namespace

std::unique_ptr<ExplorationStrategy> makeStrategy(const std::string& name, ParamReader& settings, std::uint64_t seed,
                                                  const std::string& ns) {
  const StrategyFactory factory = registry().find(name);
  if (!factory)
    throw std::invalid_argument("unknown exploration strategy '" + name + "'; known: " + registry().namesJoined());
  const ParamReader::Scope section(settings, ns);
  return factory(settings, seed);
}

std::unique_ptr<ExplorationStrategy> makeStrategy(const std::string& name, std::uint64_t seed) {
  const NoParameters none;
  ParamReader defaults(none);
  auto strategy = makeStrategy(name, defaults, seed);
  // A factory that needs a setting it was not given says so: that is no strategy to run.
  if (!defaults.ok()) throw std::invalid_argument("strategy '" + name + "' with its defaults: " + defaults.errors());
  return strategy;
}

bool registerStrategy(const std::string& name, StrategyFactory factory) { return registry().add(name, std::move(factory)); }

std::vector<std::string> strategyNames() { return registry().names(); }

}  // namespace gpatlas_core
