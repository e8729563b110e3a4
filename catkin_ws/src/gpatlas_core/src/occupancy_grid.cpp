#include "gpatlas_core/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace gpatlas_core {

double standardNormalCdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

OccupancyGrid OccupancyGridBuilder::build(const SurfaceModel& model) const {
  OccupancyGrid grid;
  if (!model.isFitted()) {
    grid.message = "no model: the GP is not fitted";
    return grid;
  }
  if (!(config_.resolution_m > 0.0) || !std::isfinite(config_.resolution_m) || config_.batch_size < 1) {
    grid.message = "resolution_m must be positive and finite, batch_size >= 1";
    return grid;
  }
  const Vector3 half_extent = Vector3::Constant(model.domainRadiusWorld());
  const Vector3 lower = config_.min_corner.value_or(model.centroid() - half_extent);
  const Vector3 upper = config_.max_corner.value_or(model.centroid() + half_extent);
  if (!lower.allFinite() || !upper.allFinite() || (upper.array() <= lower.array()).any()) {
    grid.message = "grid bounds must be finite with max_corner > min_corner on every axis";
    return grid;
  }
  const Eigen::Array3d cells = ((upper - lower) / config_.resolution_m).array().floor() + 1.0;
  const double num_nodes = cells.prod();
  if (num_nodes > static_cast<double>(config_.max_nodes)) {
    std::ostringstream message;
    message << "grid of " << num_nodes << " nodes exceeds max_nodes = " << config_.max_nodes;
    grid.message = message.str();
    return grid;
  }
  grid.origin = lower;
  grid.resolution = config_.resolution_m;
  grid.size = cells.cast<int>().matrix();
  grid.probabilities.assign(static_cast<std::size_t>(num_nodes), 0.0f);

  // Reported variance -> raw posterior variance, the one that is commensurate with f.
  const double unit = model.varianceUnitFactor();
  std::vector<std::size_t> pending_index;
  Points3 pending(3, config_.batch_size);
  auto flush = [&]() {
    if (pending_index.empty()) return;
    const BatchPrediction prediction =
        model.predictBatch(pending.leftCols(static_cast<Eigen::Index>(pending_index.size())), false, false);
    for (std::size_t k = 0; k < pending_index.size(); ++k) {
      const Eigen::Index q = static_cast<Eigen::Index>(k);
      const double mean = prediction.mean(q);
      const double sd = std::sqrt(std::max(prediction.variance(q) / unit, 0.0));
      double p = 0.0;
      if (!std::isfinite(mean) || !std::isfinite(sd)) p = 0.5;  // unknown
      else if (sd > 0.0) p = standardNormalCdf(-mean / sd);
      else p = mean < 0.0 ? 1.0 : 0.0;
      grid.probabilities[pending_index[k]] = static_cast<float>(p);
    }
    pending_index.clear();
  };
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j)
      for (int i = 0; i < grid.size.x(); ++i) {
        const Vector3 x = grid.position(i, j, k);
        if (!model.inDomain(x)) continue;
        pending.col(static_cast<Eigen::Index>(pending_index.size())) = x;
        pending_index.push_back(grid.index(i, j, k));
        if (static_cast<int>(pending_index.size()) == config_.batch_size) flush();
      }
  flush();
  grid.ok = true;
  return grid;
}

}  // namespace gpatlas_core
