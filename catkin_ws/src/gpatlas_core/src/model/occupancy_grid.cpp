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

namespace {

// The grid's frame and size for the model and config, its probabilities all 0; a message and no
// nodes when the config or the bounds are unusable.
OccupancyGrid layoutGrid(const SurfaceModel& model, const OccupancyGridBuilder::Config& config) {
  OccupancyGrid grid;
  if (!(config.resolution_m > 0.0) || !std::isfinite(config.resolution_m) || config.batch_size < 1 ||
      config.variance_stride < 1 || config.mean_stride < 1) {
    grid.message = "resolution_m must be positive and finite, batch_size, variance_stride and mean_stride >= 1";
    return grid;
  }
  const Vector3 half_extent = Vector3::Constant(model.domainRadiusWorld());
  const Vector3 lower = config.min_corner.value_or(model.centroid() - half_extent);
  const Vector3 upper = config.max_corner.value_or(model.centroid() + half_extent);
  if (!lower.allFinite() || !upper.allFinite() || (upper.array() <= lower.array()).any()) {
    grid.message = "grid bounds must be finite with max_corner > min_corner on every axis";
    return grid;
  }
  const Eigen::Array3d cells = ((upper - lower) / config.resolution_m).array().floor() + 1.0;
  const double num_nodes = cells.prod();
  if (num_nodes > static_cast<double>(config.max_nodes)) {
    std::ostringstream message;
    message << "grid of " << num_nodes << " nodes exceeds max_nodes = " << config.max_nodes;
    grid.message = message.str();
    return grid;
  }
  // Nodes at the centres of OctoMap's voxels (which sit at multiples of the resolution), so that
  // each voxel of the collision octree holds its node's probability.
  grid.origin = ((lower / config.resolution_m).array().floor() + 0.5).matrix() * config.resolution_m;
  grid.resolution = config.resolution_m;
  grid.size = cells.cast<int>().matrix();
  grid.probabilities.assign(static_cast<std::size_t>(num_nodes), 0.0f);
  return grid;
}

// Along one axis: the lattice's nodes at or below and above index i, and i's weight on the upper
// one. The lattice holds every stride-th index and the last.
struct Bracket {
  int lower, upper;
  double weight;
};

std::vector<Bracket> brackets(int size, int stride) {
  std::vector<Bracket> out(static_cast<std::size_t>(size));
  const int last = size - 1;
  for (int i = 0; i < size; ++i) {
    const int lower = std::min(i / stride * stride, last);
    const int upper = std::min(lower + stride, last);
    out[static_cast<std::size_t>(i)] = {lower, upper, upper > lower ? double(i - lower) / (upper - lower) : 0.0};
  }
  return out;
}

// The brackets of the three axes.
struct Lattice {
  std::vector<Bracket> x, y, z;
  Lattice(const Eigen::Vector3i& size, int stride)
      : x(brackets(size.x(), stride)), y(brackets(size.y(), stride)), z(brackets(size.z(), stride)) {}
  bool holds(int i, int j, int k) const {
    return x[static_cast<std::size_t>(i)].lower == i && y[static_cast<std::size_t>(j)].lower == j &&
           z[static_cast<std::size_t>(k)].lower == k;
  }
};

// One build of the grid's probabilities: the model's mean, gradient and variance at the nodes in
// its domain, evaluated or interpolated, then P(occupied) from them.
class GridBuild {
 public:
  GridBuild(const SurfaceModel& model, const OccupancyGridBuilder::Config& config, OccupancyGrid& grid,
            std::optional<double> occupied_probability)
      : model_(model), config_(config), grid_(grid), occupied_probability_(occupied_probability),
        num_(grid.probabilities.size()), nx_(static_cast<std::size_t>(grid.size.x())),
        ny_(static_cast<std::size_t>(grid.size.y())),
        // P > 0.5 exactly where the lowest mean is below 0, whatever the variance.
        without_variance_(occupied_probability && *occupied_probability == 0.5),
        mean_stride_(without_variance_ ? config.mean_stride : 1), variance_lattice_(grid.size, config.variance_stride),
        mean_lattice_(grid.size, mean_stride_), mean_(num_, 0.0), variance_(num_, std::nan("")),
        gradient_norm_(num_, 0.0), downhill_(num_, 0), in_domain_(num_, 0) {}

  void run() {
    findDomain();
    grid_.domain_nodes = domain_.size();
    if (mean_stride_ <= 1) {
      evaluate(domain_, true, config_.variance_stride <= 1 && !without_variance_);
      grid_.exact_mean_nodes = domain_.size();
    } else {
      evaluateMeanNearSurface();
    }
    if (without_variance_) grid_.exact_variance_nodes = 0;
    else if (config_.variance_stride <= 1) grid_.exact_variance_nodes = domain_.size();
    else evaluateVarianceOnLattice();
    setProbabilities();
  }

 private:
  Eigen::Vector3i coordinates(std::size_t n) const {
    return Eigen::Vector3i(static_cast<int>(n % nx_), static_cast<int>(n / nx_ % ny_), static_cast<int>(n / (nx_ * ny_)));
  }

