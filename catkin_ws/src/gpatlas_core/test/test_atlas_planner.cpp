#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/planning/atlas_planner.h"
#include "gpatlas_core/planning/baseline_strategies.h"
#include "gpatlas_core/observations/surface_evidence.h"
#include "gpatlas_core/planning/strategy_registry.h"
#include "gpatlas_core/model/surface_projection.h"

#include "gpatlas_core/testing/analytic_sphere.h"
#include "gpatlas_core/testing/strategy_settings.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace gpatlas_core;
using gpatlas_core::testing::AnalyticSphere;
using gpatlas_core::testing::strategyWith;

namespace {

// The paper's reference noise variance (0.1) on every observation.
constexpr double kNoiseSigma = 0.316;
constexpr double kVMax = 0.1;

// A GP fit to the top of the sphere (directions with z >= 0.3, a third of its area).
GpisModel capModel(const AnalyticSphere& sphere) {
  GpisModel model;
  const FitReport report = model.fit(sphere.view(200, 0.3, kNoiseSigma, 1));
  EXPECT_TRUE(report.ok) << report.message;
  return model;
}

// Algorithm 1 verbatim: the first chart that needs a touch ends the path.
AtlasPlanner::Config firstChartConfig() {
  AtlasPlanner::Config config;
  config.selection = AtlasPlanner::Config::Selection::kFirst;
  config.extend_path_charts = 0;
  return config;
}

AtlasPlanResult planOnCap(const GpisModel& model, std::uint64_t seed) {
  return AtlasPlanner(firstChartConfig(), seed).plan(model, StopRule{kVMax});
}

TEST(AtlasPlanner, CapOfSphereChartsLieOnTheSurfaceAndPathReachesUncertainty) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const AtlasPlanResult result = planOnCap(model, seed);
    ASSERT_EQ(result.status, PlanStatus::kTouch) << result.message;
    ASSERT_GE(result.path.size(), 2u);
    const Atlas& atlas = result.atlas;

    for (std::size_t i = 0; i < atlas.size(); ++i) {
      const Chart& chart = atlas.chart(static_cast<int>(i));
      const Prediction at_centre = model.predict(chart.centre);
      // On the predicted surface (f is unitless: targets are 0 on the surface, +-1 off it).
      EXPECT_LT(std::abs(at_centre.mean), 1e-3) << "chart " << i;
      // On the true sphere within the GP's own error: the posterior standard deviation of f
      // turned into metres by the slope of f, at three sigma, plus 1 mm. (Far from the data
      // the thin-plate GP's mean is biased inward, by about 2.5 sigma on this cap.)
      const double raw_sd = std::sqrt(at_centre.variance / model.varianceUnitFactor());
      const double allowed = 3.0 * raw_sd / at_centre.gradient.norm() + 1e-3;
      EXPECT_LT(std::abs(sphere.signedDistance(chart.centre)), allowed) << "chart " << i;
      // Where the camera saw the sphere, the surface is known to a few millimetres.
      if ((chart.centre - sphere.centre).normalized().z() > 0.45)
        EXPECT_LT(std::abs(sphere.signedDistance(chart.centre)), 3e-3) << "chart " << i;
      // Tangent basis (eq. 11): orthonormal and orthogonal to the gradient.
      const Eigen::Matrix2d gram = chart.tangent_basis.transpose() * chart.tangent_basis;
      EXPECT_LT((gram - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
      const Vector3 gradient_direction = at_centre.gradient.normalized();
      EXPECT_LT((gradient_direction.transpose() * chart.tangent_basis).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_GT(chart.normal.dot(gradient_direction), 1.0 - 1e-9);
      // Radius from the variance (eq. 14) within the configured bounds.
      EXPECT_GE(chart.radius, AtlasPlanner::Config().chart.rho_min_m);
      EXPECT_LE(chart.radius, AtlasPlanner::Config().chart.rho_max_m);
    }

    // Consecutive path charts: the child is the projection (eq. 13) of a parent's candidate, so
    // its parent-chart coordinates lie in the annulus [0.8 rho, rho] of the parent.
    EXPECT_EQ(atlas.chart(result.path.front()).parent, -1);
    for (std::size_t k = 1; k < result.path.size(); ++k) {
      const Chart& parent = atlas.chart(result.path[k - 1]);
      const Chart& child = atlas.chart(result.path[k]);
      EXPECT_EQ(child.parent, result.path[k - 1]);
      const double tangent_distance = (parent.tangent_basis.transpose() * (child.centre - parent.centre)).norm();
      EXPECT_LE(tangent_distance, parent.radius * (1.0 + 1e-9));
      EXPECT_GE(tangent_distance, 0.8 * parent.radius * (1.0 - 1e-9));
      // And in space it stays near: the normal offset of a projection is small at this scale.
      EXPECT_LT((child.centre - parent.centre).norm(), 1.5 * parent.radius);
    }
    // Only the last chart of the path exceeds V_max (the planner stops at the first one).
    EXPECT_GT(atlas.chart(result.path.back()).variance, kVMax);
    for (std::size_t k = 1; k + 1 < result.path.size(); ++k)
      EXPECT_LE(atlas.chart(result.path[k]).variance, kVMax);
  }
}

TEST(AtlasPlanner, SameSeedGivesTheSamePath) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  const AtlasPlanResult first = planOnCap(model, 42);
  const AtlasPlanResult second = planOnCap(model, 42);
  ASSERT_EQ(first.status, PlanStatus::kTouch) << first.message;
  ASSERT_EQ(first.path, second.path);
  ASSERT_EQ(first.atlas.size(), second.atlas.size());
  for (int index : first.path) EXPECT_EQ(first.atlas.chart(index).centre, second.atlas.chart(index).centre);
}

// extend_path_charts: the same plan up to the first chart above V_max, then up to k more charts,
// each a child of the previous one grown from its highest-variance candidate, in the unknown.
TEST(AtlasPlanner, AnExtendedPathContinuesPastTheFirstChartAboveVMax) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    AtlasPlanner::Config config = firstChartConfig();
    const AtlasPlanResult base = AtlasPlanner(config, seed).plan(model, StopRule{kVMax});
    config.extend_path_charts = 5;
    const AtlasPlanResult extended = AtlasPlanner(config, seed).plan(model, StopRule{kVMax});
    ASSERT_EQ(base.status, PlanStatus::kTouch) << base.message;
    ASSERT_EQ(extended.status, PlanStatus::kTouch) << extended.message;
    ASSERT_GT(extended.path.size(), base.path.size());
    ASSERT_LE(extended.path.size(), base.path.size() + 5);
    for (std::size_t k = 0; k < base.path.size(); ++k)
      EXPECT_EQ(extended.atlas.chart(extended.path[k]).centre, base.atlas.chart(base.path[k]).centre);
    for (std::size_t k = base.path.size(); k < extended.path.size(); ++k) {
      const Chart& parent = extended.atlas.chart(extended.path[k - 1]);
      const Chart& child = extended.atlas.chart(extended.path[k]);
      EXPECT_EQ(child.parent, extended.path[k - 1]);
      EXPECT_LT((child.centre - parent.centre).norm(), 1.5 * parent.radius);
      EXPECT_LT(std::abs(model.mean(child.centre)), 1e-3);  // on the predicted surface
      EXPECT_GT(child.variance, kVMax);                     // beyond the known part
    }
  }
  AtlasPlanner::Config invalid;
  invalid.extend_path_charts = -1;
  EXPECT_EQ(AtlasPlanner(invalid).plan(model, StopRule{kVMax}).status, PlanStatus::kError);
}

