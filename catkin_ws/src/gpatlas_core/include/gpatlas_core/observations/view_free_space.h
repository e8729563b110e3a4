#pragma once

#include "gpatlas_core/observations/view_samples.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// Free space seen by a depth sensor: every pixel's ray crossed empty space between the sensor
// and the surface it hit. Samples along those rays are outside points for the GPIS, labelled
// with their distance to the nearest observed surface point (an upper bound on the true
// distance, see GpisModel::nearestSurfaceDistance).
//
// Why: surface points alone leave the sign of f undetermined wherever the data have a gap. A
// smooth GP then closes the opening of a cup, a bowl or a funnel with a lid, because the
// centroid's inside point (or the general "inside is the bulk" bias) makes the cavity's air
// inside. The camera looked through that opening; its rays say the cavity is empty.
struct ViewFreeSpaceConfig {
  // Rays used (a random subset of the view's points when it has more).
  int max_rays{300};
  int samples_per_ray{2};
  // Sample depths before the hit, as fractions of the view's radius (the largest distance of
  // a view point from their centroid): close enough to shape the surface, far enough to clear
  // the sensor noise and to reach into a cavity.
  double min_offset_fraction{0.05};
  double max_offset_fraction{1.0};
  // Noise sigma of the samples, in the model's reference units (as the touch free space).
  double noise_sigma{0.3162};
};

// `surface_points` are the view's points (world frame, every one of them: the labels use the
// nearest); `sensor_origin` is the optical centre in the same frame; `seed` the run's stream for
// the rays' subset and depths (viewTrainingPoints derives it from the run's seed).
ViewSamples sampleViewFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                std::uint64_t seed, const ViewFreeSpaceConfig& config = ViewFreeSpaceConfig());

}  // namespace gpatlas_core
