#pragma once

// A surface model measured against the true shape: the one measurement of gpatlas_bench and of
// the exploration node (their runs.csv, history.csv and report.json).

#include "gpatlas_core/common/triangle_mesh.h"
#include "gpatlas_core/model/model_calibration.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_geometry/shape_metrics.h"
#include "gpatlas_geometry/surface_mesher.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace gpatlas_geometry {

// The truth samples of the calibration: the same for every measurement of one truth.
constexpr std::size_t kCalibrationSamples = 2000;
constexpr std::uint64_t kCalibrationSeed = 11;

// What measureModel measures besides the shape. Each costs time, and a run measures its model
// every few actions: the extras are for the final model.
struct MeasurementRequest {
  // The largest variance over SurfaceSampler's default sample of the predicted surface.
  bool sampled_max_variance{true};
  // The predicted surface's vertices carry their variance (a saved mesh is coloured by it); one
  // variance per vertex costs more than the mesh.
  bool vertex_variances{false};
  // And their position sd in metres (SurfaceMesher::Config::vertex_position_sd), for a saved mesh.
  bool vertex_position_sd{false};
  // Keep each truth sample's distance to the predicted surface
  // (ShapeMetricsResult::truth_to_predicted_distances), for RMSEs over parts of the truth
  // (maskedRmse): 20000 numbers.
  bool truth_distances{false};
  // How well the variance covers the truth: surfaceCalibration on kCalibrationSamples samples of
  // the truth, with their distances to the predicted surface (coverage, sharpness).
  bool calibration{false};
  // How the surfaces are compared (its keep_truth_distances is truth_distances'): fewer samples
  // make a cheaper, noisier measurement, e.g. of every action's model.
  ShapeMetrics::Config shape;
};

struct ModelMeasurement {
  // NaN when not asked for, or when the surface cannot be sampled.
  double sampled_max_variance{std::nan("")};
  // The predicted surface: the zero level set of the mean, meshed only when there is a truth.
  SurfaceMeshResult surface;
  // The predicted surface against the truth, both ways; not ok without a truth or a predicted
  // surface, and the message says which.
  ShapeMetricsResult shape;
  gpatlas_core::CalibrationResult calibration;  // not ok unless asked for (and with a truth)
  double sample_s{0.0};   // time spent sampling the variance
  double mesh_s{0.0};     // meshing
  double metrics_s{0.0};  // and comparing
};

// Meshes `model` with `mesher` (its vertex_variances and vertex_position_sd replaced by the
// request's) and compares the surface with `truth` (request.shape: RMSE both ways, chamfer,
// F-score at 5 mm).
// An empty truth measures only the sampled variance.
ModelMeasurement measureModel(const gpatlas_core::SurfaceModel& model, const TriangleMesh& truth,
                              const SurfaceMesher::Config& mesher, const MeasurementRequest& request = {});

// The RMSE of the distances whose mask entry equals `in`, e.g. truth_to_predicted_distances
// over a mask of the same truth samples; NaN when there are none.
double maskedRmse(const std::vector<double>& distances, const std::vector<bool>& mask, bool in);

}  // namespace gpatlas_geometry
