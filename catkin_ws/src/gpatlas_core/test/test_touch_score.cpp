#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/model/position_uncertainty.h"
#include "gpatlas_core/observations/touch_training.h"
#include "gpatlas_core/planning/touch_score.h"
#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

namespace {

using gpatlas_core::Contact;
using gpatlas_core::Points3;
using gpatlas_core::SurfaceModel;
using gpatlas_core::TrainingPoint;
using gpatlas_core::Vector3;
using gpatlas_core::testing::AnalyticSphere;

// Points on the whole true sphere (the references), uniformly in area.
Points3 spherePoints(const AnalyticSphere& sphere, int count, unsigned seed) {
  const std::vector<TrainingPoint> all = sphere.view(count, -1.0, 0.0, seed);
  Points3 points(3, count);
  for (int i = 0; i < count; ++i) points.col(i) = all[static_cast<std::size_t>(i)].position;
  return points;
}

// `count` points of the true sphere as the predicted surface's patches (close enough for a
// score), each with the sphere's area over the count, and the error they carry under a model.
struct SpherePatches {
  SpherePatches(const AnalyticSphere& sphere, int count)
      : points(spherePoints(sphere, count, 7)), area(4.0 * M_PI * sphere.radius * sphere.radius / count) {}
  std::vector<gpatlas_core::SurfacePatch> of(const SurfaceModel& m) const {
    const gpatlas_core::BatchPrediction p = m.predictBatch(points, true, false, true);
    std::vector<gpatlas_core::SurfacePatch> patches;
    for (Eigen::Index i = 0; i < points.cols(); ++i)
      patches.push_back({points.col(i), area, p.variance[i], p.gradient.col(i).norm()});
    return patches;
  }
  double summedError(const SurfaceModel& m, const gpatlas_core::StopRule& rule) const {
    double sum = 0.0;
    for (const gpatlas_core::SurfacePatch& patch : of(m))
      sum += patch.area_m2 * gpatlas_core::surfaceError(m, rule, patch.variance, patch.slope);
    return sum;
  }
  Points3 points;
  double area;
};

// What a poke of the true sphere at `direction` adds (its contact, the point behind it, its
// normal's slopes), the same with its approach's free space (as scoreTouches fantasises it), a
// contact alone on the other side, and a free-space point off the front.
std::vector<std::vector<TrainingPoint>> batches(const SurfaceModel& model, const AnalyticSphere& sphere) {
  const Vector3 back = Vector3(0.2, -0.3, -0.9).normalized();
  const Vector3 side = Vector3(-0.9, 0.1, -0.3).normalized();
  const gpatlas_core::TouchObservationConfig touch;
  std::vector<std::vector<TrainingPoint>> out;
  out.push_back(gpatlas_core::touchTrainingPoints(model, {Contact{sphere.centre + sphere.radius * back, back}}, {}, touch));
  const gpatlas_core::TouchCandidate poke{sphere.centre + sphere.radius * side, side, 0.1};
  gpatlas_core::TouchPointCounts counts;
  out.push_back(gpatlas_core::touchTrainingPoints(model, {Contact{poke.point, poke.normal}},
                                                  gpatlas_core::approachFreeSpace(poke, touch.min_free_space_spacing_m),
                                                  touch, &counts));
  EXPECT_GE(counts.free_space, 4u);  // the approach's free space is in the batch
  TrainingPoint contact;
  contact.position = sphere.centre + sphere.radius * side;
  contact.noise_sigma = touch.contact_noise_sigma;
  contact.source = gpatlas_core::PointSource::kTouch;
  out.push_back({contact});
  TrainingPoint free = contact;
  free.position = sphere.centre + 1.3 * sphere.radius * Vector3(0.0, 0.6, 0.8);
  free.label = gpatlas_core::PointLabel::kOutside;
  out.push_back({free});
  out.push_back({});
  return out;
}

// The variance after each batch from a model of the same kind built from scratch with the
// batch's points added (restore: the same hyperparameters and frame, one full fit).
void expectMatchesAFullRefit(const SurfaceModel& model, std::unique_ptr<SurfaceModel> fresh,
                             const AnalyticSphere& sphere) {
  const Points3 references = spherePoints(sphere, 80, 11);
  const std::vector<std::vector<TrainingPoint>> touches = batches(model, sphere);
  const Eigen::MatrixXd after = model.varianceAfter(references, touches);
  const Eigen::VectorXd before = model.predictBatch(references, false, false, true).variance;
  ASSERT_EQ(after.rows(), references.cols());
  ASSERT_EQ(after.cols(), static_cast<Eigen::Index>(touches.size()));
  for (std::size_t b = 0; b < touches.size(); ++b) {
    gpatlas_core::SurfaceModelState state = model.state();
    state.observations.insert(state.observations.end(), touches[b].begin(), touches[b].end());
    const std::unique_ptr<SurfaceModel> refit = fresh->clone();
    ASSERT_TRUE(refit->restore(state).ok);
    const Eigen::VectorXd truth = refit->predictBatch(references, false, false, true).variance;
    double largest_fall = 0.0;
    for (Eigen::Index j = 0; j < references.cols(); ++j) {
      EXPECT_NEAR(after(j, static_cast<Eigen::Index>(b)), truth[j], 1e-6 * before[j]) << "batch " << b << ", reference " << j;
      largest_fall = std::max(largest_fall, (before[j] - truth[j]) / before[j]);
    }
    // Every batch but the empty one teaches something somewhere.
    if (!touches[b].empty()) EXPECT_GT(largest_fall, 1e-3) << "batch " << b;
  }
}

TEST(VarianceAfter, GpisModelMatchesAFullRefitWithTheBatchAdded) {
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(150, 0.0, 0.1, 3)).ok);
  expectMatchesAFullRefit(model, std::make_unique<gpatlas_core::GpisModel>(), sphere);
}

