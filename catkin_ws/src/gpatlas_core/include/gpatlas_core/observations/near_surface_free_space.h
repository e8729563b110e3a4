#pragma once

#include "gpatlas_core/observations/view_samples.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// Free space just in front of every view point, along its camera ray: a thin part (a handle, a
// mug's wall) is a few millimetres of material between two such layers, and a model that can
// resolve it needs them to tell its two faces from a blob. The sparse ray samples above are
// too few and too far out for that. Labels: the distance to the nearest view point (at most
// offset_m).
struct NearSurfaceFreeSpaceConfig {
  // Distance in front of each view point, along the ray to the sensor.
  double offset_m{0.003};
  // At most this many (an even subset of the view's points); 0 disables them.
  int max_points{50000};
  // Noise sigma of the samples, in the model's reference units.
  double noise_sigma{0.1};
};

ViewSamples sampleNearSurfaceFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                         const NearSurfaceFreeSpaceConfig& config);

}  // namespace gpatlas_core
