#include "probe_sim/depth_camera.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace probe_sim {

Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& up) {
  const Eigen::Vector3d forward = target - eye;
  if (forward.norm() < 1e-12) throw std::runtime_error("lookAt: eye and target coincide");
  const Eigen::Vector3d z = forward.normalized();
  // Image rows grow downwards, so the optical y axis is the negated "up" seen by the camera.
  const Eigen::Vector3d x_unnormalised = z.cross(up);
  if (x_unnormalised.norm() < 1e-9) {
    throw std::runtime_error("lookAt: up vector is parallel to the viewing direction");
  }
  const Eigen::Vector3d x = x_unnormalised.normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = y;
  pose.linear().col(2) = z;
  pose.translation() = eye;
  return pose;
}

DepthCamera::DepthCamera(const Config& config, const Eigen::Isometry3d& pose)
    : config_(config), pose_(pose), rng_(config.seed) {
  if (config_.width <= 0 || config_.height <= 0 || config_.pixel_stride <= 0) {
    throw std::runtime_error("DepthCamera: width, height and pixel_stride must be > 0");
  }
  if (!(config_.horizontal_fov_rad > 0.0 && config_.horizontal_fov_rad < M_PI)) {
    throw std::runtime_error("DepthCamera: horizontal field of view must be in (0, pi)");
  }
  if (!(config_.min_range_m >= 0.0 && config_.max_range_m > config_.min_range_m)) {
    throw std::runtime_error("DepthCamera: need 0 <= min_range_m < max_range_m");
  }
  if (!(config_.depth_noise_sigma_m >= 0.0)) {
    throw std::runtime_error("DepthCamera: depth noise sigma must be >= 0");
  }
  focal_px_ = (config_.width / 2.0) / std::tan(config_.horizontal_fov_rad / 2.0);
}

DepthCloud DepthCamera::capture(const Scene& scene) {
  const double cx = (config_.width - 1) / 2.0;
  const double cy = (config_.height - 1) / 2.0;
  // The table always blocks rays (it occludes whatever is behind it); it is only dropped from
  // the returned cloud.
  unsigned returned_kinds = static_cast<unsigned>(SurfaceKind::kObject);
  if (config_.include_table) returned_kinds |= static_cast<unsigned>(SurfaceKind::kTable);
  if (config_.include_obstacles) returned_kinds |= static_cast<unsigned>(SurfaceKind::kObstacle);

  std::normal_distribution<double> noise(0.0, config_.depth_noise_sigma_m);
  std::vector<Eigen::Vector3d> camera_points;
  DepthCloud cloud;
  const Eigen::Vector3d origin = pose_.translation();
  for (int row = 0; row < config_.height; row += config_.pixel_stride) {
    for (int column = 0; column < config_.width; column += config_.pixel_stride) {
      // Direction with unit optical z, so that depth = distance along it.
      const Eigen::Vector3d ray((column - cx) / focal_px_, (row - cy) / focal_px_, 1.0);
      const Eigen::Vector3d end = pose_ * (config_.max_range_m * ray);
      const RayHit hit = scene.castRay(origin, end);
      if (!hit.hit) continue;
      if ((static_cast<unsigned>(hit.kind) & returned_kinds) == 0) continue;
      double depth = hit.distance / ray.norm();
      if (config_.depth_noise_sigma_m > 0.0) depth += noise(rng_);
      if (depth < config_.min_range_m || depth > config_.max_range_m) continue;
      camera_points.push_back(depth * ray);
      cloud.labels.push_back(hit.kind);
      cloud.pixels.emplace_back(column, row);
    }
  }
  cloud.points_camera.resize(3, static_cast<Eigen::Index>(camera_points.size()));
  for (std::size_t i = 0; i < camera_points.size(); ++i) {
    cloud.points_camera.col(static_cast<Eigen::Index>(i)) = camera_points[i];
  }
  cloud.points_world = pose_ * cloud.points_camera;
  return cloud;
}

}  // namespace probe_sim