TEST(VarianceAfter, MultiscaleModelMatchesAFullRefitWithTheBatchAdded) {
  const AnalyticSphere sphere;
  // Few enough view points that no cell is thinned (max_points_per_cell), where the update is exact.
  gpatlas_core::MultiscaleGpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(300, 0.0, 0.1, 3)).ok);
  ASSERT_GT(model.numCells(), 10u);
  expectMatchesAFullRefit(model, std::make_unique<gpatlas_core::MultiscaleGpisModel>(), sphere);
}

TEST(VarianceAfter, TheDefaultAddsEachBatchToAClone) {
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(100, 0.0, 0.1, 3)).ok);
  const Points3 references = spherePoints(sphere, 30, 5);
  const std::vector<std::vector<TrainingPoint>> touches = batches(model, sphere);
  const Eigen::MatrixXd low_rank = model.varianceAfter(references, touches);
  const Eigen::MatrixXd cloned = model.SurfaceModel::varianceAfter(references, touches);
  EXPECT_LT((low_rank - cloned).cwiseAbs().maxCoeff(), 1e-6 * cloned.cwiseAbs().maxCoeff());
}

TEST(SurfaceError, IsZeroWithinTheBoundAndGrowsWithThePositionSd) {
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(100, 0.0, 0.1, 3)).ok);
  const gpatlas_core::StopRule rule{0.1, 0.005};
  // The reported variance for a position sd s at slope g: (s g / scale_sd)^2 * unit.
  const auto varianceFor = [&](double sd, double slope) {
    const double f_sd = sd * slope / model.positionSdScale();
    return f_sd * f_sd * model.varianceUnitFactor();
  };
  EXPECT_EQ(gpatlas_core::surfaceError(model, rule, varianceFor(0.004, 10.0), 10.0), 0.0);
  const double at_2b = gpatlas_core::surfaceError(model, rule, varianceFor(0.010, 10.0), 10.0);
  const double at_10b = gpatlas_core::surfaceError(model, rule, varianceFor(0.050, 10.0), 10.0);
  // 2 Phi(-1/2) - 2 Phi(-1) and 2 Phi(-1/10) - 2 Phi(-1).
  EXPECT_NEAR(at_2b, 0.617075 - 0.317311, 1e-4);
  EXPECT_NEAR(at_10b, 0.920344 - 0.317311, 1e-4);
  // Under V_max alone: the variance's relative excess.
  EXPECT_NEAR(gpatlas_core::surfaceError(model, {0.1, std::nullopt}, 0.3, 1.0), 2.0, 1e-12);
  EXPECT_EQ(gpatlas_core::surfaceError(model, {0.1, std::nullopt}, 0.05, 1.0), 0.0);
}

