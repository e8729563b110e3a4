#pragma once

// The objects gpatlas_bench explores, with what is known of their truth before any run.

#include "bench_options.h"

#include <probe_sim/object_mesh.h>
#include <probe_sim/simulation_settings.h>

#include <string>
#include <vector>

namespace gpatlas_bench {

// A ground-truth object placed as the simulator places it (simulation/object_position_xy_m).
struct GroundTruth {
  std::string name;
  probe_sim::TriangleMesh mesh;
  // Which of the shape metrics' truth samples lie on the part of the surface a camera or a ray
  // probe outside the object can reach (probe_sim::splitReachableSurface), and the floor the
  // rest sets: the truth-to-predicted RMSE of a prediction that is exactly the reachable
  // surface (a prediction that also guesses hidden layers could come closer).
  bool reachability_measured{false};
  double reachable_area_fraction{1.0};
  double floor_rmse_gt_to_pred{0.0};
  std::vector<bool> sample_reachable;
  // Which of the same samples the camera sees; empty without a camera.
  std::vector<bool> sample_seen;
};

// The object `spec` (a mesh file or procedural:NAME) at `scale`, placed as o.simulation places
// it, with the samples its camera sees. Throws when the object cannot be loaded.
GroundTruth loadObject(const std::string& spec, double scale, const Options& o);

// Fills the reachability fields of `gt` (escape lines tried per triangle: `directions`).
void measureReachability(GroundTruth& gt, const probe_sim::SimulationSettings& simulation, int directions);

}  // namespace gpatlas_bench
