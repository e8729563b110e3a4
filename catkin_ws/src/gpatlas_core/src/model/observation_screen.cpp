#include "gpatlas_core/model/observation_screen.h"

#include <cmath>
#include <string>

namespace gpatlas_core {

std::vector<TrainingPoint> screenObservations(const std::vector<TrainingPoint>& points,
                                              const ObservationScreenOptions& options, FitReport* report) {
  std::vector<TrainingPoint> accepted;
  accepted.reserve(points.size());
  std::size_t non_finite = 0, bad_noise = 0, bad_direction = 0;
  for (const TrainingPoint& p : points) {
    if (!p.position.allFinite() || !p.slope_direction.allFinite()) {
      ++non_finite;
      continue;
    }
    if (observesSlope(p) && !(p.slope_direction.norm() > 1e-9)) {
      ++bad_direction;
      continue;
    }
    if (!std::isfinite(p.noise_sigma) || p.noise_sigma < 0.0) {
      ++bad_noise;
      continue;
    }
    accepted.push_back(p);
    if (options.normalise_slope_directions && observesSlope(p) && std::abs(p.slope_direction.norm() - 1.0) > 1e-12)
      accepted.back().slope_direction.normalize();
  }
  if (non_finite > 0)
    report->warnings.push_back(std::to_string(non_finite) + " point(s) with NaN/Inf coordinates dropped");
  if (bad_noise > 0)
    report->warnings.push_back(std::to_string(bad_noise) + " point(s) with a negative or NaN noise sigma dropped");
  if (bad_direction > 0)
    report->warnings.push_back(std::to_string(bad_direction) + " slope observation(s) with a near-zero direction dropped");
  report->num_rejected += non_finite + bad_noise + bad_direction;
  return accepted;
}

}  // namespace gpatlas_core
