#include "gpatlas_core/exploration/explorer.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>
#include <sstream>

namespace gpatlas_core {

namespace {

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

std::vector<double> targetErrors(const std::vector<Vector3>& targets, const std::vector<Contact>& contacts) {
  std::vector<double> errors;
  errors.reserve(targets.size());
  for (const Vector3& target : targets) {
    double nearest = std::numeric_limits<double>::quiet_NaN();
    for (const Contact& contact : contacts)
      if (contact.position.allFinite()) {
        const double d = (contact.position - target).norm();
        if (!(d >= nearest)) nearest = d;
      }
    errors.push_back(nearest);
  }
  return errors;
}

std::vector<double> passedTargetErrors(const Touch& touch, const std::vector<Contact>& contacts) {
  const std::vector<Vector3> aimed = aimedPoints(touch);
  const std::size_t first = touch.points.size() - aimed.size();  // a poke aims at its last waypoint
  std::vector<double> errors(aimed.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < aimed.size() && first + i < touch.normals.size(); ++i) {
    const Contact* nearest = nullptr;
    for (const Contact& contact : contacts)
      if (contact.position.allFinite() &&
          (!nearest || (contact.position - aimed[i]).norm() < (nearest->position - aimed[i]).norm()))
        nearest = &contact;
    // The probe moves along -normal: a contact beyond the target means it went through there.
    if (nearest && (nearest->position - aimed[i]).dot(-touch.normals[first + i]) > 0.0)
      errors[i] = (nearest->position - aimed[i]).norm();
  }
  return errors;
}

std::string validate(const Explorer::Config& config) {
  std::ostringstream problem;
  if (const std::string rule = validate(StopRule{config.v_max, config.max_position_sd_m}); !rule.empty())
    problem << rule << "; ";
  if (config.max_actions < 0) problem << "max_actions must be >= 0; ";
  if (config.max_consecutive_failures < 1) problem << "max_consecutive_failures must be >= 1; ";
  if (config.max_approach_attempts < 1) problem << "max_approach_attempts must be >= 1; ";
  return problem.str();
}

PlanResult ModelTouchPlanner::plan(const PlanRequest& request) {
  PlanRequest full = request;
  full.touch_observations = touch_;
  std::string problem;
  if (!mergeEvidenceState(known_, request.evidence_state, &full.evidence_state, &problem)) {
    PlanResult error;
    error.status = PlanStatus::kError;
    error.message = problem;
    return error;
  }
  return strategy_.plan(model_, full);
}

TouchUpdate ModelTouchUpdater::update(const ProbeResult& probed) {
  return applyTouch(model_, probed.contacts, probed.free_space, config_);
}

ExplorationResult Explorer::run(SurfaceModel& model, const ExplorationStrategy& strategy, Prober& prober,
                                const TouchObservationConfig& touch, const EvidenceState& known,
                                const Progress& progress, TouchApproacher* approacher) const {
  if (!model.isFitted()) {
    ExplorationResult result;
    result.stop_reason = "planner_error: no model: the GP is not fitted";
    return result;
  }
  if (const std::string problem = validate(touch) + validate(known); !problem.empty()) {
    ExplorationResult result;
    result.stop_reason = "invalid_config: " + problem;
    return result;
  }
  ModelTouchPlanner planner(model, strategy, known, touch);
  ModelTouchUpdater updater(model, touch);
  return run(planner, prober, updater, progress, approacher);
}

namespace {

// One run of Algorithm 2: its steps, and what it carries from one action to the next.
class ExplorationRun {
 public:
  ExplorationRun(const Explorer::Config& config, TouchPlanner& planner, Prober& prober, ModelUpdater& updater,
                 const Explorer::Progress& progress, TouchApproacher* approacher)
      : config_(config), planner_(planner), prober_(prober), updater_(updater), progress_(progress),
        approacher_(approacher) {}

  // Runs actions until one stops the run; an exception from a step stops it with "error: ...".
  ExplorationResult run() {
    try {
      for (int action = 0;; ++action)
        if (!act(action)) break;
    } catch (const std::exception& e) {
      result_.stop_reason = std::string("error: ") + e.what();
    }
    return std::move(result_);
  }

 private:
  // How an action's planning ended.
  enum class Planned { kTouch, kApproachRefused, kStop };

