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

namespace {

bool validConfig(const SupportFreeSpaceConfig& config) {
  const auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
  return positive(config.spacing_m) && config.height_m >= 0.0 && std::isfinite(config.height_m) &&
         config.min_distance_m >= 0.0 && config.max_distance_m > config.min_distance_m &&
         config.max_bound_gap_m >= 0.0 && std::isfinite(config.max_bound_gap_m) &&
         std::isfinite(config.max_distance_m) && positive(config.pixel_m) && config.max_points >= 0 &&
         positive(config.noise_sigma);
}

// The view as a range image: per pixel the nearest hit. Pixels are squares in the image plane at
// unit depth, pixel_m wide at the centroid's depth.
class RangeImage {
 public:
  RangeImage(const View& view, const Vector3& sensor_origin, double pixel_m)
      : sensor_origin_(sensor_origin), forward_((view.centroid - sensor_origin).normalized()),
        right_(forward_.unitOrthogonal()), up_(forward_.cross(right_)),
        pixel_(pixel_m / (view.centroid - sensor_origin).norm()) {
    nearest_range_.reserve(view.points.size());
    for (const auto& p : view.points) {
      std::uint64_t key = 0;
      if (!pixelKey(p, 0, 0, &key)) continue;
      const double range = (p - sensor_origin_).norm();
      auto found = nearest_range_.emplace(key, range);
      if (!found.second) found.first->second = std::min(found.first->second, range);
    }
  }

  // Whether no view point in x's pixel or the 8 around it is nearer to the sensor than x: the
  // camera saw past the object there.
  bool seesPast(const Vector3& x) const {
    const double range = (x - sensor_origin_).norm();
    bool seen = true;
    for (int di = -1; di <= 1 && seen; ++di)
      for (int dj = -1; dj <= 1 && seen; ++dj) {
        std::uint64_t key = 0;
        if (!pixelKey(x, di, dj, &key)) {
          seen = false;
          break;
        }
        const auto hit = nearest_range_.find(key);
        if (hit != nearest_range_.end() && hit->second < range) seen = false;
      }
    return seen;
  }

 private:
  // The pixel (di, dj) away from p's; false when p is not in front of the sensor.
  bool pixelKey(const Vector3& p, int di, int dj, std::uint64_t* key) const {
    const Vector3 ray = p - sensor_origin_;
    const double depth = ray.dot(forward_);
    if (!(depth > 0.0)) return false;
    const auto i = static_cast<std::int64_t>(std::floor(ray.dot(right_) / depth / pixel_)) + di;
    const auto j = static_cast<std::int64_t>(std::floor(ray.dot(up_) / depth / pixel_)) + dj;
    *key = (static_cast<std::uint64_t>(i + (1 << 30)) << 32) | static_cast<std::uint64_t>(j + (1 << 30));
    return true;
  }

