#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/model_calibration.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace {

using gpatlas_core::Vector3;

std::vector<Vector3> onSphere(const Vector3& centre, double radius, int count) {
  std::vector<Vector3> points;
  for (const Vector3& d : gpatlas_core::fibonacciSphere(count)) points.push_back(centre + radius * d);
  return points;
}

// The count by one prediction per point, from the definition.
double bruteForceFraction(const gpatlas_core::SurfaceModel& model, const std::vector<Vector3>& points, double k) {
  int within = 0;
  for (const Vector3& p : points) {
    if (!model.inDomain(p)) continue;
    const gpatlas_core::Prediction prediction = model.predict(p);
    within += std::abs(prediction.mean) <= k * std::sqrt(prediction.variance / model.varianceUnitFactor()) ? 1 : 0;
  }
  return static_cast<double>(within) / static_cast<double>(points.size());
}

TEST(SurfaceCalibration, HighOnTheTrueSurfaceLowOnAWrongOne) {
  gpatlas_core::testing::AnalyticSphere sphere;
  // A GP whose prior on f is tight (sd 0.5, noise sd 0.01 in f), so that it is sure of f near its
  // data: the default GPIS's f has a prior sd above 2, within which any nearby surface lies.
  gpatlas_core::GpisModelConfig config;
  config.kernel = "squared_exponential";
  config.initial_params = {std::log(0.5), std::log(0.6)};
  config.noise_in_reported_units = false;
  gpatlas_core::GpisModel model(config);
  ASSERT_TRUE(model.fit(sphere.view(300, -1.0, 0.01, 3)).ok);

  const std::vector<Vector3> truth = onSphere(sphere.centre, sphere.radius, 500);
  const gpatlas_core::CalibrationResult on_truth = gpatlas_core::surfaceCalibration(model, truth);
  ASSERT_TRUE(on_truth.ok) << on_truth.message;
  EXPECT_EQ(on_truth.samples, truth.size());
  EXPECT_GT(on_truth.fraction, 0.9);
  EXPECT_NEAR(on_truth.fraction, bruteForceFraction(model, truth, 2.0), 1e-12);
  // Sharpness: sd(f) / |grad f| at the median truth point, from the definition.
  std::vector<double> position_sd;
  for (const Vector3& p : truth) {
    const gpatlas_core::Prediction prediction = model.predict(p);
    position_sd.push_back(std::sqrt(prediction.variance / model.varianceUnitFactor()) / prediction.gradient.norm());
  }
  std::nth_element(position_sd.begin(), position_sd.begin() + position_sd.size() / 2, position_sd.end());
  EXPECT_NEAR(on_truth.median_position_sd_m, position_sd[position_sd.size() / 2], 1e-9);
  EXPECT_GT(on_truth.median_position_sd_m, 0.0);

  // A surface 3 cm outside the data: the model is sure f is well above 0 there.
  const std::vector<Vector3> wrong = onSphere(sphere.centre, sphere.radius + 0.03, 500);
  const gpatlas_core::CalibrationResult on_wrong = gpatlas_core::surfaceCalibration(model, wrong);
  ASSERT_TRUE(on_wrong.ok);
  EXPECT_LT(on_wrong.fraction, 0.2);
  EXPECT_NEAR(on_wrong.fraction, bruteForceFraction(model, wrong, 2.0), 1e-12);
}

TEST(SurfaceCalibration, CountsPointsOutsideTheDomainAsNotWithinAndRefusesBadInput) {
  gpatlas_core::testing::AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  EXPECT_FALSE(gpatlas_core::surfaceCalibration(model, {sphere.centre}).ok);  // not fitted
  ASSERT_TRUE(model.fit(sphere.view(100, -1.0, 0.1, 4)).ok);
  std::vector<Vector3> points = onSphere(sphere.centre, sphere.radius, 10);
  points.push_back(sphere.centre + Vector3(10.0, 0.0, 0.0));
  points.push_back(Vector3::Constant(std::nan("")));
  const gpatlas_core::CalibrationResult result = gpatlas_core::surfaceCalibration(model, points);
  ASSERT_TRUE(result.ok);
  EXPECT_EQ(result.samples, 11u);
  EXPECT_EQ(result.out_of_domain, 1u);
  EXPECT_LE(result.within, 10u);
  EXPECT_FALSE(gpatlas_core::surfaceCalibration(model, points, 0.0).ok);
  EXPECT_FALSE(gpatlas_core::surfaceCalibration(model, {Vector3::Constant(std::nan(""))}).ok);
}

}  // namespace
