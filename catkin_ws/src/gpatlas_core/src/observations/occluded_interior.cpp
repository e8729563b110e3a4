#include "gpatlas_core/observations/occluded_interior.h"

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

// A coarse range image in the sensor's frame: per pixel, the range of the farthest hit. The
// farthest, not the nearest: a pixel on a depth edge (a rim in front of a cavity's far wall)
// would otherwise call the air just past the rim occluded, though the camera saw through it.
// Every view point must lie in front of the sensor.
class FarthestRangeImage {
 public:
  FarthestRangeImage(const std::vector<Vector3>& points, const Vector3& sensor_origin, const Vector3& forward_raw)
      : sensor_origin_(sensor_origin), forward_(forward_raw.normalized()), right_(forward_.unitOrthogonal()),
        up_(forward_.cross(right_)) {
    for (const auto& p : points) {
      double a = 0.0, b = 0.0;
      imageOf(p, &a, &b);
      a_min_ = std::min(a_min_, a);
      a_max_ = std::max(a_max_, a);
      b_min_ = std::min(b_min_, b);
      b_max_ = std::max(b_max_, b);
    }
    // About 4 points per pixel on average, so that a pixel inside the silhouette is rarely empty
    // (an empty pixel is unknown, never occluded: the background seen through a handle).
    pixels_ = std::clamp(static_cast<int>(std::sqrt(static_cast<double>(points.size()) / 4.0)), 4, 128);
    a_step_ = std::max(a_max_ - a_min_, 1e-12) / pixels_;
    b_step_ = std::max(b_max_ - b_min_, 1e-12) / pixels_;
    farthest_range_.assign(static_cast<std::size_t>(pixels_ * pixels_), -1.0);
    for (const auto& p : points) {
      double a = 0.0, b = 0.0;
      imageOf(p, &a, &b);
      const int px = pixelOf(a, b);
      auto& r = farthest_range_[static_cast<std::size_t>(px)];
      r = std::max(r, (p - sensor_origin_).norm());
    }
  }

  // Whether x lies at least `margin` behind the farthest hit in its pixel (false in an empty
  // pixel, outside the image or behind the sensor).
  bool occludes(const Vector3& x, double margin) const {
    double a = 0.0, b = 0.0;
    if (!imageOf(x, &a, &b)) return false;
    const int px = pixelOf(a, b);
    if (px < 0) return false;
    const double hit = farthest_range_[static_cast<std::size_t>(px)];
    return !(hit < 0.0 || (x - sensor_origin_).norm() < hit + margin);
  }

 private:
  bool imageOf(const Vector3& p, double* a, double* b) const {
    const Vector3 v = p - sensor_origin_;
    const double depth = v.dot(forward_);
    if (!(depth > 0.0)) return false;
    *a = v.dot(right_) / depth;
    *b = v.dot(up_) / depth;
    return true;
  }
  // Outside the image: -1. The image's far edges (a == a_max) belong to its last pixels.
  int pixelOf(double a, double b) const {
    if (a < a_min_ || a > a_max_ || b < b_min_ || b > b_max_) return -1;
    const int i = std::min(static_cast<int>(std::floor((a - a_min_) / a_step_)), pixels_ - 1);
    const int j = std::min(static_cast<int>(std::floor((b - b_min_) / b_step_)), pixels_ - 1);
    return i * pixels_ + j;
  }

  const Vector3 sensor_origin_, forward_, right_, up_;
  double a_min_{std::numeric_limits<double>::infinity()}, a_max_{-std::numeric_limits<double>::infinity()};
  double b_min_{std::numeric_limits<double>::infinity()}, b_max_{-std::numeric_limits<double>::infinity()};
  int pixels_{0};
  double a_step_{0.0}, b_step_{0.0};
  std::vector<double> farthest_range_;
};

// The convex hull, approximated from outside by its support planes in evenly spread directions
// (Fibonacci lattice), shrunk by the margin.
class ShrunkHull {
 public:
  ShrunkHull(const std::vector<Vector3>& points, int num_directions, double margin)
      : directions_(fibonacciSphere(num_directions)) {
    for (const Vector3& u : directions_) {
      double h = -std::numeric_limits<double>::infinity();
      for (const auto& p : points) h = std::max(h, u.dot(p));
      support_.push_back(h - margin);
    }
  }
  bool contains(const Vector3& x) const {
    bool in_hull = true;
    for (std::size_t k = 0; k < directions_.size() && in_hull; ++k) in_hull = directions_[k].dot(x) <= support_[k];
    return in_hull;
  }

