#pragma once

#include "gpatlas_core/model/surface_model.h"

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

namespace gpatlas_core {

// Does the uncertainty tell the truth, and is it sharp? Measured on samples of the true surface,
// where f is 0 and the predicted surface should be within a few position sds.
struct CalibrationResult {
  bool ok{false};
  std::string message;
  std::size_t samples{0};        // finite points given
  std::size_t within{0};         // |mean| <= k * sd(f)
  std::size_t out_of_domain{0};  // counted as not within: the model makes no claim there
  // within / samples: the variance of f alone, without the position sd's scale (the paper's
  // variance; a calibrated model gets about 0.954 at k = 2).
  double fraction{0.0};
  // The median over the in-domain samples of positionSd() (metres).
  double median_position_sd_m{0.0};
  // With the samples' position errors (their distance to the predicted surface):
  // coverage, the share with error <= k * position sd (0.954 for a calibrated Gaussian at k = 2);
  // sharpness, the median position sd over the median error: 1.48 for a calibrated Gaussian (its
  // median |error| is 0.674 sd), more when the sd is vaguer than the errors. NaN without errors.
  double coverage{std::nan("")};
  double sharpness{std::nan("")};
  double median_position_error_m{std::nan("")};
};

// `surface_points`: samples of the true surface (world frame). `position_errors_m`: empty, or
// per point its distance to the predicted surface (NaN: none measured; such points are left out
// of coverage and sharpness).
CalibrationResult surfaceCalibration(const SurfaceModel& model, const std::vector<Vector3>& surface_points,
                                     double k_sigma = 2.0, const std::vector<double>& position_errors_m = {});

}  // namespace gpatlas_core