// The first touch of a half-seen sphere: the score's predicted fall of the summed error, and the
// fall measured on the model after the real touch (its contact where the ray meets the true
// sphere, its free space, the model's new mean and slopes), over the same surface points.
TEST(TouchScore, PredictsTheFallOfTheErrorThatTheTouchBrings) {
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(150, 0.0, 0.1, 3)).ok);
  const gpatlas_core::StopRule rule{0.1, std::nullopt};
  const SpherePatches patches(sphere, 400);
  const auto patchesOf = [&](const SurfaceModel& m) { return patches.of(m); };
  const auto summedError = [&](const SurfaceModel& m) { return patches.summedError(m, rule); };
  const Vector3 back = Vector3(0.1, 0.2, -1.0).normalized();
  const gpatlas_core::TouchCandidate candidate{sphere.centre + sphere.radius * back, back};
  gpatlas_core::TouchScoreConfig config;
  config.max_reference_points = 400;  // every patch: the comparison is then exact in the references
  const gpatlas_core::TouchObservationConfig touch;
  const gpatlas_core::TouchScores scores =
      gpatlas_core::scoreTouches(model, rule, patchesOf(model), {candidate}, touch, config, 1);
  ASSERT_TRUE(scores.ok) << scores.message;
  const double before = summedError(model);
  EXPECT_NEAR(scores.total_error, before, 1e-9 * before);
  ASSERT_GT(scores.reduction[0], 0.05 * before);

  gpatlas_core::testing::AnalyticSphereProber prober(sphere);
  gpatlas_core::Touch poke;
  poke.points = {candidate.point};
  poke.normals = {candidate.normal};
  const gpatlas_core::ProbeResult probed = prober.probe(poke);
  ASSERT_FALSE(probed.contacts.empty());
  ASSERT_TRUE(gpatlas_core::applyTouch(model, probed.contacts, probed.free_space, touch).ok);
  const double actual = before - summedError(model);
  EXPECT_NEAR(scores.reduction[0], actual, 0.2 * actual);
}

TEST(TouchScore, ApproachFreeSpaceLiesAlongTheNormalOutToTheApproachStart) {
  const gpatlas_core::TouchCandidate poke{Vector3(0.5, 0.1, 0.2), Vector3(0.0, 3.0, 4.0), 0.1};
  const std::vector<Vector3> line = gpatlas_core::approachFreeSpace(poke, 0.015);
  ASSERT_EQ(line.size(), 6u);  // 0.015 ... 0.09 m out; none at the contact, none past the start
  for (std::size_t k = 0; k < line.size(); ++k)
    EXPECT_LT((line[k] - (poke.point + 0.015 * static_cast<double>(k + 1) * Vector3(0.0, 0.6, 0.8))).norm(), 1e-12);
  EXPECT_TRUE(gpatlas_core::approachFreeSpace({poke.point, poke.normal, 0.0}, 0.015).empty());
  EXPECT_TRUE(gpatlas_core::approachFreeSpace({poke.point, Vector3::Zero(), 0.1}, 0.015).empty());
}

// A poke's way in is free space the model learns from too: the score with the approach counts it
// (more fall than the contact alone), and equals the error's fall under a model refitted with the
// contact and that free space.
TEST(TouchScore, CountsTheApproachsFreeSpace) {
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(150, 0.0, 0.1, 3)).ok);
  const gpatlas_core::StopRule rule{0.1, std::nullopt};
  const SpherePatches patches(sphere, 300);
  const auto patchesOf = [&](const SurfaceModel& m) { return patches.of(m); };
  const auto summedError = [&](const SurfaceModel& m) { return patches.summedError(m, rule); };
  const Vector3 side = Vector3(0.3, 1.0, -0.6).normalized();
  const gpatlas_core::TouchCandidate bare{sphere.centre + sphere.radius * side, side, 0.0};
  const gpatlas_core::TouchCandidate approached{bare.point, bare.normal, 0.1};
  gpatlas_core::TouchScoreConfig config;
  config.max_reference_points = 300;
  const gpatlas_core::TouchObservationConfig touch;
  const gpatlas_core::TouchScores scores =
      gpatlas_core::scoreTouches(model, rule, patchesOf(model), {bare, approached}, touch, config, 1);
  ASSERT_TRUE(scores.ok) << scores.message;
  // Free space only adds information: more fall than the contact alone, by more than round-off.
  EXPECT_GT(scores.reduction[1], scores.reduction[0] + 1e-3 * scores.total_error);

  const std::vector<TrainingPoint> added = gpatlas_core::touchTrainingPoints(
      model, {Contact{approached.point, approached.normal}},
      gpatlas_core::approachFreeSpace(approached, touch.min_free_space_spacing_m), touch);
  gpatlas_core::SurfaceModelState state = model.state();
  state.observations.insert(state.observations.end(), added.begin(), added.end());
  gpatlas_core::GpisModel refit;
  ASSERT_TRUE(refit.restore(state).ok);
  // The variance after the refit, with the slopes of the model before (the score keeps them).
  const std::vector<gpatlas_core::SurfacePatch> now = patchesOf(model);
  const gpatlas_core::BatchPrediction later = refit.predictBatch(patches.points, false, false, true);
  double fall = 0.0;
  for (std::size_t i = 0; i < now.size(); ++i)
    fall += patches.area * (gpatlas_core::surfaceError(model, rule, now[i].variance, now[i].slope) -
                    gpatlas_core::surfaceError(model, rule, later.variance[static_cast<Eigen::Index>(i)], now[i].slope));
  EXPECT_NEAR(scores.reduction[1], fall, 1e-6 * summedError(model));
}

}  // namespace
