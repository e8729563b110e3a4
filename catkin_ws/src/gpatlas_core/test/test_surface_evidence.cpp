// SurfaceEvidence and the evidence test of the planners: checked against brute-force distances
// to the measured surface points.

#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/planning/atlas_planner.h"
#include "gpatlas_core/planning/atlas_strategy.h"
#include "gpatlas_core/planning/baseline_strategies.h"
#include "gpatlas_core/planning/strategy_registry.h"
#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/observations/surface_evidence.h"

#include "gpatlas_core/testing/analytic_sphere.h"
#include "gpatlas_core/testing/strategy_settings.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <random>

using namespace gpatlas_core;
using gpatlas_core::testing::AnalyticSphere;
using gpatlas_core::testing::strategyWith;

namespace {

constexpr double kNoiseSigma = 0.316;
// So large that no variance exceeds it: only the evidence test can ask for a touch.
constexpr double kHugeVMax = 1e9;

double bruteForceDistance(const GpisModel& model, const Vector3& x) {
  double best = std::numeric_limits<double>::infinity();
  for (const TrainingPoint& p : model.observations())
    if (p.label == PointLabel::kSurface && (p.source == PointSource::kVision || p.source == PointSource::kTouch))
      best = std::min(best, (p.position - x).norm());
  return best;
}

// The sphere seen all over except a cap around +z (directions with z > 0.6), or around -z.
GpisModel modelWithAHoleOnTop(const AnalyticSphere& sphere, double hole_side = 1.0) {
  std::vector<TrainingPoint> points;
  for (const TrainingPoint& p : sphere.view(1200, -1.0, kNoiseSigma, 3))
    if (hole_side * (p.position - sphere.centre).normalized().z() <= 0.6) points.push_back(p);
  GpisModel model;
  const FitReport report = model.fit(points);
  EXPECT_TRUE(report.ok) << report.message;
  return model;
}

// A view of the sphere's top, and touches among `touch_samples` points all over it on its lower half.
std::vector<TrainingPoint> viewAndTouchesBelow(const AnalyticSphere& sphere, int view_points, int touch_samples) {
  std::vector<TrainingPoint> points = sphere.view(view_points, 0.2, kNoiseSigma, 1);
  for (const TrainingPoint& p : sphere.view(touch_samples, -1.0, kNoiseSigma, 2)) {
    TrainingPoint touch = p;
    touch.source = PointSource::kTouch;
    if ((p.position - sphere.centre).z() < 0.0) points.push_back(touch);
  }
  return points;
}

TEST(SurfaceEvidence, DistancesMatchABruteForceSearchOverMeasuredSurfacePointsOnly) {
  const AnalyticSphere sphere;
  // Touches on the other side; free space, guessed inside points and a far surface guess that
  // is not a measurement must all be ignored.
  std::vector<TrainingPoint> points = viewAndTouchesBelow(sphere, 150, 20);
  TrainingPoint free;
  free.position = sphere.centre + Vector3(0.0, 0.0, -1.5 * sphere.radius);
  free.label = PointLabel::kOutside;
  free.source = PointSource::kFreeSpace;
  free.noise_sigma = kNoiseSigma;
  points.push_back(free);
  TrainingPoint inside = free;
  inside.position = sphere.centre + Vector3(0.0, 0.3 * sphere.radius, 0.0);
  inside.label = PointLabel::kInside;
  inside.source = PointSource::kVision;
  points.push_back(inside);
  GpisModel model;
  ASSERT_TRUE(model.fit(points).ok);

  const double max_distance = 0.03;
  const SurfaceEvidence evidence(model, max_distance);
  ASSERT_TRUE(evidence.enabled());
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  int unsupported = 0, supported = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vector3 x = sphere.centre + sphere.radius * Vector3(u(rng), u(rng), u(rng));
    const double truth = bruteForceDistance(model, x);
    const double found = evidence.distance(x);
    if (truth <= max_distance) {
      EXPECT_NEAR(found, truth, 1e-12);
      EXPECT_FALSE(evidence.isUnsupported(x));
      EXPECT_NEAR(evidence.radiusCap(x, 0.005), std::max(0.005, max_distance - truth), 1e-12);
      ++supported;
    } else {
      EXPECT_TRUE(std::isinf(found));
      EXPECT_TRUE(evidence.isUnsupported(x));
      EXPECT_EQ(evidence.radiusCap(x, 0.005), 0.005);
      ++unsupported;
    }
  }
  EXPECT_GT(supported, 100);
  EXPECT_GT(unsupported, 100);
  // The free-space and inside points are far from every surface point: unsupported there.
  EXPECT_TRUE(evidence.isUnsupported(free.position));
  EXPECT_TRUE(evidence.isUnsupported(inside.position));

