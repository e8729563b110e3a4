#pragma once

#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// A regular grid of P(occupied) for the collision map used while approaching a touch.
// Node (i, j, k) sits at origin + resolution * (i, j, k), the centre of a voxel of the lattice of
// cubes whose corners are multiples of the resolution (OctoMap's); i runs fastest in `probabilities`.
struct OccupancyGrid {
  bool ok{false};
  std::string message;
  Vector3 origin{Vector3::Zero()};
  double resolution{0.0};
  Eigen::Vector3i size{Eigen::Vector3i::Zero()};
  std::vector<float> probabilities;

  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(size.x()) *
           (static_cast<std::size_t>(j) + static_cast<std::size_t>(size.y()) * static_cast<std::size_t>(k));
  }
  Vector3 position(int i, int j, int k) const { return origin + resolution * Vector3(i, j, k); }
  std::size_t domain_nodes{0};          // nodes inside the model's domain
  std::size_t exact_mean_nodes{0};      // of which the mean was evaluated
  std::size_t exact_variance_nodes{0};  // of which the variance was evaluated, not interpolated
};

// Builds the grid from the GP. A node (a voxel's centre) inside the object (mean < 0) has
// P(occupied) = Phi(-mean / sqrt(variance)), the probability that f < 0 there. A node outside
// with the surface within half a voxel (lowest = mean - (resolution / 2) |grad mean| < 0, the
// smallest mean over the ball inscribed in its voxel, linearised) whose neighbour one step down
// the mean's steepest axis is not inside either has the object between them thinner than a voxel:
// the nearer of the two to the surface gets Phi(-lowest / sqrt(variance)), and a wall thinner
// than a voxel stays in the map. The variance is in the GP's own (raw) units. Nodes outside the
// model's domain get 0: there the model is pinned to +1 by its outside pseudo-points, i.e. it
// regards them as free.
class OccupancyGridBuilder {
 public:
  struct Config {
    double resolution_m{0.01};
    // Axis-aligned bounds; without them the cube enclosing the model's domain ball.
    std::optional<Vector3> min_corner;
    std::optional<Vector3> max_corner;
    // Refuses grids with more nodes than this instead of running for minutes.
    std::size_t max_nodes{2'000'000};
    // GP queries per batch: bounds the n x batch cross-covariance matrix in memory.
    int batch_size{2048};
    // The mean and its gradient are evaluated at every node, the variance, which costs far more
    // (a triangular solve per node), on every variance_stride-th node of each axis and
    // interpolated trilinearly in between (1: at every node), except where the surface passes
    // within half a voxel of the node. Which nodes are occupied (P > 0.5) does not depend on it.
    int variance_stride{2};
    // For buildOccupancy at 0.5 (the approach planner's map), the mean too is evaluated on every
    // mean_stride-th node first, then node by node only in the blocks the surface can come within
    // two voxels of (1: every node).
    int mean_stride{2};
  };

  OccupancyGridBuilder() = default;
  explicit OccupancyGridBuilder(Config config) : config_(std::move(config)) {}
  OccupancyGrid build(const SurfaceModel& model) const;
  // The grid as a planner that only asks "P > occupied_probability?" sees it: 1 where build()'s P
  // exceeds occupied_probability, 0 elsewhere. At 0.5 no variance is evaluated (P > 0.5 exactly
  // where the lowest mean is below 0), which is most of build()'s cost, and the mean only near the
  // surface (mean_stride); at any other threshold the grid is build()'s, thresholded.
  // occupied_probability must be in (0, 1).
  OccupancyGrid buildOccupancy(const SurfaceModel& model, double occupied_probability) const;

 private:
  OccupancyGrid buildGrid(const SurfaceModel& model, std::optional<double> occupied_probability) const;

  Config config_;
};

// Standard normal cumulative distribution.
double standardNormalCdf(double x);

}  // namespace gpatlas_core
