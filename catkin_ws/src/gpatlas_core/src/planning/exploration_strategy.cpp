#include "gpatlas_core/planning/exploration_strategy.h"


#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace gpatlas_core {

std::string vMaxNoiseNote(const SurfaceModel& model, double v_max) {
  double smallest = std::numeric_limits<double>::infinity();
  for (const TrainingPoint& point : model.observations())
    if (isSurfaceValue(point) && point.noise_sigma > 0.0 && std::isfinite(point.noise_sigma))
      smallest = std::min(smallest, point.noise_sigma * point.noise_sigma);
  if (!std::isfinite(smallest) || !(v_max < 0.1 * smallest)) return "";
  std::ostringstream note;
  note << "V_max " << v_max << " is below a tenth of the smallest observation noise variance (" << smallest
       << "): a point must be observed more than ten times to get there, so the exploration may not converge";
  return note.str();
}

std::optional<PlanResult> checkPlanInput(const SurfaceModel& model, const PlanRequest& request) {
  PlanResult error;
  error.status = PlanStatus::kError;
  if (!model.isFitted()) {
    error.message = "no model: the GP is not fitted";
    return error;
  }
  if (std::string problem = validate(request.stopRule()); !problem.empty()) {
    error.message = problem;
    return error;
  }
  if (std::string problem = validate(request.evidence_state); !problem.empty()) {
    error.message = problem;
    return error;
  }
  if (!(request.footprint_radius_m >= 0.0) || !std::isfinite(request.footprint_radius_m)) {
    std::ostringstream message;
    message << "footprint_radius_m " << request.footprint_radius_m
            << " is not a radius: the probe's footprint radius must be finite and >= 0 (0: a point probe)";
    error.message = message.str();
    return error;
  }
  if (request.start && !request.start->allFinite()) {
    error.message = "start point is not finite";
    return error;
  }
  return std::nullopt;
}

}  // namespace gpatlas_core