  const SurfaceEvidence off(model, std::nullopt);
  EXPECT_FALSE(off.enabled());
  EXPECT_FALSE(off.isUnsupported(free.position));
  EXPECT_TRUE(std::isinf(off.radiusCap(free.position, 0.005)));
  // No number means "off": a distance that is none is refused.
  EXPECT_THROW(SurfaceEvidence(model, 0.0), std::invalid_argument);
  EXPECT_THROW(SurfaceEvidence(model, std::nan("")), std::invalid_argument);
  EXPECT_THROW(SurfaceEvidence(model, max_distance, std::nullopt, 0.0, {}, -0.01), std::invalid_argument);
  EXPECT_THROW(SurfaceEvidence(model, max_distance, std::nullopt, 0.0, {}, std::nullopt, {}, 0.0), std::invalid_argument);
  for (const double fraction : {0.0, 1.5, std::nan("")})
    EXPECT_THROW(SurfaceEvidence(model, max_distance, std::nullopt, 0.0, {}, std::nullopt, {}, 0.005, fraction),
                 std::invalid_argument);
}

// A view point vouches for the surface within view_max_distance, a contact (or an attempted
// target) within max_distance: the support slack, the test and the chart radius cap against a
// full search over both kinds of points.
TEST(SurfaceEvidence, AViewPointVouchesForLessThanAContact) {
  const AnalyticSphere sphere;
  const std::vector<TrainingPoint> points = viewAndTouchesBelow(sphere, 300, 30);
  GpisModel model;
  ASSERT_TRUE(model.fit(points).ok);
  const std::vector<Vector3> attempted{sphere.centre + Vector3(0.0, 0.0, -sphere.radius)};
  const double max_distance = 0.03, view_max_distance = 0.01;
  const SurfaceEvidence evidence(model, max_distance, std::nullopt, 0.0, attempted, view_max_distance);
  const auto bruteSlack = [&](const Vector3& x) {
    double best = max_distance - (attempted[0] - x).norm();
    for (const TrainingPoint& p : model.observations()) {
      if (p.label != PointLabel::kSurface) continue;
      if (p.source == PointSource::kVision) best = std::max(best, view_max_distance - (p.position - x).norm());
      if (p.source == PointSource::kTouch) best = std::max(best, max_distance - (p.position - x).norm());
    }
    return best;
  };
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.3, 1.3);
  int by_view_alone = 0, unsupported_near_view = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vector3 x = sphere.centre + sphere.radius * Vector3(u(rng), u(rng), u(rng));
    const double slack = bruteSlack(x);
    if (slack >= 0.0) {
      EXPECT_NEAR(evidence.supportSlack(x), slack, 1e-12);
      EXPECT_FALSE(evidence.isUnsupported(x));
      EXPECT_NEAR(evidence.radiusCap(x, 0.002), std::max(0.002, slack), 1e-12);
    } else {
      EXPECT_TRUE(evidence.isUnsupported(x));
      EXPECT_EQ(evidence.radiusCap(x, 0.002), 0.002);
    }
    // Within max_distance of a view point, yet too far for it to vouch: a touch is needed.
    const double distance = evidence.distance(x);
    if (slack < 0.0 && distance <= max_distance) ++unsupported_near_view;
    if (slack >= 0.0 && distance > view_max_distance - 1e-12) ++by_view_alone;
  }
  EXPECT_GT(unsupported_near_view, 50);
  EXPECT_GT(by_view_alone, 0);  // supported by a contact or the aim beyond a view point's reach
  // None: view points vouch as far as contacts (the distance test alone).
  const SurfaceEvidence as_far(model, max_distance, std::nullopt, 0.0, attempted, std::nullopt);
  for (int i = 0; i < 500; ++i) {
    const Vector3 x = sphere.centre + sphere.radius * Vector3(u(rng), u(rng), u(rng));
    EXPECT_EQ(as_far.isUnsupported(x), !(as_far.distance(x) <= max_distance));
  }
  EvidenceRule rule;
  rule.view_max_distance = -0.1;
  EXPECT_FALSE(validate(rule).empty());
  rule.view_max_distance = std::nan("");
  EXPECT_FALSE(validate(rule).empty());
  rule.view_max_distance = 0.0;  // view points vouch for nothing: contacts alone
  EXPECT_TRUE(validate(rule).empty());
}

