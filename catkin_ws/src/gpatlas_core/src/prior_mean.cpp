#include "gpatlas_core/prior_mean.h"

#include <cmath>
#include <stdexcept>
#include <unordered_map>

namespace gpatlas_core {

struct InteriorPriorMean::Grid {
  double cell{1.0};
  std::unordered_map<std::int64_t, std::vector<std::size_t>> buckets;

  static std::int64_t key(std::int64_t i, std::int64_t j, std::int64_t k) {
    // 21 bits per axis: ample for an object's neighbourhood at any sensible radius.
    const std::int64_t mask = (1 << 21) - 1;
    return ((i & mask) << 42) | ((j & mask) << 21) | (k & mask);
  }
  std::int64_t index(double v) const { return static_cast<std::int64_t>(std::floor(v / cell)); }
};

InteriorPriorMean::InteriorPriorMean(std::vector<Vector3> centres, double radius_m, double depth)
    : centres_(std::move(centres)), radius_(radius_m), depth_(depth) {
  if (!(radius_m > 0.0) || !std::isfinite(radius_m)) throw std::invalid_argument("InteriorPriorMean: radius_m must be > 0");
  if (!(depth >= 0.0) || !std::isfinite(depth)) throw std::invalid_argument("InteriorPriorMean: depth must be >= 0");
  auto grid = std::make_shared<Grid>();
  grid->cell = radius_m;
  for (std::size_t c = 0; c < centres_.size(); ++c) {
    const Vector3& p = centres_[c];
    if (!p.allFinite()) throw std::invalid_argument("InteriorPriorMean: a centre is not finite");
    grid->buckets[Grid::key(grid->index(p.x()), grid->index(p.y()), grid->index(p.z()))].push_back(c);
  }
  grid_ = std::move(grid);
}

double InteriorPriorMean::value(const Vector3& x, Vector3* gradient) const {
  if (gradient) gradient->setZero();
  if (centres_.empty() || depth_ == 0.0 || !x.allFinite()) return 0.0;
  double sum = 0.0;
  Vector3 sum_gradient = Vector3::Zero();
  const std::int64_t i0 = grid_->index(x.x()), j0 = grid_->index(x.y()), k0 = grid_->index(x.z());
  for (std::int64_t di = -1; di <= 1; ++di)
    for (std::int64_t dj = -1; dj <= 1; ++dj)
      for (std::int64_t dk = -1; dk <= 1; ++dk) {
        const auto it = grid_->buckets.find(Grid::key(i0 + di, j0 + dj, k0 + dk));
        if (it == grid_->buckets.end()) continue;
        for (std::size_t c : it->second) {
          const Vector3 d = x - centres_[c];
          const double r = d.norm();
          const double t = r / radius_;
          if (t >= 1.0) continue;
          // Wendland C2: (1 - t)^4 (4 t + 1), derivative -20 t (1 - t)^3.
          const double u = 1.0 - t;
          sum += u * u * u * u * (4.0 * t + 1.0);
          if (gradient && r > 0.0) sum_gradient += (-20.0 * t * u * u * u / radius_) * (d / r);
        }
      }
  const double saturation = std::exp(-sum);
  if (gradient) *gradient = -depth_ * saturation * sum_gradient;
  return -depth_ * (1.0 - saturation);
}

}  // namespace gpatlas_core