// ADDCHART drops the candidates that fall inside another chart's ball, whatever their variance.
// best_score: the atlas covers the whole predicted surface, the touched chart's predicted fall
// of the error is the largest of the scored ones (recomputed with the clone's variance, not the
// low-rank one) and at least that of the chart Algorithm 1 touches; a filter's refusals are
// passed over in the order of the scores.
TEST(AtlasPlanner, BestScoreTouchesTheChartThatRemovesTheMostError) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  const StopRule rule{kVMax};
  AtlasPlanner::Config config;
  config.selection = AtlasPlanner::Config::Selection::kBestScore;
  config.extend_path_charts = 0;  // the path ends at the chosen chart
  config.score.max_reference_points = 100000;  // every chart, so the recomputation sees the same sum
  const AtlasPlanResult best = AtlasPlanner(config, 2).plan(model, rule);
  const AtlasPlanResult first = AtlasPlanner(firstChartConfig()).plan(model, rule);
  ASSERT_EQ(best.status, PlanStatus::kTouch) << best.message;
  ASSERT_EQ(first.status, PlanStatus::kTouch) << first.message;
  EXPECT_GT(best.atlas.size(), first.atlas.size());
  EXPECT_GT(best.needy_charts, 1);
  EXPECT_GT(best.predicted_reduction, 0.0);

  std::vector<SurfacePatch> patches;
  for (const Chart& chart : best.atlas.charts())
    patches.push_back({chart.centre, M_PI * chart.radius * chart.radius, chart.variance, chart.slope});
  // The touched chart, every 4th other chart above V_max, and (last) the chart Algorithm 1 touches.
  const Chart& touched = best.atlas.chart(best.path.back());
  const Chart& first_touched = first.atlas.chart(first.path.back());
  // Each poke's fantasy holds its approach's free space, from the approach pose's distance in.
  const double approach_m = config.evidence.approach_distance_m;
  std::vector<TouchCandidate> candidates{{touched.centre, touched.normal, approach_m}};
  int above = 0;
  for (const Chart& chart : best.atlas.charts())
    if (chart.variance > kVMax && ++above % 4 == 0) candidates.push_back({chart.centre, chart.normal, approach_m});
  candidates.push_back({first_touched.centre, first_touched.normal, approach_m});

  // The clone's way: SurfaceModel's own varianceAfter, through a model that does not override it.
  class CloneOnly : public GpisModel {
   public:
    explicit CloneOnly(const GpisModel& m) : GpisModel(m) {}
    Eigen::MatrixXd varianceAfter(const Points3& x, const std::vector<std::vector<TrainingPoint>>& t) const override {
      return SurfaceModel::varianceAfter(x, t);
    }
  };
  const TouchScores recomputed =
      scoreTouches(CloneOnly(model), rule, patches, candidates, TouchObservationConfig{}, config.score, 1);
  ASSERT_TRUE(recomputed.ok) << recomputed.message;
  EXPECT_NEAR(recomputed.reduction.front(), best.predicted_reduction, 1e-6 * best.predicted_reduction);
  // Within the planner's tie (2 %) of the best of the 32 it scored (8 furthest past the rule, a
  // sample of the rest); of a sample of every chart above V_max, close to the best.
  EXPECT_GE(best.predicted_reduction, recomputed.reduction.back() * (1.0 - 0.02 - 1e-6));
  const double best_of_all = *std::max_element(recomputed.reduction.begin(), recomputed.reduction.end());
  EXPECT_GE(best.predicted_reduction, 0.8 * best_of_all);

  // The half (in x) of the best touch refused: the touch is in the other half, each refusal
  // counted and marked, the best touch's chart among them.
  const double best_side = touched.centre.x() > sphere.centre.x() ? 1.0 : -1.0;
  int asked = 0;
  const TouchFilter other_half = [&](const Vector3& point, const Vector3& normal) {
    ++asked;
    return best_side * (point.x() - sphere.centre.x()) < 0.0 ? std::optional<Vector3>(normal) : std::nullopt;
  };
  const AtlasPlanResult refused = AtlasPlanner(config, 2).plan(model, rule, std::nullopt, {}, other_half);
  ASSERT_EQ(refused.status, PlanStatus::kTouch) << refused.message;
  EXPECT_LT(best_side * (refused.atlas.chart(refused.path.back()).centre.x() - sphere.centre.x()), 0.0);
  EXPECT_EQ(asked, refused.unreachable_skipped + 1);
  int marked = 0;
  for (const Chart& chart : refused.atlas.charts()) {
    marked += chart.out_of_reach ? 1 : 0;
    if (chart.out_of_reach) EXPECT_GE(best_side * (chart.centre.x() - sphere.centre.x()), 0.0);
  }
  EXPECT_EQ(marked, refused.unreachable_skipped);
  EXPECT_GT(marked, 0);  // the best touch's chart came first and was refused
}