// A contact found far from the predicted surface (prediction_error_m), and an attempted target
// its touch found the surface far from, support max_distance * clamp(surprise / error, min, 1):
// the support slack against a full search with those radii.
TEST(SurfaceEvidence, ASurprisingTouchSupportsLessAroundIt) {
  const AnalyticSphere sphere;
  std::vector<TrainingPoint> points = viewAndTouchesBelow(sphere, 300, 30);
  // Errors from none to ten surprise distances, in turn over the contacts.
  const double surprise = 0.005, min_fraction = 0.2, max_distance = 0.03;
  const std::vector<double> errors{std::nan(""), 0.002, 0.005, 0.01, 0.02, 0.05};
  std::size_t k = 0;
  for (TrainingPoint& p : points)
    if (p.source == PointSource::kTouch) p.prediction_error_m = errors[k++ % errors.size()];
  GpisModel model;
  ASSERT_TRUE(model.fit(points).ok);
  const std::vector<Vector3> attempted{sphere.centre + Vector3(0.0, 0.0, -sphere.radius),
                                       sphere.centre + Vector3(sphere.radius, 0.0, 0.0)};
  const std::vector<double> attempted_errors{0.04, std::nan("")};
  const SurfaceEvidence evidence(model, max_distance, std::nullopt, 0.0, attempted, 0.01, attempted_errors, surprise,
                                 min_fraction);
  const auto radius = [&](double error) {
    if (!std::isfinite(error) || error <= surprise) return max_distance;
    return max_distance * std::max(min_fraction, surprise / error);
  };
  EXPECT_DOUBLE_EQ(evidence.surpriseFraction(0.02), 0.25);
  EXPECT_DOUBLE_EQ(evidence.surpriseFraction(0.05), 0.2);
  EXPECT_DOUBLE_EQ(evidence.surpriseFraction(0.004), 1.0);
  const auto bruteSlack = [&](const Vector3& x) {
    double best = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < attempted.size(); ++i)
      best = std::max(best, radius(attempted_errors[i]) - (attempted[i] - x).norm());
    for (const TrainingPoint& p : model.observations()) {
      if (p.label != PointLabel::kSurface) continue;
      if (p.source == PointSource::kVision) best = std::max(best, 0.01 - (p.position - x).norm());
      if (p.source == PointSource::kTouch) best = std::max(best, radius(p.prediction_error_m) - (p.position - x).norm());
    }
    return best;
  };
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.3, 1.3);
  int shrunk = 0, supported = 0;
  const SurfaceEvidence unsurprised(model, max_distance, std::nullopt, 0.0, attempted, 0.01);
  for (int i = 0; i < 3000; ++i) {
    const Vector3 x = sphere.centre + sphere.radius * Vector3(u(rng), u(rng), u(rng));
    const double slack = bruteSlack(x);
    if (slack >= 0.0) {
      ++supported;
      EXPECT_NEAR(evidence.supportSlack(x), slack, 1e-12);
    }
    EXPECT_EQ(evidence.isUnsupported(x), slack < 0.0);
    if (evidence.isUnsupported(x) && !unsurprised.isUnsupported(x)) ++shrunk;
    EXPECT_FALSE(!evidence.isUnsupported(x) && unsurprised.isUnsupported(x));  // only ever less support
  }
  EXPECT_GT(shrunk, 20);
  EXPECT_GT(supported, 20);  // the slack was compared
  EvidenceRule rule;
  rule.min_surprise_fraction = 0.0;
  EXPECT_FALSE(validate(rule).empty());
  rule.min_surprise_fraction = 0.2;
  rule.surprise_distance_m = -1.0;
  EXPECT_FALSE(validate(rule).empty());
  rule.surprise_distance_m = 0.005;
  EXPECT_TRUE(validate(rule).empty());
  EvidenceState state;
  state.attempted_targets = attempted;
  state.attempted_target_errors_m = {0.01};
  EXPECT_FALSE(validate(state).empty());
  state.attempted_target_errors_m = attempted_errors;
  EXPECT_TRUE(validate(state).empty());
  state.attempted_targets.push_back(Vector3(std::nan(""), 0.0, 0.0));
  state.attempted_target_errors_m.push_back(0.01);
  EXPECT_EQ(validate(state), "attempted_targets[" + std::to_string(attempted.size()) + "] is not finite");
}

