#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_geometry/model_measurement.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace gpatlas_core;
using namespace gpatlas_geometry;
using gpatlas_core::testing::AnalyticSphere;

namespace {

// A model of the whole sphere, seen all round.
GpisModel sphereModel(const AnalyticSphere& sphere) {
  GpisModel model;
  const FitReport report = model.fit(sphere.view(600, -1.0, 0.1, 3));
  EXPECT_TRUE(report.ok) << report.message;
  return model;
}

SurfaceMesher::Config mesher() {
  SurfaceMesher::Config config;
  config.resolution_m = 0.005;
  return config;
}

MeasurementRequest everything() {
  MeasurementRequest request;
  request.vertex_variances = true;
  request.truth_distances = true;
  request.calibration = true;
  return request;
}

TEST(MeasureModel, AModelOfTheSphereMatchesItsTruth) {
  const AnalyticSphere sphere;
  const GpisModel model = sphereModel(sphere);
  const ModelMeasurement measured =
      measureModel(model, makeIcosphere(sphere.centre, sphere.radius, 4), mesher(), everything());
  ASSERT_TRUE(measured.surface.ok) << measured.surface.message;
  EXPECT_EQ(measured.surface.mesh.vertex_variances.size(), measured.surface.mesh.vertices.size());
  for (const Vector3& v : measured.surface.mesh.vertices) EXPECT_NEAR(sphere.signedDistance(v), 0.0, 0.002);
  ASSERT_TRUE(measured.shape.ok) << measured.shape.message;
  EXPECT_LT(measured.shape.rmse_predicted_to_truth, 0.001);
  EXPECT_LT(measured.shape.rmse_truth_to_predicted, 0.001);
  EXPECT_GT(measured.shape.f_score, 0.99);
  EXPECT_EQ(measured.shape.truth_to_predicted_distances.size(), measured.shape.samples_per_mesh);
  ASSERT_TRUE(measured.calibration.ok) << measured.calibration.message;
  EXPECT_EQ(measured.calibration.samples, kCalibrationSamples);
  EXPECT_GT(measured.calibration.fraction, 0.9);
  EXPECT_TRUE(std::isfinite(measured.sampled_max_variance));
  EXPECT_GT(measured.sampled_max_variance, 0.0);
}

// The truth 10 mm outside the model's sphere: every distance is 10 mm and none within the
// F-score's 5 mm. The calibration samples that truth, where the model, away from its data, is
// less sure of the surface's position.
TEST(MeasureModel, ATruthOneCentimetreOutIsOneCentimetreOff) {
  const AnalyticSphere sphere;
  const GpisModel model = sphereModel(sphere);
  const double gap = 0.01;
  const ModelMeasurement right =
      measureModel(model, makeIcosphere(sphere.centre, sphere.radius, 4), mesher(), everything());
  const ModelMeasurement off =
      measureModel(model, makeIcosphere(sphere.centre, sphere.radius + gap, 4), mesher(), everything());
  ASSERT_TRUE(off.shape.ok) << off.shape.message;
  EXPECT_NEAR(off.shape.rmse_predicted_to_truth, gap, 0.001);
  EXPECT_NEAR(off.shape.rmse_truth_to_predicted, gap, 0.001);
  EXPECT_NEAR(off.shape.chamfer_l1, gap, 0.001);
  EXPECT_LT(off.shape.f_score, 0.01);
  ASSERT_TRUE(off.calibration.ok);
  ASSERT_TRUE(right.calibration.ok);
  EXPECT_GT(off.calibration.median_position_sd_m, 2.0 * right.calibration.median_position_sd_m);
}

// The cheaper comparison of the bench's curve (fewer samples, smaller indices) measures the same
// 10 mm gap with the samples it was asked for.
TEST(MeasureModel, FewerSamplesMeasureTheSameGap) {
  const AnalyticSphere sphere;
  const GpisModel model = sphereModel(sphere);
  const double gap = 0.01;
  MeasurementRequest cheap;
  cheap.sampled_max_variance = false;
  cheap.shape.samples_per_mesh = 2000;
  cheap.shape.index.index_samples = 6000;
  const ModelMeasurement off = measureModel(model, makeIcosphere(sphere.centre, sphere.radius + gap, 4), mesher(), cheap);
  ASSERT_TRUE(off.shape.ok) << off.shape.message;
  EXPECT_EQ(off.shape.samples_per_mesh, 2000u);
  EXPECT_NEAR(off.shape.rmse_predicted_to_truth, gap, 0.001);
  EXPECT_NEAR(off.shape.rmse_truth_to_predicted, gap, 0.001);
  EXPECT_LT(off.shape.f_score, 0.01);
}

// A model of the top alone against the whole sphere: the truth-to-predicted RMSE over the seen
// top is that of a good model, and the two parts make up the whole.
TEST(MeasureModel, MaskedRmseMeasuresPartsOfTheTruth) {
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(400, 0.3, 0.1, 4)).ok);
  const TriangleMesh truth = makeIcosphere(sphere.centre, sphere.radius, 4);
  const ModelMeasurement measured = measureModel(model, truth, mesher(), everything());
  ASSERT_TRUE(measured.shape.ok) << measured.shape.message;
  const ShapeMetrics::Config metrics;
  const std::vector<Vector3> samples =
      sampleMeshSurface(truth, metrics.samples_per_mesh, truthSampleSeed(metrics.seed));
  std::vector<bool> seen;
  std::size_t seen_count = 0;
  for (const Vector3& s : samples) {
    seen.push_back((s - sphere.centre).normalized().z() > 0.5);
    seen_count += seen.back() ? 1 : 0;
  }
  const std::vector<double>& distances = measured.shape.truth_to_predicted_distances;
  const double rmse_seen = maskedRmse(distances, seen, true);
  const double rmse_unseen = maskedRmse(distances, seen, false);
  EXPECT_LT(rmse_seen, 0.001);
  EXPECT_GT(rmse_unseen, rmse_seen);
  const double n = static_cast<double>(samples.size());
  EXPECT_NEAR(std::sqrt((seen_count * rmse_seen * rmse_seen + (n - seen_count) * rmse_unseen * rmse_unseen) / n),
              measured.shape.rmse_truth_to_predicted, 1e-12);
  EXPECT_TRUE(std::isnan(maskedRmse(distances, std::vector<bool>(distances.size(), false), true)));
}

TEST(MeasureModel, WithoutATruthOnlyTheVarianceIsMeasured) {
  const AnalyticSphere sphere;
  const GpisModel model = sphereModel(sphere);
  const ModelMeasurement measured = measureModel(model, TriangleMesh(), mesher(), everything());
  EXPECT_TRUE(std::isfinite(measured.sampled_max_variance));
  EXPECT_FALSE(measured.surface.ok);
  EXPECT_FALSE(measured.shape.ok);
  EXPECT_NE(measured.shape.message.find("no truth"), std::string::npos) << measured.shape.message;
  EXPECT_FALSE(measured.calibration.ok);

  // Only what is asked for: no sampled variance, no vertex variances, no distances kept.
  const ModelMeasurement shape_only =
      measureModel(model, makeIcosphere(sphere.centre, sphere.radius, 4), mesher(), MeasurementRequest{false});
  EXPECT_TRUE(std::isnan(shape_only.sampled_max_variance));
  ASSERT_TRUE(shape_only.shape.ok);
  EXPECT_TRUE(shape_only.surface.mesh.vertex_variances.empty());
  EXPECT_TRUE(shape_only.shape.truth_to_predicted_distances.empty());
  EXPECT_FALSE(shape_only.calibration.ok);
}

}  // namespace
