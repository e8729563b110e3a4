#include "gpatlas_core/model/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace gpatlas_core {

double standardNormalCdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

OccupancyGrid OccupancyGridBuilder::build(const SurfaceModel& model) const { return buildGrid(model, std::nullopt); }

OccupancyGrid OccupancyGridBuilder::buildOccupancy(const SurfaceModel& model, double occupied_probability) const {
  if (!(occupied_probability > 0.0 && occupied_probability < 1.0)) {
    OccupancyGrid grid;
    grid.message = "occupied_probability must be in (0, 1)";
    return grid;
  }
  return buildGrid(model, occupied_probability);
}

OccupancyGrid OccupancyGridBuilder::buildGrid(const SurfaceModel& model, std::optional<double> occupied_probability) const {
  OccupancyGrid grid;
  if (!model.isFitted()) {
    grid.message = "no model: the GP is not fitted";
    return grid;
  }
  if (!(config_.resolution_m > 0.0) || !std::isfinite(config_.resolution_m) || config_.batch_size < 1 ||
      config_.variance_stride < 1 || config_.mean_stride < 1) {
    grid.message = "resolution_m must be positive and finite, batch_size, variance_stride and mean_stride >= 1";
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
  // Nodes at the centres of OctoMap's voxels (which sit at multiples of the resolution), so that
  // each voxel of the collision octree holds its node's probability.
  grid.origin = ((lower / config_.resolution_m).array().floor() + 0.5).matrix() * config_.resolution_m;
  grid.resolution = config_.resolution_m;
  grid.size = cells.cast<int>().matrix();
  grid.probabilities.assign(static_cast<std::size_t>(num_nodes), 0.0f);

  // Reported variance -> raw posterior variance, the one that is commensurate with f.
  const double unit = model.varianceUnitFactor();
  const int stride = config_.variance_stride;
  const double half = 0.5 * config_.resolution_m;
  const std::size_t num = static_cast<std::size_t>(num_nodes);
  const std::size_t nx = static_cast<std::size_t>(grid.size.x()), ny = static_cast<std::size_t>(grid.size.y());
  std::vector<double> mean(num, 0.0), variance(num, std::nan("")), gradient_norm(num, 0.0);
  // The neighbour one step down the mean's steepest axis (+-(axis + 1), 0 for none): across the
  // surface when the surface is near.
  std::vector<signed char> downhill(num, 0);
  const auto coordinates = [&](std::size_t n) {
    return Eigen::Vector3i(static_cast<int>(n % nx), static_cast<int>(n / nx % ny), static_cast<int>(n / (nx * ny)));
  };

  // The mean, and the variance when asked, of the nodes in `nodes`, in batches.
  const auto evaluate = [&](const std::vector<std::size_t>& nodes, bool with_mean, bool with_variance) {
    Points3 batch(3, config_.batch_size);
    for (std::size_t first = 0; first < nodes.size(); first += static_cast<std::size_t>(config_.batch_size)) {
      const std::size_t count = std::min(nodes.size() - first, static_cast<std::size_t>(config_.batch_size));
      for (std::size_t q = 0; q < count; ++q) {
        const Eigen::Vector3i c = coordinates(nodes[first + q]);
        batch.col(static_cast<Eigen::Index>(q)) = grid.position(c.x(), c.y(), c.z());
      }
      const BatchPrediction prediction =
          model.predictBatch(batch.leftCols(static_cast<Eigen::Index>(count)), with_mean, false, with_variance);
      for (std::size_t q = 0; q < count; ++q) {
        const Eigen::Index e = static_cast<Eigen::Index>(q);
        if (with_mean) {
          const std::size_t node = nodes[first + q];
          const Vector3 gradient = prediction.gradient.col(e);
          mean[node] = prediction.mean(e);
          gradient_norm[node] = gradient.norm();
          Eigen::Index axis = 0;
          if (gradient.allFinite() && gradient.cwiseAbs().maxCoeff(&axis) > 0.0)
            downhill[node] = static_cast<signed char>(gradient[axis] > 0.0 ? -(axis + 1) : axis + 1);
        }
        if (with_variance) variance[nodes[first + q]] = prediction.variance(e);
      }
    }
  };
  // Along one axis: the variance lattice's nodes at or below and above index i, and i's weight
  // on the upper one. The lattice holds every stride-th index and the last.
  struct Bracket {
    int lower, upper;
    double weight;
  };
  const auto brackets = [](int size, int stride) {
    std::vector<Bracket> out(static_cast<std::size_t>(size));
    const int last = size - 1;
    for (int i = 0; i < size; ++i) {
      const int lower = std::min(i / stride * stride, last);
      const int upper = std::min(lower + stride, last);
      out[static_cast<std::size_t>(i)] = {lower, upper, upper > lower ? double(i - lower) / (upper - lower) : 0.0};
    }
    return out;
  };
  const std::vector<Bracket> bx = brackets(grid.size.x(), stride), by = brackets(grid.size.y(), stride),
                             bz = brackets(grid.size.z(), stride);
  // P > 0.5 exactly where the lowest mean is below 0, whatever the variance.
  const bool without_variance = occupied_probability && *occupied_probability == 0.5;
  const int mean_stride = without_variance ? config_.mean_stride : 1;
  const std::vector<Bracket> mx = brackets(grid.size.x(), mean_stride), my = brackets(grid.size.y(), mean_stride),
                             mz = brackets(grid.size.z(), mean_stride);

  std::vector<std::size_t> domain, lattice, mean_lattice;
  std::vector<char> in_domain(num, 0);
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j)
      for (int i = 0; i < grid.size.x(); ++i) {
        const std::size_t n = grid.index(i, j, k);
        if (!model.inDomain(grid.position(i, j, k))) continue;
        domain.push_back(n);
        in_domain[n] = 1;
        const std::size_t si = static_cast<std::size_t>(i), sj = static_cast<std::size_t>(j), sk = static_cast<std::size_t>(k);
        if (bx[si].lower == i && by[sj].lower == j && bz[sk].lower == k) lattice.push_back(n);
        if (mean_stride > 1 && mx[si].lower == i && my[sj].lower == j && mz[sk].lower == k) mean_lattice.push_back(n);
      }
  grid.domain_nodes = domain.size();
  if (mean_stride <= 1) {
    evaluate(domain, true, stride <= 1 && !without_variance);
    grid.exact_mean_nodes = domain.size();
  } else {
    // The mean on the coarse lattice first, then node by node only in the blocks the surface can
    // come within two voxels of: their corners differ in sign, or one lies closer to the zero
    // level than a block diagonal and two voxels (in f, which near the data grows like the
    // distance over the model's scale; the mesher's rule). Elsewhere the block's nodes are at
    // least two voxels from the surface, further than any voxel the thin-object rule looks at:
    // they take the corner nearest the zero level, whose sign decides them.
    std::vector<char> evaluated(num, 0);
    evaluate(mean_lattice, true, false);
    for (const std::size_t n : mean_lattice) evaluated[n] = 1;
    const double band = (std::sqrt(3.0) * mean_stride + 2.0) * config_.resolution_m / model.scale();
    std::vector<std::size_t> exact;
    for (const std::size_t n : domain) {
      if (evaluated[n]) continue;
      const Eigen::Vector3i at = coordinates(n);
      const Bracket& x = mx[static_cast<std::size_t>(at.x())];
      const Bracket& y = my[static_cast<std::size_t>(at.y())];
      const Bracket& z = mz[static_cast<std::size_t>(at.z())];
      double low = HUGE_VAL, high = -HUGE_VAL;
      bool complete = true;
      for (int c = 0; c < 8 && complete; ++c) {
        const std::size_t corner =
            grid.index((c & 1) ? x.upper : x.lower, (c & 2) ? y.upper : y.lower, (c & 4) ? z.upper : z.lower);
        complete = in_domain[corner] && std::isfinite(mean[corner]);
        low = std::min(low, mean[corner]);
        high = std::max(high, mean[corner]);
      }
      if (complete && low > band) mean[n] = low;
      else if (complete && high < -band) mean[n] = high;
      else exact.push_back(n);
    }
    evaluate(exact, true, false);
    grid.exact_mean_nodes = mean_lattice.size() + exact.size();
  }
  if (without_variance) {
    grid.exact_variance_nodes = 0;
  } else if (stride <= 1) {
    grid.exact_variance_nodes = domain.size();
  } else {
    evaluate(lattice, false, true);
    // Trilinear between the eight lattice corners; evaluated where a corner is outside the domain.
    std::vector<std::size_t> exact;
    for (const std::size_t n : domain) {
      if (std::isfinite(variance[n])) continue;  // a lattice node
      // Where the surface passes within half a voxel the variance has its sharp dip at the data,
      // which the lattice would smooth over, and P depends on it most.
      if (std::abs(mean[n]) <= half * gradient_norm[n]) {
        exact.push_back(n);
        continue;
      }
      const Eigen::Vector3i at = coordinates(n);
      const Bracket& x = bx[static_cast<std::size_t>(at.x())];
      const Bracket& y = by[static_cast<std::size_t>(at.y())];
      const Bracket& z = bz[static_cast<std::size_t>(at.z())];
      double interpolated = 0.0;
      bool complete = true;
      for (int c = 0; c < 8 && complete; ++c) {
        const double corner = variance[grid.index((c & 1) ? x.upper : x.lower, (c & 2) ? y.upper : y.lower,
                                                  (c & 4) ? z.upper : z.lower)];
        const double w = ((c & 1) ? x.weight : 1.0 - x.weight) * ((c & 2) ? y.weight : 1.0 - y.weight) *
                         ((c & 4) ? z.weight : 1.0 - z.weight);
        if (w == 0.0) continue;
        if (!std::isfinite(corner)) complete = false;
        interpolated += w * corner;
      }
      if (complete) variance[n] = interpolated;
      else exact.push_back(n);
    }
    evaluate(exact, false, true);
    grid.exact_variance_nodes = lattice.size() + exact.size();
  }
  // The surface's distance from the node, linearised.
  const auto distance = [&](std::size_t n) { return gradient_norm[n] > 0.0 ? mean[n] / gradient_norm[n] : HUGE_VAL; };
  // Whether the node stands for an object thinner than a voxel beside it: its neighbour one step
  // down the steepest axis is not inside either, and not nearer to the surface (one voxel of the
  // two on either side of a wall is enough).
  const auto standsForThinObject = [&](std::size_t n) {
    if (downhill[n] == 0) return false;
    Eigen::Vector3i at = coordinates(n);
    const int axis = std::abs(downhill[n]) - 1;
    at[axis] += downhill[n] > 0 ? 1 : -1;
    if (at[axis] < 0 || at[axis] >= grid.size[axis]) return true;
    const std::size_t m = grid.index(at.x(), at.y(), at.z());
    return !(mean[m] < 0.0) && distance(n) <= distance(m);
  };
  // A voxel whose centre is inside is occupied. So is one whose centre is outside with the surface
  // within half a voxel of it (the smallest mean over the ball inscribed in the voxel, linearised
  // about its centre, mean - (resolution / 2) |grad mean|, is below 0) when the neighbour across
  // that surface, one step down the steepest axis, is not inside either: the object between them
  // is thinner than a voxel (a wall, a rim, a handle) and would otherwise vanish from the map.
  // The nearer of the two stands for it. Where that neighbour is inside, it stands for the
  // object, and the map is not grown.
  for (const std::size_t n : domain) {
    const double sd = std::sqrt(std::max(variance[n] / unit, 0.0));
    const bool thin = mean[n] >= 0.0 && mean[n] < half * gradient_norm[n] && standsForThinObject(n);
    const double lowest = thin ? mean[n] - half * gradient_norm[n] : mean[n];
    double p = 0.0;
    if (without_variance) p = lowest < 0.0 ? 1.0 : (std::isfinite(lowest) ? 0.0 : 0.5);
    else if (!std::isfinite(lowest) || !std::isfinite(sd)) p = 0.5;  // unknown
    else if (sd > 0.0) p = standardNormalCdf(-lowest / sd);
    else p = lowest < 0.0 ? 1.0 : 0.0;
    if (occupied_probability) p = p > *occupied_probability ? 1.0 : 0.0;
    grid.probabilities[n] = static_cast<float>(p);
  }
  grid.ok = true;
  return grid;
}

}  // namespace gpatlas_core
