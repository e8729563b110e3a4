#pragma once

#include "gpatlas_core/planning/exploration_strategy.h"
#include "gpatlas_core/observations/observation_gate.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/exploration/prober.h"
#include "gpatlas_core/observations/touch_training.h"
#include "gpatlas_core/observations/surface_evidence.h"
#include "gpatlas_core/common/types.h"
#include "gpatlas_core/observations/support_plane.h"
#include "gpatlas_core/observations/occluded_interior.h"
#include "gpatlas_core/planning/stop_rule.h"

#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// One iteration of Algorithm 2.
struct ExplorationRecord {
  int index{0};                  // 0-based action number
  PlanStatus plan_status{PlanStatus::kError};
  bool probe_success{false};
  std::string probe_reason;      // the prober's reason when the touch failed
  int contacts_added{0};         // surface points accepted by the model
  std::vector<Vector3> contact_positions;  // where they are, world frame (TouchUpdate)
  int free_points_added{0};      // outside points accepted by the model
  int contacts_total{0};         // contacts accepted since the start, this action's included
  std::size_t n_train{0};        // observations of the model this action's plan was made on
  double max_evaluated_variance{0.0};  // this action's plan's (PlanResult::max_evaluated_variance)
  // Wall clock of each step, with what the step waits for (a service's answer, a replica).
  double plan_ms{0.0};
  double probe_ms{0.0};
  double update_ms{0.0};
  // The planner's own time (PlanResult::elapsed_s): plan_ms minus this is waiting.
  double plan_compute_ms{0.0};
  // The work budget, not convergence or a touch found, ended a plan of this action
  // (PlanResult::budget_exhausted).
  bool plan_budget_exhausted{false};
  // The caller's progress callback (logging, measurements it makes on the loop's thread).
  double progress_ms{0.0};
  // The whole action, wall clock, the progress callback included; set after the callback.
  double action_ms{0.0};
  std::string update_message;    // why the model refused the new points, if it did
  // Approach planning (TouchApproacher), when the loop has one: the touches it refused before
  // this one (each asked the planner for another), why the last was refused, its wall clock
  // over every try (with what it waits for: a collision map of the updated model) and the
  // motion planner's own time (ApproachResult::planning_ms), and the unexpected contacts the
  // probe reported on the way to the touch and back (ProbeResult).
  int approach_refusals{0};
  int unreachable_candidates{0};  // candidates the strategy passed over (PlanResult), every try
  std::string approach_message;
  double approach_ms{0.0};
  double approach_compute_ms{0.0};
  int approach_collisions{0};
  int retreat_collisions{0};
  bool guarded_entry{false};  // the touch's way ends in a guarded entry (ApproachResult)
  InteriorRetraction retraction; // occluded-interior guesses this touch contradicted
  Touch touch;
  // How far from where it aimed the touch found the surface: the median over its aimed points
  // (aimedPoints) of the distance to the nearest contact; NaN without a contact. Where the
  // model's prediction was right it is a few millimetres: on a robot, without a truth, it is
  // the measured error of the model where it was last touched.
  double target_error_m{std::nan("")};
  // Filled by the caller's progress callback where it measures the model (NaN otherwise): the
  // largest variance of a fixed surface sample, and the shape error against a known truth (RMSE
  // both ways, F-score at 5 mm).
  double sampled_max_variance{std::nan("")};
  double rmse_pred_to_gt_m{std::nan("")};
  double rmse_gt_to_pred_m{std::nan("")};
  double fscore_5mm{std::nan("")};
};

