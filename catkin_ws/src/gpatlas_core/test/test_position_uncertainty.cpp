#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/exploration/observation_history.h"
#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/model_calibration.h"
#include "gpatlas_core/model/position_uncertainty.h"
#include "gpatlas_core/model/surface_projection.h"
#include "gpatlas_core/planning/strategy_registry.h"
#include "gpatlas_core/testing/analytic_sphere.h"
#include "gpatlas_core/testing/strategy_settings.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace {

using gpatlas_core::GpisModel;
using gpatlas_core::TrainingPoint;
using gpatlas_core::Points3;
using gpatlas_core::Vector3;
using gpatlas_core::testing::AnalyticSphere;

// A GP on a sphere whose prior is tight enough that the surface's position is known to a few
// millimetres: the regime where the first-order position sd is meant to hold.
GpisModel tightSphereModel(const AnalyticSphere& sphere) {
  gpatlas_core::GpisModelConfig config;
  config.kernel = "squared_exponential";
  config.initial_params = {std::log(0.5), std::log(0.6)};
  config.noise_in_reported_units = false;
  GpisModel model(config);
  EXPECT_TRUE(model.fit(sphere.view(60, -1.0, 0.05, 5)).ok);
  return model;
}

// One sample of the posterior of f at `points`, drawn point by point with the chain rule: each
// value from the model's predictive distribution given the values drawn before it, which a
// clone takes as noise-free observations. Uses nothing but the model's public interface.
std::vector<double> posteriorSample(const GpisModel& model, const std::vector<Vector3>& points, std::mt19937_64& rng) {
  std::unique_ptr<gpatlas_core::SurfaceModel> conditioned = model.clone();
  std::normal_distribution<double> gaussian;
  std::vector<double> values;
  for (const Vector3& x : points) {
    const gpatlas_core::Prediction p = conditioned->predict(x);
    const double value = p.mean + std::sqrt(std::max(p.variance / conditioned->varianceUnitFactor(), 0.0)) * gaussian(rng);
    values.push_back(value);
    TrainingPoint drawn;
    drawn.position = x;
    drawn.target_override = value;
    drawn.noise_sigma = 1e-4;
    drawn.source = gpatlas_core::PointSource::kPseudo;
    EXPECT_TRUE(conditioned->addPoints({drawn}).ok);
  }
  return values;
}

TEST(PositionSd, MatchesAMonteCarloOfTheZeroCrossingOfPosteriorSamples) {
  const AnalyticSphere sphere;
  const GpisModel model = tightSphereModel(sphere);
  // A point of the true surface between the data, and the line along its normal.
  const Vector3 normal = Vector3(0.3, -0.5, 0.8).normalized();
  const Vector3 point = sphere.centre + sphere.radius * normal;
  Points3 query(3, 1);
  query.col(0) = point;
  const double predicted_sd = gpatlas_core::positionSd(model, query)[0];
  ASSERT_GT(predicted_sd, 1e-4);
  ASSERT_LT(predicted_sd, 0.02);

  // Where each sample's f crosses zero along the normal, nearest the point.
  const gpatlas_core::Prediction at_point = model.predict(point);
  const double centre_offset = -at_point.mean / at_point.gradient.norm();
  std::vector<Vector3> line;
  const int steps = 13;
  for (int i = 0; i < steps; ++i)
    line.push_back(point + (centre_offset + (i - steps / 2) * 0.6 * predicted_sd) * normal);
  std::mt19937_64 rng(17);
  std::vector<double> crossings;
  for (int s = 0; s < 400; ++s) {
    const std::vector<double> f = posteriorSample(model, line, rng);
    double best = std::nan("");
    for (int i = 0; i + 1 < steps; ++i) {
      if ((f[i] < 0.0) == (f[i + 1] < 0.0)) continue;
      const double t0 = (line[i] - point).dot(normal), t1 = (line[i + 1] - point).dot(normal);
      const double t = t0 + (t1 - t0) * f[i] / (f[i] - f[i + 1]);
      if (std::isnan(best) || std::abs(t - centre_offset) < std::abs(best - centre_offset)) best = t;
    }
    if (!std::isnan(best)) crossings.push_back(best);
  }
  ASSERT_GT(crossings.size(), 380u);
  double mean = 0.0, squares = 0.0;
  for (double t : crossings) mean += t;
  mean /= static_cast<double>(crossings.size());
  for (double t : crossings) squares += (t - mean) * (t - mean);
  const double sampled_sd = std::sqrt(squares / static_cast<double>(crossings.size() - 1));
  // 400 samples give the sd to about 4% (one sigma).
  EXPECT_NEAR(predicted_sd / sampled_sd, 1.0, 0.15) << "first order " << predicted_sd << " m, sampled " << sampled_sd;
}

