#pragma once

#include "gpatlas_core/exploration_strategy.h"
#include "gpatlas_core/observation_gate.h"
#include "gpatlas_core/surface_model.h"
#include "gpatlas_core/prober.h"
#include "gpatlas_core/surface_evidence.h"
#include "gpatlas_core/types.h"
#include "gpatlas_core/view_free_space.h"

#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// How a touch's measurements become training points (touchTrainingPoints, applyTouch): the
// same rules in the bench's loop and in the GP model nodelet.
struct TouchObservationConfig {
  // Noise standard deviations of the new observations, in the model's reference units
  // (GpisModelConfig). The default is the paper's noise variance of 0.1 on every point.
  // With the paper's thin-plate kernel it must not be much smaller: that covariance is not
  // positive definite for dense point sets in 3-D, and the model would refuse touches as
  // singular.
  double contact_noise_sigma{0.3162};
  double free_space_noise_sigma{0.3162};
  // New contacts closer than this to one already kept from the same touch are dropped: a slide
  // reports a contact every few millimetres, and near-duplicates add O(n^2) cost to every later
  // query for almost no information (the GP's correlation length is centimetres). 0 keeps all.
  double min_point_spacing_m{0.004};
  // The same for free-space points, coarser: a slide's approach rays yield thousands of them,
  // each costing as much as a contact in every later query.
  double min_free_space_spacing_m{0.015};
  // A point this far behind each contact (against the contact's normal, which faces the side
  // the probe came from) is labelled inside with that depth. Without it a thin wall touched
  // from one side has surface points and free space but nothing inside, so the GP's level
  // set can vanish there. It must stay below the thinnest wall to be explored; 0: contacts
  // alone (the paper). Contacts without a normal (zero vector) get none.
  double contact_inside_depth_m{0.003};
  // Their noise, in reference units: tighter than contact_noise_sigma, or the tiny target
  // (-depth / scale) would be lost in the noise.
  double contact_inside_noise_sigma{0.1};
  // Each kept contact with a normal also observes that f does not change across that normal:
  // two slope observations (TrainingPoint::slope_direction) along tangents, target 0, with
  // this noise sigma (reference units). They give the GP the measured normal's direction
  // without assuming f's slope along it: between sparse contacts the surface follows the
  // measured normals. A probe that reports no normal gives none. Negative: none (the paper).
  double contact_tangent_noise_sigma{0.1};
  // A touch's contacts and free space retract the occluded-interior guesses they contradict
  // (retractContradictedInterior), dropping those left shallower than this fraction of the
  // model's scale (the view's radius; the occluded interior's own margin_fraction).
  double guess_min_depth_fraction{0.08};
  // At most this many contacts and free-space points per touch after thinning: a touch with
  // more is thinned at a coarser spacing (0: no cap). Every contact costs the model's coarse
  // level a row of its O(n^3) factor, so one dense touch must not be able to stall it.
  std::size_t max_contacts_per_touch{500};
  std::size_t max_free_space_per_touch{1000};
  // The most training points from touches (contacts, the points behind them, slopes, free
  // space) the model holds: the bound on its memory and on the cost of every later query
  // however long the exploration runs (0: no bound). A touch that would pass it is thinned to
  // the room left, its free space first; once there is no room, touches are refused and the
  // exploration stops (TouchUpdate::budget_full).
  std::size_t max_touch_observations{20000};
  // Which observations the model takes at all (gateObservations), checked first.
  ObservationGateConfig gate;
};

// Empty when the config is usable; otherwise what is wrong with it.
std::string validate(const TouchObservationConfig& config);

// What adding one touch's measurements did to the model.
struct TouchUpdate {
  // False when the model refused the touch (it is then unchanged) or was not fitted.
  bool ok{false};
  std::string message;
  int contacts_added{0};     // surface points accepted by the model
  int free_points_added{0};  // outside points accepted by the model
  int points_added{0};       // every training point accepted (points behind contacts, slopes too)
  InteriorRetraction retraction;  // occluded-interior guesses the touch contradicted
  // Observations the gate refused (TouchObservationConfig::gate), and why in `warnings`.
  GateRefusals contacts_refused;
  GateRefusals free_space_refused;
  // Non-zero: the touch had this many contacts after thinning, above max_contacts_per_touch.
  std::size_t contacts_capped_from{0};
  // The model holds max_touch_observations points from touches: this touch was refused, and
  // so will every other be.
  bool budget_full{false};
  std::vector<std::string> warnings;
};

// One iteration of Algorithm 2.
struct ExplorationRecord {
  int index{0};                  // 0-based action number
  PlanStatus plan_status{PlanStatus::kError};
  bool probe_success{false};
  std::string probe_reason;      // the prober's reason when the touch failed
  int contacts_added{0};         // surface points accepted by the model
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
  InteriorRetraction retraction; // occluded-interior guesses this touch contradicted
  Touch touch;
  // How far from where it aimed the touch found the surface: the median over its aimed points
  // (aimedPoints) of the distance to the nearest contact; NaN without a contact. Where the
  // model's prediction was right it is a few millimetres: on a robot, without a truth, it is
  // the measured error of the model where it was last touched.
  double target_error_m{std::nan("")};
  // Filled by the caller's progress callback where it measures the model (NaN otherwise): the
  // largest variance of a fixed surface sample, and the shape error against a known truth.
  double sampled_max_variance{std::nan("")};
  double rmse_pred_to_gt_m{std::nan("")};
  double rmse_gt_to_pred_m{std::nan("")};
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
  // Touches the approach planner refused (not executed; those refused before the plan that
  // ended the run are in no record), and the probe's unexpected contacts on the way to the
  // touches and back.
  int unreachable_touches{0};
  int unreachable_candidates{0};  // passed over by the strategies before they chose (PlanRequest::reachable)
  int approach_collisions{0};
  int retreat_collisions{0};
};

