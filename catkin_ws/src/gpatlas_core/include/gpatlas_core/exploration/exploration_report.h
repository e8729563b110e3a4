#pragma once

#include "gpatlas_core/exploration/explorer.h"

#include <cmath>
#include <string>

namespace gpatlas_core {

// One line for an action, for progress output (the bench's --verbose, the exploration node).
std::string describeAction(const ExplorationRecord& record);

// The final predicted shape against the truth, when there is one.
struct FinalShape {
  bool measured{false};
  double rmse_pred_to_gt_m{0.0};
  double rmse_gt_to_pred_m{0.0};
  double chamfer_l1_m{0.0};
  double fscore_5mm{0.0};
  // The position sd on samples of the truth (CalibrationResult): coverage, sharpness, median.
  double coverage_2sd{std::nan("")};
  double sharpness{std::nan("")};
  double position_sd_m{std::nan("")};
};

// Everything report.json says about one exploration.
struct ExplorationReport {
  std::string strategy;
  std::string model;  // the surface model (model/type)
  Explorer::Config loop;
  // The initial model's measurements (n_train, sampled_max_variance, RMSEs); action -1.
  ExplorationRecord initial;
  ExplorationResult result;
  // "converged" only when the run converged and left a predicted surface: a run without one is
  // an error (result.stop_reason says why the loop stopped, status what the user got).
  std::string status;
  FinalShape final_shape;
};

// The median over the actions that planned an approach of the motion planner's own time
// (ExplorationRecord::approach_compute_ms); NaN when none did.
double approachPlanMsMedian(const ExplorationResult& result);
// The median of ExplorationRecord::target_error_m over the last `touches` touches that found the
// surface (NaN when none did): how far from the model's prediction the surface was where the run
// touched last, the model's error measured without a truth.
double recentTargetError(const ExplorationResult& result, std::size_t touches = 5);

// The status of a finished run: "converged", "stopped: <reason>" or "error: <reason>", and
// "error: no predicted surface: ..." whenever there is no surface, whatever the loop said.
std::string runStatus(const ExplorationResult& result, bool has_surface, const std::string& surface_message);
// What the plan that ended the run left out of reach, for a status line: empty, or " (12
// candidates left out of reach: 8.30% of the atlas's area)" (the area for the atlas strategies).
std::string outOfReachNote(const ExplorationResult& result);

// report.json: the settings, the outcome, the final shape, the initial model, every action's
// record (with its accepted contacts' positions, contact_points), and the curve: the shape error (RMSE both ways, F@5mm) against the touches, from the
// initial model on, null where an action's model was not measured (no truth, or skipped).
std::string toJson(const ExplorationReport& report);

}  // namespace gpatlas_core
