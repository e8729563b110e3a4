#include "gpatlas_core/planning/surface_sampler.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace gpatlas_core {

double SurfaceSample::maxVariance() const {
  return variances.empty() ? 0.0 : *std::max_element(variances.begin(), variances.end());
}

SurfaceSample SurfaceSampler::sample(const SurfaceModel& model, std::uint64_t seed) const {
  SurfaceSample result;
  if (!model.isFitted()) {
    result.message = "no model: the GP is not fitted";
    return result;
  }
  if (config_.num_seeds < 1 || !(config_.seed_radius_fraction > 0.0 && config_.seed_radius_fraction <= 1.0)) {
    result.message = "surface sampler needs num_seeds >= 1 and seed_radius_fraction in (0, 1]";
    return result;
  }
  const double radius = config_.seed_radius_fraction * model.domainRadiusWorld();
  if (!(radius > 0.0) || !std::isfinite(radius) || !model.centroid().allFinite()) {
    result.message = "the model's domain is degenerate";
    return result;
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Points3 seeds(3, config_.num_seeds);
  for (int i = 0; i < config_.num_seeds; ++i) {
    Vector3 direction(gaussian(rng), gaussian(rng), gaussian(rng));
    while (!(direction.norm() > 1e-12)) direction = Vector3(gaussian(rng), gaussian(rng), gaussian(rng));
    seeds.col(i) = model.centroid() + direction.normalized() * radius * std::cbrt(unit(rng));
  }
  result.seeds_tried = config_.num_seeds;
  for (const SurfacePoint& point : projectAlongGradient(model, seeds, config_.projection)) {
    if (!point.ok) continue;
    result.points.push_back(point.position);
    result.normals.push_back(point.outwardNormal());
    result.variances.push_back(point.variance);
    result.slopes.push_back(point.gradient.norm());
  }
  if (result.points.empty()) {
    result.message = "no seed could be projected onto the predicted surface";
    return result;
  }
  result.ok = true;
  return result;
}

void readSurfaceSampler(ParamReader& r, SurfaceSampler::Config* c) {
  c->num_seeds = r.integer("planner/surface_samples", c->num_seeds, 1, 1000000);
}

}  // namespace gpatlas_core
