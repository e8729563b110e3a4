#include "gpatlas_core/model/observation_screen.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace gpatlas_core;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TrainingPoint valueAt(const Vector3& position, PointLabel label = PointLabel::kSurface, double noise_sigma = 0.01) {
  TrainingPoint p;
  p.position = position;
  p.label = label;
  p.noise_sigma = noise_sigma;
  return p;
}

TrainingPoint slopeAt(const Vector3& position, const Vector3& direction) {
  TrainingPoint p = valueAt(position);
  p.slope_direction = direction;
  return p;
}

const ObservationScreenOptions kNormalise{/*normalise_slope_directions=*/true};
const ObservationScreenOptions kAsGiven{/*normalise_slope_directions=*/false};

TEST(ObservationScreen, KeepsGoodPointsInTheirOrderAndReportsNothing) {
  const std::vector<TrainingPoint> points{valueAt(Vector3(0.1, 0.2, 0.3)),
                                          valueAt(Vector3(-1.0, 0.0, 2.0), PointLabel::kOutside, 0.0),
                                          valueAt(Vector3(0.0, 0.0, 0.0), PointLabel::kInside, 1.0),
                                          slopeAt(Vector3(0.5, 0.5, 0.5), Vector3(0.0, 0.0, 1.0))};
  FitReport report;
  const std::vector<TrainingPoint> accepted = screenObservations(points, kNormalise, &report);
  ASSERT_EQ(accepted.size(), 4u);
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(accepted[i].position, points[i].position);
    EXPECT_EQ(accepted[i].label, points[i].label);
    EXPECT_EQ(accepted[i].noise_sigma, points[i].noise_sigma);
    EXPECT_EQ(accepted[i].slope_direction, points[i].slope_direction);
  }
  EXPECT_EQ(report.num_rejected, 0u);
  EXPECT_TRUE(report.warnings.empty());
}

TEST(ObservationScreen, DropsNonFinitePositionsAndSlopeDirections) {
  std::vector<TrainingPoint> points{valueAt(Vector3(kNaN, 0.0, 0.0)), valueAt(Vector3(0.0, kInf, 0.0)),
                                    valueAt(Vector3(0.0, 0.0, -kInf)), slopeAt(Vector3::Zero(), Vector3(kNaN, 0.0, 1.0)),
                                    valueAt(Vector3(1.0, 2.0, 3.0))};
  FitReport report;
  const std::vector<TrainingPoint> accepted = screenObservations(points, kNormalise, &report);
  ASSERT_EQ(accepted.size(), 1u);
  EXPECT_EQ(accepted[0].position, Vector3(1.0, 2.0, 3.0));
  EXPECT_EQ(report.num_rejected, 4u);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_EQ(report.warnings[0], "4 point(s) with NaN/Inf coordinates dropped");
}

TEST(ObservationScreen, DropsNegativeAndNonFiniteNoise) {
  const std::vector<TrainingPoint> points{valueAt(Vector3::Zero(), PointLabel::kSurface, -0.01),
                                          valueAt(Vector3::Zero(), PointLabel::kSurface, kNaN),
                                          valueAt(Vector3::Zero(), PointLabel::kSurface, kInf),
                                          valueAt(Vector3::UnitX(), PointLabel::kSurface, 0.0)};
  FitReport report;
  const std::vector<TrainingPoint> accepted = screenObservations(points, kNormalise, &report);
  ASSERT_EQ(accepted.size(), 1u);
  EXPECT_EQ(accepted[0].position, Vector3::UnitX());
  EXPECT_EQ(report.num_rejected, 3u);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_EQ(report.warnings[0], "3 point(s) with a negative or NaN noise sigma dropped");
}

TEST(ObservationScreen, DropsSlopesWithANearZeroDirection) {
  // A direction of norm 1e-10 observes a slope (it is not zero) along no usable direction; one of
  // norm 1e-8 is made unit.
  const std::vector<TrainingPoint> points{slopeAt(Vector3::Zero(), Vector3(1e-10, 0.0, 0.0)),
                                          slopeAt(Vector3::Zero(), Vector3(0.0, 1e-8, 0.0))};
  FitReport report;
  const std::vector<TrainingPoint> accepted = screenObservations(points, kNormalise, &report);
  ASSERT_EQ(accepted.size(), 1u);
  EXPECT_NEAR(accepted[0].slope_direction.y(), 1.0, 1e-15);
  EXPECT_EQ(report.num_rejected, 1u);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_EQ(report.warnings[0], "1 slope observation(s) with a near-zero direction dropped");
}

TEST(ObservationScreen, CountsAPointUnderTheFirstTestItFails) {
  // Non-finite before a near-zero direction before bad noise.
  TrainingPoint nan_and_bad_noise = valueAt(Vector3(kNaN, 0.0, 0.0), PointLabel::kSurface, -1.0);
  TrainingPoint zero_slope_and_bad_noise = slopeAt(Vector3::Zero(), Vector3(0.0, 0.0, 1e-12));
  zero_slope_and_bad_noise.noise_sigma = kNaN;
  FitReport report;
  const std::vector<TrainingPoint> accepted =
      screenObservations({nan_and_bad_noise, zero_slope_and_bad_noise}, kNormalise, &report);
  EXPECT_TRUE(accepted.empty());
  EXPECT_EQ(report.num_rejected, 2u);
  EXPECT_EQ(report.warnings, (std::vector<std::string>{"1 point(s) with NaN/Inf coordinates dropped",
                                                       "1 slope observation(s) with a near-zero direction dropped"}));
}

TEST(ObservationScreen, AddsToWhatTheReportHolds) {
  FitReport report;
  report.num_rejected = 5;
  report.warnings.push_back("earlier");
  screenObservations({valueAt(Vector3(kNaN, 0.0, 0.0)), valueAt(Vector3::Zero(), PointLabel::kSurface, -1.0)},
                     kNormalise, &report);
  EXPECT_EQ(report.num_rejected, 7u);
  EXPECT_EQ(report.warnings, (std::vector<std::string>{"earlier", "1 point(s) with NaN/Inf coordinates dropped",
                                                       "1 point(s) with a negative or NaN noise sigma dropped"}));
}

TEST(ObservationScreen, NormalisesSlopeDirectionsOnlyWhenAskedAndNotTheUnitOnes) {
  const Vector3 long_direction(0.0, 3.0, 4.0);
  // Within 1e-12 of unit length: kept bit for bit, though normalize() would change its last bits.
  const Vector3 nearly_unit(1.0 + 4e-13, 0.0, 0.0);
  const std::vector<TrainingPoint> points{slopeAt(Vector3::Zero(), long_direction),
                                          slopeAt(Vector3::UnitX(), nearly_unit)};
  FitReport report;
  const std::vector<TrainingPoint> normalised = screenObservations(points, kNormalise, &report);
  ASSERT_EQ(normalised.size(), 2u);
  EXPECT_DOUBLE_EQ(normalised[0].slope_direction.y(), 0.6);
  EXPECT_DOUBLE_EQ(normalised[0].slope_direction.z(), 0.8);
  EXPECT_EQ(normalised[1].slope_direction, nearly_unit);
  EXPECT_NE(nearly_unit.normalized(), nearly_unit);

  const std::vector<TrainingPoint> as_given = screenObservations(points, kAsGiven, &report);
  ASSERT_EQ(as_given.size(), 2u);
  EXPECT_EQ(as_given[0].slope_direction, long_direction);
  EXPECT_EQ(as_given[1].slope_direction, nearly_unit);
  EXPECT_EQ(report.num_rejected, 0u);
}

}  // namespace