// Per target, the distance to the nearest of a touch's contacts: how far from where it aimed the
// touch found the surface (NaN when it found none).
std::vector<double> targetErrors(const std::vector<Vector3>& targets, const std::vector<Contact>& contacts);
// Per aimed point of a touch (aimedPoints), the same where the nearest contact lies beyond it along
// the approach (-normal): the probe went through where the model put the surface, which was
// wrong. NaN where the probe stopped before it (something unpredicted was in the way, the target
// is still unreached) or found nothing: EvidenceRule::attempted_target_errors_m.
std::vector<double> passedTargetErrors(const Touch& touch, const std::vector<Contact>& contacts);
// The median of the finite values (NaN when there is none).
double finiteMedian(std::vector<double> values);

// Greedy thinning of one touch's contacts or free space: the finite points, in order, that lie at
// least `spacing_m` from every point kept before them (spacing_m <= 0 keeps them all).
std::vector<Vector3> thinToSpacing(const std::vector<Vector3>& points, double spacing_m);
// A touch's free space thinned to `spacing_m`, the points nearest the touch's contacts kept
// first: they pin the surface down, while those a probe's length away hardly constrain it.
std::vector<Vector3> thinFreeSpace(const std::vector<Vector3>& free_space, const std::vector<Vector3>& contacts,
                                   double spacing_m);

// The three steps of Algorithm 2 that the loop delegates. In one process they act on a
// GpisModel (ModelTouchPlanner, ModelTouchUpdater); in ROS they are the next_touch, probe and
// add_observations services. Any of them may throw: the run then stops with "error: ...".
class TouchPlanner {
 public:
  virtual ~TouchPlanner() = default;
  // `request.evidence.attempted_targets` holds where earlier touches aimed; the planner adds
  // the rest of its evidence rule.
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
    int max_actions{100};
    // The paper's extra stop on the real robot: this many failed touches in a row. A touch
    // fails when the probe reports failure or the model accepts none of its contacts.
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

  // In one process: plans with `strategy` on `model` (fitted: the initial view) under
  // `evidence`, and adds the touches to it with `touch` (applyTouch).
  ExplorationResult run(SurfaceModel& model, const ExplorationStrategy& strategy, Prober& prober,
                        const TouchObservationConfig& touch = {}, const EvidenceRule& evidence = {},
                        const Progress& progress = {}, TouchApproacher* approacher = nullptr) const;

 private:
  Config config_;
};

std::string validate(const Explorer::Config& config);

// Plans with a strategy on a model held elsewhere (the caller updates it between plans).
class ModelTouchPlanner : public TouchPlanner {
 public:
  ModelTouchPlanner(const SurfaceModel& model, const ExplorationStrategy& strategy, EvidenceRule evidence)
      : model_(model), strategy_(strategy), evidence_(std::move(evidence)) {}
  PlanResult plan(const PlanRequest& request) override;
  std::size_t modelSize() const override { return model_.observations().size(); }

 private:
  const SurfaceModel& model_;
  const ExplorationStrategy& strategy_;
  EvidenceRule evidence_;
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

// How many of touchTrainingPoints' points are of each kind (in this order in its output).
struct TouchPointCounts {
  std::size_t contacts{0};
  std::size_t contact_inside{0};
  std::size_t contact_tangents{0};
  std::size_t free_space{0};
  // Non-zero when the per-touch caps thinned further: the counts before, and the spacing used.
  std::size_t contacts_before_cap{0};
  double capped_contact_spacing_m{0.0};
  std::size_t free_space_before_cap{0};
  double capped_free_space_spacing_m{0.0};
};

// A touch's observations as training points for `model` (used by the Explorer and by the GP
// model nodelet): contacts thinned to config.min_point_spacing_m; behind each kept contact with
// a normal, an inside point at config.contact_inside_depth_m, then (when
// config.contact_tangent_noise_sigma >= 0) its two tangent slope observations; free space inside the model's
// domain thinned to config.min_free_space_spacing_m, nearest the contacts first, and labelled
// with its distance to the nearest contact or model surface point.
std::vector<TrainingPoint> touchTrainingPoints(const SurfaceModel& model, const std::vector<Contact>& contacts,
                                               const std::vector<Vector3>& free_space, const TouchObservationConfig& config,
                                               TouchPointCounts* counts = nullptr);

// Where a touch measured something: its contacts' positions and its free space (before
// thinning), the points that retract the guesses they contradict (addTouchPoints).
std::vector<Vector3> measuredPositions(const std::vector<Contact>& contacts, const std::vector<Vector3>& free_space);

// Adds a touch's training points (from touchTrainingPoints) to a fitted model. First the
// touch's measured points (`evidence`: measuredPositions of the touch) retract
// the occluded-interior guesses they contradict; the
// update is incremental when nothing was retracted, and a full refit in the model's current
// frame otherwise. On failure the model is unchanged. The report's num_added counts the new
// points the model accepted (not the retained old ones).
FitReport addTouchPoints(SurfaceModel& model, const std::vector<TrainingPoint>& new_points,
                         const std::vector<Vector3>& evidence, const TouchObservationConfig& config,
                         InteriorRetraction* retraction = nullptr);

// What one touch measured, added to a fitted model: touchTrainingPoints, then addTouchPoints.
// A batch the model refuses as numerically singular (e.g. a free-space point right next to a
// surface point) is retried with the contacts alone (and the points behind them): the
// contacts are what the touch was for. The refused free space still retracts guesses.
TouchUpdate applyTouch(SurfaceModel& model, const std::vector<Contact>& contacts, const std::vector<Vector3>& free_space,
                       const TouchObservationConfig& config);

}  // namespace gpatlas_core
