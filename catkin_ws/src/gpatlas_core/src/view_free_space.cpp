#include "gpatlas_core/view_free_space.h"

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
namespace {

// The finite points of a view, their centroid, radius (largest distance from the centroid)
// and bounding box.
struct View {
  std::vector<Vector3> points;
  Vector3 centroid{Vector3::Zero()};
  double radius{0.0};
  Vector3 lo{Vector3::Zero()}, hi{Vector3::Zero()};  // bounding box
};

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

}  // namespace

ViewFreeSpace sampleViewFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                  const ViewFreeSpaceConfig& config) {
  ViewFreeSpace out;
  if (!sensor_origin.allFinite()) {
    out.message = "the sensor origin is not finite";
    return out;
  }
  if (config.max_rays < 0 || config.samples_per_ray < 0 || !(config.min_offset_fraction > 0.0) ||
      !(config.max_offset_fraction >= config.min_offset_fraction) || !(config.noise_sigma >= 0.0) ||
      !std::isfinite(config.max_offset_fraction) || !std::isfinite(config.noise_sigma)) {
    out.message =
        "invalid view free-space settings (max_rays, samples_per_ray >= 0; 0 < min_offset_fraction <= "
        "max_offset_fraction; noise_sigma >= 0)";
    return out;
  }
  View view;
  out.message = finiteView(surface_points, 2, &view);
  if (!out.message.empty()) return out;
  const std::vector<Vector3>& points = view.points;
  const double radius = view.radius;

  std::vector<std::size_t> rays(points.size());
  std::iota(rays.begin(), rays.end(), 0);
  std::mt19937_64 rng(config.seed);
  std::shuffle(rays.begin(), rays.end(), rng);
  rays.resize(std::min<std::size_t>(rays.size(), static_cast<std::size_t>(config.max_rays)));
  std::uniform_real_distribution<double> depth(config.min_offset_fraction * radius, config.max_offset_fraction * radius);

  for (std::size_t r : rays) {
    const Vector3 to_hit = points[r] - sensor_origin;
    const double range = to_hit.norm();
    if (!(range > 0.0)) continue;
    const Vector3 direction = to_hit / range;
    for (int s = 0; s < config.samples_per_ray; ++s) {
      const double offset = depth(rng);
      if (offset >= range) continue;  // the sensor itself is closer than that
      TrainingPoint t;
      t.position = points[r] - offset * direction;
      t.label = PointLabel::kOutside;
      t.source = PointSource::kVision;
      t.noise_sigma = config.noise_sigma;
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& p : points) nearest = std::min(nearest, (p - t.position).squaredNorm());
      t.surface_distance_m = std::sqrt(nearest);
      out.points.push_back(t);
    }
  }
  out.ok = true;
  return out;
}


ViewFreeSpace sampleNearSurfaceFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                         const NearSurfaceFreeSpaceConfig& config) {
  ViewFreeSpace out;
  if (!sensor_origin.allFinite()) {
    out.message = "the sensor origin is not finite";
    return out;
  }
  if (!(config.offset_m > 0.0) || !std::isfinite(config.offset_m) || config.max_points < 0 ||
      !(config.noise_sigma > 0.0) || !std::isfinite(config.noise_sigma)) {
    out.message = "invalid near-surface free space settings (need offset_m > 0, max_points >= 0, noise_sigma > 0)";
    return out;
  }
  std::vector<Vector3> points;
  for (const Vector3& p : surface_points)
    if (p.allFinite()) points.push_back(p);
  if (points.empty()) {
    out.message = "no finite view point";
    return out;
  }
  // Every sample is within offset_m of its own view point, so its nearest view point lies in the
  // 27 cells of side offset_m around it.
  const double cell = config.offset_m;
  const auto key = [cell](const Vector3& x) {
    const Eigen::Array3d c = (x.array() / cell).floor();
    return std::array<long long, 3>{static_cast<long long>(c[0]), static_cast<long long>(c[1]),
                                    static_cast<long long>(c[2])};
  };
  std::map<std::array<long long, 3>, std::vector<std::uint32_t>> cells;
  for (std::size_t i = 0; i < points.size(); ++i) cells[key(points[i])].push_back(static_cast<std::uint32_t>(i));

  const std::size_t wanted = std::min<std::size_t>(points.size(), static_cast<std::size_t>(config.max_points));
  out.points.reserve(wanted);
  for (std::size_t k = 0; k < wanted; ++k) {
    const Vector3& hit = points[k * points.size() / wanted];  // an even subset, in the view's order
    const Vector3 to_sensor = sensor_origin - hit;
    const double range = to_sensor.norm();
    if (!(range > config.offset_m)) continue;
    TrainingPoint t;
    t.position = hit + config.offset_m * to_sensor / range;
    t.label = PointLabel::kOutside;
    t.source = PointSource::kVision;
    t.noise_sigma = config.noise_sigma;
    double nearest = config.offset_m * config.offset_m;
    const std::array<long long, 3> centre = key(t.position);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto found = cells.find({centre[0] + dx, centre[1] + dy, centre[2] + dz});
          if (found == cells.end()) continue;
          for (std::uint32_t i : found->second) nearest = std::min(nearest, (points[i] - t.position).squaredNorm());
        }
    t.surface_distance_m = std::sqrt(nearest);
    out.points.push_back(t);
  }
  out.ok = true;
  return out;
}

