#include "gpatlas_core/baseline_strategies.h"
#include "gpatlas_core/surface_evidence.h"

#include <algorithm>
#include <chrono>
#include <random>

namespace gpatlas_core {

namespace {

using Clock = std::chrono::steady_clock;

// A sampled surface and, per point, whether it needs a touch: variance above V_max or no
// measured surface point within the request's evidence distance.
struct NeedySample {
  SurfaceSample sample;
  std::vector<char> unsupported;
  bool anyNeedsTouch(double v_max) const {
    for (std::size_t i = 0; i < sample.points.size(); ++i)
      if (sample.variances[i] > v_max || unsupported[i]) return true;
    return false;
  }
};

// Samples the surface and handles the shared outcomes: errors and the convergence rule.
// Returns nullopt when a touch must be chosen from `needy`.
std::optional<PlanResult> sampleOrFinish(const SurfaceModel& model, const PlanRequest& request,
                                         SurfaceSampler::Config config, std::uint64_t seed, NeedySample* needy) {
  if (auto error = checkPlanInput(model, request)) return error;
  config.seed = seed;
  needy->sample = SurfaceSampler(config).sample(model);
  PlanResult result;
  if (!needy->sample.ok) {
    result.status = PlanStatus::kError;
    result.message = "surface sampling failed: " + needy->sample.message;
    return result;
  }
  const SurfaceEvidence evidence(model, request.evidence);
  needy->unsupported.clear();
  for (std::size_t i = 0; i < needy->sample.points.size(); ++i)
    needy->unsupported.push_back(evidence.isUnsupported(needy->sample.points[i], needy->sample.normals[i]));
  result.max_surface_variance = needy->sample.maxVariance();
  if (!needy->anyNeedsTouch(request.v_max)) {
    result.status = PlanStatus::kConverged;
    result.message = "no sampled surface point has variance above V_max or lacks evidence";
    return result;
  }
  return std::nullopt;
}

PlanResult pokeAt(const SurfaceSample& sample, std::size_t index, const std::string& strategy) {
  PlanResult result;
  result.status = PlanStatus::kTouch;
  result.message = "touch at a sampled surface point";
  result.max_surface_variance = sample.maxVariance();
  result.touch.kind = Touch::Kind::kPoke;
  result.touch.strategy = strategy;
  result.touch.points.push_back(sample.points[index]);
  result.touch.normals.push_back(sample.normals[index]);
  result.touch.variances.push_back(sample.variances[index]);
  return result;
}

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The baselines share everything but the choice of the sampled point they poke.
template <typename Pick>
PlanResult planOnSample(const SurfaceModel& model, const PlanRequest& request, const SurfaceSampler::Config& config,
                        std::uint64_t seed, const std::string& name, Pick pick) {
  const Clock::time_point started = Clock::now();
  NeedySample needy;
  if (auto finished = sampleOrFinish(model, request, config, seed, &needy)) {
    finished->elapsed_s = secondsSince(started);
    return *finished;
  }
  PlanResult result = pokeAt(needy.sample, pick(needy, request, seed), name);
  result.elapsed_s = secondsSince(started);
  return result;
}

}  // namespace

RandomStrategy::RandomStrategy(SurfaceSampler::Config config, std::uint64_t seed)
    : config_(std::move(config)), seed_(seed) {}

PlanResult RandomStrategy::plan(const SurfaceModel& model, const PlanRequest& request) const {
  return planOnSample(model, request, config_, mixSeeds(mixSeeds(seed_, config_.seed), request.seed), name(),
                      [](const NeedySample& needy, const PlanRequest&, std::uint64_t seed) {
                        std::mt19937_64 rng(mixSeeds(seed, 1));
                        return std::uniform_int_distribution<std::size_t>(0, needy.sample.points.size() - 1)(rng);
                      });
}

MaxVarianceStrategy::MaxVarianceStrategy(SurfaceSampler::Config config, std::uint64_t seed)
    : config_(std::move(config)), seed_(seed) {}

PlanResult MaxVarianceStrategy::plan(const SurfaceModel& model, const PlanRequest& request) const {
  return planOnSample(model, request, config_, mixSeeds(mixSeeds(seed_, config_.seed), request.seed), name(),
                      [](const NeedySample& needy, const PlanRequest& request, std::uint64_t) {
                        const std::vector<double>& variances = needy.sample.variances;
                        const auto best = std::max_element(variances.begin(), variances.end());
                        if (*best > request.v_max) return static_cast<std::size_t>(best - variances.begin());
                        // Every variance is below V_max: the first point without evidence.
                        const auto unsupported = std::find(needy.unsupported.begin(), needy.unsupported.end(), 1);
                        return static_cast<std::size_t>(unsupported - needy.unsupported.begin());
                      });
}

}  // namespace gpatlas_core
