#pragma once

#include "gpatlas_core/common/types.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// Training points sampled from a camera view (free space, guessed interior, the support's
// surroundings): what a sampler returns.
struct ViewSamples {
  bool ok{false};
  std::string message;
  // Label kOutside, source kVision (they belong to the view: a new view replaces them),
  // surface_distance_m set.
  std::vector<TrainingPoint> points;
};

namespace detail {

// The finite points of a view, their centroid, radius (largest distance from the centroid)
// and bounding box.
struct View {
  std::vector<Vector3> points;
  Vector3 centroid{Vector3::Zero()};
  double radius{0.0};
  Vector3 lo{Vector3::Zero()}, hi{Vector3::Zero()};  // bounding box
};

// Empty message: ok; otherwise why the view cannot be used.
std::string finiteView(const std::vector<Vector3>& surface_points, std::size_t min_points, View* view);

}  // namespace detail

}  // namespace gpatlas_core
