#include "gpatlas_core/exploration_strategy.h"

#include "gpatlas_core/atlas_strategy.h"
#include "gpatlas_core/baseline_strategies.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
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
      return std::make_unique<AtlasStrategy>(AtlasStrategy::Mode::kPoke, atlas, c.seed);
    };
    factories["atlas_slide"] = [](const StrategyConfig& c) {
      return std::make_unique<AtlasStrategy>(AtlasStrategy::Mode::kSlide, c.atlas, c.seed);
    };
    factories["random"] = [](const StrategyConfig& c) { return std::make_unique<RandomStrategy>(c.sampler, c.seed); };
    factories["max_variance"] = [](const StrategyConfig& c) {
      return std::make_unique<MaxVarianceStrategy>(c.sampler, c.seed);
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

std::string vMaxNoiseNote(const SurfaceModel& model, double v_max) {
  double smallest = std::numeric_limits<double>::infinity();
  for (const TrainingPoint& point : model.observations())
    if (isSurfaceValue(point) && point.noise_sigma > 0.0 && std::isfinite(point.noise_sigma))
      smallest = std::min(smallest, point.noise_sigma * point.noise_sigma);
  if (!std::isfinite(smallest) || !(v_max < 0.1 * smallest)) return "";
  std::ostringstream note;
  note << "V_max " << v_max << " is below a tenth of the smallest observation noise variance (" << smallest
       << "): a point must be observed more than ten times to get there, so the exploration may not converge";
  return note.str();
}

std::optional<PlanResult> checkPlanInput(const SurfaceModel& model, const PlanRequest& request) {
  PlanResult error;
  error.status = PlanStatus::kError;
  if (!model.isFitted()) {
    error.message = "no model: the GP is not fitted";
    return error;
  }
  if (!(request.v_max > 0.0) || !std::isfinite(request.v_max)) {
    error.message = "V_max must be a positive finite number";
    return error;
  }
  if (std::string problem = validate(request.evidence); !problem.empty()) {
    error.message = problem;
    return error;
  }
  if (!(request.footprint_radius_m >= 0.0) || !std::isfinite(request.footprint_radius_m)) {
    error.message = "the probe's footprint radius must be finite and >= 0";
    return error;
  }
  if (request.start && !request.start->allFinite()) {
    error.message = "start point is not finite";
    return error;
  }
  return std::nullopt;
}

std::uint64_t mixSeeds(std::uint64_t a, std::uint64_t b) {
  std::uint64_t z = a + 0x9e3779b97f4a7c15ULL * (b + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace gpatlas_core