// The planner's own state and a request's: the targets one after the other, the errors one per
// target (NaN for a side that gave none), the planner's table first. The bench's planner and
// the ROS planner nodelet both plan through this merge.
TEST(SurfaceEvidence, APlannersStateAndARequestsMergeTargetByTarget) {
  const Vector3 a(0.1, 0.0, 0.0), b(0.2, 0.0, 0.0), c(0.3, 0.0, 0.0);
  SupportPlane table;
  table.offset = 0.05;
  EvidenceState own;
  own.support_plane = table;
  own.attempted_targets = {a};
  EvidenceState requested;
  requested.attempted_targets = {b, c};
  EvidenceState merged;
  std::string error;
  ASSERT_TRUE(mergeEvidenceState(own, requested, &merged, &error)) << error;
  EXPECT_EQ(merged.attempted_targets, (std::vector<Vector3>{a, b, c}));
  EXPECT_TRUE(merged.attempted_target_errors_m.empty());  // neither side gave errors
  ASSERT_TRUE(merged.support_plane.has_value());
  EXPECT_EQ(merged.support_plane->offset, 0.05);

  // Errors on one side: NaN for the other's targets, in place.
  requested.attempted_target_errors_m = {0.004, std::nan("")};
  ASSERT_TRUE(mergeEvidenceState(own, requested, &merged, &error)) << error;
  ASSERT_EQ(merged.attempted_target_errors_m.size(), 3u);
  EXPECT_TRUE(std::isnan(merged.attempted_target_errors_m[0]));
  EXPECT_EQ(merged.attempted_target_errors_m[1], 0.004);
  EXPECT_TRUE(std::isnan(merged.attempted_target_errors_m[2]));
  own.attempted_target_errors_m = {0.02};
  requested.attempted_target_errors_m.clear();
  ASSERT_TRUE(mergeEvidenceState(own, requested, &merged, &error)) << error;
  ASSERT_EQ(merged.attempted_target_errors_m.size(), 3u);
  EXPECT_EQ(merged.attempted_target_errors_m[0], 0.02);
  EXPECT_TRUE(std::isnan(merged.attempted_target_errors_m[1]));

  // A planner without a table takes the request's; with one, its own.
  EvidenceState bare;
  SupportPlane other;
  other.offset = -0.3;
  requested.support_plane = other;
  ASSERT_TRUE(mergeEvidenceState(bare, requested, &merged, &error)) << error;
  EXPECT_EQ(merged.support_plane->offset, -0.3);
  ASSERT_TRUE(mergeEvidenceState(own, requested, &merged, &error)) << error;
  EXPECT_EQ(merged.support_plane->offset, 0.05);

  // Errors that do not match their targets, on either side: refused, with why.
  requested.attempted_target_errors_m = {0.01};
  EXPECT_FALSE(mergeEvidenceState(own, requested, &merged, &error));
  EXPECT_NE(error.find("one value per attempted target"), std::string::npos) << error;
  requested.attempted_target_errors_m.clear();
  own.attempted_target_errors_m = {0.01, 0.02};
  EXPECT_FALSE(mergeEvidenceState(own, requested, &merged, &error));
}

// A hole in the data that the variance does not flag (V_max is out of reach): the planners
// converge on variance alone, and with an evidence distance they poke into the hole.
// measuredNear (the retouch rule) against a full search over the measured surface points and
// the attempted targets, with the distance test on and off, at radii below and above the grid's.
TEST(SurfaceEvidence, MeasuredNearMatchesABruteForceSearch) {
  const AnalyticSphere sphere;
  const GpisModel model = modelWithAHoleOnTop(sphere);
  const std::vector<Vector3> attempted{sphere.centre + Vector3(0.0, 0.0, sphere.radius)};
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  for (const std::optional<double> max_distance : {std::optional<double>(), std::optional<double>(0.03)}) {
    const SurfaceEvidence evidence(model, max_distance, std::nullopt, 0.0, attempted);
    for (int i = 0; i < 400; ++i) {
      const Vector3 x = sphere.centre + sphere.radius * Vector3(u(rng), u(rng), u(rng));
      const double to_target = (attempted[0] - x).norm();
      const double nearest = std::min(bruteForceDistance(model, x), to_target);
      for (const double radius : {0.005, 0.02, 0.05})
        EXPECT_EQ(evidence.measuredNear(x, radius), nearest <= radius)
            << "max_distance " << max_distance.value_or(0.0) << " radius " << radius << " nearest " << nearest;
    }
  }
}