TEST(PositionSd, ScalesWithTheCalibrationAndIsCappedWhereTheGradientVanishes) {
  const AnalyticSphere sphere;
  GpisModel model = tightSphereModel(sphere);
  const Vector3 point = sphere.centre + sphere.radius * Vector3::UnitX();
  const gpatlas_core::Prediction p = model.predict(point);
  Points3 query(3, 1);
  query.col(0) = point;
  const double sd = gpatlas_core::positionSd(model, query)[0];
  EXPECT_NEAR(sd, std::sqrt(p.variance / model.varianceUnitFactor()) / p.gradient.norm(), 1e-12);
  EXPECT_TRUE(model.setPositionSdScale(0.25));
  EXPECT_NEAR(gpatlas_core::positionSd(model, query)[0], 0.25 * sd, 1e-12);
  // A scale that would switch the rule off silently is refused.
  EXPECT_FALSE(model.setPositionSdScale(0.0));
  EXPECT_FALSE(model.setPositionSdScale(std::nan("")));
  EXPECT_EQ(model.positionSdScale(), 0.25);
  // No slope: the surface could be anywhere in the domain.
  EXPECT_EQ(gpatlas_core::positionSd(model, p.variance, 0.0), model.domainRadiusWorld());
  EXPECT_EQ(gpatlas_core::positionSd(model, std::nan(""), 1.0), model.domainRadiusWorld());
  EXPECT_LE(gpatlas_core::positionSd(model, 1e9, 1e-9), model.domainRadiusWorld());
}

// Each truth point's distance to the predicted surface along the sphere's radius: the mean's
// zero crossing on the ray from the centre, found by bisection.
std::vector<double> radialErrors(const gpatlas_core::SurfaceModel& model, const AnalyticSphere& sphere,
                                 const std::vector<Vector3>& truth) {
  std::vector<double> errors;
  for (const Vector3& x : truth) {
    const Vector3 direction = (x - sphere.centre).normalized();
    double inside = 0.2 * sphere.radius, outside = 2.0 * sphere.radius;
    if (!(model.mean(sphere.centre + inside * direction) < 0.0) || !(model.mean(sphere.centre + outside * direction) > 0.0)) {
      errors.push_back(std::nan(""));
      continue;
    }
    for (int i = 0; i < 40; ++i) {
      const double middle = 0.5 * (inside + outside);
      (model.mean(sphere.centre + middle * direction) < 0.0 ? inside : outside) = middle;
    }
    errors.push_back(std::abs(0.5 * (inside + outside) - sphere.radius));
  }
  return errors;
}

TEST(PositionCalibration, SharpensTheSdOfAHalfSeenSphereAndStillCoversItsTruth) {
  const AnalyticSphere sphere;
  GpisModel model;  // the default (paper-like) GPIS: honest but vague
  ASSERT_TRUE(model.fit(sphere.view(300, 0.0, 0.02, 7)).ok);
  std::vector<Vector3> truth;
  for (const Vector3& d : gpatlas_core::fibonacciSphere(600)) truth.push_back(sphere.centre + sphere.radius * d);
  const std::vector<double> errors = radialErrors(model, sphere, truth);
  const gpatlas_core::CalibrationResult before = gpatlas_core::surfaceCalibration(model, truth, 2.0, errors);
  ASSERT_TRUE(before.ok);

  const gpatlas_core::PositionCalibration calibration = gpatlas_core::calibratePositionSd(model, {});
  ASSERT_TRUE(calibration.ok) << calibration.message;
  EXPECT_EQ(model.positionSdScale(), calibration.scale);
  EXPECT_GT(calibration.folds_used, 3);
  const gpatlas_core::CalibrationResult after = gpatlas_core::surfaceCalibration(model, truth, 2.0, errors);
  std::cout << "half-seen sphere: scale " << calibration.scale << "; coverage " << before.coverage << " -> "
            << after.coverage << ", sharpness " << before.sharpness << " -> " << after.sharpness << std::endl;
  EXPECT_GT(before.sharpness, 5.0);  // vague
  EXPECT_LT(after.sharpness, 0.5 * before.sharpness);
  EXPECT_GE(after.coverage, 0.8);
  // The mean is the model's own, untouched.
  EXPECT_EQ(radialErrors(model, sphere, truth), errors);
}