 private:
  const std::vector<Vector3> directions_;
  std::vector<double> support_;
};

bool validConfig(const OccludedInteriorConfig& config) {
  return !(config.grid_cells < 2 || config.grid_cells > 100 || config.max_points < 0 || config.hull_directions < 4 ||
           !(config.margin_fraction >= 0.0) || !std::isfinite(config.margin_fraction) || !(config.noise_sigma > 0.0) ||
           !std::isfinite(config.noise_sigma));
}

}  // namespace

ViewSamples sampleOccludedInterior(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                   std::uint64_t seed, const OccludedInteriorConfig& config) {
  ViewSamples out;
  if (!sensor_origin.allFinite()) {
    out.message = "the sensor origin is not finite";
    return out;
  }
  if (!validConfig(config)) {
    out.message =
        "invalid occluded-interior settings (2 <= grid_cells <= 100, max_points >= 0, hull_directions >= 4, "
        "margin_fraction >= 0, noise_sigma > 0)";
    return out;
  }
  View view;
  out.message = finiteView(surface_points, 4, &view);
  if (!out.message.empty()) return out;
  const std::vector<Vector3>& points = view.points;
  const double radius = view.radius;
  const Vector3 forward_raw = view.centroid - sensor_origin;
  if (!(forward_raw.norm() > radius)) {
    out.message = "the view's points surround the sensor";
    return out;
  }
  const double margin = config.margin_fraction * radius;
  const FarthestRangeImage range_image(points, sensor_origin, forward_raw);
  const ShrunkHull hull(points, config.hull_directions, margin);
  const Vector3& lo = view.lo;
  const Vector3& hi = view.hi;

  // Cheap tests first (hull, range image) on the whole grid, then the O(view) distance test on
  // a random order of the survivors until max_points are accepted.
  std::vector<Vector3> candidates;
  const int n = config.grid_cells;
  for (int ix = 0; ix < n; ++ix)
    for (int iy = 0; iy < n; ++iy)
      for (int iz = 0; iz < n; ++iz) {
        const Vector3 t((ix + 0.5) / n, (iy + 0.5) / n, (iz + 0.5) / n);
        const Vector3 x = lo + (hi - lo).cwiseProduct(t);
        if (hull.contains(x) && range_image.occludes(x, margin)) candidates.push_back(x);
      }
  std::mt19937_64 rng(seed);
  std::shuffle(candidates.begin(), candidates.end(), rng);
  for (const Vector3& x : candidates) {
    if (out.points.size() >= static_cast<std::size_t>(config.max_points)) break;
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& p : points) nearest = std::min(nearest, (p - x).squaredNorm());
    nearest = std::sqrt(nearest);
    if (nearest < margin) continue;
    TrainingPoint s;
    s.position = x;
    s.label = PointLabel::kInside;
    s.source = PointSource::kVision;
    s.noise_sigma = config.noise_sigma;
    s.surface_distance_m = nearest;
    out.points.push_back(s);
  }
  out.ok = true;
  return out;
}

bool isOccludedInteriorGuess(const TrainingPoint& point) {
  return point.label == PointLabel::kInside && point.source == PointSource::kVision;
}

InteriorRetraction retractContradictedInterior(std::vector<TrainingPoint>* observations,
                                               const std::vector<Vector3>& evidence, double min_depth_m) {
  InteriorRetraction result;
  if (!observations || evidence.empty()) return result;
  std::vector<TrainingPoint> kept;
  kept.reserve(observations->size());
  for (TrainingPoint& point : *observations) {
    if (isOccludedInteriorGuess(point) && std::isfinite(point.surface_distance_m)) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const Vector3& e : evidence)
        if (e.allFinite()) nearest = std::min(nearest, (e - point.position).norm());
      if (nearest < point.surface_distance_m) {
        if (!(nearest >= min_depth_m)) {
          ++result.dropped;
          continue;
        }
        point.surface_distance_m = nearest;
        ++result.shrunk;
      }
    }
    kept.push_back(point);
  }
  if (result.any()) *observations = std::move(kept);
  return result;
}

}  // namespace gpatlas_core
