#include "gpatlas_core/observations/below_support.h"

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

using detail::finiteView;
using detail::View;

ViewSamples sampleBelowSupport(const std::vector<Vector3>& surface_points, const SupportPlane& plane,
                                 const BelowSupportConfig& config) {
  ViewSamples out;
  if (!plane.normal.allFinite() || std::abs(plane.normal.norm() - 1.0) > 1e-6 || !std::isfinite(plane.offset)) {
    out.message = "the support plane needs a finite unit normal and a finite offset";
    return out;
  }
  bool depths_ok = !config.depth_fractions.empty();
  for (double f : config.depth_fractions) depths_ok = depths_ok && f > 0.0 && std::isfinite(f);
  if (config.grid_cells < 1 || config.grid_cells > 100 || !depths_ok || !(config.footprint_margin_fraction >= 0.0) ||
      !std::isfinite(config.footprint_margin_fraction) || !(config.noise_sigma > 0.0) || !std::isfinite(config.noise_sigma)) {
    out.message =
        "invalid below-support settings (1 <= grid_cells <= 100, depth fractions > 0, footprint margin >= 0, "
        "noise_sigma > 0)";
    return out;
  }
  View view;
  out.message = finiteView(surface_points, 2, &view);
  if (!out.message.empty()) return out;
  std::vector<double> heights;
  for (const auto& p : view.points) heights.push_back(plane.height(p));
  std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
  if (!(heights[heights.size() / 2] > 0.0)) {
    out.message = "the view is not above the support plane (is its normal flipped?)";
    return out;
  }

  // The footprint: the view projected on the plane, in an orthonormal frame (u, v) of it.
  const Vector3 u = plane.normal.unitOrthogonal();
  const Vector3 v = plane.normal.cross(u);
  double u_min = std::numeric_limits<double>::infinity(), u_max = -u_min, v_min = u_min, v_max = -u_min;
  for (const auto& p : view.points) {
    u_min = std::min(u_min, u.dot(p));
    u_max = std::max(u_max, u.dot(p));
    v_min = std::min(v_min, v.dot(p));
    v_max = std::max(v_max, v.dot(p));
  }
  const double grow = config.footprint_margin_fraction * view.radius;
  u_min -= grow;
  u_max += grow;
  v_min -= grow;
  v_max += grow;
  const Vector3 on_plane = -plane.offset * plane.normal;  // the plane's point nearest the origin
  // Only under the view: within `grow` of a projected view point. The label (the depth) is
  // close to the true distance only there; under a corner of the rectangle, far from the
  // object, it would understate the distance and pull the predicted surface out along the table.
  std::vector<Eigen::Vector2d> footprint;
  for (const auto& p : view.points) footprint.emplace_back(u.dot(p), v.dot(p));
  const int n = config.grid_cells;
  std::vector<Eigen::Vector2d> cells;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector2d c(u_min + (u_max - u_min) * (i + 0.5) / n, v_min + (v_max - v_min) * (j + 0.5) / n);
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& f : footprint) nearest = std::min(nearest, (f - c).squaredNorm());
      if (nearest <= grow * grow) cells.push_back(c);
    }
  for (double fraction : config.depth_fractions) {
    const double depth = fraction * view.radius;
    for (const auto& c : cells) {
      TrainingPoint t;
      t.position = on_plane + c.x() * u + c.y() * v - depth * plane.normal;
      t.label = PointLabel::kOutside;
      t.source = PointSource::kVision;
      t.noise_sigma = config.noise_sigma;
      t.surface_distance_m = depth;
      out.points.push_back(t);
    }
  }
  out.ok = true;
  return out;
}

}  // namespace gpatlas_core
