#pragma once

// Analytic scenes for the approach planners' tests: axis-aligned boxes, and octrees made of them
// as the CollisionMap nodelet builds its maps.
#include <octomap/OcTree.h>

#include <Eigen/Core>

#include <cmath>
#include <memory>
#include <vector>

namespace gpatlas_motion_test {

constexpr double kVoxel = 0.01;

struct Box {
  Eigen::Vector3d lower, upper;
  double distance(const Eigen::Vector3d& p) const {
    return (lower - p).cwiseMax(p - upper).cwiseMax(0.0).norm();  // 0 inside
  }
};

// Every voxel of the region known: P(occupied) 0.999 inside the boxes (by voxel centre) and
// 0.001 elsewhere.
inline std::shared_ptr<octomap::OcTree> mapOf(const std::vector<Box>& boxes, const Box& region) {
  auto tree = std::make_shared<octomap::OcTree>(kVoxel);
  const float occupied = std::log(0.999f / 0.001f), free = -occupied;
  for (double x = region.lower.x() + 0.5 * kVoxel; x < region.upper.x(); x += kVoxel)
    for (double y = region.lower.y() + 0.5 * kVoxel; y < region.upper.y(); y += kVoxel)
      for (double z = region.lower.z() + 0.5 * kVoxel; z < region.upper.z(); z += kVoxel) {
        bool inside = false;
        for (const Box& b : boxes) inside = inside || b.distance(Eigen::Vector3d(x, y, z)) == 0.0;
        tree->setNodeValue(octomap::point3d(float(x), float(y), float(z)), inside ? occupied : free);
      }
  tree->updateInnerOccupancy();
  return tree;
}

}  // namespace gpatlas_motion_test
