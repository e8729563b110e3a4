#include "gpatlas_core/observations/near_surface_free_space.h"

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

ViewSamples sampleNearSurfaceFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                         const NearSurfaceFreeSpaceConfig& config) {
  ViewSamples out;
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

}  // namespace gpatlas_core
