#include "gpatlas_core/planning/strategy_registry.h"

#include "gpatlas_core/planning/atlas_strategy.h"
#include "gpatlas_core/planning/baseline_strategies.h"

#include <map>
#include <mutex>
#include <stdexcept>

namespace gpatlas_core {

namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, StrategyFactory> factories;

  Registry() {
    factories["atlas_poke"] = [](const StrategyConfig& c) {
      AtlasPlanner::Config atlas = c.atlas;
      atlas.extend_path_charts = 0;
      atlas.evidence = c.evidence;
      return std::make_unique<AtlasStrategy>(AtlasStrategy::Mode::kPoke, atlas, c.seed);
    };
    factories["atlas_slide"] = [](const StrategyConfig& c) {
      AtlasPlanner::Config atlas = c.atlas;
      atlas.evidence = c.evidence;
      return std::make_unique<AtlasStrategy>(AtlasStrategy::Mode::kSlide, atlas, c.seed);
    };
    factories["random"] = [](const StrategyConfig& c) {
      return std::make_unique<RandomStrategy>(c.sampler, c.evidence, c.seed);
    };
    factories["max_variance"] = [](const StrategyConfig& c) {
      return std::make_unique<MaxVarianceStrategy>(c.sampler, c.evidence, c.seed);
    };
  }
};

Registry& registry() {
  static Registry instance;
  return instance;
}

}  // namespace

std::unique_ptr<ExplorationStrategy> makeStrategy(const std::string& name, const StrategyConfig& config) {
  StrategyFactory factory;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    const auto found = r.factories.find(name);
    if (found != r.factories.end()) factory = found->second;
  }
  if (!factory) {
    std::string known;
    for (const std::string& n : strategyNames()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown exploration strategy '" + name + "'; known: " + known);
  }
  return factory(config);
}

bool registerStrategy(const std::string& name, StrategyFactory factory) {
  if (name.empty() || !factory) return false;
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  return r.factories.emplace(name, std::move(factory)).second;
}

std::vector<std::string> strategyNames() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<std::string> names;
  for (const auto& entry : r.factories) names.push_back(entry.first);
  return names;
}

}  // namespace gpatlas_core
