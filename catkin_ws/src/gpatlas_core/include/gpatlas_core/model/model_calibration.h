#pragma once

#include "gpatlas_core/model/surface_model.h"

#include <cstddef>
#include <string>
#include <vector>

namespace gpatlas_core {

// Does the variance tell the truth? On points of the true surface f is 0, so a calibrated model
// predicts a mean within k standard deviations of 0 at about the Gaussian share of them (0.954
// for k = 2). A model that is sure of a wrong surface scores far lower: the planner would never
// go back there.
struct CalibrationResult {
  bool ok{false};
  std::string message;
  std::size_t samples{0};        // finite points given
  std::size_t within{0};         // |mean| <= k * sd
  std::size_t out_of_domain{0};  // counted as not within: the model makes no claim there
  double fraction{0.0};          // within / samples
  // Sharpness, the other half of the story: a model can be calibrated by being vague. The median
  // over the in-domain samples of sd(f) / |grad f|, the standard deviation of the surface's
  // position along its normal (metres).
  double median_position_sd_m{0.0};
};

// `surface_points`: samples of the true surface (world frame). The standard deviation is that
// of f (the reported variance divided by the model's varianceUnitFactor()).
CalibrationResult surfaceCalibration(const SurfaceModel& model, const std::vector<Vector3>& surface_points,
                                     double k_sigma = 2.0);

}  // namespace gpatlas_core