  // One action: plan (and approach), probe, update. False when the run stops.
  bool act(int action) {
    const Clock::time_point action_started = Clock::now();
    ExplorationRecord record;
    record.index = action;
    record.n_train = planner_.modelSize();
    if (approacher_) {
      const Clock::time_point prepare_started = Clock::now();
      approacher_->prepare();
      record.approach_ms += millisecondsSince(prepare_started);
    }
    PlanResult plan;
    const Planned planned = planTouch(action, record, &plan);
    if (planned == Planned::kStop) return false;
    record.touch = plan.touch;
    if (planned == Planned::kApproachRefused) return giveUpOnTheAction(record, action_started);
    const bool budget_full = probeAndUpdate(plan.touch, record);
    // A poke into unobserved space that found nothing but free space did what it was for.
    const bool touched = (record.probe_success && record.contacts_added > 0) ||
                         (plan.touch.explores_unknown && record.free_points_added > 0);
    consecutive_failures_ = touched ? 0 : consecutive_failures_ + 1;
    report(record, action_started);
    result_.records.push_back(record);
    if (budget_full) {
      result_.stop_reason = "observation_budget_full";
      return false;
    }
    return !stopsAfterFailures();
  }

  // Plans; with an approacher, until it finds a way to the touch or has refused too many. The
  // touch, with the approacher's paths, in *plan.
  Planned planTouch(int action, ExplorationRecord& record, PlanResult* plan) {
    for (int attempt = 0;; ++attempt) {
      const Clock::time_point plan_started = Clock::now();
      *plan = planner_.plan(request(action, attempt));
      record.unreachable_candidates += plan->unreachable_candidates;
      result_.unreachable_candidates += plan->unreachable_candidates;
      record.plan_ms += millisecondsSince(plan_started);
      record.plan_compute_ms += 1000.0 * plan->elapsed_s;
      record.plan_budget_exhausted = record.plan_budget_exhausted || plan->budget_exhausted;
      record.plan_status = plan->status;
      record.max_evaluated_variance = plan->max_evaluated_variance;
      result_.final_max_evaluated_variance = plan->max_evaluated_variance;
      result_.final_unreachable_candidates = plan->unreachable_candidates;
      result_.final_unreachable_area_fraction = plan->unreachable_area_fraction;
      if (stopsAfterPlan(*plan, action)) return Planned::kStop;
      if (!approacher_ || approach(record, plan)) return Planned::kTouch;
      if (record.approach_refusals >= config_.max_approach_attempts) return Planned::kApproachRefused;
    }
  }

  PlanRequest request(int action, int attempt) const {
    PlanRequest request;
    request.v_max = config_.v_max;
    request.max_position_sd_m = config_.max_position_sd_m;
    request.evidence_state = attempted_;
    request.footprint_radius_m = footprint_radius_m_;
    request.seed = mixSeeds(config_.seed, static_cast<std::uint64_t>(action));
    if (attempt > 0) request.seed = mixSeeds(request.seed, static_cast<std::uint64_t>(attempt));
    if (approacher_)
      request.reachable = [approacher = approacher_](const Vector3& point, const Vector3& normal) {
        return approacher->approachDirection(point, normal);
      };
    return request;
  }

  // Whether the plan ends the run (and why, in the result).
  bool stopsAfterPlan(const PlanResult& plan, int action) {
    if (plan.status == PlanStatus::kConverged) {
      result_.stop_reason = "converged";
      result_.converged = true;
      return true;
    }
    if (plan.status == PlanStatus::kCapReached) {
      result_.stop_reason = "planner_cap_reached";
      return true;
    }
    if (plan.status == PlanStatus::kError) {
      result_.stop_reason = "planner_error: " + plan.message;
      return true;
    }
    // Checked after planning so that a model that converges exactly at the cap says so.
    if (action >= config_.max_actions) {
      result_.stop_reason = "max_actions";
      return true;
    }
    return false;
  }

  // The approacher's way to the planned touch, put into it; false when it found none.
  bool approach(ExplorationRecord& record, PlanResult* plan) {
    const Clock::time_point approach_started = Clock::now();
    ApproachResult approach = approacher_->plan(plan->touch);
    record.approach_ms += millisecondsSince(approach_started);
    record.approach_compute_ms += approach.planning_ms;
    if (approach.ok) {
      plan->touch.approach_path = std::move(approach.approach_path);
      plan->touch.retreat_path = std::move(approach.retreat_path);
      plan->touch.approach_joints = std::move(approach.approach_joints);
      plan->touch.retreat_joints = std::move(approach.retreat_joints);
      record.guarded_entry = approach.guarded_entry;
      return true;
    }
    // No safe way there: the target counts as evidence, as a touch made would, so that the
    // next plan looks elsewhere.
    ++record.approach_refusals;
    ++result_.unreachable_touches;
    record.approach_message = approach.message;
    const std::vector<Vector3> aimed = aimedPoints(plan->touch);
    attempted_.attempted_targets.insert(attempted_.attempted_targets.end(), aimed.begin(), aimed.end());
    attempted_.attempted_target_errors_m.insert(attempted_.attempted_target_errors_m.end(), aimed.size(),
                                                std::numeric_limits<double>::quiet_NaN());
    return false;
  }