TEST(Atlas, CoverageDropsTheCandidatesInsideAnotherChartsBall) {
  const auto makeChart = [](const Vector3& centre, double radius, std::vector<ChartCandidate> candidates) {
    Chart chart;
    chart.centre = centre;
    chart.radius = radius;
    chart.candidates = std::move(candidates);
    return chart;
  };
  const auto candidateAt = [](const Vector3& ambient, double variance) {
    ChartCandidate c;
    c.ambient = ambient;
    c.variance = variance;
    return c;
  };
  // Chart A has two candidates 0.03 m east of its centre: one uncertain, one certain. Chart B,
  // added next (centre 0.04 m east, radius 0.02 m), covers both: they are 0.010 m from its centre.
  Atlas atlas;
  atlas.addChart(makeChart(Vector3::Zero(), 0.03,
                           {candidateAt(Vector3(0.03, 0.0, 0.0), 0.2), candidateAt(Vector3(0.03, 0.001, 0.0), 0.05)}));
  atlas.addChart(makeChart(Vector3(0.04, 0.0, 0.0), 0.02, {}));
  EXPECT_TRUE(atlas.chart(0).candidates.empty());
}

TEST(AtlasPlanner, DenseDataAllOverTheSphereConverges) {
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(400, -1.0, kNoiseSigma, 2)).ok);
  AtlasPlanner::Config config;
  // 400 points over the whole sphere are farther apart than a camera's: here view points
  // vouch as far as contacts.
  config.evidence.view_max_distance = *config.evidence.max_distance;
  const AtlasPlanResult result = AtlasPlanner(config, 5).plan(model, StopRule{kVMax});
  EXPECT_EQ(result.status, PlanStatus::kConverged) << result.message;
  EXPECT_TRUE(result.path.empty());
  EXPECT_LE(result.max_chart_variance, kVMax);
  // Converged means covered: the atlas spans the sphere, not just the root's neighbourhood.
  Vector3 lowest = sphere.centre, highest = sphere.centre;
  for (const Chart& chart : result.atlas.charts()) {
    if (chart.centre.z() < lowest.z()) lowest = chart.centre;
    if (chart.centre.z() > highest.z()) highest = chart.centre;
  }
  EXPECT_GT(highest.z() - lowest.z(), 1.5 * sphere.radius);
  // The strategies agree, and a converged plan carries no touch.
  for (const std::string name : {"atlas_poke", "max_variance"}) {
    const PlanResult plan =
        strategyWith(name, {"evidence/view_max_distance=" + std::to_string(*config.evidence.max_distance)})
            ->plan(model, PlanRequest());
    EXPECT_EQ(plan.status, PlanStatus::kConverged) << name << ": " << plan.message;
    EXPECT_TRUE(plan.touch.points.empty());
  }
}

// Two separate objects: one seen all over (certain everywhere), one seen from above only. A
// tree rooted on the first cannot reach the second; covering every surface observation must.
TEST(AtlasPlanner, ConvergenceCoversEveryPieceOfThePredictedSurface) {
  AnalyticSphere known, partly_seen;
  known.centre = Vector3(0.5, -0.2, 0.1);
  known.radius = 0.06;
  partly_seen.centre = Vector3(0.5, 0.2, 0.1);
  partly_seen.radius = 0.06;
  std::vector<TrainingPoint> points = known.view(300, -1.0, kNoiseSigma, 3);
  const auto cap = partly_seen.view(80, 0.5, kNoiseSigma, 4);
  points.insert(points.end(), cap.begin(), cap.end());
  GpisModel::Config gp;
  gp.inside_point_at_centroid = false;  // the centroid of the pair lies in the air between them
  GpisModel model(gp);
  ASSERT_TRUE(model.fit(points).ok);
  // Both pieces exist in the prediction and do not touch.
  ASSERT_LT(model.mean(known.centre), 0.0);
  ASSERT_LT(model.mean(partly_seen.centre), 0.0);
  ASSERT_GT(model.mean(Vector3(0.5, 0.0, 0.1)), 0.0);

  const Vector3 start = known.centre + known.radius * Vector3(0, 0, 1);
  AtlasPlanner::Config one_tree;
  one_tree.cover_all_observations = false;
  const AtlasPlanResult single = AtlasPlanner(one_tree).plan(model, StopRule{kVMax}, start);
  EXPECT_EQ(single.status, PlanStatus::kConverged) << single.message;

  AtlasPlanner::Config covering_config;
  covering_config.extend_path_charts = 0;  // the path ends at the chart that needs a touch
  const AtlasPlanResult covering = AtlasPlanner(covering_config).plan(model, StopRule{kVMax}, start);
  ASSERT_EQ(covering.status, PlanStatus::kTouch) << covering.message;
  const Vector3 end = covering.atlas.chart(covering.path.back()).centre;
  EXPECT_LT((end - partly_seen.centre).norm(), (end - known.centre).norm());
  EXPECT_GT(covering.atlas.chart(covering.path.back()).variance, kVMax);
}

