#pragma once

// atlas_frontier: atlas_poke on the predicted surface, then pokes into the space no sensor has
// observed near the predicted object, where a part the model does not predict can hide (the
// camera's shadow; a mug's handle behind its body).

#include "gpatlas_core/observations/view_shadow.h"
#include "gpatlas_core/planning/atlas_strategy.h"
#include "gpatlas_core/planning/exploration_strategy.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// The unobserved space near the predicted object, on a voxel grid around the model's centroid:
// what a frontier plan aims at, built from the model, the views and the touches each plan.
struct UnknownSpace {
  enum class Cell : std::uint8_t {
    kIgnored = 0,   // outside the domain, under the table, seen by a camera, or too far from or
                    // too near the predicted object to be looked for there
    kPredicted = 1, // inside the predicted object (mean f < 0)
    kUnknown = 2,   // unobserved, outside the predicted object, near enough to it to hold a part
    kCleared = 3,   // as kUnknown, but a touch measured it (its path crossed it, or a contact or target lies near)
    kTooSmall = 4,  // as kUnknown, in a connected piece too small to look for (Config::min_cluster_cells)
  };
  Vector3 origin{Vector3::Zero()};  // the centre of cell (0, 0, 0)
  double cell_m{0.0};
  Eigen::Vector3i size{Eigen::Vector3i::Zero()};
  std::vector<Cell> cells;          // i fastest
  std::vector<float> distance_m;    // per cell, to the nearest kPredicted cell (infinity beyond reach)
  // Per cell, to the nearest cell a view saw (infinity beyond Config::part_size_m; 0 when seen).
  std::vector<float> shadow_depth_m;
  int unknown_cells{0};             // kUnknown after the small pieces were dropped
  int clusters{0};                  // connected (26-neighbour) pieces of them

  // The cell holding x, or -1 outside the grid.
  long index(const Vector3& x) const;
  Vector3 centre(long index) const;
};

class FrontierStrategy : public ExplorationStrategy {
 public:
  struct Config {
    ViewShadow::Config shadow;
    // The unknown space's voxel, and the cube it spans: this many times the model's data radius
    // about its centroid (within the model's domain).
    double cell_m{0.01};
    double search_radius_fraction{2.0};
    // A hidden part is attached to the object: unobserved space farther than reach_m from the
    // predicted object is not looked at, nor space nearer than min_gap_m (the atlas's touches of
    // the predicted surface measure that).
    double reach_m{0.05};
    double min_gap_m{0.01};
    // Nor space this close above the table (a poke there hits the table).
    double support_clearance_m{0.01};
    // A touch's free-space points and contacts, and the targets of earlier touches, clear the
    // unknown cells within this distance; the cells a probe's path crossed are cleared too.
    double clear_radius_m{0.006};
    // Connected pieces of unknown space with fewer cells are not looked for.
    int min_cluster_cells{3};
    // The probe starts this far out along the approach direction (its approach pose) and its
    // path counts this far past the target: a poke through empty space goes on past its target.
    double approach_distance_m{0.1};
    double past_m{0.03};
    // The approach line, from the probe's start outward, must reach space a camera saw (or a
    // touch measured) within this distance of the target: the probe comes from there. Space
    // right behind an object is in its shadow far beyond the probe's start.
    double observed_within_m{0.25};
    // Approach directions tried per target (evenly spread), targets evaluated per plan (a
    // stride through the unknown cells beyond), and the best targets offered to the approacher's
    // cheap test (PlanRequest::reachable) before giving up.
    int approach_directions{64};
    int max_targets{800};
    int max_reachability_checks{20};
    // The run's budget of pokes into unknown space that found nothing
    // (EvidenceState::empty_unknown_pokes): once spent, the strategy reports convergence.
    int max_empty_pokes{10};
    // A poke's expected gain: the unknown cells its path crosses, each weighted by the chance it
    // holds a part the views missed: exp(-distance to the predicted object / prior_length_m)
    // times min(1, distance to observed space / part_size_m) (a part wholly in the shadow lies
    // deep in it).
    double prior_length_m{0.02};
    double part_size_m{0.03};
  };

  // `atlas`: atlas_poke's planner (AtlasStrategy), with which every plan first looks for a chart
  // above V_max on the predicted surface. `seed`: the run's.
  FrontierStrategy(Config config, AtlasPlanner::Config atlas, std::uint64_t seed);
  std::string name() const override { return "atlas_frontier"; }
  // An atlas_poke touch while one is needed; when the predicted surface has converged, a poke
  // into the unknown space (UnknownSpace, PlanRequest::evidence_state's views) with the largest
  // expected gain, approached from observed space; converged when no unknown space is left that
  // a poke can reach, or the budget of empty pokes is spent. Without views: atlas_poke.
  PlanResult plan(const SurfaceModel& model, const PlanRequest& request) const override;

  // The unknown space the strategy sees on `model` with `state` (for tests and displays).
  UnknownSpace unknownSpace(const SurfaceModel& model, const EvidenceState& state) const;

 private:
  // The same, with the views' shadow already built (a plan needs it again for the approaches).
  UnknownSpace unknownSpace(const SurfaceModel& model, const EvidenceState& state, const ViewShadow& shadow) const;
  PlanResult planShadowPoke(const SurfaceModel& model, const PlanRequest& request, PlanResult atlas_result) const;

  Config config_;
  AtlasStrategy poke_;
};

// Empty when the config is usable; otherwise what is wrong with it.
std::string validate(const FrontierStrategy::Config& config);
// Its reader: frontier/ (the strategy's planner is atlas_poke's: readAtlasPlanner).
void readFrontier(ParamReader& r, FrontierStrategy::Config* c);

}  // namespace gpatlas_core
