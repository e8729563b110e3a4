#pragma once

#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/model/surface_projection.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// Points on the predicted surface f = 0 with their variance, for the baselines and for
// summaries such as "the largest variance left on the surface".
struct SurfaceSample {
  bool ok{false};
  std::string message;
  std::vector<Vector3> points;
  std::vector<Vector3> normals;  // outward unit normals
  std::vector<double> variances; // reported units
  std::vector<double> slopes;    // |grad f| per metre (positionSd)
  int seeds_tried{0};
  double maxVariance() const;    // 0 when empty
};

// Draws seeds uniformly in a ball around the model's centroid and projects each onto the
// predicted surface along the mean's gradient (the projector of eq. 13 with the gradient at
// the seed as the chart normal). Seeds that fail to project are discarded. The result is not
// uniform in area (it is denser where the surface is closer to the centroid), which is fine
// for maxima and random picks but should not be read as an area-weighted sample.
class SurfaceSampler {
 public:
  struct Config {
    int num_seeds{600};
    // Seeds are drawn within this fraction of the domain radius; the outer shell of the domain
    // holds the outside pseudo-points and has no surface.
    double seed_radius_fraction{0.95};
    ProjectionConfig projection;
  };

  SurfaceSampler() = default;
  explicit SurfaceSampler(Config config) : config_(std::move(config)) {}
  const Config& config() const { return config_; }

  // `seed` draws the seeds: the caller's stream (a strategy derives it from the run's seed and
  // the plan's).
  SurfaceSample sample(const SurfaceModel& model, std::uint64_t seed) const;

 private:
  Config config_;
};

// Its reader: planner/surface_samples, the baselines' sample.
void readSurfaceSampler(ParamReader& r, SurfaceSampler::Config* c);

}  // namespace gpatlas_core