TEST(AtlasPlanner, BadInputGivesAnErrorStatus) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  const GpisModel unfitted;
  const AtlasPlanner planner;
  const double nan = std::numeric_limits<double>::quiet_NaN();

  EXPECT_EQ(planner.plan(unfitted, StopRule{kVMax}).status, PlanStatus::kError);
  EXPECT_NE(planner.plan(unfitted, StopRule{kVMax}).message.find("no model"), std::string::npos);
  for (const double v_max : {0.0, -1.0, nan, std::numeric_limits<double>::infinity()})
    EXPECT_EQ(planner.plan(model, StopRule{v_max}).status, PlanStatus::kError) << v_max;
  EXPECT_EQ(planner.plan(model, StopRule{kVMax}, Vector3(nan, 0.0, 0.0)).status, PlanStatus::kError);
  // 10 cm above the top of the sphere: still inside the domain, but far from the surface.
  const AtlasPlanResult far = planner.plan(model, StopRule{kVMax}, Vector3(sphere.centre + Vector3(0, 0, 0.16)));
  EXPECT_EQ(far.status, PlanStatus::kError);
  EXPECT_FALSE(far.message.empty());
  // A start just above the surface is accepted and becomes the root.
  const Vector3 near = sphere.centre + Vector3(0, 0, sphere.radius + 0.004);
  const AtlasPlanResult from_start = planner.plan(model, StopRule{kVMax}, near);
  ASSERT_NE(from_start.status, PlanStatus::kError) << from_start.message;
  EXPECT_LT((from_start.atlas.chart(0).centre - near).norm(), 0.01);

  AtlasPlanner::Config broken;
  broken.chart.rho_min_m = -1.0;
  EXPECT_EQ(AtlasPlanner(broken).plan(model, StopRule{kVMax}).status, PlanStatus::kError);

  for (const std::string& name : strategyNames()) {
    const auto strategy = makeStrategy(name);
    PlanRequest request;
    EXPECT_EQ(strategy->plan(unfitted, request).status, PlanStatus::kError) << name;
    request.v_max = nan;
    EXPECT_EQ(strategy->plan(model, request).status, PlanStatus::kError) << name;
    request.v_max = 0.0;
    EXPECT_EQ(strategy->plan(model, request).status, PlanStatus::kError) << name;
  }
  EXPECT_THROW(makeStrategy("no_such_strategy"), std::invalid_argument);
}

}  // namespace