  const Vector3 sensor_origin_, forward_, right_, up_;
  const double pixel_;
  std::unordered_map<std::uint64_t, double> nearest_range_;
};

double turn(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

// The points' convex hull, counter-clockwise (Andrew's monotone chain).
std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> sorted) {
  std::sort(sorted.begin(), sorted.end(),
            [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
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
  return hull;
}

// The view projected on the plane (coordinates (u, v) in it), hashed on a grid of cell_m: a
// point's view points within that distance (in the plane, so also in 3-D) lie in its 9
// neighbouring cells.
class ProjectedView {
 public:
  ProjectedView(const std::vector<Vector3>& points, const SupportPlane& plane, double cell_m)
      : points_(points), u_(plane.normal.unitOrthogonal()), v_(plane.normal.cross(u_)), cell_(cell_m) {
    projected_.reserve(points.size());
    for (const auto& p : points) projected_.emplace_back(u_.dot(p), v_.dot(p));
    lo_ = projected_.front();
    hi_ = lo_;
    for (std::size_t i = 0; i < projected_.size(); ++i) {
      grid_[cellKey(cellOf(projected_[i].x(), projected_[i].y()))].push_back(static_cast<std::uint32_t>(i));
      lo_ = lo_.cwiseMin(projected_[i]);
      hi_ = hi_.cwiseMax(projected_[i]);
    }
    hull_ = convexHull(projected_);
  }

  const Vector3& u() const { return u_; }
  const Vector3& v() const { return v_; }
  const Eigen::Vector2d& lowerCorner() const { return lo_; }  // of the projection's box
  const Eigen::Vector2d& upperCorner() const { return hi_; }

  // The squared planar distance from (cu, cv) and the squared distance from x, its point in 3-D,
  // to the nearest view point within a cell (infinity for none).
  void squaredDistances(double cu, double cv, const Vector3& x, double* planar2, double* nearest2) const {
    *planar2 = std::numeric_limits<double>::infinity();
    *nearest2 = *planar2;
    const Eigen::Vector2i c = cellOf(cu, cv);
    for (int du = -1; du <= 1; ++du)
      for (int dv = -1; dv <= 1; ++dv) {
        const auto found = grid_.find(cellKey(c + Eigen::Vector2i(du, dv)));
        if (found == grid_.end()) continue;
        for (std::uint32_t i : found->second) {
          *planar2 = std::min(*planar2, (projected_[i] - Eigen::Vector2d(cu, cv)).squaredNorm());
          *nearest2 = std::min(*nearest2, (points_[i] - x).squaredNorm());
        }
      }
  }

  bool insideHull(const Eigen::Vector2d& q) const {
    if (hull_.size() < 3) return false;
    for (std::size_t i = 0; i < hull_.size(); ++i)
      if (turn(hull_[i], hull_[(i + 1) % hull_.size()], q) < 0.0) return false;
    return true;
  }

 private:
  Eigen::Vector2i cellOf(double pu, double pv) const {
    return Eigen::Vector2i(static_cast<int>(std::floor(pu / cell_)), static_cast<int>(std::floor(pv / cell_)));
  }
  static std::uint64_t cellKey(const Eigen::Vector2i& c) {
    return (static_cast<std::uint64_t>(c.x() + (1 << 30)) << 32) | static_cast<std::uint64_t>(c.y() + (1 << 30));
  }

  const std::vector<Vector3>& points_;
  const Vector3 u_, v_;
  const double cell_;
  std::vector<Eigen::Vector2d> projected_;  // (u, v) of points_[i]
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid_;
  Eigen::Vector2d lo_, hi_;
  std::vector<Eigen::Vector2d> hull_;
};

// At most max_points of the points, evenly spread over their order.
void keepEvenSubset(std::vector<TrainingPoint>& points, int max_points) {
  if (points.size() <= static_cast<std::size_t>(max_points)) return;
  std::vector<TrainingPoint> even;
  const double step = static_cast<double>(points.size()) / static_cast<double>(std::max(max_points, 1));
  for (int j = 0; j < max_points; ++j) even.push_back(points[static_cast<std::size_t>(j * step)]);
  points.swap(even);
}

}  // namespace

ViewSamples sampleSupportFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                     const SupportPlane& plane, const SupportFreeSpaceConfig& config) {
  ViewSamples out;
  if (!validConfig(config)) {
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
  if (!((view.centroid - sensor_origin).norm() > view.radius)) {
    out.message = "the view's points surround the sensor";
    return out;
  }
  const RangeImage range_image(view, sensor_origin, config.pixel_m);
  const double grow = config.max_distance_m;
  const ProjectedView projection(view.points, plane, config.max_distance_m + config.max_bound_gap_m);
  const Vector3 &u = projection.u(), &v = projection.v();
  const double u_min = projection.lowerCorner().x(), u_max = projection.upperCorner().x();
  const double v_min = projection.lowerCorner().y(), v_max = projection.upperCorner().y();
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
      double planar2 = 0.0, nearest2 = 0.0;
      projection.squaredDistances(cu, cv, x, &planar2, &nearest2);
      const double planar = std::sqrt(planar2);
      const double nearest = std::sqrt(nearest2);
      if (planar < config.min_distance_m || planar >= grow || nearest > planar + config.max_bound_gap_m ||
          projection.insideHull(Eigen::Vector2d(cu, cv)))
        continue;
      if (!range_image.seesPast(x)) continue;
      TrainingPoint t;
      t.position = x;
      t.label = PointLabel::kOutside;
      t.source = PointSource::kViewSupport;
      t.noise_sigma = config.noise_sigma;
      t.surface_distance_m = 0.5 * (planar + nearest);
      out.points.push_back(t);
    }
  keepEvenSubset(out.points, config.max_points);
  out.ok = true;
  return out;
}

}  // namespace gpatlas_core
