#include "gpatlas_core/observations/view_free_space.h"

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

ViewSamples sampleViewFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                std::uint64_t seed, const ViewFreeSpaceConfig& config) {
  ViewSamples out;
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
  std::mt19937_64 rng(seed);
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

}  // namespace gpatlas_core