// A touch filter (the approacher's cheap test) that refuses the sphere's western half: the
// planner grows past those charts and returns a touch in the eastern half, counting what it
// passed over; a filter that refuses everything leaves nothing to touch.
TEST(AtlasPlanner, ChartsTheTouchFilterRefusesArePassedOver) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const AtlasPlanner::Config config = firstChartConfig();
    int asked = 0;
    const TouchFilter east = [&](const Vector3& point, const Vector3& normal) {
      ++asked;
      EXPECT_NEAR(normal.norm(), 1.0, 1e-9);
      return point.x() > sphere.centre.x() ? std::optional<Vector3>(normal) : std::nullopt;
    };
    const AtlasPlanResult result = AtlasPlanner(config, seed).plan(model, StopRule{kVMax}, std::nullopt, {}, east);
    ASSERT_EQ(result.status, PlanStatus::kTouch) << result.message;
    const Chart& target = result.atlas.chart(result.path.back());
    EXPECT_GT(target.centre.x(), sphere.centre.x());
    EXPECT_GT(target.variance, kVMax);
    EXPECT_EQ(asked, result.unreachable_skipped + 1);
    // Every chart in the western half that needs a touch (above V_max and not at a
    // measurement, or unsupported by the evidence) was passed over, not returned.
    const SurfaceEvidence evidence(model, config.evidence);
    int western_needy = 0;
    double area = 0.0, western_needy_area = 0.0;  // the charts' discs
    for (std::size_t i = 0; i < result.atlas.size(); ++i) {
      const Chart& chart = result.atlas.chart(static_cast<int>(i));
      const bool needy = evidence.isUnsupported(chart.centre, chart.normal) ||
                         (chart.variance > kVMax && !evidence.measuredNear(chart.centre, config.evidence.retouch_radius_m));
      const bool west = needy && chart.centre.x() <= sphere.centre.x();
      western_needy += west ? 1 : 0;
      area += M_PI * chart.radius * chart.radius;
      western_needy_area += west ? M_PI * chart.radius * chart.radius : 0.0;
    }
    EXPECT_EQ(result.unreachable_skipped, western_needy);
    EXPECT_NEAR(result.unreachable_area_fraction, western_needy_area / area, 1e-12);
  }
  // A slide: its extension stops before the first refused chart, and it starts at the first
  // chart of the path the filter accepts. Algorithm 1's path: every chart before its end is
  // below V_max (best_score's may pass through refused ones on its way).
  const std::vector<std::string> first_chart{"planner/selection=first"};
  const auto slide = strategyWith("atlas_slide", first_chart, 4);
  PlanRequest request;
  request.v_max = kVMax;
  // The filter's direction: tilted from the normal toward +z (a made-up rule the touch must
  // carry, whatever it is).
  const auto tilted = [](const Vector3& normal) { return Vector3((normal + Vector3::UnitZ()).normalized()); };
  request.reachable = [&](const Vector3& point, const Vector3& normal) {
    return point.x() > sphere.centre.x() ? std::optional<Vector3>(tilted(normal)) : std::nullopt;
  };
  const PlanResult slid = slide->plan(model, request);
  ASSERT_EQ(slid.status, PlanStatus::kTouch) << slid.message;
  EXPECT_GT(slid.touch.points.front().x(), sphere.centre.x());
  // The slide is approached and left along the filter's directions, pressed along the normal
  // in between.
  const std::vector<int>& slid_path = slid.atlas->path;
  const std::size_t slid_first = slid_path.size() - slid.touch.points.size();
  for (std::size_t k = 0; k < slid.touch.points.size(); ++k) {
    const Vector3 normal = slid.atlas->atlas.chart(slid_path[slid_first + k]).normal;
    const bool end = k == 0 || slid.atlas->atlas.chart(slid_path[slid_first + k]).approach_direction.norm() > 0.0;
    EXPECT_LT((slid.touch.normals[k] - (end ? tilted(normal) : normal)).norm(), 1e-9) << "waypoint " << k;
  }
  EXPECT_LT((slid.touch.normals.back() - tilted(slid.atlas->atlas.chart(slid_path.back()).normal)).norm(), 1e-9);
  // A poke comes in along the direction the filter chose for its target.
  const PlanResult poked = strategyWith("atlas_poke", first_chart, 4)->plan(model, request);
  ASSERT_EQ(poked.status, PlanStatus::kTouch) << poked.message;
  ASSERT_EQ(poked.touch.normals.size(), 1u);
  EXPECT_LT((poked.touch.normals.front() - tilted(poked.atlas->atlas.chart(poked.atlas->path.back()).normal)).norm(), 1e-9);
  const std::vector<int>& path = slid.atlas->path;
  std::size_t needy = 0;  // the first chart of the path above V_max: the extension follows it
  while (needy < path.size() && !(slid.atlas->atlas.chart(path[needy]).variance > kVMax)) ++needy;
  for (std::size_t k = needy; k < path.size(); ++k)
    EXPECT_GT(slid.atlas->atlas.chart(path[k]).centre.x(), sphere.centre.x()) << "chart " << k << " of the path";

  AtlasPlanner::Config config;
  config.max_charts = 400;
  const AtlasPlanResult nowhere =
      AtlasPlanner(config).plan(model, StopRule{kVMax}, std::nullopt, {}, [](const Vector3&, const Vector3&) { return std::optional<Vector3>(); });
  EXPECT_NE(nowhere.status, PlanStatus::kTouch);
  EXPECT_GT(nowhere.unreachable_skipped, 0);
  EXPECT_GT(nowhere.unreachable_area_fraction, 0.0);
  EXPECT_LE(nowhere.unreachable_area_fraction, 1.0);
  EXPECT_NE(nowhere.message.find("no safe approach"), std::string::npos) << nowhere.message;
}

// The baselines too: a filter that refuses their first choice gets their second, approached
// along the direction it chose, and the refusal is counted.
TEST(AtlasPlanner, TheBaselinesPassOverTheChoicesTheTouchFilterRefuses) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  const Vector3 chosen_direction = Vector3(0.3, 0.0, 1.0).normalized();
  for (const std::string name : {"random", "max_variance"}) {
    const auto baseline = makeStrategy(name, 4);
    PlanRequest free_request;
    free_request.v_max = kVMax;
    const PlanResult first = baseline->plan(model, free_request);
    ASSERT_EQ(first.status, PlanStatus::kTouch) << name << ": " << first.message;
    const Vector3 first_choice = first.touch.points.front();
    PlanRequest filtered = free_request;
    int asked = 0;
    filtered.reachable = [&](const Vector3& point, const Vector3&) {
      ++asked;
      return point == first_choice ? std::nullopt : std::optional<Vector3>(chosen_direction);
    };
    const PlanResult second = baseline->plan(model, filtered);
    ASSERT_EQ(second.status, PlanStatus::kTouch) << name << ": " << second.message;
    EXPECT_NE(second.touch.points.front(), first_choice) << name;
    EXPECT_LT((second.touch.normals.front() - chosen_direction).norm(), 1e-12) << name;
    EXPECT_EQ(second.unreachable_candidates, 1) << name;
    EXPECT_EQ(asked, 2) << name;
  }
}

