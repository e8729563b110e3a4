#include "gpatlas_core/model/model_calibration.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gpatlas_core {

CalibrationResult surfaceCalibration(const SurfaceModel& model, const std::vector<Vector3>& surface_points,
                                     double k_sigma) {
  CalibrationResult result;
  if (!model.isFitted()) {
    result.message = "no model";
    return result;
  }
  if (!(k_sigma > 0.0) || !std::isfinite(k_sigma)) {
    result.message = "k_sigma must be finite and > 0";
    return result;
  }
  std::vector<Vector3> in_domain;
  for (const Vector3& p : surface_points) {
    if (!p.allFinite()) continue;
    ++result.samples;
    if (model.inDomain(p)) in_domain.push_back(p);
    else ++result.out_of_domain;
  }
  if (result.samples == 0) {
    result.message = "no finite surface point";
    return result;
  }
  const double unit = model.varianceUnitFactor();
  constexpr std::size_t kBatch = 1024;
  std::vector<double> position_sd;
  for (std::size_t begin = 0; begin < in_domain.size(); begin += kBatch) {
    const std::size_t count = std::min(kBatch, in_domain.size() - begin);
    Points3 batch(3, static_cast<Eigen::Index>(count));
    for (std::size_t k = 0; k < count; ++k) batch.col(static_cast<Eigen::Index>(k)) = in_domain[begin + k];
    const BatchPrediction prediction = model.predictBatch(batch, true, false, true);
    for (Eigen::Index k = 0; k < batch.cols(); ++k) {
      const double sd = std::sqrt(std::max(prediction.variance[k] / unit, 0.0));
      if (std::abs(prediction.mean[k]) <= k_sigma * sd) ++result.within;
      const double slope = prediction.gradient.col(k).norm();
      position_sd.push_back(slope > 0.0 ? sd / slope : std::numeric_limits<double>::infinity());
    }
  }
  result.fraction = static_cast<double>(result.within) / static_cast<double>(result.samples);
  if (!position_sd.empty()) {
    std::nth_element(position_sd.begin(), position_sd.begin() + position_sd.size() / 2, position_sd.end());
    result.median_position_sd_m = position_sd[position_sd.size() / 2];
  }
  result.ok = true;
  return result;
}

}  // namespace gpatlas_core
