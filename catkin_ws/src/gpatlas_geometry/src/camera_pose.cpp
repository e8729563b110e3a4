#include "gpatlas_geometry/camera_pose.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace gpatlas_geometry {

namespace {

// The finite points, every k-th when there are more than max_points.
pcl::PointCloud<pcl::PointXYZ>::Ptr thinned(const std::vector<gpatlas_core::Vector3>& points, std::size_t max_points) {
  std::size_t finite = 0;
  for (const auto& p : points) finite += p.allFinite() ? 1 : 0;
  const std::size_t stride = std::max<std::size_t>(1, (finite + max_points - 1) / std::max<std::size_t>(1, max_points));
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  std::size_t k = 0;
  for (const auto& p : points) {
    if (!p.allFinite()) continue;
    if (k++ % stride == 0) cloud->push_back(pcl::PointXYZ(float(p.x()), float(p.y()), float(p.z())));
  }
  return cloud;
}

}  // namespace

CameraPose estimateCameraPose(const std::vector<gpatlas_core::Vector3>& points, const CameraPoseConfig& c) {
  CameraPose pose;
  const pcl::PointCloud<pcl::PointXYZ>::Ptr cloud = thinned(points, c.max_points);
  if (cloud->size() < c.min_inliers) {
    pose.message = "the cloud has " + std::to_string(cloud->size()) + " finite points, fewer than the " +
                   std::to_string(c.min_inliers) + " a table needs";
    return pose;
  }
  pcl::SACSegmentation<pcl::PointXYZ> sac;
  sac.setOptimizeCoefficients(true);
  // The camera's up in an optical frame is -y: the table's normal lies near it.
  sac.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  sac.setAxis(Eigen::Vector3f(0.0f, -1.0f, 0.0f));
  sac.setEpsAngle(c.max_tilt_deg * M_PI / 180.0);
  sac.setMethodType(pcl::SAC_RANSAC);
  sac.setDistanceThreshold(c.plane_distance_m);
  sac.setMaxIterations(c.max_iterations);
  sac.setInputCloud(cloud);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coefficients;
  sac.segment(inliers, coefficients);
  pose.inliers = inliers.indices.size();
  if (coefficients.values.size() != 4 || pose.inliers < c.min_inliers) {
    std::ostringstream message;
    message << "no table: the largest plane within " << c.max_tilt_deg << " degrees of the camera's up (-y) has "
            << pose.inliers << " of " << cloud->size() << " points within " << c.plane_distance_m
            << " m, fewer than " << c.min_inliers << " (is the cloud in the camera's optical frame, z forward, y down?)";
    pose.message = message.str();
    return pose;
  }
  Eigen::Vector3d n(coefficients.values[0], coefficients.values[1], coefficients.values[2]);
  double d = coefficients.values[3] / n.norm();
  n.normalize();
  // Toward the camera (at the origin): the camera is above the table, d its height.
  if (d < 0.0) n = -n, d = -d;
  if (d < 1e-3) {
    pose.message = "the plane found passes through the camera: no table in view";
    return pose;
  }
  // x: the optical axis projected onto the table; straight down, the image's up (-y).
  Eigen::Vector3d x = Eigen::Vector3d::UnitZ() - n.z() * n;
  if (x.norm() < 1e-3) x = -Eigen::Vector3d::UnitY() + n.y() * n;
  x.normalize();
  const Eigen::Vector3d y = n.cross(x);
  Eigen::Matrix3d world_axes;  // the world's axes in the cloud's frame, as columns
  world_axes << x, y, n;
  // p_world = M^T (p_cloud - o) with o = -d n, the camera's foot on the table.
  const Eigen::Matrix3d rotation = world_axes.transpose();
  pose.rotation = Eigen::Quaterniond(rotation).normalized();
  // q and -q are one rotation: w >= 0 prints the same argument for the same pose.
  if (pose.rotation.w() < 0.0) pose.rotation.coeffs() *= -1.0;
  // rotation * (d n): the camera straight above the origin (x and y are 0 by construction).
  pose.translation = Eigen::Vector3d(0.0, 0.0, d);
  pose.table_normal = n;
  pose.table_offset = d;
  pose.looking_down_deg = std::asin(std::clamp(-n.z(), -1.0, 1.0)) * 180.0 / M_PI;
  pose.ok = true;
  return pose;
}

std::string cameraPoseArgument(const CameraPose& pose) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(6) << pose.translation.x() << " " << pose.translation.y() << " "
      << pose.translation.z() << " " << pose.rotation.x() << " " << pose.rotation.y() << " " << pose.rotation.z() << " "
      << pose.rotation.w();
  return out.str();
}

}  // namespace gpatlas_geometry
