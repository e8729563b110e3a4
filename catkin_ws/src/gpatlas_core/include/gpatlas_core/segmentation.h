#pragma once

#include "gpatlas_core/types.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// Counts after each stage, so that a user can see which one removed the object.
struct SegmentationStats {
  std::size_t input{0};
  std::size_t finite{0};
  std::size_t after_crop{0};
  std::size_t after_voxel{0};
  std::size_t plane_inliers{0};
  std::size_t after_plane{0};
  std::size_t after_outliers{0};
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
};

// Extracts the object from a scene cloud in the world frame (z up): crop box, voxel grid,
// RANSAC removal of the (near-horizontal) support plane, statistical outlier removal and
// Euclidean clustering; keeps the largest cluster, or the one closest to a hint point.
// Implemented with PCL in its own library (gpatlas_segmentation).
class ObjectSegmenter {
 public:
  struct Config {
    Vector3 crop_min_m{0.2, -0.5, -0.05};
    Vector3 crop_max_m{1.4, 0.5, 0.6};
    double voxel_leaf_m{0.002};  // 0 disables the voxel grid
    bool remove_plane{true};
    double plane_distance_m{0.006};
    int plane_max_iterations{300};
    double plane_max_tilt_deg{20.0};  // only planes whose normal is this close to world z
    std::size_t plane_min_inliers{200};
    // The plane is a support only if at most this fraction of the points lies below it.
    double plane_max_fraction_below{0.05};
    int outlier_mean_k{20};           // 0 disables statistical outlier removal
    double outlier_stddev_multiplier{2.5};
    double cluster_tolerance_m{0.012};
    std::size_t cluster_min_points{50};
    std::size_t cluster_max_points{2'000'000};
    // Keep the cluster closest to this point instead of the largest one.
    std::optional<Vector3> object_hint_m;
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

}  // namespace gpatlas_core