TEST(SurfaceEvidence, AtlasPlannerTouchesUnsupportedSurfaceWhateverItsVariance) {
  const AnalyticSphere sphere;
  const GpisModel model = modelWithAHoleOnTop(sphere);
  AtlasPlanner::Config config;
  config.extend_path_charts = 0;  // the path ends at the chart that needs a touch
  config.evidence.max_distance = std::nullopt;  // variance alone (Algorithm 1)
  const AtlasPlanResult variance_only = AtlasPlanner(config, 3).plan(model, StopRule{kHugeVMax});
  EXPECT_EQ(variance_only.status, PlanStatus::kConverged) << variance_only.message;

  config.evidence.max_distance = 0.3;
  config.evidence.view_max_distance = 0.3;  // view points vouch as far as contacts here
  const double max_distance_m = *config.evidence.max_distance * model.scale();
  for (const auto selection : {AtlasPlanner::Config::Selection::kFirst, AtlasPlanner::Config::Selection::kBestScore})
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    config.selection = selection;
    const AtlasPlanResult result = AtlasPlanner(config, seed).plan(model, StopRule{kHugeVMax});
    ASSERT_EQ(result.status, PlanStatus::kTouch) << result.message;
    const Chart& end = result.atlas.chart(result.path.back());
    EXPECT_GT(bruteForceDistance(model, end.centre), max_distance_m);
    // In the hole: on top of the sphere.
    EXPECT_GT((end.centre - sphere.centre).normalized().z(), 0.6);
    // Algorithm 1: every other chart's ball is supported (its radius is capped by its evidence),
    // or the planner would have stopped there. (best_score grows over all of them.)
    if (selection == AtlasPlanner::Config::Selection::kBestScore) continue;
    for (std::size_t i = 0; i < result.atlas.size(); ++i) {
      if (static_cast<int>(i) == result.path.back()) continue;
      const Chart& chart = result.atlas.chart(static_cast<int>(i));
      const double d = bruteForceDistance(model, chart.centre);
      EXPECT_LE(d, max_distance_m) << "chart " << i;
      EXPECT_LE(chart.radius, std::max(config.chart.rho_min_m, max_distance_m - d) + 1e-12) << "chart " << i;
    }
  }
}

TEST(SurfaceEvidence, APokeAimsPastTheEdgeOfTheSupportedSurfaceWhileTouchesAreStillNeeded) {
  const AnalyticSphere sphere;
  const GpisModel model = modelWithAHoleOnTop(sphere);
  AtlasPlanner::Config config;
  config.selection = AtlasPlanner::Config::Selection::kFirst;  // the first chart, at the edge
  config.extend_path_charts = 0;  // the aim's condition
  config.evidence.max_distance = 0.3;
  config.evidence.view_max_distance = 0.3;
  const double max_distance_m = *config.evidence.max_distance * model.scale();
  for (const double fraction : {0.25, 0.5}) {
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      SCOPED_TRACE(::testing::Message() << "fraction " << fraction << ", seed " << seed);
      const AtlasPlanResult first = AtlasPlanner(config, seed).plan(model, StopRule{kHugeVMax});
      const AtlasPlanResult aimed =
          AtlasPlanner(config, seed).plan(model, StopRule{kHugeVMax}, std::nullopt, {}, {}, {}, {}, nullptr,
                                          fraction * max_distance_m);
      ASSERT_EQ(first.status, PlanStatus::kTouch) << first.message;
      ASSERT_EQ(aimed.status, PlanStatus::kTouch) << aimed.message;
      // The same search up to the first chart that needs a touch, then the aim's charts.
      ASSERT_GT(aimed.path.size(), first.path.size());
      for (std::size_t k = 0; k < first.path.size(); ++k)
        EXPECT_LT((aimed.atlas.chart(aimed.path[k]).centre - first.atlas.chart(first.path[k]).centre).norm(), 1e-12);
      const double aim_m = fraction * max_distance_m;
      double aimed_m = 0.0;
      for (std::size_t k = first.path.size(); k < aimed.path.size(); ++k) {
        const Chart& chart = aimed.atlas.chart(aimed.path[k]);
        EXPECT_GT(bruteForceDistance(model, chart.centre), max_distance_m) << "chart " << k << " needs no touch";
        const double step = (chart.centre - aimed.atlas.chart(aimed.path[k - 1]).centre).norm();
        // The aim stops at the first chart that reaches the distance.
        EXPECT_LT(aimed_m, aim_m);
        aimed_m += step;
      }
      EXPECT_LT(aimed_m, aim_m + config.chart.rho_max_m);
      // Deeper into the hole than the first chart: farther from every measurement.
      EXPECT_GT(bruteForceDistance(model, aimed.atlas.chart(aimed.path.back()).centre),
                bruteForceDistance(model, first.atlas.chart(first.path.back()).centre));
    }
  }
  for (const double aim_past_m : {-0.01, std::numeric_limits<double>::quiet_NaN()})
    EXPECT_EQ(AtlasPlanner(config, 1).plan(model, StopRule{kHugeVMax}, std::nullopt, {}, {}, {}, {}, nullptr, aim_past_m)
                  .status,
              PlanStatus::kError);
}

