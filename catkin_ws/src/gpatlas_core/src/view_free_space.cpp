#include "gpatlas_core/view_free_space.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

namespace gpatlas_core {

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
  std::vector<Vector3> points;
  points.reserve(surface_points.size());
  for (const auto& p : surface_points)
    if (p.allFinite()) points.push_back(p);
  if (points.size() < 2) {
    out.message = "the view has fewer than 2 finite points";
    return out;
  }
  Vector3 centroid = Vector3::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  double radius = 0.0;
  for (const auto& p : points) radius = std::max(radius, (p - centroid).norm());
  if (!(radius > 0.0)) {
    out.message = "the view's points all coincide";
    return out;
  }

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

}  // namespace gpatlas_core
