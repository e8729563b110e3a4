#include "gpatlas_core/observations/support_free_space.h"

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

ViewSamples sampleSupportFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                     const SupportPlane& plane, const SupportFreeSpaceConfig& config) {
  ViewSamples out;
  const auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
  if (!positive(config.spacing_m) || !(config.height_m >= 0.0) || !std::isfinite(config.height_m) ||
      !(config.min_distance_m >= 0.0) || !(config.max_distance_m > config.min_distance_m) ||
      !(config.max_bound_gap_m >= 0.0) || !std::isfinite(config.max_bound_gap_m) ||
      !std::isfinite(config.max_distance_m) || !positive(config.pixel_m) || config.max_points < 0 ||
      !positive(config.noise_sigma)) {
    out.message =
        "invalid support free-space settings (spacing_m, pixel_m, noise_sigma > 0; height_m >= 0; "
        "0 <= min_distance_m < max_distance_m; max_bound_gap_m >= 0; max_points >= 0)";
    return out;
  }
  if (!sensor_origin.allFinite() || !(plane.height(sensor_origin) > 0.0)) {
    out.message = "the sensor is not above the support plane";
    return out;
  }
  View view;
  out.message = finiteView(surface_points, 4, &view);
  if (!out.message.empty()) return out;
  const std::vector<Vector3>& points = view.points;
  const Vector3 forward_raw = view.centroid - sensor_origin;
  if (!(forward_raw.norm() > view.radius)) {
    out.message = "the view's points surround the sensor";
    return out;
  }

  // Range image: per pixel the nearest hit. Pixels are squares in the image plane at unit depth,
  // pixel_m wide at the centroid's depth.
  const Vector3 forward = forward_raw.normalized();
  const Vector3 right = forward.unitOrthogonal();
  const Vector3 up = forward.cross(right);
  const double pixel = config.pixel_m / forward_raw.norm();
  const auto pixelKey = [&](const Vector3& p, int di, int dj, std::uint64_t* key) {
    const Vector3 ray = p - sensor_origin;
    const double depth = ray.dot(forward);
    if (!(depth > 0.0)) return false;
    const auto i = static_cast<std::int64_t>(std::floor(ray.dot(right) / depth / pixel)) + di;
    const auto j = static_cast<std::int64_t>(std::floor(ray.dot(up) / depth / pixel)) + dj;
    *key = (static_cast<std::uint64_t>(i + (1 << 30)) << 32) | static_cast<std::uint64_t>(j + (1 << 30));
    return true;
  };
  std::unordered_map<std::uint64_t, double> nearest_range;
  nearest_range.reserve(points.size());
  for (const auto& p : points) {
    std::uint64_t key = 0;
    if (!pixelKey(p, 0, 0, &key)) continue;
    const double range = (p - sensor_origin).norm();
    auto found = nearest_range.emplace(key, range);
    if (!found.second) found.first->second = std::min(found.first->second, range);
  }

  // The view projected on the plane, hashed on a grid of max_distance_m + max_bound_gap_m: a
  // candidate's view points within that distance (in the plane, so also in 3-D) lie in its 9
  // neighbouring cells.
  const Vector3 u = plane.normal.unitOrthogonal();
  const Vector3 v = plane.normal.cross(u);
  const double grow = config.max_distance_m;
  const double cell = config.max_distance_m + config.max_bound_gap_m;
  const auto cellOf = [&](double pu, double pv) -> Eigen::Vector2i {
    return Eigen::Vector2i(static_cast<int>(std::floor(pu / cell)), static_cast<int>(std::floor(pv / cell)));
  };
  const auto cellKey = [](const Eigen::Vector2i& c) {
    return (static_cast<std::uint64_t>(c.x() + (1 << 30)) << 32) | static_cast<std::uint64_t>(c.y() + (1 << 30));
  };
  std::vector<Eigen::Vector2d> projected;  // (u, v) of points[i]
  projected.reserve(points.size());
  for (const auto& p : points) projected.emplace_back(u.dot(p), v.dot(p));
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  Eigen::Vector2d lo = projected.front(), hi = lo;
  for (std::size_t i = 0; i < projected.size(); ++i) {
    grid[cellKey(cellOf(projected[i].x(), projected[i].y()))].push_back(static_cast<std::uint32_t>(i));
    lo = lo.cwiseMin(projected[i]);
    hi = hi.cwiseMax(projected[i]);
  }
  const double u_min = lo.x(), u_max = hi.x(), v_min = lo.y(), v_max = hi.y();
  // The projected view's convex hull (counter-clockwise, Andrew's monotone chain).
  std::vector<Eigen::Vector2d> sorted = projected;
  std::sort(sorted.begin(), sorted.end(),
            [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  const auto turn = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Eigen::Vector2d> hull(2 * sorted.size());
  std::size_t k = 0;  // the hull's size so far
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    while (k >= 2 && turn(hull[k - 2], hull[k - 1], sorted[i]) <= 0.0) --k;
    hull[k++] = sorted[i];
  }
  for (std::size_t i = sorted.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && turn(hull[k - 2], hull[k - 1], sorted[i]) <= 0.0) --k;
    hull[k++] = sorted[i];
  }
  hull.resize(k > 0 ? k - 1 : 0);
  const auto insideHull = [&](const Eigen::Vector2d& q) {
    if (hull.size() < 3) return false;
    for (std::size_t i = 0; i < hull.size(); ++i)
      if (turn(hull[i], hull[(i + 1) % hull.size()], q) < 0.0) return false;
    return true;
  };

  const Vector3 base = (config.height_m - plane.offset) * plane.normal;  // on the plane, height_m above it
  const int nu = static_cast<int>(std::ceil((u_max - u_min + 2.0 * grow) / config.spacing_m));
  const int nv = static_cast<int>(std::ceil((v_max - v_min + 2.0 * grow) / config.spacing_m));
  if (static_cast<double>(nu) * nv > 1e8) {
    out.message = "the view's footprint is too large for spacing_m";
    return out;
  }
  for (int a = 0; a <= nu; ++a)
    for (int b = 0; b <= nv; ++b) {
      const double cu = u_min - grow + a * config.spacing_m, cv = v_min - grow + b * config.spacing_m;
      const Vector3 x = base + cu * u + cv * v;
      double planar2 = std::numeric_limits<double>::infinity(), nearest2 = planar2;
      const Eigen::Vector2i c = cellOf(cu, cv);
      for (int du = -1; du <= 1; ++du)
        for (int dv = -1; dv <= 1; ++dv) {
          const auto found = grid.find(cellKey(c + Eigen::Vector2i(du, dv)));
          if (found == grid.end()) continue;
          for (std::uint32_t i : found->second) {
            planar2 = std::min(planar2, (projected[i] - Eigen::Vector2d(cu, cv)).squaredNorm());
            nearest2 = std::min(nearest2, (points[i] - x).squaredNorm());
          }
        }
      const double planar = std::sqrt(planar2);
      const double nearest = std::sqrt(nearest2);
      if (planar < config.min_distance_m || planar >= grow || nearest > planar + config.max_bound_gap_m ||
          insideHull(Eigen::Vector2d(cu, cv)))
        continue;
      const double range = (x - sensor_origin).norm();
      bool seen = true;
      for (int di = -1; di <= 1 && seen; ++di)
        for (int dj = -1; dj <= 1 && seen; ++dj) {
          std::uint64_t key = 0;
          if (!pixelKey(x, di, dj, &key)) {
            seen = false;
            break;
          }
          const auto hit = nearest_range.find(key);
          if (hit != nearest_range.end() && hit->second < range) seen = false;
        }
      if (!seen) continue;
      TrainingPoint t;
      t.position = x;
      t.label = PointLabel::kOutside;
      t.source = PointSource::kViewSupport;
      t.noise_sigma = config.noise_sigma;
      t.surface_distance_m = 0.5 * (planar + nearest);
      out.points.push_back(t);
    }
  if (out.points.size() > static_cast<std::size_t>(config.max_points)) {
    std::vector<TrainingPoint> even;
    const double step = static_cast<double>(out.points.size()) / static_cast<double>(std::max(config.max_points, 1));
    for (int j = 0; j < config.max_points; ++j) even.push_back(out.points[static_cast<std::size_t>(j * step)]);
    out.points.swap(even);
  }
  out.ok = true;
  return out;
}

}  // namespace gpatlas_core
