#pragma once

// One gpatlas_bench run: an object, a strategy and a seed, from the camera's view to the measured
// final model.

#include "bench_options.h"
#include "bench_truth.h"

#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_geometry/shape_metrics.h>

#include <cmath>
#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

namespace gpatlas_bench {

struct RunResult {
  std::string object, strategy, probe, stop_reason;
  // "converged", "stopped: ..." or "error: ..." (gpatlas_core::runStatus): no surface is an error.
  std::string status;
  int seed{0};
  double v_max{0.0};
  std::optional<double> max_position_sd_m;  // empty: V_max alone ("off" in runs.csv)
  int curve_every{0};  // --curve-every: which history entries were measured
  int actions{0};
  int contacts{0};
  bool converged{false};
  std::size_t n_train{0};
  gpatlas_geometry::ShapeMetricsResult metrics;
  // Truth-to-predicted RMSE over the reachable truth only (GroundTruth::sample_reachable).
  double rmse_gt_to_pred_reachable{std::nan("")};
  // Truth-to-predicted RMSE over the truth the camera saw, and over the rest (touch's part).
  double rmse_gt_to_pred_seen{std::nan("")};
  double rmse_gt_to_pred_unseen{std::nan("")};
  // The share of true-surface samples whose predicted f is within 2 sd of 0 (0.95 is calibrated).
  double calibration{std::nan("")};
  // Its sharpness: the median sd of the surface's position along the normal there (m).
  double position_sd_m{std::nan("")};
  // The share of those samples whose distance to the predicted surface is within 2 position sd
  // (0.90-0.99 is calibrated), and the median position sd over the median distance (1 is sharp).
  double coverage{std::nan("")};
  double sharpness{std::nan("")};
  // The final model's SurfaceModel::positionSdScale (1: not calibrated).
  double position_sd_scale{std::nan("")};
  double max_evaluated_variance{0.0};
  double wall_s{0.0};
  double plan_ms_median{0.0};
  double update_ms_median{0.0};
  // Approach planning (approach/): touches refused for want of a safe approach, the probe's
  // contacts with the true scene on the way to the touches and back, and the planner's time.
  int unreachable_touches{0};
  int unreachable_candidates{0};
  int final_unreachable_candidates{0};  // in the plan that ended the run
  double final_unreachable_area_fraction{0.0};  // their share of its atlas's area
  std::string out_of_reach_note;                // gpatlas_core::outOfReachNote
  int approach_collisions{0};
  int retreat_collisions{0};
  // The touches whose way there or back met a neighbour (simulation/neighbours).
  int neighbour_collision_touches{0};
  // The touches whose way ended in a guarded entry into space no sensor observed (the approach
  // pose of every acceptable direction lay in it: gpatlas_core::ApproachResult::guarded_entry).
  int guarded_entries{0};
  double approach_plan_ms_median{std::nan("")};
  // How far from their targets the last touches found the surface (recentTargetError).
  double recent_target_error_m{std::nan("")};
  // The initial model (action 0) and every action, as the ROS exploration node records them. Each
  // entry's progress_ms is the time the bench spent measuring it for the curve (and on its --verbose
  // line); the initial model's too.
  std::vector<gpatlas_core::ExplorationRecord> history;
  std::string error;
};

// A run's identity: which object, strategy, probe, seed and V_max.
RunResult runIdentity(const GroundTruth& gt, const std::string& strategy_name, int seed, const Options& o);

// The camera's view of the object segmented and fitted as the pipeline does it, then the
// exploration loop with the strategy against the simulated probe, and the final model measured
// against the truth. `print_mutex` guards the --verbose lines. Throws on an error the run cannot
// report itself (a strategy or probe that cannot be built).
RunResult runOne(const GroundTruth& gt, const std::string& strategy_name, int seed, const Options& o,
                 std::mutex& print_mutex);

// How history entry `i` of `r` was measured: "final" (the last, as the run's runs.csv row),
// "curve" (--curve-every, at the curve's cheaper quality) or "" (not measured).
std::string measuredAs(const RunResult& r, std::size_t i);

}  // namespace gpatlas_bench