  // The nodes inside the model's domain, and those of them on the variance and the mean lattices.
  void findDomain() {
    for (int k = 0; k < grid_.size.z(); ++k)
      for (int j = 0; j < grid_.size.y(); ++j)
        for (int i = 0; i < grid_.size.x(); ++i) {
          const std::size_t n = grid_.index(i, j, k);
          if (!model_.inDomain(grid_.position(i, j, k))) continue;
          domain_.push_back(n);
          in_domain_[n] = 1;
          if (variance_lattice_.holds(i, j, k)) lattice_.push_back(n);
          if (mean_stride_ > 1 && mean_lattice_.holds(i, j, k)) mean_lattice_nodes_.push_back(n);
        }
  }

  // The mean, and the variance when asked, of the nodes in `nodes`, in batches.
  void evaluate(const std::vector<std::size_t>& nodes, bool with_mean, bool with_variance) {
    Points3 batch(3, config_.batch_size);
    for (std::size_t first = 0; first < nodes.size(); first += static_cast<std::size_t>(config_.batch_size)) {
      const std::size_t count = std::min(nodes.size() - first, static_cast<std::size_t>(config_.batch_size));
      for (std::size_t q = 0; q < count; ++q) {
        const Eigen::Vector3i c = coordinates(nodes[first + q]);
        batch.col(static_cast<Eigen::Index>(q)) = grid_.position(c.x(), c.y(), c.z());
      }
      const BatchPrediction prediction =
          model_.predictBatch(batch.leftCols(static_cast<Eigen::Index>(count)), with_mean, false, with_variance);
      for (std::size_t q = 0; q < count; ++q) {
        const Eigen::Index e = static_cast<Eigen::Index>(q);
        if (with_mean) {
          const std::size_t node = nodes[first + q];
          const Vector3 gradient = prediction.gradient.col(e);
          mean_[node] = prediction.mean(e);
          gradient_norm_[node] = gradient.norm();
          Eigen::Index axis = 0;
          if (gradient.allFinite() && gradient.cwiseAbs().maxCoeff(&axis) > 0.0)
            downhill_[node] = static_cast<signed char>(gradient[axis] > 0.0 ? -(axis + 1) : axis + 1);
        }
        if (with_variance) variance_[nodes[first + q]] = prediction.variance(e);
      }
    }
  }

  // The mean on the coarse lattice first, then node by node only in the blocks the surface can
  // come within two voxels of: their corners differ in sign, or one lies closer to the zero
  // level than a block diagonal and two voxels (in f, which near the data grows like the
  // distance over the model's scale; the mesher's rule). Elsewhere the block's nodes are at
  // least two voxels from the surface, further than any voxel the thin-object rule looks at:
  // they take the corner nearest the zero level, whose sign decides them.
  void evaluateMeanNearSurface() {
    std::vector<char> evaluated(num_, 0);
    evaluate(mean_lattice_nodes_, true, false);
    for (const std::size_t n : mean_lattice_nodes_) evaluated[n] = 1;
    const double band = (std::sqrt(3.0) * mean_stride_ + 2.0) * config_.resolution_m / model_.scale();
    std::vector<std::size_t> exact;
    for (const std::size_t n : domain_) {
      if (evaluated[n]) continue;
      const Eigen::Vector3i at = coordinates(n);
      const Bracket& x = mean_lattice_.x[static_cast<std::size_t>(at.x())];
      const Bracket& y = mean_lattice_.y[static_cast<std::size_t>(at.y())];
      const Bracket& z = mean_lattice_.z[static_cast<std::size_t>(at.z())];
      double low = HUGE_VAL, high = -HUGE_VAL;
      bool complete = true;
      for (int c = 0; c < 8 && complete; ++c) {
        const std::size_t corner =
            grid_.index((c & 1) ? x.upper : x.lower, (c & 2) ? y.upper : y.lower, (c & 4) ? z.upper : z.lower);
        complete = in_domain_[corner] && std::isfinite(mean_[corner]);
        low = std::min(low, mean_[corner]);
        high = std::max(high, mean_[corner]);
      }
      if (complete && low > band) mean_[n] = low;
      else if (complete && high < -band) mean_[n] = high;
      else exact.push_back(n);
    }
    evaluate(exact, true, false);
    grid_.exact_mean_nodes = mean_lattice_nodes_.size() + exact.size();
  }

