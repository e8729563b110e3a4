#include "gpatlas_core/model/surface_model_factory.h"
#include "gpatlas_core/observations/view_training.h"
#include "gpatlas_core/observations/view_update.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

using namespace gpatlas_core;
using gpatlas_core::testing::AnalyticSphere;

namespace {

// The camera above the sphere, as the bench's head camera looks down on the table.
Vector3 cameraAbove(const AnalyticSphere& sphere) { return sphere.centre + Vector3(0.1, 0.0, 0.5); }

// The training data of one view of the sphere's top (every random choice from `seed`).
std::vector<TrainingPoint> viewOfTheTop(const AnalyticSphere& sphere, unsigned seed) {
  std::vector<Vector3> points;
  for (const TrainingPoint& p : sphere.view(800, 0.3, 0.0, seed)) points.push_back(p.position);
  const ViewTraining view = buildViewTraining(points, cameraAbove(sphere), std::nullopt, ViewTrainingConfig(), seed);
  EXPECT_TRUE(view.ok) << view.message;
  return view.points;
}

// Where the model's mean crosses zero on the ray from the sphere's centre along `direction`,
// as a radius (bisection between half and one and a half radii); NaN without a sign change.
double zeroCrossingRadius(const SurfaceModel& model, const AnalyticSphere& sphere, const Vector3& direction) {
  const Vector3 d = direction.normalized();
  double inside = 0.5 * sphere.radius, outside = 1.5 * sphere.radius;
  if (!(model.mean(sphere.centre + inside * d) < 0.0 && model.mean(sphere.centre + outside * d) > 0.0))
    return std::nan("");
  for (int i = 0; i < 40; ++i) {
    const double middle = 0.5 * (inside + outside);
    (model.mean(sphere.centre + middle * d) < 0.0 ? inside : outside) = middle;
  }
  return 0.5 * (inside + outside);
}

std::vector<Contact> contactsOnTheUnderside(const AnalyticSphere& sphere) {
  std::vector<Contact> contacts;
  for (const Vector3& d : {Vector3(0.0, 0.0, -1.0), Vector3(0.4, 0.0, -1.0), Vector3(-0.3, 0.3, -1.0)}) {
    Contact c;
    c.normal = d.normalized();
    c.position = sphere.centre + sphere.radius * c.normal;
    contacts.push_back(c);
  }
  return contacts;
}

bool holds(const SurfaceModel& model, const TrainingPoint& point) {
  return std::any_of(model.observations().begin(), model.observations().end(), [&](const TrainingPoint& held) {
    return held.position == point.position && held.label == point.label && held.source == point.source;
  });
}

TEST(ApplyView, TheFittedZeroLevelSetLiesOnTheSeenSphere) {
  const AnalyticSphere sphere;
  const std::unique_ptr<SurfaceModel> model = makeSurfaceModel(SurfaceModelConfig());
  const ViewUpdate update = applyView(*model, viewOfTheTop(sphere, 1), TouchObservationConfig());
  ASSERT_TRUE(update.ok) << update.fit.message;
  EXPECT_EQ(update.touch_points_kept, 0u);
  EXPECT_FALSE(update.retraction.any());
  EXPECT_FALSE(update.calibration.has_value());
  int checked = 0;
  for (const Vector3& d : fibonacciSphere(60)) {
    if (d.z() < 0.5) continue;  // the part the camera saw
    EXPECT_NEAR(zeroCrossingRadius(*model, sphere, d), sphere.radius, 0.002) << d.transpose();
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

TEST(ApplyView, ANewViewReplacesTheOldOneAndKeepsTheTouches) {
  const AnalyticSphere sphere;
  const TouchObservationConfig touch;
  const std::unique_ptr<SurfaceModel> model = makeSurfaceModel(SurfaceModelConfig());
  const std::vector<TrainingPoint> first_view = viewOfTheTop(sphere, 1);
  ASSERT_TRUE(applyView(*model, first_view, touch).ok);
  const std::vector<Contact> contacts = contactsOnTheUnderside(sphere);
  const std::vector<Vector3> free_space{sphere.centre + Vector3(0.0, 0.0, -1.6 * sphere.radius)};
  ASSERT_TRUE(applyTouch(*model, contacts, free_space, touch).ok);
  std::vector<TrainingPoint> touch_points;
  for (const TrainingPoint& p : model->observations())
    if (!fromView(p.source)) touch_points.push_back(p);
  ASSERT_FALSE(touch_points.empty());

  const ViewUpdate update = applyView(*model, viewOfTheTop(sphere, 2), touch);
  ASSERT_TRUE(update.ok) << update.fit.message;
  EXPECT_EQ(update.touch_points_kept, touch_points.size());
  for (const TrainingPoint& p : touch_points) EXPECT_TRUE(holds(*model, p)) << p.position.transpose();
  std::size_t first_view_surface_left = 0;
  for (const TrainingPoint& p : first_view)
    if (p.source == PointSource::kVision && isSurfaceValue(p) && holds(*model, p)) ++first_view_surface_left;
  EXPECT_EQ(first_view_surface_left, 0u);
  // The touched underside, which no view saw, stays where the touches found it.
  for (const Contact& c : contacts)
    EXPECT_NEAR(zeroCrossingRadius(*model, sphere, c.normal), sphere.radius, 0.003) << c.normal.transpose();
}

TEST(ApplyView, TheTouchesRetractTheNewViewsGuessesTheyContradict) {
  const AnalyticSphere sphere;
  const TouchObservationConfig touch;
  const std::unique_ptr<SurfaceModel> model = makeSurfaceModel(SurfaceModelConfig());
  ASSERT_TRUE(applyView(*model, viewOfTheTop(sphere, 1), touch).ok);
  // The probe went through air beside the sphere...
  const Vector3 air = sphere.centre + Vector3(1.5 * sphere.radius, 0.0, 0.0);
  Contact contact;
  contact.normal = Vector3(1.0, 0.0, 0.0);
  contact.position = sphere.centre + sphere.radius * contact.normal;
  ASSERT_TRUE(applyTouch(*model, {contact}, {air}, touch).ok);
  // ... where the new view guesses solid material 4 cm deep.
  std::vector<TrainingPoint> second_view = viewOfTheTop(sphere, 2);
  TrainingPoint guess;
  guess.position = air + Vector3(0.0, 0.0, 0.002);
  guess.label = PointLabel::kInside;
  guess.source = PointSource::kVision;
  guess.surface_distance_m = 0.04;
  guess.noise_sigma = 0.3;
  ASSERT_TRUE(isOccludedInteriorGuess(guess));
  second_view.push_back(guess);

  const ViewUpdate update = applyView(*model, second_view, touch);
  ASSERT_TRUE(update.ok) << update.fit.message;
  EXPECT_GE(update.retraction.dropped, 1u);
  EXPECT_FALSE(holds(*model, guess));
  EXPECT_GT(model->mean(air), 0.0);
}

TEST(ApplyView, CalibrationFollowsASuccessfulFitOnly) {
  const AnalyticSphere sphere;
  const TouchObservationConfig touch;
  const PositionCalibrationConfig calibration;
  SurfaceModelConfig global;
  global.type = GpisModel::kName;
  const std::unique_ptr<SurfaceModel> model = makeSurfaceModel(global);
  const ViewUpdate calibrated = applyView(*model, sphere.view(150, 0.3, 0.1, 1), touch, &calibration);
  ASSERT_TRUE(calibrated.ok) << calibrated.fit.message;
  ASSERT_TRUE(calibrated.calibration.has_value());

  // Three points cannot be fitted: the model stays as it was, and nothing is calibrated.
  const std::size_t held = model->observations().size();
  const double scale = model->positionSdScale();
  const std::vector<TrainingPoint> too_few(sphere.view(3, 0.3, 0.1, 5));
  const ViewUpdate failed = applyView(*model, too_few, touch, &calibration);
  EXPECT_FALSE(failed.ok);
  EXPECT_FALSE(failed.fit.message.empty());
  EXPECT_FALSE(failed.calibration.has_value());
  EXPECT_EQ(model->observations().size(), held);
  EXPECT_EQ(model->positionSdScale(), scale);
}

}  // namespace