TEST(PositionCalibration, RefusesBadInputAndKeepsTheScale) {
  GpisModel unfitted;
  EXPECT_FALSE(gpatlas_core::calibratePositionSd(unfitted, {}).ok);
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(100, 0.0, 0.02, 7)).ok);
  gpatlas_core::PositionCalibrationConfig bad;
  bad.coverage = 1.5;
  EXPECT_FALSE(gpatlas_core::calibratePositionSd(model, bad).ok);
  gpatlas_core::PositionCalibrationConfig off;
  off.folds = 0;
  EXPECT_FALSE(gpatlas_core::calibratePositionSd(model, off).ok);
  EXPECT_EQ(model.positionSdScale(), 1.0);
}

TEST(TouchCalibration, EachFoldAndEachTouchWeighsOneWhateverItsSize) {
  gpatlas_core::PositionSdEvidence evidence;
  evidence.coverage = 0.95;
  EXPECT_TRUE(std::isnan(gpatlas_core::positionSdScale(evidence)));  // no view folds: not calibrated
  // One fold of 100 tests at 1 and one touch at 3: half the weight each, so the 95 % quantile is
  // the touch's 3, though it is one point in 101.
  evidence.view_folds = {std::vector<double>(100, 1.0)};
  evidence.touches = {{3.0}};
  EXPECT_DOUBLE_EQ(gpatlas_core::positionSdScale(evidence), 1.5);
  // With equal groups of one point each it is quantile() of the points, over 2.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 4.0);
  std::vector<double> all;
  evidence.view_folds.clear();
  evidence.touches.clear();
  for (int i = 0; i < 37; ++i) {
    all.push_back(uniform(rng));
    evidence.touches.push_back({all.back()});
  }
  evidence.view_folds = {{all.front()}};
  evidence.touches.erase(evidence.touches.begin());
  EXPECT_DOUBLE_EQ(gpatlas_core::positionSdScale(evidence), gpatlas_core::quantile(all, 0.95) / 2.0);
  // 20 groups of ten at 0.95: the target, 19, is reached by summing tenths; quantile() of the
  // 20 values (rank 19) whatever the rounding.
  evidence.view_folds.clear();
  evidence.touches.clear();
  std::vector<double> twenty;
  for (int g = 0; g < 20; ++g) {
    twenty.push_back(0.1 * (g + 1));
    evidence.touches.push_back(std::vector<double>(10, twenty.back()));
  }
  evidence.view_folds = {evidence.touches.front()};
  evidence.touches.erase(evidence.touches.begin());
  EXPECT_DOUBLE_EQ(gpatlas_core::positionSdScale(evidence), gpatlas_core::quantile(twenty, 0.95) / 2.0);
  evidence.max_scale = 0.5;
  EXPECT_DOUBLE_EQ(gpatlas_core::positionSdScale(evidence), 0.5);
}

TEST(TouchCalibration, HeldOutRatiosAreTheMeanOverTheUnscaledSd) {
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(100, 0.0, 0.02, 7)).ok);
  ASSERT_TRUE(model.setPositionSdScale(0.1));  // the ratios do not depend on it
  Points3 x(3, 3);
  x.col(0) = sphere.centre + Vector3(0.0, 0.0, -sphere.radius);
  x.col(1) = sphere.centre + Vector3(0.0, sphere.radius, 0.0);
  x.col(2) = sphere.centre + Vector3(0.0, 0.0, 10.0);  // outside the domain: not a test
  const std::vector<double> ratios = gpatlas_core::heldOutRatios(model, x);
  ASSERT_EQ(ratios.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    const gpatlas_core::Prediction p = model.predict(x.col(k));
    EXPECT_NEAR(ratios[k], std::abs(p.mean) / std::sqrt(p.variance / model.varianceUnitFactor()), 1e-9);
  }
}

