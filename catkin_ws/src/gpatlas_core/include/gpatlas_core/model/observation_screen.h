#pragma once

#include "gpatlas_core/common/types.h"
#include "gpatlas_core/model/surface_model.h"

#include <vector>

namespace gpatlas_core {

struct ObservationScreenOptions {
  // Make each slope direction unit length. One already within 1e-12 of unit length is kept as
  // given, bit for bit, so that callers can find their points among the model's observations.
  bool normalise_slope_directions{true};
};

// The points a GP model can take, in their order: a finite position and slope direction, a
// finite noise sigma >= 0, and a slope direction that is not near zero (norm > 1e-9) for a point
// that observes a slope. A point that fails is dropped and counted under the first test it fails
// in that order; `report` gets the total added to num_rejected and one warning per cause.
// Labels, targets, duplicates and the domain are the model's own business: they depend on its
// frame and on the points it already holds.
std::vector<TrainingPoint> screenObservations(const std::vector<TrainingPoint>& points,
                                              const ObservationScreenOptions& options, FitReport* report);

}  // namespace gpatlas_core
