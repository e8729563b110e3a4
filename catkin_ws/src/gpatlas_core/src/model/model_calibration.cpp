#include "gpatlas_core/model/model_calibration.h"

#include "gpatlas_core/model/position_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gpatlas_core {

CalibrationResult surfaceCalibration(const SurfaceModel& model, const std::vector<Vector3>& surface_points,
                                     double k_sigma, const std::vector<double>& position_errors_m) {
  CalibrationResult result;
  if (!model.isFitted()) {
    result.message = "no model";
    return result;
  }
  if (!(k_sigma > 0.0) || !std::isfinite(k_sigma)) {
    result.message = "k_sigma must be finite and > 0";
    return result;
  }
  if (!position_errors_m.empty() && position_errors_m.size() != surface_points.size()) {
    result.message = "one position error per surface point, or none";
    return result;
  }
  std::vector<std::size_t> in_domain;
  for (std::size_t i = 0; i < surface_points.size(); ++i) {
    if (!surface_points[i].allFinite()) continue;
    ++result.samples;
    if (model.inDomain(surface_points[i])) in_domain.push_back(i);
    else ++result.out_of_domain;
  }
  if (result.samples == 0) {
    result.message = "no finite surface point";
    return result;
  }
  const double unit = model.varianceUnitFactor();
  constexpr std::size_t kBatch = 1024;
  std::vector<double> position_sd, measured_sd, measured_error;
  std::size_t covered = 0;
  for (std::size_t begin = 0; begin < in_domain.size(); begin += kBatch) {
    const std::size_t count = std::min(kBatch, in_domain.size() - begin);
    Points3 batch(3, static_cast<Eigen::Index>(count));
    for (std::size_t k = 0; k < count; ++k) batch.col(static_cast<Eigen::Index>(k)) = surface_points[in_domain[begin + k]];
    const BatchPrediction prediction = model.predictBatch(batch, true, false, true);
    for (Eigen::Index k = 0; k < batch.cols(); ++k) {
      const double sd = std::sqrt(std::max(prediction.variance[k] / unit, 0.0));
      if (std::abs(prediction.mean[k]) <= k_sigma * sd) ++result.within;
      const double sd_m = positionSd(model, prediction.variance[k], prediction.gradient.col(k).norm());
      position_sd.push_back(sd_m);
      if (position_errors_m.empty()) continue;
      const double error = position_errors_m[in_domain[begin + static_cast<std::size_t>(k)]];
      if (!std::isfinite(error)) continue;
      measured_sd.push_back(sd_m);
      measured_error.push_back(error);
      if (error <= k_sigma * sd_m) ++covered;
    }
  }
  result.fraction = static_cast<double>(result.within) / static_cast<double>(result.samples);
  if (!position_sd.empty()) result.median_position_sd_m = quantile(position_sd, 0.5);
  if (!measured_error.empty()) {
    result.coverage = static_cast<double>(covered) / static_cast<double>(measured_error.size());
    result.median_position_error_m = quantile(measured_error, 0.5);
    result.sharpness = quantile(measured_sd, 0.5) / std::max(result.median_position_error_m, 1e-6);
  }
  result.ok = true;
  return result;
}

}  // namespace gpatlas_core
