#pragma once

#include "gpatlas_core/common/types.h"
#include "gpatlas_core/observations/support_plane.h"
#include "gpatlas_core/observations/view_free_space.h"
#include "gpatlas_core/observations/near_surface_free_space.h"
#include "gpatlas_core/observations/occluded_interior.h"
#include "gpatlas_core/observations/below_support.h"
#include "gpatlas_core/observations/support_free_space.h"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// How a camera view becomes the GPIS's initial training data. The GP model nodelet and
// gpatlas_bench both call buildViewTraining with this Config, so a view gives the same data in
// both.
struct ViewTrainingConfig {
  // At most this many of the object's points (a random subset): the multi-scale model takes every
  // one; the global GPIS's fit is O(n^3) in them (config/paper.yaml: 600).
  int max_surface_points{50000};
  // Their noise sigma, in the model's reference units (GpisModelConfig).
  double vision_noise_sigma{0.1};
  // The camera's free space in front of the object (outside points); max_rays 0 disables it.
  ViewFreeSpaceConfig free_space;
  // Free space a few millimetres in front of the view's points (thin parts); max_points 0 disables it.
  NearSurfaceFreeSpaceConfig near_surface_free_space;
  // Inside points behind the view, within its hull; max_points 0 disables them.
  OccludedInteriorConfig occluded_interior;
  // The table under the object, when segmentation found one: outside points below it, and no
  // guessed inside points closer than support_clearance_m to it.
  BelowSupportConfig below_support;
  // Free space on the table beside the object where the camera saw the table; needs the
  // sensor's origin; max_points 0 disables it.
  SupportFreeSpaceConfig support_free_space;
  double support_clearance_m{0.005};
};

// Empty when the config is usable; otherwise what is wrong with it.
std::string validate(const ViewTrainingConfig& config);

struct ViewTraining {
  bool ok{false};
  std::string message;
  std::vector<TrainingPoint> points;  // surface subset, then free space, near-surface free space, interior, below support, beside the support
  std::size_t surface{0};
  std::size_t free_space{0};
  std::size_t near_surface_free_space{0};
  std::size_t occluded_interior{0};
  std::size_t below_support{0};
  std::size_t support_free_space{0};
  std::vector<std::string> warnings;  // parts that could not be built (the rest is still used)
};

// `view_points`: the object's points (world frame, after segmentation), every one of them (the
// labels of the free space and interior use the nearest); `sensor_origin`: the camera's optical
// centre (none: no free space or interior); `support`: the table, if found. Every random choice
// derives from `seed`. Fails only when the view has fewer than 4 finite points.
ViewTraining buildViewTraining(const std::vector<Vector3>& view_points, const std::optional<Vector3>& sensor_origin,
                               const std::optional<SupportPlane>& support, const ViewTrainingConfig& config,
                               std::uint64_t seed);

}  // namespace gpatlas_core
