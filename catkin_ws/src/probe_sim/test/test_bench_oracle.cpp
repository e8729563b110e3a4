// gpatlas_bench's oracle_poke (tools/bench_oracle.h) on an analytic sphere seen from above.

#include "../tools/bench_oracle.h"

#include <gpatlas_core/model/gpis_model.h>
#include <gpatlas_core/observations/touch_training.h>
#include <gpatlas_core/testing/analytic_sphere.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

namespace {

using gpatlas_core::Vector3;
using gpatlas_core::testing::AnalyticSphere;
using gpatlas_core::testing::AnalyticSphereProber;

// The score against the truth: minus the mean |f| of the model's mean over the true sphere.
double truthScore(const gpatlas_core::SurfaceModel& model, const AnalyticSphere& sphere) {
  double sum = 0.0;
  const int n = 12;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double polar = M_PI * (i + 0.5) / n, azimuth = 2.0 * M_PI * j / n;
      const Vector3 direction(std::sin(polar) * std::cos(azimuth), std::sin(polar) * std::sin(azimuth), std::cos(polar));
      sum += std::abs(model.mean(sphere.centre + sphere.radius * direction));
    }
  return -sum / (n * n);
}

bool samePoint(const gpatlas_core::Touch& a, const gpatlas_core::Touch& b) {
  return (a.points.back() - b.points.back()).norm() < 1e-9 && (a.normals.back() - b.normals.back()).norm() < 1e-9;
}

// Its touch is the best of its candidates by scores the test computes itself (a probe of the
// true sphere added to a copy of the model), and its candidates hold atlas_poke's and
// max_variance's own choices.
TEST(OracleStrategy, PokesTheBestScoringOfItsCandidates) {
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(150, 0.3, 0.316, 1)).ok);
  gpatlas_bench::OracleStrategy::Config config;
  std::string error;
  const auto defaults = gpatlas_core::YamlParameters::fromString("{}", &error);  // every setting's default
  gpatlas_core::ParamReader settings(*defaults);
  gpatlas_core::PlanRequest request;
  request.v_max = 0.1;
  request.max_position_sd_m = 0.005;
  request.seed = 3;

  gpatlas_bench::OraclePlan reported;
  AnalyticSphereProber oracle_prober(sphere);
  const gpatlas_bench::OracleStrategy oracle(
      config, settings, 0, [&](const gpatlas_core::Touch& touch) { return oracle_prober.probe(touch); },
      [&](const gpatlas_core::SurfaceModel& m) { return truthScore(m, sphere); },
      [&](const gpatlas_bench::OraclePlan& plan) { reported = plan; });
  const gpatlas_core::PlanResult plan = oracle.plan(model, request);
  ASSERT_EQ(plan.status, gpatlas_core::PlanStatus::kTouch) << plan.message;
  ASSERT_GE(reported.candidates.size(), 5u);

  const gpatlas_core::PlanResult atlas = gpatlas_core::makeStrategy("atlas_poke")->plan(model, request);
  const gpatlas_core::PlanResult max_variance = gpatlas_core::makeStrategy("max_variance")->plan(model, request);
  ASSERT_EQ(atlas.status, gpatlas_core::PlanStatus::kTouch);
  ASSERT_EQ(max_variance.status, gpatlas_core::PlanStatus::kTouch);
  EXPECT_TRUE(samePoint(reported.candidates.front().touch, atlas.touch));
  EXPECT_TRUE(std::any_of(reported.candidates.begin(), reported.candidates.end(),
                          [&](const auto& c) { return samePoint(c.touch, max_variance.touch); }));

  std::vector<double> scores;
  AnalyticSphereProber prober(sphere);
  for (const gpatlas_bench::OracleCandidate& c : reported.candidates) {
    const gpatlas_core::ProbeResult probed = prober.probe(c.touch);
    const std::unique_ptr<gpatlas_core::SurfaceModel> copy = model.clone();
    ASSERT_TRUE(gpatlas_core::applyTouch(*copy, probed.contacts, probed.free_space, {}).ok);
    scores.push_back(truthScore(*copy, sphere));
  }
  const std::size_t best = static_cast<std::size_t>(std::max_element(scores.begin(), scores.end()) - scores.begin());
  // The candidates differ enough that the choice means something.
  EXPECT_GT(scores[best] - *std::min_element(scores.begin(), scores.end()), 1e-4);
  EXPECT_TRUE(samePoint(plan.touch, reported.candidates[best].touch)) << plan.message;
  EXPECT_NEAR(reported.candidates[best].score, scores[best], 1e-9);
}

}  // namespace
