#include "bench_oracle.h"

#include <gpatlas_core/planning/baseline_strategies.h>
#include <gpatlas_core/observations/touch_training.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>

namespace gpatlas_bench {

namespace {

using gpatlas_core::Vector3;

gpatlas_core::Touch pokeAt(const Vector3& point, const Vector3& direction, double variance) {
  gpatlas_core::Touch touch;
  touch.kind = gpatlas_core::Touch::Kind::kPoke;
  touch.strategy = kOracleStrategy;
  touch.points = {point};
  touch.normals = {direction.normalized()};
  touch.variances = {variance};
  return touch;
}

// The direction the approacher's cheap test chose for a touch of `point`; the normal without a test.
std::optional<Vector3> approachDirection(const gpatlas_core::PlanRequest& request, const Vector3& point,
                                         const Vector3& normal) {
  if (!request.reachable) return normal;
  return request.reachable(point, normal);
}

}  // namespace

std::string describe(const OracleCandidate& c) {
  std::ostringstream out;
  out.precision(3);
  const Vector3& p = c.touch.points.back();
  const Vector3& n = c.touch.normals.back();
  out << c.source << " at (" << p.x() << ", " << p.y() << ", " << p.z() << ") m along (" << n.x() << ", " << n.y()
      << ", " << n.z() << ")";
  return out.str();
}

namespace {
gpatlas_core::MaxVarianceStrategy maxVariance(gpatlas_core::ParamReader& settings, std::uint64_t seed) {
  gpatlas_core::SurfaceSampler::Config sampler;
  gpatlas_core::readSurfaceSampler(settings, &sampler);
  gpatlas_core::EvidenceRule evidence;
  gpatlas_core::readEvidence(settings, &evidence);
  return gpatlas_core::MaxVarianceStrategy(sampler, evidence, seed);
}
}  // namespace

OracleStrategy::OracleStrategy(Config config, gpatlas_core::ParamReader& settings, std::uint64_t seed, Probe probe,
                               Score score, Report report)
    : config_(std::move(config)),
      atlas_poke_(gpatlas_core::makeStrategy("atlas_poke", settings, seed)),
      max_variance_(maxVariance(settings, seed)),
      probe_(std::move(probe)),
      score_(std::move(score)),
      report_(std::move(report)) {}

std::vector<OracleCandidate> OracleStrategy::candidates(const gpatlas_core::SurfaceModel& model,
                                                        const gpatlas_core::PlanRequest& request,
                                                        const gpatlas_core::PlanResult& atlas_plan) const {
  std::vector<OracleCandidate> out;
  // Candidates at the same point are one: the first kept (atlas_poke's choice is among its scored charts).
  const auto add = [&out](OracleCandidate candidate) {
    for (const OracleCandidate& c : out)
      if ((c.touch.points.back() - candidate.touch.points.back()).norm() < 1e-6) return;
    out.push_back(std::move(candidate));
  };
  gpatlas_core::Touch chosen = atlas_plan.touch;
  chosen.strategy = kOracleStrategy;
  add({chosen, "atlas_poke"});
  if (atlas_plan.atlas)
    for (int index : atlas_plan.atlas->scored_charts) {
      const gpatlas_core::Chart& chart = atlas_plan.atlas->atlas.chart(index);
      if (const auto direction = approachDirection(request, chart.centre, chart.normal))
        add({pokeAt(chart.centre, *direction, chart.variance), "scored"});
    }
  int rank = 0;
  for (gpatlas_core::Touch& touch : max_variance_.rankedPokes(model, request, config_.max_variance_candidates)) {
    touch.strategy = kOracleStrategy;
    add({std::move(touch), "max_variance " + std::to_string(++rank)});
  }
  return out;
}

double OracleStrategy::scoreAfter(const gpatlas_core::SurfaceModel& model, const gpatlas_core::Touch& touch,
                                  const gpatlas_core::TouchObservationConfig& observations, double score_before) const {
  const gpatlas_core::ProbeResult probed = probe_(touch);
  // As the Explorer's loop: a probe that found nothing leaves the model as it was.
  if (probed.contacts.empty() && probed.free_space.empty()) return score_before;
  const std::unique_ptr<gpatlas_core::SurfaceModel> copy = model.clone();
  const gpatlas_core::TouchUpdate update =
      gpatlas_core::applyTouch(*copy, probed.contacts, probed.free_space, observations);
  return update.ok ? score_(*copy) : score_before;
}

gpatlas_core::PlanResult OracleStrategy::plan(const gpatlas_core::SurfaceModel& model,
                                              const gpatlas_core::PlanRequest& request) const {
  const auto started = std::chrono::steady_clock::now();
  gpatlas_core::PlanResult result = atlas_poke_->plan(model, request);
  if (result.status != gpatlas_core::PlanStatus::kTouch) return result;
  OraclePlan plan;
  plan.score_before = score_(model);
  plan.candidates = candidates(model, request, result);
  // NaN (no surface) is the worst score; ties go to the first.
  double best = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < plan.candidates.size(); ++i) {
    OracleCandidate& c = plan.candidates[i];
    c.score = scoreAfter(model, c.touch, request.touch_observations, plan.score_before);
    if (!std::isnan(c.score) && c.score > best) {
      best = c.score;
      plan.best = i;
    }
  }
  plan.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const OracleCandidate& chosen = plan.candidates[plan.best];
  result.touch = chosen.touch;
  std::ostringstream message;
  message.precision(3);
  message << "oracle: " << describe(chosen) << ", score " << chosen.score << " after it (" << plan.score_before
          << " before), best of " << plan.candidates.size() << " candidates; atlas_poke's: " << result.message;
  result.message = message.str();
  result.elapsed_s = plan.seconds;
  if (report_) report_(plan);
  return result;
}

}  // namespace gpatlas_bench
