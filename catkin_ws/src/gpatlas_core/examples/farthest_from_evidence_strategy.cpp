// An exploration strategy of your own, built as a shared library and loaded by path
// (gpatlas_bench --strategy-library FILE --strategy farthest_from_evidence). It is also a
// baseline worth having: pure geometric coverage, blind to the GP's variance except for when to
// stop. It pokes, among the sampled surface points that still need a touch, the one farthest
// from everything measured (view points and contacts). It stops by the built-in baselines' rule:
// no sampled surface point above V_max or without evidence. It reads a setting of its own,
// farthest_from_evidence/surface_samples, and the evidence test's evidence/ as every strategy does.
#include <gpatlas_core/planning/exploration_strategy.h>
#include <gpatlas_core/planning/strategy_library.h>
#include <gpatlas_core/observations/surface_evidence.h>
#include <gpatlas_core/planning/surface_sampler.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>
#include <string>

namespace {

using gpatlas_core::SurfaceModel;
using gpatlas_core::PlanRequest;
using gpatlas_core::PlanResult;
using gpatlas_core::PlanStatus;
using gpatlas_core::Vector3;

class FarthestFromEvidenceStrategy : public gpatlas_core::ExplorationStrategy {
 public:
  // Its settings, read when the registry makes it: the surface points it chooses among, and the
  // evidence rule.
  FarthestFromEvidenceStrategy(gpatlas_core::ParamReader& settings, std::uint64_t seed) : seed_(seed) {
    sampler_config_.num_seeds =
        settings.integer("farthest_from_evidence/surface_samples", sampler_config_.num_seeds, 1, 1000000);
    gpatlas_core::readEvidence(settings, &evidence_);
  }

  std::string name() const override { return "farthest_from_evidence"; }

  PlanResult plan(const SurfaceModel& model, const PlanRequest& request) const override {
    const auto started = std::chrono::steady_clock::now();
    PlanResult result = choose(model, request);
    result.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return result;
  }

 private:
  PlanResult choose(const SurfaceModel& model, const PlanRequest& request) const {
    if (auto error = gpatlas_core::checkPlanInput(model, request)) return *error;
    // Its own stream, from the run's seed and the plan's.
    const std::uint64_t seed = gpatlas_core::mixSeeds(gpatlas_core::mixSeeds(seed_, kSampleStream), request.seed);
    const gpatlas_core::SurfaceSample sample = gpatlas_core::SurfaceSampler(sampler_config_).sample(model, seed);
    PlanResult result;
    if (!sample.ok) {
      result.status = PlanStatus::kError;
      result.message = "surface sampling failed: " + sample.message;
      return result;
    }
    result.max_evaluated_variance = sample.maxVariance();

    // Measured surface: view points and contacts (not free space, guesses or pseudo-points).
    std::vector<Vector3> measured;
    for (const auto& point : model.observations())
      if (gpatlas_core::isSurfaceValue(point)) measured.push_back(point.position);
    if (const std::string problem = gpatlas_core::validate(evidence_); !problem.empty()) {
      result.status = PlanStatus::kError;
      result.message = problem;
      return result;
    }
    const gpatlas_core::SurfaceEvidence evidence(model, evidence_, request.evidence_state);

    double farthest = -1.0;
    std::size_t chosen = 0;
    for (std::size_t i = 0; i < sample.points.size(); ++i) {
      const bool needs_touch =
          sample.variances[i] > request.v_max || evidence.isUnsupported(sample.points[i], sample.normals[i]);
      if (!needs_touch) continue;
      double nearest = std::numeric_limits<double>::infinity();
      for (const Vector3& m : measured) nearest = std::min(nearest, (m - sample.points[i]).squaredNorm());
      if (nearest > farthest) {
        farthest = nearest;
        chosen = i;
      }
    }
    if (farthest < 0.0) {
      result.status = PlanStatus::kConverged;
      result.message = "no sampled surface point has variance above V_max or lacks evidence" + sampled(sample);
      return result;
    }
    result.status = PlanStatus::kTouch;
    result.message = "touch at the sampled surface point farthest from the measurements" + sampled(sample);
    result.touch.kind = gpatlas_core::Touch::Kind::kPoke;
    result.touch.strategy = name();
    result.touch.points.push_back(sample.points[chosen]);
    result.touch.normals.push_back(sample.normals[chosen]);
    result.touch.variances.push_back(sample.variances[chosen]);
    return result;
  }

  static constexpr std::uint64_t kSampleStream = 7;

  static std::string sampled(const gpatlas_core::SurfaceSample& sample) {
    return " (" + std::to_string(sample.seeds_tried) + " surface samples)";
  }

  gpatlas_core::SurfaceSampler::Config sampler_config_;
  gpatlas_core::EvidenceRule evidence_;
  std::uint64_t seed_;
};

}  // namespace

GPATLAS_REGISTER_STRATEGY("farthest_from_evidence", [](gpatlas_core::ParamReader& settings, std::uint64_t seed) {
  return std::make_unique<FarthestFromEvidenceStrategy>(settings, seed);
});
