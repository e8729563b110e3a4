#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/exploration/observation_history.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <utility>
#include <vector>

using namespace gpatlas_core;
using gpatlas_core::testing::AnalyticSphere;

namespace {

std::vector<Contact> contactsAt(const AnalyticSphere& sphere, const std::vector<Vector3>& directions, double offset) {
  std::vector<Contact> contacts;
  for (const Vector3& d : directions) {
    Contact c;
    c.position = sphere.centre + (sphere.radius + offset) * d.normalized();
    c.normal = d.normalized();
    contacts.push_back(c);
  }
  return contacts;
}

void expectSameModel(const SurfaceModel& a, const SurfaceModel& b, const AnalyticSphere& sphere) {
  ASSERT_EQ(a.observations().size(), b.observations().size());
  for (std::size_t i = 0; i < a.observations().size(); ++i)
    EXPECT_TRUE(a.observations()[i].position.isApprox(b.observations()[i].position)) << i;
  for (const Vector3& d : fibonacciSphere(20)) {
    const Vector3 x = sphere.centre + sphere.radius * d;
    EXPECT_NEAR(a.mean(x), b.mean(x), 1e-9);
    EXPECT_NEAR(a.variance(x), b.variance(x), 1e-9);
  }
}

// A wrong touch (its contacts 2 cm inside the true underside) is taken back out: the model is
// then the one that the view and the good touch alone give, whatever order they came in.
TEST(ObservationHistory, RemovingATouchGivesTheModelWithoutIt) {
  const AnalyticSphere sphere;
  const std::vector<TrainingPoint> view = sphere.view(600, 0.0, 0.1, 2);
  std::unique_ptr<SurfaceModel> model = std::make_unique<MultiscaleGpisModel>();
  ASSERT_TRUE(model->fit(view).ok);
  const std::unique_ptr<SurfaceModel> after_view = model->clone();
  const TouchObservationConfig touch;

  ObservationHistory history;
  const std::uint32_t view_id = history.setView(view);
  const std::vector<Contact> good = contactsAt(sphere, {Vector3(0.3, 0.0, -1.0), Vector3(-0.3, 0.2, -1.0)}, 0.0);
  const std::vector<Contact> wrong = contactsAt(sphere, {Vector3(0.0, 0.0, -1.0)}, -0.02);
  const std::vector<Vector3> free_space{sphere.centre + Vector3(0.0, 0.0, -2.0 * sphere.radius)};
  ASSERT_TRUE(applyTouch(*model, wrong, {}, touch).ok);
  const std::uint32_t wrong_id = history.addTouch(wrong, {});
  ASSERT_TRUE(applyTouch(*model, good, free_space, touch).ok);
  const std::uint32_t good_id = history.addTouch(good, free_space);
  EXPECT_EQ(history.lastTouches(5), (std::vector<std::uint32_t>{wrong_id, good_id}));

  // Refused: an unknown batch and the view; the model and the history stay.
  const SurfaceModel* before = model.get();
  const std::size_t observations = model->observations().size();
  std::string error;
  EXPECT_FALSE(history.remove({999}, touch, &model, &error));
  EXPECT_NE(error.find("no batch 999"), std::string::npos) << error;
  EXPECT_FALSE(history.remove({view_id}, touch, &model, &error));
  EXPECT_NE(error.find("is the view"), std::string::npos) << error;
  EXPECT_EQ(model.get(), before);
  EXPECT_EQ(model->observations().size(), observations);
  EXPECT_EQ(history.batches().size(), 3u);

  // The rebuild says how far it is: after the view, then after each touch kept (here one).
  std::vector<std::pair<std::size_t, std::size_t>> progress;
  ASSERT_TRUE(history.remove({wrong_id}, touch, &model, &error,
                             [&](std::size_t applied, std::size_t total) { progress.emplace_back(applied, total); }))
      << error;
  EXPECT_EQ(progress, (std::vector<std::pair<std::size_t, std::size_t>>{{0, 1}, {1, 1}}));
  EXPECT_FALSE(history.contains(wrong_id));
  EXPECT_EQ(history.lastTouches(5), (std::vector<std::uint32_t>{good_id}));

  // The independent truth: the model after the view, given the good touch only.
  std::unique_ptr<SurfaceModel> without = after_view->clone();
  ASSERT_TRUE(applyTouch(*without, good, free_space, touch).ok);
  expectSameModel(*model, *without, sphere);
  // The wrong contacts are gone: the underside is where the good touch put it.
  EXPECT_LT(std::abs(model->mean(sphere.centre + Vector3(0.0, 0.0, -sphere.radius))), 0.05);
}

TEST(ObservationHistory, ANewViewKeepsTheTouchesAndRebuildNeedsAView) {
  const AnalyticSphere sphere;
  ObservationHistory history;
  MultiscaleGpisModel model;
  EXPECT_FALSE(history.rebuild(model, TouchObservationConfig()).ok);
  history.addTouch(contactsAt(sphere, {Vector3(0.0, 0.0, -1.0)}, 0.0), {});
  const std::uint32_t first = history.setView(sphere.view(300, 0.2, 0.1, 3));
  const std::uint32_t second = history.setView(sphere.view(300, 0.0, 0.1, 4));
  EXPECT_NE(first, second);
  ASSERT_EQ(history.batches().size(), 2u);
  EXPECT_EQ(history.batches().front().id, second);
  EXPECT_EQ(history.lastTouches(1).size(), 1u);
  EXPECT_TRUE(history.rebuild(model, TouchObservationConfig()).ok);
  history.clear();
  EXPECT_TRUE(history.batches().empty());
}

}  // namespace