TEST(SurfaceEvidence, OnlyAPokeAimsByTheProbesFootprint) {
  const AnalyticSphere sphere;
  const GpisModel model = modelWithAHoleOnTop(sphere);
  const std::vector<std::string> evidence{"evidence/max_distance=0.3", "evidence/view_max_distance=0.3"};
  PlanRequest request;
  request.v_max = kHugeVMax;
  request.seed = 5;
  PlanRequest with_pad = request;
  with_pad.footprint_radius_m = 0.01;
  std::vector<std::string> settings = evidence;
  settings.push_back("planner/selection=best_score");
  // A strategy each: a poke strategy keeps its last atlas for the next plan (AtlasMemory).
  const PlanResult point = strategyWith("atlas_poke", settings)->plan(model, request);
  const PlanResult pad = strategyWith("atlas_poke", settings)->plan(model, with_pad);
  ASSERT_EQ(point.status, PlanStatus::kTouch) << point.message;
  ASSERT_EQ(pad.status, PlanStatus::kTouch) << pad.message;
  ASSERT_EQ(pad.touch.points.size(), 1u);
  // The best-scoring chart lies wherever its touch removes the most error: no aim.
  EXPECT_EQ(pad.touch.points.front(), point.touch.points.front());
  // The first chart lies at the edge of the supported surface: the pad aims past it.
  settings.back() = "planner/selection=first";
  const auto first = strategyWith("atlas_poke", settings);
  const PlanResult first_point = first->plan(model, request);
  const PlanResult first_pad = strategyWith("atlas_poke", settings)->plan(model, with_pad);
  ASSERT_EQ(first_pad.status, PlanStatus::kTouch) << first_pad.message;
  EXPECT_GT(bruteForceDistance(model, first_pad.touch.points.front()),
            bruteForceDistance(model, first_point.touch.points.front()));
  EXPECT_GT(first_pad.atlas->path.size(), first_point.atlas->path.size());
  // A footprint that is not a radius is refused, naming the field and its value.
  for (const double bad : {-1.0, std::nan("")}) {
    PlanRequest broken = with_pad;
    broken.footprint_radius_m = bad;
    const PlanResult refused = first->plan(model, broken);
    EXPECT_EQ(refused.status, PlanStatus::kError);
    EXPECT_EQ(refused.message.rfind("footprint_radius_m " + std::string(bad < 0.0 ? "-1" : "nan"), 0), 0u)
        << refused.message;
  }
  // A slide's path runs on into the unknown by itself: the footprint changes nothing.
  const auto slide = strategyWith("atlas_slide", settings);
  const PlanResult slid = slide->plan(model, request), slid_with_pad = slide->plan(model, with_pad);
  ASSERT_EQ(slid.status, PlanStatus::kTouch) << slid.message;
  ASSERT_EQ(slid.touch.points.size(), slid_with_pad.touch.points.size());
  for (std::size_t k = 0; k < slid.touch.points.size(); ++k)
    EXPECT_EQ(slid.touch.points[k], slid_with_pad.touch.points[k]);
}

