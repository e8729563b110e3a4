#pragma once

#include "gpatlas_core/common/types.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// The support the object rests on (a table, found by segmentation): the plane n . x + d = 0,
// n unit and pointing to the object's side. Everything below it is outside the object.
//
// Why: the occluded interior and the GP's smoothness extend the predicted object below its
// lowest visible points, i.e. into the table. The planner then picks charts under the table,
// every touch there hits the table first, and the exploration ends by failed touches.
struct SupportPlane {
  Vector3 normal{Vector3::UnitZ()};
  double offset{0.0};
  double height(const Vector3& x) const { return normal.dot(x) + offset; }
};

// Removes the points less than `clearance_m` above the plane (inside points guessed into the
// table); returns how many.
std::size_t dropNearOrBelowPlane(std::vector<TrainingPoint>* points, const SupportPlane& plane, double clearance_m);

}  // namespace gpatlas_core
