#include "gpatlas_core/planning/baseline_strategies.h"
#include "gpatlas_core/observations/surface_evidence.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <random>
#include <utility>

namespace gpatlas_core {

namespace {

using Clock = std::chrono::steady_clock;

// A plan's surface sample: the baselines' own stream of the run's seed, varied by the plan's.
std::uint64_t sampleSeed(std::uint64_t run_seed, const PlanRequest& request) {
  constexpr std::uint64_t kSampleStream = 7;
  return mixSeeds(mixSeeds(run_seed, kSampleStream), request.seed);
}

// A sampled surface and, per point, whether it needs a touch: above the StopRule or no
// measured surface point within the rule's evidence distance, and no measurement or earlier
// touch's target right there (EvidenceRule::retouch_radius_m): a touch would find what was found.
struct NeedySample {
  SurfaceSample sample;
  std::vector<char> unsupported;
  std::vector<char> retouched;
  bool exceeds(std::size_t i, const SurfaceModel& model, const StopRule& rule) const {
    return rule.exceeded(model, sample.variances[i], sample.slopes[i]);
  }
  bool needsTouch(std::size_t i, const SurfaceModel& model, const StopRule& rule) const {
    return (unsupported[i] || exceeds(i, model, rule)) && !retouched[i];
  }
  bool anyNeedsTouch(const SurfaceModel& model, const StopRule& rule) const {
    for (std::size_t i = 0; i < sample.points.size(); ++i)
      if (needsTouch(i, model, rule)) return true;
    return false;
  }
};

// Samples the surface and handles the shared outcomes: errors and the convergence rule.
// Returns nullopt when a touch must be chosen from `needy`.
std::optional<PlanResult> sampleOrFinish(const SurfaceModel& model, const PlanRequest& request,
                                         const SurfaceSampler::Config& config, const EvidenceRule& rule, std::uint64_t seed,
                                         NeedySample* needy) {
  if (auto error = checkPlanInput(model, request)) return error;
  if (std::string problem = validate(rule); !problem.empty()) {
    PlanResult error;
    error.status = PlanStatus::kError;
    error.message = problem;
    return error;
  }
  needy->sample = SurfaceSampler(config).sample(model, seed);
  PlanResult result;
  if (!needy->sample.ok) {
    result.status = PlanStatus::kError;
    result.message = "surface sampling failed: " + needy->sample.message;
    return result;
  }
  const SurfaceEvidence evidence(model, rule, request.evidence_state);
  needy->unsupported.clear();
  needy->retouched.clear();
  for (std::size_t i = 0; i < needy->sample.points.size(); ++i) {
    needy->unsupported.push_back(evidence.isUnsupported(needy->sample.points[i], needy->sample.normals[i]));
    needy->retouched.push_back(evidence.measuredNear(needy->sample.points[i], rule.retouch_radius_m));
  }
  result.max_evaluated_variance = needy->sample.maxVariance();
  if (!needy->anyNeedsTouch(model, request.stopRule())) {
    result.status = PlanStatus::kConverged;
    result.message = "no sampled surface point has " + request.stopRule().describe() + " or lacks evidence";
    std::size_t retouched = 0;
    for (std::size_t i = 0; i < needy->retouched.size(); ++i)
      retouched += needy->retouched[i] && needy->exceeds(i, model, request.stopRule()) ? 1 : 0;
    if (retouched > 0)
      result.message += " (" + std::to_string(retouched) + " above the bound at measurements or earlier targets)";
    return result;
  }
  return std::nullopt;
}

PlanResult pokeAt(const SurfaceSample& sample, std::size_t index, const std::string& strategy,
                  const std::optional<Vector3>& approach_direction = std::nullopt) {
  PlanResult result;
  result.status = PlanStatus::kTouch;
  result.message = "touch at a sampled surface point";
  result.max_evaluated_variance = sample.maxVariance();
  result.touch.kind = Touch::Kind::kPoke;
  result.touch.strategy = strategy;
  result.touch.points.push_back(sample.points[index]);
  result.touch.normals.push_back(approach_direction ? approach_direction->normalized() : sample.normals[index]);
  result.touch.variances.push_back(sample.variances[index]);
  return result;
}

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The sampled points a baseline tries, in its order, are offered to the approacher's cheap test
// (PlanRequest::reachable) at most this many times per plan: the first it accepts is poked
// along the direction it chose. When it accepts none, the first is poked along its normal and
// the approacher refuses it (a failed touch, as without the test): a baseline has no coverage
// argument to converge on. Each test costs a few collision checks of the probe's approach;
// 32 keeps a plan's tests below the atlas's typical count.
constexpr std::size_t kMaxReachabilityChecks = 32;

PlanResult pokeFirstReachable(const NeedySample& needy, const std::vector<std::size_t>& ranked,
                              const PlanRequest& request, const std::string& name) {
  const SurfaceSample& sample = needy.sample;
  if (!request.reachable) return pokeAt(sample, ranked.front(), name);
  int refused = 0;
  for (std::size_t k = 0; k < ranked.size() && k < kMaxReachabilityChecks; ++k) {
    const std::size_t i = ranked[k];
    if (const std::optional<Vector3> direction = request.reachable(sample.points[i], sample.normals[i])) {
      PlanResult result = pokeAt(sample, i, name, direction);
      result.unreachable_candidates = refused;
      return result;
    }
    ++refused;
  }
  PlanResult result = pokeAt(sample, ranked.front(), name);
  result.unreachable_candidates = refused;
  result.message += " (no safe approach found for the first " + std::to_string(refused) + " tried)";
  return result;
}

// The baselines share everything but the order in which they try the sampled points (`rank`).
template <typename Rank>
PlanResult planOnSample(const SurfaceModel& model, const PlanRequest& request, const SurfaceSampler::Config& config,
                        const EvidenceRule& rule, std::uint64_t seed, const std::string& name, Rank rank) {
  const Clock::time_point started = Clock::now();
  NeedySample needy;
  const auto noted = [&](PlanResult result) {
    if (result.status != PlanStatus::kError)
      if (const std::string note = vMaxNoiseNote(model, request.v_max); !note.empty()) result.message += "; " + note;
    result.elapsed_s = secondsSince(started);
    return result;
  };
  if (auto finished = sampleOrFinish(model, request, config, rule, seed, &needy)) return noted(*finished);
  return noted(pokeFirstReachable(needy, rank(needy, request, seed), request, name));
}

// The points that need a touch (one does), furthest past the stop rule first: under V_max alone,
// by variance.
std::vector<std::size_t> rankByExcess(const NeedySample& needy, const SurfaceModel& model, const StopRule& rule) {
  const SurfaceSample& sample = needy.sample;
  std::vector<std::pair<double, std::size_t>> needing;
  for (std::size_t i = 0; i < sample.points.size(); ++i)
    if (needy.needsTouch(i, model, rule)) {
      // A point whose variance is unknown counts as the most uncertain.
      const double excess = rule.excess(model, sample.variances[i], sample.slopes[i]);
      needing.emplace_back(std::isnan(excess) ? std::numeric_limits<double>::infinity() : excess, i);
    }
  std::stable_sort(needing.begin(), needing.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::size_t> ranked;
  for (const auto& [excess, i] : needing) ranked.push_back(i);
  return ranked;
}

}  // namespace

RandomStrategy::RandomStrategy(SurfaceSampler::Config config, EvidenceRule evidence, std::uint64_t seed)
    : config_(std::move(config)), evidence_(std::move(evidence)), seed_(seed) {}

PlanResult RandomStrategy::plan(const SurfaceModel& model, const PlanRequest& request) const {
  return planOnSample(model, request, config_, evidence_, sampleSeed(seed_, request), name(),
                      [](const NeedySample& needy, const PlanRequest&, std::uint64_t seed) {
                        // Every sampled point, in random order.
                        std::vector<std::size_t> order(needy.sample.points.size());
                        std::iota(order.begin(), order.end(), std::size_t{0});
                        std::mt19937_64 rng(mixSeeds(seed, 1));
                        std::shuffle(order.begin(), order.end(), rng);
                        return order;
                      });
}

MaxVarianceStrategy::MaxVarianceStrategy(SurfaceSampler::Config config, EvidenceRule evidence, std::uint64_t seed)
    : config_(std::move(config)), evidence_(std::move(evidence)), seed_(seed) {}

PlanResult MaxVarianceStrategy::plan(const SurfaceModel& model, const PlanRequest& request) const {
  return planOnSample(model, request, config_, evidence_, sampleSeed(seed_, request), name(),
                      [&model](const NeedySample& needy, const PlanRequest& request, std::uint64_t) {
                        return rankByExcess(needy, model, request.stopRule());
                      });
}

std::vector<Touch> MaxVarianceStrategy::rankedPokes(const SurfaceModel& model, const PlanRequest& request,
                                                    int count) const {
  NeedySample needy;
  if (sampleOrFinish(model, request, config_, evidence_, sampleSeed(seed_, request), &needy))
    return {};
  const std::vector<std::size_t> ranked = rankByExcess(needy, model, request.stopRule());
  std::vector<Touch> pokes;
  for (std::size_t k = 0; k < ranked.size() && k < kMaxReachabilityChecks && static_cast<int>(pokes.size()) < count;
       ++k) {
    const std::size_t i = ranked[k];
    const std::optional<Vector3> direction =
        request.reachable ? request.reachable(needy.sample.points[i], needy.sample.normals[i])
                          : std::optional<Vector3>(needy.sample.normals[i]);
    if (direction) pokes.push_back(pokeAt(needy.sample, i, name(), direction).touch);
  }
  return pokes;
}

}  // namespace gpatlas_core
