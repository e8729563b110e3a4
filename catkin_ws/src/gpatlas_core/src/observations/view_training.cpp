#include "gpatlas_core/observations/view_training.h"

#include "gpatlas_core/common/seeds.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

namespace gpatlas_core {

namespace {

// Salts that give each random choice of a view its own stream of the run's seed.
constexpr std::uint64_t kSubsetSalt = 1;
constexpr std::uint64_t kFreeSpaceSalt = 2;
constexpr std::uint64_t kInteriorSalt = 3;

}  // namespace

std::string validate(const ViewTrainingConfig& config) {
  std::ostringstream problem;
  if (config.max_surface_points < 4) problem << "max_surface_points must be >= 4; ";
  if (!(config.vision_noise_sigma >= 0.0) || !std::isfinite(config.vision_noise_sigma))
    problem << "vision_noise_sigma must be finite and >= 0; ";
  if (config.free_space.max_rays < 0 || config.free_space.samples_per_ray < 0)
    problem << "free_space max_rays and samples_per_ray must be >= 0; ";
  if (!(config.free_space.min_offset_fraction > 0.0) ||
      !(config.free_space.max_offset_fraction >= config.free_space.min_offset_fraction))
    problem << "free_space offsets must satisfy 0 < min_offset_fraction <= max_offset_fraction; ";
  if (!(config.near_surface_free_space.offset_m > 0.0) || config.near_surface_free_space.max_points < 0)
    problem << "near_surface_free_space needs offset_m > 0 and max_points >= 0; ";
  if (config.support_free_space.max_points < 0 ||
      !(config.support_free_space.max_distance_m > config.support_free_space.min_distance_m))
    problem << "support_free_space needs max_points >= 0 and max_distance_m > min_distance_m; ";
  if (config.occluded_interior.max_points < 0) problem << "occluded_interior max_points must be >= 0; ";
  if (!(config.support_clearance_m >= 0.0)) problem << "support_clearance_m must be >= 0; ";
  return problem.str();
}

ViewTraining buildViewTraining(const std::vector<Vector3>& view_points, const std::optional<Vector3>& sensor_origin,
                               const std::optional<SupportPlane>& support, const ViewTrainingConfig& config,
                               std::uint64_t seed) {
  ViewTraining result;
  if (const std::string problem = validate(config); !problem.empty()) {
    result.message = "invalid view configuration: " + problem;
    return result;
  }
  std::vector<Vector3> points;
  points.reserve(view_points.size());
  for (const Vector3& p : view_points)
    if (p.allFinite()) points.push_back(p);
  if (points.size() < 4) {
    result.message = "the view has " + std::to_string(points.size()) + " finite points (" +
                     std::to_string(view_points.size() - points.size()) + " not finite), need at least 4";
    return result;
  }

  std::vector<Vector3> subset = points;
  std::mt19937_64 rng(mixSeeds(seed, kSubsetSalt));
  std::shuffle(subset.begin(), subset.end(), rng);
  if (subset.size() > static_cast<std::size_t>(config.max_surface_points))
    subset.resize(static_cast<std::size_t>(config.max_surface_points));
  for (const Vector3& p : subset) {
    TrainingPoint t;
    t.position = p;
    t.label = PointLabel::kSurface;
    t.noise_sigma = config.vision_noise_sigma;
    t.source = PointSource::kVision;
    result.points.push_back(t);
  }
  result.surface = result.points.size();

  if (sensor_origin) {
    // The camera's rays crossed free space up to the object: outside points that keep the
    // model from closing cavities the camera looked into. Labels use the whole view.
    if (config.free_space.max_rays > 0 && config.free_space.samples_per_ray > 0) {
      const ViewSamples free = sampleViewFreeSpace(points, *sensor_origin, mixSeeds(seed, kFreeSpaceSalt), config.free_space);
      if (free.ok) {
        result.points.insert(result.points.end(), free.points.begin(), free.points.end());
        result.free_space = free.points.size();
      } else {
        result.warnings.push_back("no view free space: " + free.message);
      }
    }
    if (config.near_surface_free_space.max_points > 0) {
      const ViewSamples near = sampleNearSurfaceFreeSpace(points, *sensor_origin, config.near_surface_free_space);
      if (near.ok) {
        result.points.insert(result.points.end(), near.points.begin(), near.points.end());
        result.near_surface_free_space = near.points.size();
      } else {
        result.warnings.push_back("no near-surface free space: " + near.message);
      }
    }
    // Material behind what the camera saw, within the view's hull: without it a surface the
    // camera never saw (a bowl's bottom behind its rim) has no zero crossing to explore.
    if (config.occluded_interior.max_points > 0) {
      ViewSamples inside =
          sampleOccludedInterior(points, *sensor_origin, mixSeeds(seed, kInteriorSalt), config.occluded_interior);
      if (inside.ok) {
        if (support) dropNearOrBelowPlane(&inside.points, *support, config.support_clearance_m);
        result.points.insert(result.points.end(), inside.points.begin(), inside.points.end());
        result.occluded_interior = inside.points.size();
      } else {
        result.warnings.push_back("no occluded interior: " + inside.message);
      }
    }
  }
  if (support) {
    const ViewSamples below = sampleBelowSupport(points, *support, config.below_support);
    if (below.ok) {
      result.points.insert(result.points.end(), below.points.begin(), below.points.end());
      result.below_support = below.points.size();
    } else {
      result.warnings.push_back("support plane not used: " + below.message);
    }
    if (sensor_origin && config.support_free_space.max_points > 0) {
      const ViewSamples beside = sampleSupportFreeSpace(points, *sensor_origin, *support, config.support_free_space);
      if (beside.ok) {
        result.points.insert(result.points.end(), beside.points.begin(), beside.points.end());
        result.support_free_space = beside.points.size();
      } else {
        result.warnings.push_back("no free space beside the object on the support: " + beside.message);
      }
    }
  }
  result.ok = true;
  std::ostringstream message;
  message << result.surface << " of " << points.size() << " view points, " << result.free_space << " free space, "
          << result.near_surface_free_space << " near-surface free space, "
          << result.occluded_interior << " occluded interior, " << result.below_support << " below the support, "
          << result.support_free_space << " on the support beside the object";
  result.message = message.str();
  return result;
}

}  // namespace gpatlas_core
