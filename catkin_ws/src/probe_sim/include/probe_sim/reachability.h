#pragma once

#include "probe_sim/object_mesh.h"
#include "probe_sim/scene.h"

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace probe_sim {

// Which parts of an object's surface anything outside it can see or touch. A scanned mesh
// often has surface no exterior sensor reaches: the inner layers of a wall scanned as several
// sheets, the inside of a closed vessel. A camera and a ray probe meet only the first surface
// along their line, so nothing they measure is on those parts: a prediction that is exactly the
// reachable surface still has their distance to it as truth-to-predicted error.
struct ReachabilityConfig {
  // Straight escape lines tried per point (a Fibonacci lattice on the sphere). A point seen
  // only through a narrow opening needs many: with too few, no line passes through it and the
  // point counts as unreachable.
  int directions{256};
  // Lines start this far off the surface along their direction, so that they do not hit the
  // triangle they start on; sheets closer together than this are not told apart.
  double start_offset_m{1e-5};
  // The surfaces that block a line (SurfaceKind bits): the object, and the table where the
  // scene has one (what stands on a table is not reachable from below it).
  unsigned blocking_kinds{kAllSurfaces};
};

// For every point: true when a straight line from it runs out of the scene in at least one of
// the directions without meeting a blocking surface. Points that are not finite are false.
std::vector<bool> reachableFromOutside(const Scene& scene, const std::vector<Eigen::Vector3d>& points,
                                       const ReachabilityConfig& config = ReachabilityConfig());

// The scene's object mesh split by reachability of each triangle's centroid.
struct ReachableSurface {
  TriangleMesh reachable;            // the triangles whose centroid is reachable
  std::vector<bool> triangle_reachable;  // per triangle of the object mesh
  double reachable_area_fraction{0.0};
  std::size_t triangles_tested{0};
};
ReachableSurface splitReachableSurface(const Scene& scene, const ReachabilityConfig& config = ReachabilityConfig());

}  // namespace probe_sim