  // An action whose every touch the approacher refused: a failed touch, none made.
  bool giveUpOnTheAction(ExplorationRecord& record, Clock::time_point action_started) {
    record.probe_reason = "no safe approach to " + std::to_string(record.approach_refusals) +
                          " touches in a row; the last: " + record.approach_message;
    ++consecutive_failures_;
    report(record, action_started);
    record.contacts_total = result_.contacts;
    result_.records.push_back(record);
    return !stopsAfterFailures();
  }

  // Probes the touch and adds what it found to the model. True when the model's observation
  // budget is full.
  bool probeAndUpdate(const Touch& touch, ExplorationRecord& record) {
    const Clock::time_point probe_started = Clock::now();
    const ProbeResult probed = prober_.probe(touch);
    record.probe_ms = millisecondsSince(probe_started);
    rememberWhereItAimed(touch, probed, record);
    ++result_.actions;
    record.probe_success = probed.success;
    record.probe_reason = probed.reason;
    record.approach_collisions = probed.approach_collisions;
    record.retreat_collisions = probed.retreat_collisions;
    result_.approach_collisions += probed.approach_collisions;
    result_.retreat_collisions += probed.retreat_collisions;
    result_.guarded_entries += record.guarded_entry ? 1 : 0;

    bool budget_full = false;
    if (!probed.contacts.empty() || !probed.free_space.empty()) {
      const Clock::time_point update_started = Clock::now();
      const TouchUpdate update = updater_.update(probed);
      budget_full = update.budget_full;
      record.update_ms = millisecondsSince(update_started);
      if (update.ok) {
        if (approacher_) approacher_->modelChanged();
        record.contacts_added = update.contacts_added;
        record.contact_positions = update.contact_positions;
        record.free_points_added = update.free_points_added;
        record.retraction = update.retraction;
      } else {
        // The model is unchanged; the action counts as a failed touch and exploration goes on.
        record.update_message = update.message;
      }
    }
    result_.contacts += record.contacts_added;
    record.contacts_total = result_.contacts;
    return budget_full;
  }

  // Where touches aimed counts as evidence, whatever they found: otherwise a point whose
  // approach another part of the object blocks is asked for again after every touch. Also the
  // probe's footprint: half the side of the largest pad it has reported.
  void rememberWhereItAimed(const Touch& touch, const ProbeResult& probed, ExplorationRecord& record) {
    const std::vector<Vector3> aimed = aimedPoints(touch);
    const std::vector<double> passed = passedTargetErrors(touch, probed.contacts);
    attempted_.attempted_targets.insert(attempted_.attempted_targets.end(), aimed.begin(), aimed.end());
    attempted_.attempted_target_errors_m.insert(attempted_.attempted_target_errors_m.end(), passed.begin(),
                                                passed.end());
    record.target_error_m = median(targetErrors(aimed, probed.contacts));
    if (touch.explores_unknown && probed.contacts.empty()) ++attempted_.empty_unknown_pokes;
    for (const PadPress& pad : probed.pads)
      if (std::isfinite(pad.size_m)) footprint_radius_m_ = std::max(footprint_radius_m_, 0.5 * pad.size_m);
  }

  // The caller's progress callback, and the action's times.
  void report(ExplorationRecord& record, Clock::time_point action_started) const {
    const Clock::time_point progress_started = Clock::now();
    if (progress_) progress_(record);
    record.progress_ms = millisecondsSince(progress_started);
    record.action_ms = millisecondsSince(action_started);
  }

  bool stopsAfterFailures() {
    if (consecutive_failures_ < config_.max_consecutive_failures) return false;
    result_.stop_reason = "consecutive_failures";
    return true;
  }

  const Explorer::Config& config_;
  TouchPlanner& planner_;
  Prober& prober_;
  ModelUpdater& updater_;
  const Explorer::Progress& progress_;
  TouchApproacher* approacher_;
  ExplorationResult result_;
  int consecutive_failures_{0};
  EvidenceState attempted_;  // where touches aimed, and how far from it each found the surface
  double footprint_radius_m_{0.0};
};

}  // namespace

ExplorationResult Explorer::run(TouchPlanner& planner, Prober& prober, ModelUpdater& updater,
                                const Progress& progress, TouchApproacher* approacher) const {
  if (const std::string problem = validate(config_); !problem.empty()) {
    ExplorationResult result;
    result.stop_reason = "invalid_config: " + problem;
    return result;
  }
  return ExplorationRun(config_, planner, prober, updater, progress, approacher).run();
}

}  // namespace gpatlas_core