struct ExplorationResult {
  // "converged", "max_actions", "consecutive_failures", "observation_budget_full" (the model
  // refused a touch for TouchObservationConfig::max_touch_observations), "planner_cap_reached",
  // "planner_error: ...", "error: ..." (an exception from the planner, the prober or the
  // model), "invalid_config: ...". A touch whose points the model refuses counts as a failed
  // touch (see ExplorationRecord::update_message).
  std::string stop_reason;
  bool converged{false};
  int actions{0};  // touches executed (probed), failed ones included
  int contacts{0}; // contacts the model accepted
  std::vector<ExplorationRecord> records;
  // PlanResult::max_evaluated_variance of the plan that ended the run.
  double final_max_evaluated_variance{0.0};
  // The candidates the approacher's cheap test refused in that plan: "converged" with some left
  // means converged within reach, the rest of the surface out of it.
  int final_unreachable_candidates{0};
  // Their share of that plan's atlas area (PlanResult::unreachable_area_fraction): at
  // convergence, about the share of the predicted surface that needs a touch the probe cannot make.
  double final_unreachable_area_fraction{0.0};
  // Touches the approach planner refused (not executed; those refused before the plan that
  // ended the run are in no record), and the probe's unexpected contacts on the way to the
  // touches and back.
  int unreachable_touches{0};
  int unreachable_candidates{0};  // passed over by the strategies before they chose (PlanRequest::reachable)
  int approach_collisions{0};
  int retreat_collisions{0};
  int guarded_entries{0};  // executed touches whose way ended in a guarded entry
};

// Per target, the distance to the nearest of a touch's contacts: how far from where it aimed the
// touch found the surface (NaN when it found none).
std::vector<double> targetErrors(const std::vector<Vector3>& targets, const std::vector<Contact>& contacts);
// Per aimed point of a touch (aimedPoints), the same where the nearest contact lies beyond it along
// the approach (-normal): the probe went through where the model put the surface, which was
// wrong. NaN where the probe stopped before it (something unpredicted was in the way, the target
// is still unreached) or found nothing: EvidenceState::attempted_target_errors_m.
std::vector<double> passedTargetErrors(const Touch& touch, const std::vector<Contact>& contacts);

// The three steps of Algorithm 2 that the loop delegates. In one process they act on a
// GpisModel (ModelTouchPlanner, ModelTouchUpdater); in ROS they are the next_touch, probe and
// add_observations services. Any of them may throw: the run then stops with "error: ...".
class TouchPlanner {
 public:
  virtual ~TouchPlanner() = default;
  // `request.evidence_state` holds where earlier touches aimed; the planner adds what it
  // knows itself (mergeEvidenceState).
  virtual PlanResult plan(const PlanRequest& request) = 0;
  // Observations in the model the next plan is made on.
  virtual std::size_t modelSize() const = 0;
};

class ModelUpdater {
 public:
  virtual ~ModelUpdater() = default;
  virtual TouchUpdate update(const ProbeResult& probed) = 0;
};

// How the probe gets to a touch and back (Algorithm 2's APPROACHTO and MOVEAWAY), planned on
// the current model: Touch::approach_path and retreat_path, or why there is no safe way.
struct ApproachResult {
  bool ok{false};
  std::string message;  // why not, when !ok
  std::vector<Vector3> approach_path;
  std::vector<Vector3> retreat_path;
  std::vector<Eigen::VectorXd> approach_joints;  // Touch::approach_joints; empty without an arm
  std::vector<Eigen::VectorXd> retreat_joints;
  // The way ends short of the approach pose, in space no sensor observed, and the probe comes in
  // along the touch's line from there: a guarded move on a robot, the one place it may meet an
  // unpredicted part.
  bool guarded_entry{false};
  double planning_ms{0.0};
};

// Approach planning for the loop: gpatlas_motion's on a collision map of the model in one
// process, the collision map nodelet's plan_approach service in ROS. May throw (the run then
// stops with "error: ...").
class TouchApproacher {
 public:
  virtual ~TouchApproacher() = default;
  virtual ApproachResult plan(const Touch& touch) = 0;
  // A cheap test the strategies apply to their candidates before they choose one
  // (PlanRequest::reachable): the direction a touch of `point` may have a safe approach from
  // (the outward normal or one tilted from it, TouchFilter), nullopt when none. The default
  // takes every one along its normal.
  virtual std::optional<Vector3> approachDirection(const Vector3& /*point*/, const Vector3& outward_normal) {
    return outward_normal;
  }
  // The model took a touch: what the next plan sees must come from the updated model.
  virtual void modelChanged() {}
  // Called before each action's first plan: brings the approacher up to date with the model
  // (builds or waits for the collision map of the updated model), so that the wait is the
  // approach's (ExplorationRecord::approach_ms), not the plan's.
  virtual void prepare() {}
};