// A sphere seen from above, calibrated on its view. A touch that lands where the model predicts
// leaves the scale near the view's; touches far from the prediction raise it, and the undo of a
// touch gives the scale of a model that never had it.
TEST(TouchCalibration, TouchesFarFromThePredictionRaiseTheScaleAndAnUndoTakesThemBack) {
  const AnalyticSphere sphere;
  GpisModel model;
  const std::vector<TrainingPoint> view = sphere.view(300, 0.3, 0.02, 9);
  ASSERT_TRUE(model.fit(view).ok);
  ASSERT_TRUE(gpatlas_core::calibratePositionSd(model, {}).ok);
  const double view_scale = model.positionSdScale();
  gpatlas_core::ObservationHistory history;
  history.setView(view);
  const gpatlas_core::TouchObservationConfig touch;
  const auto touchAt = [&](const Vector3& direction, double radius) {
    const gpatlas_core::Contact contact{sphere.centre + radius * direction.normalized(), direction.normalized()};
    const std::uint32_t id = history.addTouch({contact}, {});
    EXPECT_TRUE(gpatlas_core::applyTouch(model, {contact}, {}, touch).ok);
    return id;
  };
  // Where the view saw it: the prediction is right.
  touchAt(Vector3(0.2, 0.1, 1.0), sphere.radius);
  ASSERT_EQ(model.positionSdEvidence().touches.size(), 1u);
  const double scale_after_good_touch = model.positionSdScale();
  EXPECT_LE(scale_after_good_touch, view_scale * 1.05);
  // The side, 3 cm inside the true sphere: a surface the model did not predict.
  std::vector<std::uint32_t> surprises;
  for (const Vector3& d : {Vector3(1, 0, 0.3), Vector3(-1, 0, 0.3), Vector3(0, 1, 0.3), Vector3(0, -1, 0.3)})
    surprises.push_back(touchAt(d, sphere.radius - 0.03));
  EXPECT_GT(model.positionSdScale(), 1.5 * view_scale);
  const double surprised_scale = model.positionSdScale();

  // Undo the surprises: a full rebuild from the view and the good touch.
  std::unique_ptr<gpatlas_core::SurfaceModel> undone = model.clone();
  std::string error;
  ASSERT_TRUE(history.remove(surprises, touch, &undone, &error)) << error;
  EXPECT_EQ(undone->positionSdEvidence().touches.size(), 1u);
  EXPECT_DOUBLE_EQ(undone->positionSdScale(), scale_after_good_touch);
  EXPECT_DOUBLE_EQ(model.positionSdScale(), surprised_scale);  // the original is untouched

  // A probe that passed through the predicted surface and found nothing: its free space inside
  // the predicted object tests the model too (a lower bound on its error).
  GpisModel missed;
  ASSERT_TRUE(missed.fit(view).ok);
  ASSERT_TRUE(gpatlas_core::calibratePositionSd(missed, {}).ok);
  std::vector<Vector3> passed;
  for (double depth = 0.0; depth <= 0.03; depth += 0.005) passed.push_back(sphere.centre + Vector3(0, 0, sphere.radius - depth));
  ASSERT_TRUE(gpatlas_core::applyTouch(missed, {}, passed, touch).ok);
  ASSERT_EQ(missed.positionSdEvidence().touches.size(), 1u);
  EXPECT_GT(missed.positionSdScale(), 1.5 * view_scale);

  // Without the view's calibration, or with it told not to take touches, touches do not calibrate.
  GpisModel uncalibrated;
  ASSERT_TRUE(uncalibrated.fit(view).ok);
  const gpatlas_core::Contact far{sphere.centre + Vector3(sphere.radius - 0.03, 0.0, 0.0), Vector3::UnitX()};
  ASSERT_TRUE(gpatlas_core::applyTouch(uncalibrated, {far}, {}, touch).ok);
  EXPECT_EQ(uncalibrated.positionSdScale(), 1.0);
  EXPECT_TRUE(uncalibrated.positionSdEvidence().touches.empty());
  gpatlas_core::PositionCalibrationConfig folds_only;
  folds_only.touches = false;
  ASSERT_TRUE(gpatlas_core::calibratePositionSd(uncalibrated, folds_only).ok);
  const double folds_scale = uncalibrated.positionSdScale();
  ASSERT_TRUE(gpatlas_core::applyTouch(uncalibrated, {far}, {}, touch).ok);
  EXPECT_EQ(uncalibrated.positionSdScale(), folds_scale);
  EXPECT_TRUE(uncalibrated.positionSdEvidence().touches.empty());
}

