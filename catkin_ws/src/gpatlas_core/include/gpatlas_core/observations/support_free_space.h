#pragma once

#include "gpatlas_core/observations/support_plane.h"
#include "gpatlas_core/observations/view_samples.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// The table the camera saw beside the object: free space at the support's surface where the
// object's silhouette does not cover it. Why: the side of a low object (a spoon, a pan, the foot
// of a bowl) is seen edge-on or not at all, so the object's own view says nothing about where it
// ends along the table, and the smooth coarse level lets the prediction bleed out over the
// table. The camera's ray to a table point beside the object crossed only air, so that point is
// outside the object. (MultiscaleGpisModel gives them to its cells only, which correct that
// bleed next to the data.)
//
// Candidates lie on a square lattice at height_m above the plane. One is kept when
// - no view point in its pixel of a range image of the view (or the 8 around it) is nearer to the
//   sensor than it: the camera saw past the object there;
// - it lies outside the convex hull of the view's projection on the plane, between
//   min_distance_m and max_distance_m from every projected view point;
// - its distance to the surface is known to within max_bound_gap_m (below).
// Segmentation removes the object's lowest millimetres with the table
// (segmentation/plane_distance_m), so the range image misses them. Within the hull, the table the
// camera saw may be the object's own floor (a pan's or a tray's), or a table point under an
// overhang that touches the table (a torus, a ball), a hair from the cut-away surface; the margin
// keeps the samples off a wall's foot.
// The distance to the surface lies between two bounds: the planar distance to the projected view
// (below it, unless the object flares out under its outline) and the distance to the nearest view
// point (above it). They agree beside a side the camera saw down to the table. Beside a side it
// did not see, the view does not say how far the side is: a box's wall is at the planar distance,
// a ball's lower half curves in far from it, and both have their nearest view point high above.
// Label: the middle of the two bounds.
struct SupportFreeSpaceConfig {
  double spacing_m{0.003};
  double height_m{0.001};
  double min_distance_m{0.006};
  double max_distance_m{0.02};
  double max_bound_gap_m{0.005};
  // The range image's pixel: its footprint at the range of the view's centroid (about twice the
  // view's point spacing, so that the silhouette has no holes).
  double pixel_m{0.004};
  // At most this many (an even subset); 0 disables them.
  int max_points{5000};
  // Noise sigma (reference units), as the camera's free space along its rays, whose labels are
  // not exact either.
  double noise_sigma{0.3162};
};

// Label kOutside, source kViewSupport, surface_distance_m set. Fails when the sensor is not
// above the plane or the view is not in front of the sensor.
ViewSamples sampleSupportFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                     const SupportPlane& plane, const SupportFreeSpaceConfig& config);

}  // namespace gpatlas_core