TEST(SurfaceEvidence, EveryStrategyAppliesTheEvidenceDistanceOfItsRule) {
  const AnalyticSphere sphere;
  const GpisModel model = modelWithAHoleOnTop(sphere);
  PlanRequest request;
  request.v_max = kHugeVMax;
  for (const std::string name : {"atlas_poke", "atlas_slide", "max_variance", "random"}) {
    const PlanResult converged = strategyWith(name, {"evidence/max_distance=off"})->plan(model, request);
    EXPECT_EQ(converged.status, PlanStatus::kConverged) << name << ": " << converged.message;

    const PlanResult touch =
        strategyWith(name, {"evidence/max_distance=0.3", "evidence/view_max_distance=0.3"})->plan(model, request);
    ASSERT_EQ(touch.status, PlanStatus::kTouch) << name << ": " << touch.message;
    ASSERT_FALSE(touch.touch.points.empty());
    // The poke (or the slide's end) lies in the hole; random pokes anywhere.
    if (name != "random")
      EXPECT_GT(bruteForceDistance(model, touch.touch.points.back()), 0.3 * model.scale()) << name;
  }
  // A rule the settings' reader would refuse, given to the strategies directly.
  AtlasPlanner::Config invalid;
  invalid.evidence.max_distance = -1.0;
  EXPECT_EQ(AtlasStrategy(AtlasStrategy::Mode::kPoke, invalid, 0).plan(model, request).status, PlanStatus::kError);
  EXPECT_EQ(AtlasStrategy(AtlasStrategy::Mode::kSlide, invalid, 0).plan(model, request).status, PlanStatus::kError);
  EXPECT_EQ(MaxVarianceStrategy(SurfaceSampler::Config(), invalid.evidence, 0).plan(model, request).status,
            PlanStatus::kError);
  EXPECT_EQ(RandomStrategy(SurfaceSampler::Config(), invalid.evidence, 0).plan(model, request).status,
            PlanStatus::kError);
}

// Touches whose approach is blocked: every poke lands on the (measured) bottom of the sphere,
// far from the hole it aimed at. Counting the aimed-at points as evidence ends the exploration;
// counting contacts only, the hole never gets any and the run uses up its actions.
TEST(SurfaceEvidence, TouchesThatCannotReachTheirTargetStillEndTheExploration) {
  const AnalyticSphere sphere;
  struct BlockedProber : Prober {
    Vector3 centre;
    double radius{0.0};
    std::vector<Vector3> targets;
    ProbeResult probe(const Touch& touch) override {
      targets.push_back(touch.points.back());
      ProbeResult result;
      result.success = true;
      // A fresh point near the bottom each time (a repeated one would be refused as a duplicate).
      const Vector3 direction = (-Vector3::UnitZ() + 0.01 * static_cast<double>(targets.size()) * Vector3::UnitX()).normalized();
      result.contacts.push_back({centre + radius * direction, direction});
      return result;
    }
  };
  // The prober's contacts lie beyond the targets: a surprise the rule would answer with more
  // touches (ATouchThatWentThroughTheTargetSupportsLess); this test is about the aim alone.
  const auto strategy = strategyWith(
      "atlas_poke", {"evidence/max_distance=0.3", "evidence/view_max_distance=0.3", "evidence/surprise_distance_m=off"});
  Explorer::Config config;
  config.v_max = kHugeVMax;
  config.max_position_sd_m = std::nullopt;  // the V_max rule: the evidence rule alone asks for touches
  config.max_actions = 40;
  // The loop passes where earlier touches aimed; a planner that drops them shows what they buy.
  struct ForgetfulPlanner : TouchPlanner {
    ModelTouchPlanner* inner{nullptr};
    PlanResult plan(const PlanRequest& request) override {
      PlanRequest forgetful = request;
      forgetful.evidence_state.attempted_targets.clear();
      forgetful.evidence_state.attempted_target_errors_m.clear();
      return inner->plan(forgetful);
    }
    std::size_t modelSize() const override { return inner->modelSize(); }
  };
  for (const bool attempts_count : {true, false}) {
    GpisModel model = modelWithAHoleOnTop(sphere);
    const GpisModel initial = model;
    BlockedProber prober;
    prober.centre = sphere.centre;
    prober.radius = sphere.radius;
    ModelTouchPlanner planner(model, *strategy, EvidenceState());
    ForgetfulPlanner forgetful;
    forgetful.inner = &planner;
    ModelTouchUpdater updater(model, TouchObservationConfig());
    const ExplorationResult result = attempts_count ? Explorer(config).run(planner, prober, updater)
                                                    : Explorer(config).run(forgetful, prober, updater);
    if (attempts_count) {
      EXPECT_TRUE(result.converged) << result.stop_reason;
      EXPECT_LT(result.actions, 20);
      // Each poke went to a point that neither data nor an earlier aim supported.
      for (std::size_t i = 0; i < prober.targets.size(); ++i) {
        double nearest_aim = std::numeric_limits<double>::infinity();
        for (std::size_t j = 0; j < i; ++j) nearest_aim = std::min(nearest_aim, (prober.targets[j] - prober.targets[i]).norm());
        EXPECT_GT(std::min(nearest_aim, bruteForceDistance(initial, prober.targets[i])), 0.3 * initial.scale()) << i;
      }
    } else {
      EXPECT_EQ(result.stop_reason, "max_actions");
      EXPECT_EQ(result.actions, config.max_actions);
    }
  }
  // The aimed-at points enter the distance like measurements.
  const GpisModel model = modelWithAHoleOnTop(sphere);
  const Vector3 top = sphere.centre + sphere.radius * Vector3::UnitZ();
  const Vector3 near_top = top + Vector3(0.01, 0.0, 0.0);
  const SurfaceEvidence with_aim(model, 0.05, std::nullopt, 0.0, {top});
  EXPECT_DOUBLE_EQ(with_aim.distance(top), 0.0);
  EXPECT_NEAR(with_aim.distance(near_top), std::min(0.01, bruteForceDistance(model, near_top)), 1e-12);
  EXPECT_TRUE(SurfaceEvidence(model, 0.05).isUnsupported(top));
  EXPECT_FALSE(with_aim.isUnsupported(top));
}