// The default GPIS on the upper part of a sphere (seen from above), its position sd calibrated.
GpisModel calibratedHalfSeenSphere(const AnalyticSphere& sphere) {
  GpisModel model;
  EXPECT_TRUE(model.fit(sphere.view(300, 0.3, 0.02, 9)).ok);
  EXPECT_TRUE(gpatlas_core::calibratePositionSd(model, {}).ok);
  return model;
}

// A strategy whose evidence rule (a touch wherever no data lie near) is off: the stop rule
// alone decides.
std::unique_ptr<gpatlas_core::ExplorationStrategy> withoutEvidenceRule(const std::string& name) {
  return gpatlas_core::testing::strategyWith(name, {"evidence/max_distance=off"});
}

// The back of a sphere seen from above: the position rule must not call it known before the
// probe has been there (or found it out of reach), where the V_max rule at a lax threshold
// does. The evidence rule (a touch wherever no data lie near) is off, so that the stop rule
// alone decides.
TEST(StopRule, AHalfSeenSphereDoesNotConvergeBeforeItsBackIsTouched) {
  const AnalyticSphere sphere;
  GpisModel model = calibratedHalfSeenSphere(sphere);
  ASSERT_TRUE(model.isFitted());
  const auto strategy = withoutEvidenceRule("atlas_poke");

  gpatlas_core::Explorer::Config lax;
  lax.v_max = 10.0;
  lax.max_position_sd_m = std::nullopt;
  GpisModel paper_rule(model);
  gpatlas_core::testing::AnalyticSphereProber unused(sphere);
  const gpatlas_core::ExplorationResult vmax_run = gpatlas_core::Explorer(lax).run(paper_rule, *strategy, unused);
  EXPECT_TRUE(vmax_run.converged);
  EXPECT_EQ(vmax_run.contacts, 0);

  gpatlas_core::Explorer::Config rule;
  rule.max_position_sd_m = 0.005;
  rule.max_actions = 60;
  gpatlas_core::testing::AnalyticSphereProber prober(sphere);
  const gpatlas_core::ExplorationResult run = gpatlas_core::Explorer(rule).run(model, *strategy, prober);
  ASSERT_FALSE(run.records.empty());
  EXPECT_EQ(run.records.front().plan_status, gpatlas_core::PlanStatus::kTouch);
  int below_the_view = 0;
  for (const TrainingPoint& p : model.observations())
    if (p.source == gpatlas_core::PointSource::kTouch && gpatlas_core::isSurfaceValue(p) &&
        (p.position - sphere.centre).normalized().z() < 0.0)
      ++below_the_view;
  std::cout << "position rule: " << run.stop_reason << " after " << run.actions << " touches, " << below_the_view
            << " contacts below the equator" << std::endl;
  EXPECT_GT(below_the_view, 0);
  // Converged means the back is known to the bound: check it against the truth.
  ASSERT_TRUE(run.converged) << run.stop_reason;
  {
    std::vector<Vector3> back;
    for (const Vector3& d : gpatlas_core::fibonacciSphere(400))
      if (d.z() < 0.0) back.push_back(sphere.centre + sphere.radius * d);
    Points3 queries(3, static_cast<Eigen::Index>(back.size()));
    for (std::size_t i = 0; i < back.size(); ++i) queries.col(static_cast<Eigen::Index>(i)) = back[i];
    const Eigen::VectorXd sd = gpatlas_core::positionSd(model, queries);
    std::vector<double> sorted(sd.data(), sd.data() + sd.size());
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    EXPECT_LE(sorted[sorted.size() / 2], 0.005);
  }
}


