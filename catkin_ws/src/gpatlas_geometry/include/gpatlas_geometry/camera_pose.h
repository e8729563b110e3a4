#pragma once

// The camera's pose from one of its clouds: the table is the world's z = 0 (README, "Your own
// camera"). Implemented with PCL's RANSAC in gpatlas_segmentation.

#include "gpatlas_core/common/types.h"

#include <Eigen/Geometry>

#include <cstddef>
#include <string>
#include <vector>

namespace gpatlas_geometry {

// The tool's settings (estimate_camera_pose's flags).
struct CameraPoseConfig {
  // RANSAC's inlier band: stereo and structured-light depth is noisier than the segmentation's
  // 4 mm at a metre.
  double plane_distance_m{0.01};
  int max_iterations{1000};
  // The table's normal lies within this of the camera's up (-y of an optical frame, z forward),
  // which is how far the camera looks down at it. A wall facing the camera lies 90 degrees
  // minus that from its up: 60 takes cameras looking up to 60 degrees down, and no wall while
  // they look less than 30 degrees down; a steeper camera needs more.
  double max_tilt_deg{60.0};
  // At most this many points go into RANSAC (every k-th of a larger cloud): a 640 x 480 cloud
  // costs seconds otherwise, for the same plane.
  std::size_t max_points{60000};
  std::size_t min_inliers{500};
};

struct CameraPose {
  bool ok{false};
  std::string message;  // why not, when !ok
  // The cloud's frame in the world frame: p_world = rotation * p_cloud + translation. The world
  // has the table at z = 0, z up, its origin under the camera and x along the optical axis
  // projected onto the table (along the image's up when it looks straight down).
  Eigen::Vector3d translation{Eigen::Vector3d::Zero()};
  Eigen::Quaterniond rotation{Eigen::Quaterniond::Identity()};
  // The table in the cloud's frame, n . x + d = 0, n toward the camera (d: its height).
  Eigen::Vector3d table_normal{Eigen::Vector3d::UnitZ()};
  double table_offset{0.0};
  std::size_t inliers{0};  // of the points RANSAC saw
  double looking_down_deg{0.0};  // the optical axis's angle below the table's plane
};

// The largest plane whose normal is within max_tilt_deg of the camera's up, as the table.
// `points` are in the camera's optical frame (z along the view, y down); non-finite ones are
// skipped.
CameraPose estimateCameraPose(const std::vector<gpatlas_core::Vector3>& points, const CameraPoseConfig& config = {});

// "x y z qx qy qz qw", as recorded_cloud.launch's camera_pose (static_transform_publisher).
std::string cameraPoseArgument(const CameraPose& pose);

}  // namespace gpatlas_geometry