// max_variance's ranked pokes are what its plan chooses among: the first is its touch, each is
// past the stop rule no less than the next (by an independent variance query), and a filter's
// refusals and chosen direction carry over as in plan().
TEST(AtlasPlanner, MaxVariancesRankedPokesAreItsPlansChoicesInOrder) {
  const AnalyticSphere sphere;
  const GpisModel model = capModel(sphere);
  const MaxVarianceStrategy max_variance(SurfaceSampler::Config(), EvidenceRule(), 4);
  PlanRequest request;
  request.v_max = kVMax;
  const PlanResult plan = max_variance.plan(model, request);
  ASSERT_EQ(plan.status, PlanStatus::kTouch) << plan.message;
  const std::vector<Touch> ranked = max_variance.rankedPokes(model, request, 5);
  ASSERT_EQ(ranked.size(), 5u);
  EXPECT_EQ(ranked.front().points.front(), plan.touch.points.front());
  for (std::size_t k = 0; k + 1 < ranked.size(); ++k)
    EXPECT_GE(model.variance(ranked[k].points.front()), model.variance(ranked[k + 1].points.front()) * (1.0 - 1e-9))
        << k;

  const Vector3 chosen_direction = Vector3(0.3, 0.0, 1.0).normalized();
  request.reachable = [&](const Vector3& point, const Vector3&) {
    return point == ranked.front().points.front() ? std::nullopt : std::optional<Vector3>(chosen_direction);
  };
  const std::vector<Touch> filtered = max_variance.rankedPokes(model, request, 2);
  ASSERT_EQ(filtered.size(), 2u);
  EXPECT_EQ(filtered[0].points.front(), ranked[1].points.front());
  EXPECT_EQ(filtered[1].points.front(), ranked[2].points.front());
  EXPECT_LT((filtered[0].normals.front() - chosen_direction).norm(), 1e-12);
  EXPECT_EQ(max_variance.plan(model, request).touch.points.front(), filtered[0].points.front());

  // Where plan() would not touch (here an error: V_max must be positive), nothing is ranked.
  request.v_max = 0.0;
  EXPECT_EQ(max_variance.plan(model, request).status, PlanStatus::kError);
  EXPECT_TRUE(max_variance.rankedPokes(model, request, 5).empty());
}

// ---- reuse between plans and the work budget (AtlasMemory, Config::max_charts, max_queries)

// The default model on a view of the sphere from above (directions with z >= 0), and a contact
// on the sphere.
MultiscaleGpisModel viewedSphere(const AnalyticSphere& sphere) {
  MultiscaleGpisModel model;
  const FitReport report = model.fit(sphere.view(1500, 0.0, 0.1, 4));
  EXPECT_TRUE(report.ok) << report.message;
  return model;
}

TrainingPoint contactAt(const AnalyticSphere& sphere, const Vector3& direction) {
  TrainingPoint contact;
  contact.position = sphere.centre + sphere.radius * direction.normalized();
  contact.noise_sigma = 0.1;
  contact.source = PointSource::kTouch;
  return contact;
}

AtlasPlanner::Config bestScoreConfig() {
  AtlasPlanner::Config config;
  config.selection = AtlasPlanner::Config::Selection::kBestScore;
  config.reuse.enabled = true;
  config.extend_path_charts = 0;  // the path ends at the chosen chart
  return config;
}
constexpr std::uint64_t kBestScoreSeed = 3;

TEST(AtlasPlanner, AReusedAtlasKeepsTheChartsFarFromATouchAndRemakesThoseNearIt) {
  const AnalyticSphere sphere;
  MultiscaleGpisModel model = viewedSphere(sphere);
  const StopRule rule{kVMax, 0.005};
  const AtlasPlanner planner(bestScoreConfig(), kBestScoreSeed);
  AtlasMemory memory;
  const AtlasPlanResult before = planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
  ASSERT_NE(before.status, PlanStatus::kError) << before.message;
  EXPECT_EQ(before.reused_charts, 0);
  ASSERT_EQ(memory.atlas.size(), before.atlas.size());

  // A touch where the camera saw the sphere (on its rim): the model changes near it only.
  const TrainingPoint contact = contactAt(sphere, Vector3(0.9, 0.3, 0.1));
  ASSERT_TRUE(model.addPoints({contact}).ok);
  const AtlasPlanResult after = planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
  ASSERT_NE(after.status, PlanStatus::kError) << after.message;
  ASSERT_GT(after.reused_charts, static_cast<int>(before.atlas.size()) / 2) << after.message;
  EXPECT_GT(after.dropped_charts, 0);
  const AtlasReuseConfig& reuse = planner.config().reuse;

  // The kept charts come first, each one of the earlier atlas unchanged (centre, basis, radius),
  // far from the contact, and right for the new model: on its surface within the tolerance, the
  // normal within its angle, and the variance an upper bound of the new one (data only lower it),
  // within a few per cent of it far from the touch.
  Points3 centres(3, static_cast<Eigen::Index>(after.atlas.size()));
  for (std::size_t i = 0; i < after.atlas.size(); ++i) centres.col(static_cast<Eigen::Index>(i)) = after.atlas.chart(static_cast<int>(i)).centre;
  const BatchPrediction now = model.predictBatch(centres, true, false, true);
  for (int i = 0; i < after.reused_charts; ++i) {
    const Chart& chart = after.atlas.chart(i);
    const auto same = std::find_if(before.atlas.charts().begin(), before.atlas.charts().end(),
                                   [&](const Chart& c) { return c.centre == chart.centre; });
    ASSERT_NE(same, before.atlas.charts().end()) << "kept chart " << i;
    EXPECT_EQ(same->radius, chart.radius);
    EXPECT_EQ(same->tangent_basis, chart.tangent_basis);
    EXPECT_GE((chart.centre - contact.position).norm(), chart.radius + reuse.near_new_data_m);
    const double slope = now.gradient.col(i).norm();
    EXPECT_LE(std::abs(now.mean(i)) / slope, reuse.max_centre_shift_m) << "kept chart " << i;
    EXPECT_GE(now.gradient.col(i).dot(chart.normal) / slope, std::cos(reuse.max_normal_change_rad));
    EXPECT_LE(now.variance(i), chart.variance * (1.0 + 1e-9)) << "kept chart " << i;
    EXPECT_NEAR(now.variance(i), chart.variance, 0.05 * chart.variance) << "kept chart " << i;
  }
  // Near the contact every chart is new, made on the new model: its variance is the model's.
  int near_contact = 0;
  for (std::size_t i = 0; i < after.atlas.size(); ++i) {
    const Chart& chart = after.atlas.chart(static_cast<int>(i));
    if ((chart.centre - contact.position).norm() >= chart.radius + reuse.near_new_data_m) continue;
    ++near_contact;
    EXPECT_GE(static_cast<int>(i), after.reused_charts);
    EXPECT_NEAR(now.variance(static_cast<Eigen::Index>(i)), chart.variance, 1e-9 * chart.variance);
  }
  EXPECT_GT(near_contact, 0);

  // A rebuild from scratch covers the surface as the reused atlas does: every one of its chart
  // centres lies in a ball of the reused atlas (but at the rim of a tree's reach).
  const AtlasPlanResult rebuilt = planner.plan(model, rule);
  ASSERT_EQ(rebuilt.status, after.status) << rebuilt.message << " / " << after.message;
  int covered = 0;
  for (const Chart& chart : rebuilt.atlas.charts()) covered += after.atlas.coveredByOtherChart(chart.centre, -1) ? 1 : 0;
  EXPECT_GE(covered, 0.97 * static_cast<double>(rebuilt.atlas.size()));
  EXPECT_NEAR(after.needy_charts, rebuilt.needy_charts, 0.2 * rebuilt.needy_charts + 2);
}

