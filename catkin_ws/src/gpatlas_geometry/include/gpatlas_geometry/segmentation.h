#pragma once

#include "gpatlas_core/common/types.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_geometry {

using gpatlas_core::Vector3;

// Counts after each stage, so that a user can see which one removed the object.
struct SegmentationStats {
  std::size_t input{0};
  std::size_t finite{0};
  std::size_t after_crop{0};
  std::size_t after_voxel{0};
  std::size_t plane_inliers{0};
  std::size_t after_plane{0};
  std::size_t clusters{0};
  std::size_t object{0};
};

struct SegmentationResult {
  bool ok{false};
  std::string message;
  std::vector<Vector3> object_points;  // world frame, metres
  Vector3 plane_normal{Vector3::UnitZ()};
  double plane_offset{0.0};  // n . x + d = 0 of the removed support plane, when found
  bool plane_found{false};
  SegmentationStats stats;
  // Every cluster (world frame), the object's at object_cluster: what a user picks from, and
  // the other objects on the table.
  std::vector<std::vector<Vector3>> clusters;
  std::size_t object_cluster{0};
};

// Extracts the object from a scene cloud in the world frame (z up): crop box, voxel grid,
// RANSAC removal of the (near-horizontal) support plane and Euclidean clustering, in which
// isolated speckle falls out (cluster_min_points); keeps the largest cluster, or the one closest
// to a hint point.
// Implemented with PCL in its own library (gpatlas_segmentation).
class ObjectSegmenter {
 public:
  struct Config {
    Vector3 crop_min_m{0.2, -0.5, -0.05};
    Vector3 crop_max_m{1.4, 0.5, 0.6};
    std::optional<double> voxel_leaf_m{0.002};  // empty: no voxel grid
    bool remove_plane{true};
    // Points within this distance of the support plane are the table: about 4 depth-noise
    // sigmas (the simulated camera's is 1 mm). Larger removes the foot of every object and most
    // of a flat one (a pan, a spoon lying down).
    double plane_distance_m{0.004};
    int plane_max_iterations{300};
    double plane_max_tilt_deg{20.0};  // only planes whose normal is this close to world z
    std::size_t plane_min_inliers{200};
    // The plane is a support only if at most this fraction of the points lies below it.
    double plane_max_fraction_below{0.05};
    // Single-linkage distance: larger than the gaps that occlusion and grazing rays leave
    // between parts of one object (a funnel's spout and its rim), smaller than the space
    // between two objects.
    double cluster_tolerance_m{0.02};
    std::size_t cluster_min_points{50};
    std::size_t cluster_max_points{2'000'000};
    // Keep the cluster closest to this point instead of the largest one.
    std::optional<Vector3> object_hint_m;
    // A user's pick (a clicked point on the object's visible surface) selects the cluster with
    // a point this close to it (about a click's error on a depth cloud), else none.
    double select_max_distance_m{0.03};
  };

  ObjectSegmenter() = default;
  explicit ObjectSegmenter(Config config) : config_(std::move(config)) {}
  const Config& config() const { return config_; }
  SegmentationResult segment(const std::vector<Vector3>& world_points) const;

 private:
  Config config_;
};

// Empty when the config is usable, else what is wrong with it.
std::string validate(const ObjectSegmenter::Config& config);

// The cluster a point picks: the one with a point nearest to `point`, when that point lies
// within max_distance_m of it; nullopt otherwise (no cluster, or all farther). `nearest_m`
// (optional) gets that nearest distance (infinity without clusters).
std::optional<std::size_t> clusterNear(const std::vector<std::vector<Vector3>>& clusters, const Vector3& point,
                                       double max_distance_m, double* nearest_m = nullptr);

// The object among the clusters: the largest, or the one whose centroid is closest to the hint
// (the first on a tie; 0 for no cluster).
std::size_t chooseObject(const std::vector<std::vector<Vector3>>& clusters, const std::optional<Vector3>& hint);

// The mean of the points (zero for none): the hint that keeps a picked cluster in later clouds.
Vector3 centroidOf(const std::vector<Vector3>& points);

}  // namespace gpatlas_geometry
