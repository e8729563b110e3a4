#include "gpatlas_core/observations/view_samples.h"

#include <algorithm>

namespace gpatlas_core {
namespace detail {

// Empty message: ok; otherwise why the view cannot be used.
std::string finiteView(const std::vector<Vector3>& surface_points, std::size_t min_points, View* view) {
  view->points.clear();
  view->points.reserve(surface_points.size());
  for (const auto& p : surface_points)
    if (p.allFinite()) view->points.push_back(p);
  if (view->points.size() < min_points)
    return "the view has fewer than " + std::to_string(min_points) + " finite points";
  view->centroid.setZero();
  for (const auto& p : view->points) view->centroid += p;
  view->centroid /= static_cast<double>(view->points.size());
  view->radius = 0.0;
  view->lo = view->hi = view->points.front();
  for (const auto& p : view->points) {
    view->radius = std::max(view->radius, (p - view->centroid).norm());
    view->lo = view->lo.cwiseMin(p);
    view->hi = view->hi.cwiseMax(p);
  }
  if (!(view->radius > 0.0)) return "the view's points all coincide";
  return "";
}

}  // namespace detail
}  // namespace gpatlas_core