ViewFreeSpace sampleOccludedInterior(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                     const OccludedInteriorConfig& config) {
  ViewFreeSpace out;
  if (!sensor_origin.allFinite()) {
    out.message = "the sensor origin is not finite";
    return out;
  }
  if (config.grid_cells < 2 || config.grid_cells > 100 || config.max_points < 0 || config.hull_directions < 4 ||
      !(config.margin_fraction >= 0.0) || !std::isfinite(config.margin_fraction) || !(config.noise_sigma > 0.0) ||
      !std::isfinite(config.noise_sigma)) {
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

  // A coarse range image in the sensor's frame: per pixel, the range of the farthest hit. The
  // farthest, not the nearest: a pixel on a depth edge (a rim in front of a cavity's far wall)
  // would otherwise call the air just past the rim occluded, though the camera saw through it.
  // Every view point lies in front of the sensor (forward_raw.norm() > radius).
  const Vector3 forward = forward_raw.normalized();
  const Vector3 right = forward.unitOrthogonal();
  const Vector3 up = forward.cross(right);
  const auto imageOf = [&](const Vector3& p, double* a, double* b) {
    const Vector3 v = p - sensor_origin;
    const double depth = v.dot(forward);
    if (!(depth > 0.0)) return false;
    *a = v.dot(right) / depth;
    *b = v.dot(up) / depth;
    return true;
  };
  double a_min = std::numeric_limits<double>::infinity(), a_max = -a_min, b_min = a_min, b_max = -a_min;
  for (const auto& p : points) {
    double a = 0.0, b = 0.0;
    imageOf(p, &a, &b);
    a_min = std::min(a_min, a);
    a_max = std::max(a_max, a);
    b_min = std::min(b_min, b);
    b_max = std::max(b_max, b);
  }
  // About 4 points per pixel on average, so that a pixel inside the silhouette is rarely empty
  // (an empty pixel is unknown, never occluded: the background seen through a handle).
  const int pixels = std::clamp(static_cast<int>(std::sqrt(static_cast<double>(points.size()) / 4.0)), 4, 128);
  const double a_step = std::max(a_max - a_min, 1e-12) / pixels, b_step = std::max(b_max - b_min, 1e-12) / pixels;
  std::vector<double> farthest_range(static_cast<std::size_t>(pixels * pixels), -1.0);
  // Outside the image: -1. The image's far edges (a == a_max) belong to its last pixels.
  const auto pixelOf = [&](double a, double b) -> int {
    if (a < a_min || a > a_max || b < b_min || b > b_max) return -1;
    const int i = std::min(static_cast<int>(std::floor((a - a_min) / a_step)), pixels - 1);
    const int j = std::min(static_cast<int>(std::floor((b - b_min) / b_step)), pixels - 1);
    return i * pixels + j;
  };
  for (const auto& p : points) {
    double a = 0.0, b = 0.0;
    imageOf(p, &a, &b);
    const int px = pixelOf(a, b);
    auto& r = farthest_range[static_cast<std::size_t>(px)];
    r = std::max(r, (p - sensor_origin).norm());
  }

  // The convex hull, approximated from outside by its support planes in evenly spread
  // directions (Fibonacci lattice), shrunk by the margin.
  const std::vector<Vector3> directions = fibonacciSphere(config.hull_directions);
  std::vector<double> support;
  for (const Vector3& u : directions) {
    double h = -std::numeric_limits<double>::infinity();
    for (const auto& p : points) h = std::max(h, u.dot(p));
    support.push_back(h - margin);
  }
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
        bool in_hull = true;
        for (std::size_t k = 0; k < directions.size() && in_hull; ++k) in_hull = directions[k].dot(x) <= support[k];
        if (!in_hull) continue;
        double a = 0.0, b = 0.0;
        if (!imageOf(x, &a, &b)) continue;
        const int px = pixelOf(a, b);
        if (px < 0) continue;
        const double hit = farthest_range[static_cast<std::size_t>(px)];
        if (hit < 0.0 || (x - sensor_origin).norm() < hit + margin) continue;
        candidates.push_back(x);
      }
  std::mt19937_64 rng(config.seed);
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

ViewFreeSpace sampleBelowSupport(const std::vector<Vector3>& surface_points, const SupportPlane& plane,
                                 const BelowSupportConfig& config) {
  ViewFreeSpace out;
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

ViewFreeSpace sampleSupportFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                     const SupportPlane& plane, const SupportFreeSpaceConfig& config) {
  ViewFreeSpace out;
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

std::size_t dropNearOrBelowPlane(std::vector<TrainingPoint>* points, const SupportPlane& plane, double clearance_m) {
  if (!points) return 0;
  const std::size_t before = points->size();
  points->erase(std::remove_if(points->begin(), points->end(),
                               [&](const TrainingPoint& p) { return !(plane.height(p.position) >= clearance_m); }),
                points->end());
  return before - points->size();
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
