#pragma once

#include "gpatlas_core/observations/view_samples.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

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
};

// Same inputs as sampleViewFreeSpace. The points have label kInside, source kVision and
// surface_distance_m set.
ViewSamples sampleOccludedInterior(const std::vector<Vector3>& surface_points, const Vector3& sensor_origin,
                                   std::uint64_t seed, const OccludedInteriorConfig& config = OccludedInteriorConfig());

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

}  // namespace gpatlas_core