TEST(StopRule, ExcessIsTheLargerRatioAndExceededIsExcessAboveOne) {
  const AnalyticSphere sphere;
  GpisModel model = calibratedHalfSeenSphere(sphere);
  ASSERT_TRUE(model.isFitted());
  const gpatlas_core::StopRule paper{0.05, std::nullopt}, in_mm{0.05, 0.005};
  int position_bound = 0;
  for (const Vector3& d : gpatlas_core::fibonacciSphere(200)) {
    const Vector3 x = sphere.centre + sphere.radius * d;
    const gpatlas_core::Prediction p = model.predict(x);
    const double slope = p.gradient.norm();
    const double by_variance = p.variance / 0.05;
    const double by_position = gpatlas_core::positionSd(model, p.variance, slope) / 0.005;
    EXPECT_DOUBLE_EQ(paper.excess(model, p.variance, slope), by_variance);
    EXPECT_DOUBLE_EQ(in_mm.excess(model, p.variance, slope), std::max(by_variance, by_position));
    EXPECT_EQ(paper.exceeded(model, p.variance, slope), by_variance > 1.0);
    EXPECT_EQ(in_mm.exceeded(model, p.variance, slope), std::max(by_variance, by_position) > 1.0);
    position_bound += by_position > by_variance ? 1 : 0;
  }
  EXPECT_GT(position_bound, 0);  // the position sd ranks some points, not only the variance
}

// On a sphere the variance and the position sd rank points alike, so this checks where the
// touch lands (near the surface's largest excess), not the ranking's formula (the test above).
TEST(StopRule, MaxVarianceTouchesNearTheSurfacesLargestExcess) {
  const AnalyticSphere sphere;
  GpisModel model = calibratedHalfSeenSphere(sphere);
  ASSERT_TRUE(model.isFitted());
  const auto strategy = withoutEvidenceRule("max_variance");
  gpatlas_core::PlanRequest request;
  request.v_max = 10.0;  // no point is above V_max: the position sd alone decides
  request.max_position_sd_m = 0.005;
  const gpatlas_core::PlanResult plan = strategy->plan(model, request);
  ASSERT_EQ(plan.status, gpatlas_core::PlanStatus::kTouch) << plan.message;
  const auto excess = [&](const Vector3& x) {
    const gpatlas_core::Prediction p = model.predict(x);
    return request.stopRule().excess(model, p.variance, p.gradient.norm());
  };
  // An independent sample of the predicted surface: the sphere's directions projected onto it.
  Points3 starts(3, 400), radial(3, 400);
  const std::vector<Vector3> directions = gpatlas_core::fibonacciSphere(400);
  for (Eigen::Index i = 0; i < starts.cols(); ++i) {
    radial.col(i) = directions[static_cast<std::size_t>(i)];
    starts.col(i) = sphere.centre + sphere.radius * radial.col(i);
  }
  double largest = 0.0;
  for (const gpatlas_core::SurfacePoint& s :
       gpatlas_core::projectOntoSurface(model, starts, radial, gpatlas_core::ProjectionConfig()))
    if (s.ok) {
      ASSERT_LE(s.variance, request.v_max);
      largest = std::max(largest, excess(s.position));
    }
  ASSERT_GT(largest, 1.0);
  EXPECT_GT(excess(plan.touch.points.front()), 0.9 * largest);
}

}  // namespace

// quantile() and median() against the sorted values by hand: NaN has no rank and is left out,
// an infinity ranks last.
TEST(Quantile, TakesTheRankedElementLeavesNaNOutAndRanksInfinityLast) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const std::vector<double> values = {4.0, nan, 1.0, inf, 3.0, 2.0, nan};  // ranked: 1 2 3 4 inf
  EXPECT_EQ(gpatlas_core::quantile(values, 0.0), 1.0);
  EXPECT_EQ(gpatlas_core::quantile(values, 0.5), 3.0);   // rank floor(0.5 * 5) = 2
  EXPECT_EQ(gpatlas_core::quantile(values, 0.79), 4.0);  // rank 3
  EXPECT_EQ(gpatlas_core::quantile(values, 1.0), inf);
  EXPECT_TRUE(std::isnan(gpatlas_core::quantile({nan, nan}, 0.5)));
  EXPECT_TRUE(std::isnan(gpatlas_core::quantile({}, 0.5)));
  // The median takes the finite values only: 1 2 3 4.
  EXPECT_EQ(gpatlas_core::median(values), 2.5);
  EXPECT_EQ(gpatlas_core::median({5.0, 1.0, 3.0}), 3.0);
}
