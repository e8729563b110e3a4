#include "gpatlas_core/baseline_strategies.h"

#include <algorithm>
#include <chrono>
#include <random>

namespace gpatlas_core {

namespace {

using Clock = std::chrono::steady_clock;

// Samples the surface and handles the shared outcomes: errors and the convergence rule.
// Returns nullopt when a touch must be chosen from `sample`.
std::optional<PlanResult> sampleOrFinish(const GpisModel& model, const PlanRequest& request,
                                         SurfaceSampler::Config config, std::uint64_t seed,
                                         SurfaceSample* sample) {
  if (auto error = checkPlanInput(model, request)) return error;
  config.seed = seed;
  *sample = SurfaceSampler(config).sample(model);
  PlanResult result;
  if (!sample->ok) {
    result.status = PlanStatus::kError;
    result.message = "surface sampling failed: " + sample->message;
    return result;
  }
  result.max_surface_variance = sample->maxVariance();
  if (result.max_surface_variance <= request.v_max) {
    result.status = PlanStatus::kConverged;
    result.message = "no sampled surface point has variance above V_max";
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
PlanResult planOnSample(const GpisModel& model, const PlanRequest& request, const SurfaceSampler::Config& config,
                        std::uint64_t seed, const std::string& name, Pick pick) {
  const Clock::time_point started = Clock::now();
  SurfaceSample sample;
  if (auto finished = sampleOrFinish(model, request, config, seed, &sample)) {
    finished->elapsed_s = secondsSince(started);
    return *finished;
  }
  PlanResult result = pokeAt(sample, pick(sample, seed), name);
  result.elapsed_s = secondsSince(started);
  return result;
}

}  // namespace

RandomStrategy::RandomStrategy(SurfaceSampler::Config config, std::uint64_t seed)
    : config_(std::move(config)), seed_(seed) {}

PlanResult RandomStrategy::plan(const GpisModel& model, const PlanRequest& request) const {
  return planOnSample(model, request, config_, mixSeeds(mixSeeds(seed_, config_.seed), request.seed), name(),
                      [](const SurfaceSample& sample, std::uint64_t seed) {
                        std::mt19937_64 rng(mixSeeds(seed, 1));
                        return std::uniform_int_distribution<std::size_t>(0, sample.points.size() - 1)(rng);
                      });
}

MaxVarianceStrategy::MaxVarianceStrategy(SurfaceSampler::Config config, std::uint64_t seed)
    : config_(std::move(config)), seed_(seed) {}

PlanResult MaxVarianceStrategy::plan(const GpisModel& model, const PlanRequest& request) const {
  return planOnSample(model, request, config_, mixSeeds(mixSeeds(seed_, config_.seed), request.seed), name(),
                      [](const SurfaceSample& sample, std::uint64_t) {
                        const auto best = std::max_element(sample.variances.begin(), sample.variances.end());
                        return static_cast<std::size_t>(best - sample.variances.begin());
                      });
}

}  // namespace gpatlas_core