// The sphere resting on a table, unseen underneath: the underside cannot be touched (every
// approach along its normal would start under the table), so with the table it needs no touch.
TEST(SurfaceEvidence, TheTableIsEvidenceForTheUnderside) {
  const AnalyticSphere sphere;
  const GpisModel model = modelWithAHoleOnTop(sphere, -1.0);
  SupportPlane table;
  table.offset = -(sphere.centre.z() - sphere.radius);  // tangent to the sphere's bottom
  const double max_distance_m = 0.3 * model.scale();

  const Vector3 bottom = sphere.centre - sphere.radius * Vector3::UnitZ();
  const SurfaceEvidence without_table(model, max_distance_m);
  const SurfaceEvidence with_table(model, max_distance_m, table, 0.1);
  EXPECT_TRUE(without_table.isUnsupported(bottom, -Vector3::UnitZ()));
  EXPECT_FALSE(with_table.isUnsupported(bottom, -Vector3::UnitZ()));
  // A probe approaching from the side reaches a point above the table: still unsupported.
  const Vector3 side_point = bottom + Vector3(0.0, 0.0, 0.05);
  EXPECT_TRUE(with_table.isUnsupported(side_point, Vector3::UnitX()));
  // Only 1 cm of approach: it starts above the table.
  EXPECT_TRUE(SurfaceEvidence(model, max_distance_m, table, 0.01).isUnsupported(side_point, -Vector3::UnitZ()));

  const std::vector<std::string> settings{"evidence/max_distance=0.3", "evidence/view_max_distance=0.3"};
  PlanRequest request;
  request.v_max = kHugeVMax;
  for (const std::string name : {"atlas_poke", "max_variance"}) {
    request.evidence_state.support_plane.reset();
    const PlanResult touch = strategyWith(name, settings)->plan(model, request);
    ASSERT_EQ(touch.status, PlanStatus::kTouch) << name << ": " << touch.message;
    EXPECT_LT((touch.touch.points.back() - sphere.centre).normalized().z(), -0.6) << name;
    request.evidence_state.support_plane = table;
    const PlanResult converged = strategyWith(name, settings)->plan(model, request);
    EXPECT_EQ(converged.status, PlanStatus::kConverged) << name << ": " << converged.message;
  }
  // A rule the settings' reader would refuse, given to the strategy directly.
  AtlasPlanner::Config config;
  config.evidence.max_distance = 0.3;
  config.evidence.view_max_distance = 0.3;
  config.evidence.approach_distance_m = std::nan("");
  EXPECT_EQ(AtlasStrategy(AtlasStrategy::Mode::kPoke, config, 0).plan(model, request).status, PlanStatus::kError);
}

}  // namespace
