#include "gpatlas_core/observations/view_shadow.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace gpatlas_core {

namespace {
// Rays more than about 84 degrees off the view's mean direction are left out: no camera sees
// that wide, and the image-plane coordinates of such rays grow without bound.
constexpr double kMinAxisCosine = 0.1;
}  // namespace

std::string validate(const CameraView& view) {
  if (!view.origin.allFinite()) return "a camera view's origin is not finite";
  for (const Vector3& p : view.points)
    if (!p.allFinite()) return "a camera view has a point that is not finite";
  return "";
}

ViewShadow::ViewShadow(const std::vector<CameraView>& views, const Config& config) : config_(config) {
  if (!(config.bin_m > 0.0) || !std::isfinite(config.bin_m) || !(config.depth_margin_m > 0.0) ||
      !std::isfinite(config.depth_margin_m))
    throw std::invalid_argument("view shadow: bin_m and depth_margin_m must be positive and finite");
  for (const CameraView& view : views) {
    if (!view.origin.allFinite()) continue;
    std::vector<Vector3> rays;  // origin to point, the finite ones in front of the origin
    for (const Vector3& p : view.points)
      if (p.allFinite() && (p - view.origin).norm() > 0.0) rays.push_back(p - view.origin);
    if (rays.empty()) continue;
    DepthMap map;
    map.origin = view.origin;
    Vector3 mean = Vector3::Zero();
    std::vector<double> ranges;
    for (const Vector3& r : rays) {
      mean += r.normalized();
      ranges.push_back(r.norm());
    }
    map.axis = mean.normalized();
    map.u = map.axis.unitOrthogonal();
    map.v = map.axis.cross(map.u);
    std::nth_element(ranges.begin(), ranges.begin() + static_cast<std::ptrdiff_t>(ranges.size() / 2), ranges.end());
    map.pitch = config.bin_m / ranges[ranges.size() / 2];
    // Every point lies within 90 degrees of the mean direction only if the view is narrower than
    // a hemisphere, which a camera's is; points behind the image plane are left out.
    std::vector<std::pair<Eigen::Vector2i, float>> binned;
    Eigen::Vector2i lo(std::numeric_limits<int>::max(), std::numeric_limits<int>::max()), hi = -lo;
    for (const Vector3& r : rays) {
      const double z = r.dot(map.axis);
      if (!(z > kMinAxisCosine * r.norm())) continue;
      const Eigen::Vector2i bin(static_cast<int>(std::floor(r.dot(map.u) / z / map.pitch)),
                                static_cast<int>(std::floor(r.dot(map.v) / z / map.pitch)));
      binned.emplace_back(bin, static_cast<float>(r.norm()));
      lo = lo.cwiseMin(bin);
      hi = hi.cwiseMax(bin);
    }
    if (binned.empty()) continue;
    map.i0 = lo.x();
    map.j0 = lo.y();
    map.width = hi.x() - lo.x() + 1;
    map.height = hi.y() - lo.y() + 1;
    map.nearest.assign(static_cast<std::size_t>(map.width) * static_cast<std::size_t>(map.height),
                       std::numeric_limits<float>::infinity());
    for (const auto& [bin, range] : binned) {
      float& cell = map.nearest[static_cast<std::size_t>(bin.y() - map.j0) * static_cast<std::size_t>(map.width) +
                                static_cast<std::size_t>(bin.x() - map.i0)];
      cell = std::min(cell, range);
    }
    maps_.push_back(std::move(map));
  }
}

bool ViewShadow::DepthMap::hides(const Vector3& x, double margin) const {
  const Vector3 r = x - origin;
  const double z = r.dot(axis);
  // Behind the camera, or beside it beyond any view's angle: no surface it saw is in front of x.
  if (!(z > kMinAxisCosine * r.norm())) return false;
  const double bin_i = std::floor(r.dot(u) / z / pitch) - i0, bin_j = std::floor(r.dot(v) / z / pitch) - j0;
  if (!(bin_i >= -1.0 && bin_i <= width && bin_j >= -1.0 && bin_j <= height)) return false;
  const int i = static_cast<int>(bin_i), j = static_cast<int>(bin_j);
  // The nearest seen surface over the bin and its neighbours: a point near the silhouette's edge
  // counts as hidden when any bin next to its own saw surface in front of it.
  float nearest = std::numeric_limits<float>::infinity();
  for (int dj = -1; dj <= 1; ++dj)
    for (int di = -1; di <= 1; ++di) {
      const int a = i + di, b = j + dj;
      if (a < 0 || b < 0 || a >= width || b >= height) continue;
      nearest = std::min(nearest, this->nearest[static_cast<std::size_t>(b) * static_cast<std::size_t>(width) +
                                                static_cast<std::size_t>(a)]);
    }
  return std::isfinite(nearest) && r.norm() > static_cast<double>(nearest) + margin;
}

bool ViewShadow::hidden(const Vector3& x) const {
  if (maps_.empty()) return false;
  for (const DepthMap& map : maps_)
    if (!map.hides(x, config_.depth_margin_m)) return false;
  return true;
}

}  // namespace gpatlas_core