// Removed data raise the variance far from any surface observation (the guesses a touch
// retracts are interior and free-space points): the kept charts take the model's variance now,
// and none is kept larger than that variance allows.
TEST(AtlasPlanner, AReusedAtlasTakesTheVarianceThatRemovedDataRaised) {
  const AnalyticSphere sphere;
  const MultiscaleGpisModel viewed = viewedSphere(sphere);
  // Interior points deep under the unseen lower half: they hardly move its surface, but lower
  // its variance.
  std::vector<TrainingPoint> guesses;
  for (const Vector3& d : gpatlas_core::fibonacciSphere(60)) {
    if (d.z() > -0.3) continue;
    TrainingPoint inside;
    inside.position = sphere.centre + 0.5 * sphere.radius * d;
    inside.label = PointLabel::kInside;
    inside.noise_sigma = 0.1;
    inside.source = PointSource::kPseudo;
    guesses.push_back(inside);
  }
  ASSERT_GT(guesses.size(), 10u);
  SurfaceModelState state = viewed.state();
  const std::size_t view_size = state.observations.size();
  state.observations.insert(state.observations.end(), guesses.begin(), guesses.end());
  MultiscaleGpisModel model;
  ASSERT_TRUE(model.restore(state).ok);
  // V_max alone, low enough that the lower half's charts are on either side of it.
  const StopRule rule{0.03};
  const AtlasPlanner planner(bestScoreConfig(), kBestScoreSeed);
  AtlasMemory memory;
  const AtlasPlanResult before = planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
  ASSERT_NE(before.status, PlanStatus::kError) << before.message;

  // The guesses go in two steps, so that a kept chart's radius is checked against the variance
  // after each, not against the one it was last given.
  int raised = 0;
  const double tolerance = planner.config().reuse.max_centre_shift_m;
  for (const std::size_t keep : {view_size + guesses.size() / 2, view_size}) {
    state.observations.resize(keep);
    ASSERT_TRUE(model.restore(state).ok);
    const AtlasPlanResult after = planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
    ASSERT_NE(after.status, PlanStatus::kError) << after.message;
    ASSERT_GT(after.reused_charts, 0) << after.message;
    Points3 centres(3, after.reused_charts);
    for (int i = 0; i < after.reused_charts; ++i) centres.col(i) = after.atlas.chart(i).centre;
    const BatchPrediction now = model.predictBatch(centres, true, false, true);
    for (int i = 0; i < after.reused_charts; ++i) {
      const Chart& chart = after.atlas.chart(i);
      EXPECT_NEAR(chart.variance, now.variance(i), 1e-9 * now.variance(i)) << "kept chart " << i;
      EXPECT_LE(chart.radius, gpatlas_core::chartRadius(now.variance(i), planner.config().chart) + tolerance) << "kept chart " << i;
      const auto same = std::find_if(before.atlas.charts().begin(), before.atlas.charts().end(),
                                     [&](const Chart& c) { return c.centre == chart.centre; });
      if (keep == view_size && same != before.atlas.charts().end())
        raised += !rule.exceeded(model, same->variance, chart.slope) && now.variance(i) > 1.01 * same->variance ? 1 : 0;
    }
  }
  // The test means something: the removal raised the variance under kept charts that did not
  // need a touch before it.
  EXPECT_GT(raised, 3);
}

