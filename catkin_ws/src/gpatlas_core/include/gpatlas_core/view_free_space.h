#pragma once

#include "gpatlas_core/types.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// Free space seen by a depth sensor: every pixel's ray crossed empty space between the sensor
// and the surface it hit. Samples along those rays are outside points for the GPIS, labelled
// with their distance to the nearest observed surface point (an upper bound on the true
// distance, see GpisModel::nearestSurfaceDistance).
//
// Why: surface points alone leave the sign of f undetermined wherever the data have a gap. A
// smooth GP then closes the opening of a cup, a bowl or a funnel with a lid, because the
// centroid's inside point (or the general "inside is the bulk" bias) makes the cavity's air
// inside. The camera looked through that opening; its rays say the cavity is empty.
struct ViewFreeSpaceConfig {
  // Rays used (a random subset of the view's points when it has more).
  int max_rays{300};
  int samples_per_ray{2};
  // Sample depths before the hit, as fractions of the view's radius (the largest distance of
  // a view point from their centroid): close enough to shape the surface, far enough to clear
  // the sensor noise and to reach into a cavity.
  double min_offset_fraction{0.05};
  double max_offset_fraction{1.0};
  // Noise sigma of the samples, in the model's reference units (as the touch free space).
  double noise_sigma{0.3162};
  std::uint64_t seed{1};
};

struct ViewFreeSpace {
  bool ok{false};
  std::string message;
  // Label kOutside, source kVision (they belong to the view: a new view replaces them),
  // surface_distance_m set.
  std::vector<TrainingPoint> points;
};

// `surface_points` are the view's points (world frame, every one of them: the labels use the
// nearest); `sensor_origin` is the optical centre in the same frame.
ViewFreeSpace sampleViewFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                  const ViewFreeSpaceConfig& config = ViewFreeSpaceConfig());

// Free space just in front of every view point, along its camera ray: a thin part (a handle, a
// mug's wall) is a few millimetres of material between two such layers, and a model that can
// resolve it needs them to tell its two faces from a blob. The sparse ray samples above are
// too few and too far out for that. Labels: the distance to the nearest view point (at most
// offset_m).
struct NearSurfaceFreeSpaceConfig {
  // Distance in front of each view point, along the ray to the sensor.
  double offset_m{0.003};
  // At most this many (an even subset of the view's points); 0 disables them.
  int max_points{50000};
  // Noise sigma of the samples, in the model's reference units.
  double noise_sigma{0.1};
};

ViewFreeSpace sampleNearSurfaceFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                         const NearSurfaceFreeSpaceConfig& config);

// The occluded interior of a view: places behind the observed surface (farther along the
// sensor's ray than every hit in their pixel of a coarse range image) that lie inside the
// convex hull of the view's points.
// Samples there are inside points for the GPIS, labelled with their distance to the nearest
// observed surface point (target -min(1, d / scale)).
//
// Why: the paper's single inside point at the centroid of the data is the GP's only evidence
// of material, and in a cup or a bowl the centroid lies in the cavity's air, so it has to go
// (GpisModelConfig::inside_point_min_clearance). Without any inside evidence, a surface the
// camera never saw (a bowl's bottom hidden behind its near rim) is not part of the predicted
// zero level set at all: f stays positive there, the planner grows charts only on the zero
// level set and never looks, and the run converges with the bottom missing. The guess: an
// object is solid behind what the camera saw, as far as the view's hull reaches. Where it is
// wrong (a cavity hidden behind a rim) only a touch can tell, and the variance does not always
// ask for one: the weak labels (noise sigma 1) keep the guessed surface's variance up, but
// near other data it can still fall below V_max, and a hidden cavity then stays filled. Where
// the guess is right, it puts into the prediction a surface the camera alone cannot.
struct OccludedInteriorConfig {
  // Candidate samples on a regular grid over the hull's bounding box, this many cells per
  // axis; at most max_points of the occluded ones (a random subset) are returned.
  int grid_cells{16};
  int max_points{60};
  // Clearance, as a fraction of the view's radius: a sample must be at least this far behind
  // the farthest hit in its pixel, from every view point and inside the hull's faces.
  double margin_fraction{0.08};
  // Directions of the planes that approximate the convex hull (its support function).
  int hull_directions{64};
  // Noise sigma of the samples (reference units): a guess, weaker than an observation.
  double noise_sigma{1.0};
  std::uint64_t seed{1};
};

// Same inputs as sampleViewFreeSpace. The points have label kInside, source kVision and
// surface_distance_m set.
ViewFreeSpace sampleOccludedInterior(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                     const OccludedInteriorConfig& config = OccludedInteriorConfig());

// True for sampleOccludedInterior's guesses (label kInside, source kVision): the only inside
// observations that nothing measured.
bool isOccludedInteriorGuess(const TrainingPoint& point);

// What retractContradictedInterior changed.
struct InteriorRetraction {
  std::size_t shrunk{0};
  std::size_t dropped{0};
  bool any() const { return shrunk + dropped > 0; }
};

// An occluded-interior guess at depth d (its surface_distance_m) claims that the surface is at
// least d away, i.e. that the ball of radius d around it is solid. A measured contact or
// free-space point at distance e < d contradicts that claim: the guess's depth becomes e, and
// the guess is dropped when e < min_depth_m (closer to measured surface or air than the
// sampling's own clearance). Why: the guess fills cavities hidden behind a rim, and the
// variance there can fall below V_max before any touch, so the touches that do pass through
// the cavity must be able to empty it; a few free-space points against 60 weak guesses are
// otherwise outvoted. Other points are left as they are. `evidence` in world coordinates.
InteriorRetraction retractContradictedInterior(std::vector<TrainingPoint>* observations,
                                               const std::vector<Vector3>& evidence, double min_depth_m);

// The support the object rests on (a table, found by segmentation): the plane n . x + d = 0,
// n unit and pointing to the object's side. Everything below it is outside the object.
//
// Why: the occluded interior and the GP's smoothness extend the predicted object below its
// lowest visible points, i.e. into the table. The planner then picks charts under the table,
// every touch there hits the table first, and the exploration ends by failed touches.
struct SupportPlane {
  Vector3 normal{Vector3::UnitZ()};
  double offset{0.0};
  double height(const Vector3& x) const { return normal.dot(x) + offset; }
};

struct BelowSupportConfig {
  // A grid of grid_cells x grid_cells cells over the view's footprint on the plane (its
  // bounding rectangle, grown by footprint_margin_fraction of the view's radius), of which the
  // cells within that margin of the projected view are kept, one layer per depth below the
  // plane (fractions of the view's radius).
  int grid_cells{8};
  std::vector<double> depth_fractions{0.1, 0.3};
  double footprint_margin_fraction{0.2};
  // Noise sigma (reference units), as the camera's free space.
  double noise_sigma{0.3162};
};

// Outside points under the support plane where the view is above it (grid cells within the
// footprint margin of a projected view point), labelled with their depth below it (their
// distance to the plane: a lower bound on their distance to an object above it). Fails when
// the view's median point is not above the plane (a flipped normal).
ViewFreeSpace sampleBelowSupport(const std::vector<Vector3>& surface_points, const SupportPlane& plane,
                                 const BelowSupportConfig& config = BelowSupportConfig());

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
ViewFreeSpace sampleSupportFreeSpace(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                     const SupportPlane& plane, const SupportFreeSpaceConfig& config);

// Removes the points less than `clearance_m` above the plane (inside points guessed into the
// table); returns how many.
std::size_t dropNearOrBelowPlane(std::vector<TrainingPoint>* points, const SupportPlane& plane, double clearance_m);

}  // namespace gpatlas_core
