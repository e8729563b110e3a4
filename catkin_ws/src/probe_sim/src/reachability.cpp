#include "probe_sim/reachability.h"

#include <cmath>
#include <stdexcept>

namespace probe_sim {

namespace {

std::vector<Eigen::Vector3d> latticeDirections(int count) {
  std::vector<Eigen::Vector3d> directions;
  const double golden_angle = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    directions.emplace_back(r * std::cos(golden_angle * i), r * std::sin(golden_angle * i), z);
  }
  return directions;
}

}  // namespace

std::vector<bool> reachableFromOutside(const Scene& scene, const std::vector<Eigen::Vector3d>& points,
                                       const ReachabilityConfig& config) {
  if (config.directions < 1) throw std::invalid_argument("reachableFromOutside: directions must be >= 1");
  if (!(config.start_offset_m >= 0.0) || !std::isfinite(config.start_offset_m))
    throw std::invalid_argument("reachableFromOutside: start_offset_m must be finite and >= 0");
  const std::vector<Eigen::Vector3d> directions = latticeDirections(config.directions);
  // Long enough to leave the object's box and the table's from anywhere on them: a line that
  // ends inside a solid is not seen to cross it.
  const Eigen::AlignedBox3d box = scene.objectMesh().boundingBox();
  double length = 2.0 * (box.isEmpty() ? 1.0 : box.diagonal().norm()) + 0.1;
  if (scene.config().add_table)
    length += scene.config().table_size_xy.norm() + scene.config().table_centre_xy.norm() +
              scene.config().table_thickness;
  std::vector<bool> reachable(points.size(), false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& p = points[i];
    if (!p.allFinite()) continue;
    for (const Eigen::Vector3d& d : directions) {
      const Eigen::Vector3d start = p + config.start_offset_m * d, end = p + length * d;
      // Both ways: a ray that starts inside a solid (the table under a face resting on it)
      // leaves it without a hit, the reverse ray does not.
      if (!scene.castRay(start, end, config.blocking_kinds).hit && !scene.castRay(end, start, config.blocking_kinds).hit) {
        reachable[i] = true;
        break;
      }
    }
  }
  return reachable;
}

ReachableSurface splitReachableSurface(const Scene& scene, const ReachabilityConfig& config) {
  const TriangleMesh& mesh = scene.objectMesh();
  std::vector<Eigen::Vector3d> centroids;
  centroids.reserve(mesh.triangles.size());
  for (const Eigen::Vector3i& t : mesh.triangles)
    centroids.push_back((mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0);
  const std::vector<bool> reachable = reachableFromOutside(scene, centroids, config);
  ReachableSurface result;
  result.triangle_reachable = reachable;
  result.triangles_tested = mesh.triangles.size();
  result.reachable.vertices = mesh.vertices;
  double total_area = 0.0, reachable_area = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    const double area = 0.5 * (mesh.vertices[tri[1]] - mesh.vertices[tri[0]])
                                   .cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]])
                                   .norm();
    total_area += area;
    if (!reachable[t]) continue;
    reachable_area += area;
    result.reachable.triangles.push_back(mesh.triangles[t]);
  }
  result.reachable_area_fraction = total_area > 0.0 ? reachable_area / total_area : 0.0;
  return result;
}

}  // namespace probe_sim