// Tactile exploration, paper Algorithm 2: plan a touch on the current model, probe it, add the
// contacts as surface points and the free-space observations as outside points, update the
// model, and repeat until the planner reports convergence. The bench and the ROS exploration
// node both run this loop, with their own planner, prober and updater.
class Explorer {
 public:
  struct Config {
    double v_max{0.1};
    // The stop rule in metres (StopRule): converged when no reachable point of the predicted
    // surface has a position sd above it (nor a variance above v_max); empty: v_max alone.
    std::optional<double> max_position_sd_m{0.005};
    int max_actions{100};
    // The paper's extra stop on the real robot: this many failed touches in a row. A touch
    // fails when the probe reports failure or the model accepts none of its contacts; a touch
    // into unobserved space (Touch::explores_unknown) succeeds with free space alone.
    int max_consecutive_failures{5};
    // Plan k is asked with seed mixSeeds(seed, k).
    std::uint64_t seed{0};
    // With an approach planner: a touch it refuses is not executed, counts as evidence (like a
    // touch made) and the planner is asked for another, up to this many touches per action.
    // An action with all of them refused is a failed touch.
    int max_approach_attempts{5};
  };
  // Called after every action with its record, which it may complete (the measurements);
  // may be empty.
  using Progress = std::function<void(ExplorationRecord& record)>;

  Explorer() = default;
  explicit Explorer(Config config) : config_(std::move(config)) {}
  const Config& config() const { return config_; }

  // Without an approacher every touch is executed as planned (the probe moves straight to it).
  ExplorationResult run(TouchPlanner& planner, Prober& prober, ModelUpdater& updater,
                        const Progress& progress = {}, TouchApproacher* approacher = nullptr) const;

  // In one process: plans with `strategy` on `model` (fitted: the initial view), knowing
  // `known` (the table under the object), and adds the touches to it with `touch` (applyTouch).
  ExplorationResult run(SurfaceModel& model, const ExplorationStrategy& strategy, Prober& prober,
                        const TouchObservationConfig& touch = {}, const EvidenceState& known = {},
                        const Progress& progress = {}, TouchApproacher* approacher = nullptr) const;

 private:
  Config config_;
};

std::string validate(const Explorer::Config& config);

// Plans with a strategy on a model held elsewhere (the caller updates it between plans), knowing
// `known` besides what each request brings (the table under the object) and how the updater
// turns a touch into observations (`touch`, for the strategies' lookahead).
class ModelTouchPlanner : public TouchPlanner {
 public:
  ModelTouchPlanner(const SurfaceModel& model, const ExplorationStrategy& strategy, EvidenceState known,
                    TouchObservationConfig touch = {})
      : model_(model), strategy_(strategy), known_(std::move(known)), touch_(std::move(touch)) {}
  PlanResult plan(const PlanRequest& request) override;
  std::size_t modelSize() const override { return model_.observations().size(); }

 private:
  const SurfaceModel& model_;
  const ExplorationStrategy& strategy_;
  EvidenceState known_;
  TouchObservationConfig touch_;
};

// Adds each touch to a model with applyTouch.
class ModelTouchUpdater : public ModelUpdater {
 public:
  ModelTouchUpdater(SurfaceModel& model, TouchObservationConfig config) : model_(model), config_(std::move(config)) {}
  TouchUpdate update(const ProbeResult& probed) override;

 private:
  SurfaceModel& model_;
  TouchObservationConfig config_;
};

}  // namespace gpatlas_core
