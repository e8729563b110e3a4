#pragma once

#include "probe_sim/scene.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <random>
#include <vector>

namespace probe_sim {

// Camera pose (optical frame: z forward, x right, y down, in the world) looking from eye at
// target; up is the world direction that should appear upwards in the image. Throws
// std::runtime_error when eye == target or up is parallel to the viewing direction.
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());

struct DepthCloud {
  Eigen::Matrix3Xd points_camera;  // optical frame
  Eigen::Matrix3Xd points_world;
  std::vector<SurfaceKind> labels;        // what each point lies on
  std::vector<Eigen::Vector2i> pixels;    // (column, row) of each point
};

// Pinhole depth camera that casts one ray per (strided) pixel into the scene. Only the first
// surface along each ray is returned, so the cloud is the partial view a real sensor gets.
class DepthCamera {
 public:
  struct Config {
    int width = 320;
    int height = 240;
    double horizontal_fov_rad = 1.0227;  // 58.6 degrees, like a Kinect / Xtion
    double min_range_m = 0.3;            // on depth (optical z), as depth sensors report it
    double max_range_m = 3.0;
    double depth_noise_sigma_m = 0.0;    // Gaussian, along the optical z axis
    int pixel_stride = 1;                // cast every n-th row and column
    bool include_table = false;          // points on the table are returned (and labelled)
    bool include_obstacles = false;
    std::uint32_t seed = 1;
  };

  DepthCamera(const Config& config, const Eigen::Isometry3d& pose);

  void setPose(const Eigen::Isometry3d& pose) { pose_ = pose; }
  const Eigen::Isometry3d& pose() const { return pose_; }
  const Config& config() const { return config_; }
  double focalLengthPixels() const { return focal_px_; }

  // Each call draws new noise from the camera's generator.
  DepthCloud capture(const Scene& scene);

 private:
  Config config_;
  Eigen::Isometry3d pose_;
  double focal_px_;
  std::mt19937 rng_;
};

}  // namespace probe_sim
