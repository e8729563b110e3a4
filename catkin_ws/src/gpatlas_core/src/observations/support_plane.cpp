#include "gpatlas_core/observations/support_plane.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <unordered_map>

namespace gpatlas_core {

std::size_t dropNearOrBelowPlane(std::vector<TrainingPoint>* points, const SupportPlane& plane, double clearance_m) {
  if (!points) return 0;
  const std::size_t before = points->size();
  points->erase(std::remove_if(points->begin(), points->end(),
                               [&](const TrainingPoint& p) { return !(plane.height(p.position) >= clearance_m); }),
                points->end());
  return before - points->size();
}

}  // namespace gpatlas_core
