#pragma once

#include "gpatlas_core/observations/support_plane.h"
#include "gpatlas_core/observations/view_samples.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

struct BelowSupportConfig {
  // A grid of grid_cells x grid_cells cells over the view's footprint on the plane (its
  // bounding rectangle, grown by footprint_margin_fraction of the view's radius), of which the
  // cells within that margin of the projected view are kept, one layer per depth below the
  // plane (fractions of the view's radius).
  int grid_cells{8};
  std::vector<double> depth_fractions{0.1, 0.3};
  double footprint_margin_fraction{0.2};
  // Noise sigma (reference units), as the camera's free space.
  double noise_sigma{0.3162};
};

// Outside points under the support plane where the view is above it (grid cells within the
// footprint margin of a projected view point), labelled with their depth below it (their
// distance to the plane: a lower bound on their distance to an object above it). Fails when
// the view's median point is not above the plane (a flipped normal).
ViewSamples sampleBelowSupport(const std::vector<Vector3>& surface_points, const SupportPlane& plane,
                                 const BelowSupportConfig& config = BelowSupportConfig());

}  // namespace gpatlas_core
