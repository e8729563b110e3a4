#include "gpatlas_geometry/model_measurement.h"

#include "gpatlas_core/planning/surface_sampler.h"

#include <chrono>

namespace gpatlas_geometry {

namespace {

// One fixed sample of the predicted surface, so that every model is measured at points drawn alike.
constexpr std::uint64_t kSampleSeed = 7;

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

ModelMeasurement measureModel(const gpatlas_core::SurfaceModel& model, const TriangleMesh& truth,
                              const SurfaceMesher::Config& mesher, const MeasurementRequest& request) {
  ModelMeasurement measured;
  if (request.sampled_max_variance) {
    const auto sample_start = std::chrono::steady_clock::now();
    const gpatlas_core::SurfaceSample sample = gpatlas_core::SurfaceSampler().sample(model, kSampleSeed);
    if (sample.ok) measured.sampled_max_variance = sample.maxVariance();
    measured.sample_s = secondsSince(sample_start);
  }
  if (truth.empty()) {
    measured.shape.message = "no truth to compare with";
    measured.calibration.message = measured.shape.message;
    return measured;
  }
  SurfaceMesher::Config mesh_config = mesher;
  mesh_config.vertex_variances = request.vertex_variances;
  mesh_config.vertex_position_sd = request.vertex_position_sd;
  const auto mesh_start = std::chrono::steady_clock::now();
  measured.surface = SurfaceMesher(mesh_config).mesh(model);
  measured.mesh_s = secondsSince(mesh_start);
  if (!measured.surface.ok || measured.surface.mesh.empty()) {
    measured.shape.message = "no predicted surface: " + measured.surface.message;
  } else {
    ShapeMetrics::Config metrics = request.shape;
    metrics.keep_truth_distances = request.truth_distances;
    const auto metrics_start = std::chrono::steady_clock::now();
    measured.shape = ShapeMetrics(metrics).compare(measured.surface.mesh, truth);
    measured.metrics_s = secondsSince(metrics_start);
  }
  if (request.calibration) {
    const std::vector<Vector3> samples = sampleMeshSurface(truth, kCalibrationSamples, kCalibrationSeed);
    // Each sample's position error: its distance to the predicted surface.
    std::vector<double> errors;
    if (measured.shape.ok) {
      const MeshDistanceIndex predicted(measured.surface.mesh);
      for (const Vector3& p : samples) errors.push_back(predicted.distance(p));
    }
    measured.calibration = gpatlas_core::surfaceCalibration(model, samples, 2.0, errors);
  } else
    measured.calibration.message = "not asked for";
  return measured;
}

double maskedRmse(const std::vector<double>& distances, const std::vector<bool>& mask, bool in) {
  double sum_squared = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < distances.size() && i < mask.size(); ++i)
    if (mask[i] == in) {
      sum_squared += distances[i] * distances[i];
      ++n;
    }
  return n > 0 ? std::sqrt(sum_squared / static_cast<double>(n)) : std::nan("");
}

}  // namespace gpatlas_geometry