// Convergence is what a run stops on: a reused atlas that finds no touch is grown again from
// scratch, so the plan claims what a plan without a memory claims.
TEST(AtlasPlanner, AReusedAtlasThatFindsNoTouchIsGrownAfreshBeforeConverging) {
  const AnalyticSphere sphere;
  const MultiscaleGpisModel model = viewedSphere(sphere);
  const StopRule rule{1e6};  // nothing needs a touch ...
  AtlasPlanner::Config config = bestScoreConfig();
  config.evidence.max_distance.reset();  // ... for want of evidence either
  const AtlasPlanner planner(config, kBestScoreSeed);
  AtlasMemory memory;
  const AtlasPlanResult first = planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
  ASSERT_EQ(first.status, PlanStatus::kConverged) << first.message;
  const AtlasPlanResult again = planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
  const AtlasPlanResult without_memory = planner.plan(model, rule);
  ASSERT_EQ(again.status, PlanStatus::kConverged) << again.message;
  EXPECT_EQ(again.reused_charts, 0);
  EXPECT_NE(again.message.find("grown afresh"), std::string::npos) << again.message;
  ASSERT_EQ(again.atlas.size(), without_memory.atlas.size());
  for (std::size_t i = 0; i < again.atlas.size(); ++i)
    EXPECT_EQ(again.atlas.chart(static_cast<int>(i)).centre, without_memory.atlas.chart(static_cast<int>(i)).centre);
  // The memory holds the fresh atlas for the next plan.
  EXPECT_EQ(memory.atlas.size(), again.atlas.size());
}

TEST(AtlasPlanner, AnotherModelOrAChangedFrameIsPlannedAfresh) {
  const AnalyticSphere sphere;
  const MultiscaleGpisModel model = viewedSphere(sphere);
  // A budget this plan does not come near: charts the budget made larger than the evidence
  // allows are dropped by the next plan, to be made right.
  AtlasPlanner::Config config = bestScoreConfig();
  config.max_charts = 100000;
  config.max_queries = 1000000;
  const AtlasPlanner planner(config, kBestScoreSeed);
  const StopRule rule{kVMax, 0.005};
  AtlasMemory memory;
  planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
  // Unchanged: everything kept (nothing to drop).
  const AtlasPlanResult again = planner.plan(model, rule, std::nullopt, {}, {}, {}, {}, &memory);
  EXPECT_EQ(again.dropped_charts, 0);
  EXPECT_GT(again.reused_charts, 0);
  // Another sphere's view: nothing in common.
  AnalyticSphere moved;
  moved.centre += Vector3(0.05, 0.0, 0.0);
  const MultiscaleGpisModel other = viewedSphere(moved);
  const AtlasPlanResult fresh = planner.plan(other, rule, std::nullopt, {}, {}, {}, {}, &memory);
  EXPECT_EQ(fresh.reused_charts, 0);
  for (const Chart& chart : fresh.atlas.charts()) EXPECT_LT(std::abs(other.mean(chart.centre)), 1e-3);
}

TEST(AtlasPlanner, TheWorkBudgetEndsAPlanWithLargerChartsAndSaysSo) {
  const AnalyticSphere sphere;
  const MultiscaleGpisModel model = viewedSphere(sphere);
  const StopRule rule{kVMax, 0.005};
  AtlasPlanner::Config config = bestScoreConfig();
  const AtlasPlanResult free_plan = AtlasPlanner(config, kBestScoreSeed).plan(model, rule);
  ASSERT_EQ(free_plan.status, PlanStatus::kTouch) << free_plan.message;
  EXPECT_FALSE(free_plan.budget_exhausted);
  ASSERT_GT(free_plan.queries, 400);

  config.max_queries = free_plan.queries / 6;
  const AtlasPlanResult capped = AtlasPlanner(config, kBestScoreSeed).plan(model, rule);
  EXPECT_TRUE(capped.budget_exhausted);
  // Still a touch (the best one the smaller atlas found), and the message says why it stopped.
  EXPECT_EQ(capped.status, PlanStatus::kTouch) << capped.message;
  EXPECT_NE(capped.message.find("work budget ran out"), std::string::npos) << capped.message;
  // Within the budget but for the last chart's queries (its projection and candidates).
  EXPECT_LE(capped.queries, config.max_queries + 2 * config.chart.max_candidates + config.projection.max_iterations);
  EXPECT_LT(capped.atlas.size(), free_plan.atlas.size());
  // Past half the budget the charts grow: the last one is made at a floor near rho_max.
  const Chart& last = capped.atlas.charts().back();
  EXPECT_GT(last.radius, 0.5 * (config.chart.rho_min_m + config.chart.rho_max_m));
  double free_mean = 0.0, capped_mean = 0.0;
  for (const Chart& c : free_plan.atlas.charts()) free_mean += c.radius / static_cast<double>(free_plan.atlas.size());
  for (const Chart& c : capped.atlas.charts()) capped_mean += c.radius / static_cast<double>(capped.atlas.size());
  EXPECT_GT(capped_mean, free_mean);

  // Through the strategy the plan's result says so too.
  PlanRequest request;
  request.max_position_sd_m = 0.005;
  const PlanResult strategy_plan = strategyWith("atlas_poke", {"planner/max_charts=10"})->plan(model, request);
  EXPECT_TRUE(strategy_plan.budget_exhausted) << strategy_plan.message;
  EXPECT_LE(strategy_plan.atlas->atlas.size(), 10u);
}