  // The variance on the lattice, trilinear between the eight lattice corners elsewhere; evaluated
  // where a corner is outside the domain.
  void evaluateVarianceOnLattice() {
    const double half = 0.5 * config_.resolution_m;
    evaluate(lattice_, false, true);
    std::vector<std::size_t> exact;
    for (const std::size_t n : domain_) {
      if (std::isfinite(variance_[n])) continue;  // a lattice node
      // Where the surface passes within half a voxel the variance has its sharp dip at the data,
      // which the lattice would smooth over, and P depends on it most.
      if (std::abs(mean_[n]) <= half * gradient_norm_[n]) {
        exact.push_back(n);
        continue;
      }
      const Eigen::Vector3i at = coordinates(n);
      const Bracket& x = variance_lattice_.x[static_cast<std::size_t>(at.x())];
      const Bracket& y = variance_lattice_.y[static_cast<std::size_t>(at.y())];
      const Bracket& z = variance_lattice_.z[static_cast<std::size_t>(at.z())];
      double interpolated = 0.0;
      bool complete = true;
      for (int c = 0; c < 8 && complete; ++c) {
        const double corner = variance_[grid_.index((c & 1) ? x.upper : x.lower, (c & 2) ? y.upper : y.lower,
                                                    (c & 4) ? z.upper : z.lower)];
        const double w = ((c & 1) ? x.weight : 1.0 - x.weight) * ((c & 2) ? y.weight : 1.0 - y.weight) *
                         ((c & 4) ? z.weight : 1.0 - z.weight);
        if (w == 0.0) continue;
        if (!std::isfinite(corner)) complete = false;
        interpolated += w * corner;
      }
      if (complete) variance_[n] = interpolated;
      else exact.push_back(n);
    }
    evaluate(exact, false, true);
    grid_.exact_variance_nodes = lattice_.size() + exact.size();
  }

  // The surface's distance from the node, linearised.
  double distance(std::size_t n) const { return gradient_norm_[n] > 0.0 ? mean_[n] / gradient_norm_[n] : HUGE_VAL; }

  // Whether the node stands for an object thinner than a voxel beside it: its neighbour one step
  // down the steepest axis is not inside either, and not nearer to the surface (one voxel of the
  // two on either side of a wall is enough).
  bool standsForThinObject(std::size_t n) const {
    if (downhill_[n] == 0) return false;
    Eigen::Vector3i at = coordinates(n);
    const int axis = std::abs(downhill_[n]) - 1;
    at[axis] += downhill_[n] > 0 ? 1 : -1;
    if (at[axis] < 0 || at[axis] >= grid_.size[axis]) return true;
    const std::size_t m = grid_.index(at.x(), at.y(), at.z());
    return !(mean_[m] < 0.0) && distance(n) <= distance(m);
  }

  // A voxel whose centre is inside is occupied. So is one whose centre is outside with the surface
  // within half a voxel of it (the smallest mean over the ball inscribed in the voxel, linearised
  // about its centre, mean - (resolution / 2) |grad mean|, is below 0) when the neighbour across
  // that surface, one step down the steepest axis, is not inside either: the object between them
  // is thinner than a voxel (a wall, a rim, a handle) and would otherwise vanish from the map.
  // The nearer of the two stands for it. Where that neighbour is inside, it stands for the
  // object, and the map is not grown.
  void setProbabilities() {
    // Reported variance -> raw posterior variance, the one that is commensurate with f.
    const double unit = model_.varianceUnitFactor();
    const double half = 0.5 * config_.resolution_m;
    for (const std::size_t n : domain_) {
      const double sd = std::sqrt(std::max(variance_[n] / unit, 0.0));
      const bool thin = mean_[n] >= 0.0 && mean_[n] < half * gradient_norm_[n] && standsForThinObject(n);
      const double lowest = thin ? mean_[n] - half * gradient_norm_[n] : mean_[n];
      double p = 0.0;
      if (without_variance_) p = lowest < 0.0 ? 1.0 : (std::isfinite(lowest) ? 0.0 : 0.5);
      else if (!std::isfinite(lowest) || !std::isfinite(sd)) p = 0.5;  // unknown
      else if (sd > 0.0) p = standardNormalCdf(-lowest / sd);
      else p = lowest < 0.0 ? 1.0 : 0.0;
      if (occupied_probability_) p = p > *occupied_probability_ ? 1.0 : 0.0;
      grid_.probabilities[n] = static_cast<float>(p);
    }
  }

  const SurfaceModel& model_;
  const OccupancyGridBuilder::Config& config_;
  OccupancyGrid& grid_;
  const std::optional<double> occupied_probability_;
  const std::size_t num_, nx_, ny_;
  const bool without_variance_;
  const int mean_stride_;
  const Lattice variance_lattice_, mean_lattice_;
  std::vector<double> mean_, variance_, gradient_norm_;
  // The neighbour one step down the mean's steepest axis (+-(axis + 1), 0 for none): across the
  // surface when the surface is near.
  std::vector<signed char> downhill_;
  std::vector<char> in_domain_;
  std::vector<std::size_t> domain_, lattice_, mean_lattice_nodes_;
};

}  // namespace

OccupancyGrid OccupancyGridBuilder::buildGrid(const SurfaceModel& model, std::optional<double> occupied_probability) const {
  if (!model.isFitted()) {
    OccupancyGrid grid;
    grid.message = "no model: the GP is not fitted";
    return grid;
  }
  OccupancyGrid grid = layoutGrid(model, config_);
  if (!grid.message.empty()) return grid;
  GridBuild(model, config_, grid, occupied_probability).run();
  grid.ok = true;
  return grid;
}

}  // namespace gpatlas_core
