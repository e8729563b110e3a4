#pragma once

// The procedural sphere the probe and camera tests measure against: 10 cm across, resting on
// the table, and the bound on how far its flat facets lie from the analytic sphere.

#include "probe_sim/object_mesh.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

namespace probe_sim_test {

constexpr double kSize = 0.10;
constexpr double kRadius = kSize / 2;
const Eigen::Vector3d kCentre(0.0, 0.0, kRadius);

// Largest distance between the tessellated and the analytic sphere, measured on the mesh: the
// flat triangles lie between their plane's distance from the centre and the radius.
inline double sagittaBound(const probe_sim::TriangleMesh& mesh) {
  double closest_plane = kRadius;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3d on_plane = mesh.vertices[mesh.triangles[t][0]];
    closest_plane = std::min(closest_plane, std::abs(mesh.triangleNormal(t).dot(on_plane - kCentre)));
  }
  return kRadius - closest_plane;
}

}  // namespace probe_sim_test
