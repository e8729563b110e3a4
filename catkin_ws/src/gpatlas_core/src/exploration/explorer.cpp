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

double finiteMedian(std::vector<double> values) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }), values.end());
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle), values.end());
  const double upper = values[middle];
  if (values.size() % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle)));
}

std::string validate(const Explorer::Config& config) {
  std::ostringstream problem;
  if (!(config.v_max > 0.0) || !std::isfinite(config.v_max)) problem << "v_max must be positive and finite; ";
  if (config.max_actions < 0) problem << "max_actions must be >= 0; ";
  if (config.max_consecutive_failures < 1) problem << "max_consecutive_failures must be >= 1; ";
  if (config.max_approach_attempts < 1) problem << "max_approach_attempts must be >= 1; ";
  return problem.str();
}

PlanResult ModelTouchPlanner::plan(const PlanRequest& request) {
  // The rule is this planner's; the targets and their errors are the request's, after the rule's own.
  PlanRequest full = request;
  full.evidence = evidence_;
  EvidenceRule& rule = full.evidence;
  const std::vector<Vector3>& attempted = request.evidence.attempted_targets;
  const std::vector<double>& errors = request.evidence.attempted_target_errors_m;
  if (!errors.empty() && errors.size() != attempted.size()) {
    PlanResult error;
    error.status = PlanStatus::kError;
    error.message = "attempted_target_errors_m must be empty or hold one value per attempted target";
    return error;
  }
  if (!errors.empty() || !rule.attempted_target_errors_m.empty()) {
    rule.attempted_target_errors_m.resize(rule.attempted_targets.size(), std::numeric_limits<double>::quiet_NaN());
    rule.attempted_target_errors_m.insert(rule.attempted_target_errors_m.end(), errors.begin(), errors.end());
    rule.attempted_target_errors_m.resize(rule.attempted_targets.size() + attempted.size(),
                                          std::numeric_limits<double>::quiet_NaN());
  }
  rule.attempted_targets.insert(rule.attempted_targets.end(), attempted.begin(), attempted.end());
  return strategy_.plan(model_, full);
}

TouchUpdate ModelTouchUpdater::update(const ProbeResult& probed) {
  return applyTouch(model_, probed.contacts, probed.free_space, config_);
}

ExplorationResult Explorer::run(SurfaceModel& model, const ExplorationStrategy& strategy, Prober& prober,
                                const TouchObservationConfig& touch, const EvidenceRule& evidence,
                                const Progress& progress, TouchApproacher* approacher) const {
  if (!model.isFitted()) {
    ExplorationResult result;
    result.stop_reason = "planner_error: no model: the GP is not fitted";
    return result;
  }
  if (const std::string problem = validate(touch) + validate(evidence); !problem.empty()) {
    ExplorationResult result;
    result.stop_reason = "invalid_config: " + problem;
    return result;
  }
  ModelTouchPlanner planner(model, strategy, evidence);
  ModelTouchUpdater updater(model, touch);
  return run(planner, prober, updater, progress, approacher);
}

ExplorationResult Explorer::run(TouchPlanner& planner, Prober& prober, ModelUpdater& updater,
                                const Progress& progress, TouchApproacher* approacher) const {
  ExplorationResult result;
  if (const std::string problem = validate(config_); !problem.empty()) {
    result.stop_reason = "invalid_config: " + problem;
    return result;
  }
  int consecutive_failures = 0;
  // Where touches aimed counts as evidence, whatever they found: otherwise a point whose
  // approach another part of the object blocks is asked for again after every touch.
  std::vector<Vector3> attempted_targets;
  std::vector<double> attempted_errors;  // per target: how far from it its touch found the surface
  double footprint_radius_m = 0.0;       // half the side of the largest pad the prober reported
  try {
    for (int action = 0;; ++action) {
      const Clock::time_point action_started = Clock::now();
      ExplorationRecord record;
      record.index = action;
      record.n_train = planner.modelSize();

      if (approacher) {
        const Clock::time_point prepare_started = Clock::now();
        approacher->prepare();
        record.approach_ms += millisecondsSince(prepare_started);
      }
      // Plan; with an approacher, until it finds a way to the touch or refused too many.
      PlanResult plan;
      bool approach_refused = false;
      for (int attempt = 0;; ++attempt) {
        PlanRequest request;
        request.v_max = config_.v_max;
        request.evidence.attempted_targets = attempted_targets;
        request.evidence.attempted_target_errors_m = attempted_errors;
        request.footprint_radius_m = footprint_radius_m;
        request.seed = mixSeeds(config_.seed, static_cast<std::uint64_t>(action));
        if (attempt > 0) request.seed = mixSeeds(request.seed, static_cast<std::uint64_t>(attempt));
        if (approacher)
          request.reachable = [approacher](const Vector3& point, const Vector3& normal) {
            return approacher->approachDirection(point, normal);
          };
        const Clock::time_point plan_started = Clock::now();
        plan = planner.plan(request);
        record.unreachable_candidates += plan.unreachable_candidates;
        result.unreachable_candidates += plan.unreachable_candidates;
        record.plan_ms += millisecondsSince(plan_started);
        record.plan_compute_ms += 1000.0 * plan.elapsed_s;
        record.plan_status = plan.status;
        record.max_evaluated_variance = plan.max_evaluated_variance;
        result.final_max_evaluated_variance = plan.max_evaluated_variance;
        result.final_unreachable_candidates = plan.unreachable_candidates;

        if (plan.status == PlanStatus::kConverged) {
          result.stop_reason = "converged";
          result.converged = true;
          return result;
        }
        if (plan.status == PlanStatus::kCapReached) {
          result.stop_reason = "planner_cap_reached";
          return result;
        }
        if (plan.status == PlanStatus::kError) {
          result.stop_reason = "planner_error: " + plan.message;
          return result;
        }
        // Checked after planning so that a model that converges exactly at the cap says so.
        if (action >= config_.max_actions) {
          result.stop_reason = "max_actions";
          return result;
        }
        if (!approacher) break;
        const Clock::time_point approach_started = Clock::now();
        ApproachResult approach = approacher->plan(plan.touch);
        record.approach_ms += millisecondsSince(approach_started);
        record.approach_compute_ms += approach.planning_ms;
        if (approach.ok) {
          plan.touch.approach_path = std::move(approach.approach_path);
          plan.touch.retreat_path = std::move(approach.retreat_path);
          plan.touch.approach_joints = std::move(approach.approach_joints);
          plan.touch.retreat_joints = std::move(approach.retreat_joints);
          break;
        }
        // No safe way there: the target counts as evidence, as a touch made would, so that the
        // next plan looks elsewhere.
        ++record.approach_refusals;
        ++result.unreachable_touches;
        record.approach_message = approach.message;
        const std::vector<Vector3> aimed = aimedPoints(plan.touch);
        attempted_targets.insert(attempted_targets.end(), aimed.begin(), aimed.end());
        attempted_errors.insert(attempted_errors.end(), aimed.size(), std::numeric_limits<double>::quiet_NaN());
        if (record.approach_refusals >= config_.max_approach_attempts) {
          approach_refused = true;
          break;
        }
      }

      record.touch = plan.touch;
      if (approach_refused) {
        record.probe_reason = "no safe approach to " + std::to_string(record.approach_refusals) +
                              " touches in a row; the last: " + record.approach_message;
        ++consecutive_failures;
        const Clock::time_point progress_started = Clock::now();
        if (progress) progress(record);
        record.progress_ms = millisecondsSince(progress_started);
        record.action_ms = millisecondsSince(action_started);
        record.contacts_total = result.contacts;
        result.records.push_back(record);
        if (consecutive_failures >= config_.max_consecutive_failures) {
          result.stop_reason = "consecutive_failures";
          return result;
        }
        continue;
      }
      const Clock::time_point probe_started = Clock::now();
      const ProbeResult probed = prober.probe(plan.touch);
      record.probe_ms = millisecondsSince(probe_started);
      const std::vector<Vector3> aimed = aimedPoints(plan.touch);
      const std::vector<double> passed = passedTargetErrors(plan.touch, probed.contacts);
      attempted_targets.insert(attempted_targets.end(), aimed.begin(), aimed.end());
      attempted_errors.insert(attempted_errors.end(), passed.begin(), passed.end());
      record.target_error_m = finiteMedian(targetErrors(aimed, probed.contacts));
      for (const PadPress& pad : probed.pads)
        if (std::isfinite(pad.size_m)) footprint_radius_m = std::max(footprint_radius_m, 0.5 * pad.size_m);
      ++result.actions;
      record.probe_success = probed.success;
      record.probe_reason = probed.reason;
      record.approach_collisions = probed.approach_collisions;
      record.retreat_collisions = probed.retreat_collisions;
      result.approach_collisions += probed.approach_collisions;
      result.retreat_collisions += probed.retreat_collisions;

      bool budget_full = false;
      if (!probed.contacts.empty() || !probed.free_space.empty()) {
        const Clock::time_point update_started = Clock::now();
        const TouchUpdate update = updater.update(probed);
        budget_full = update.budget_full;
        record.update_ms = millisecondsSince(update_started);
        if (update.ok) {
          if (approacher) approacher->modelChanged();
          record.contacts_added = update.contacts_added;
          record.free_points_added = update.free_points_added;
          record.retraction = update.retraction;
        } else {
          // The model is unchanged; the action counts as a failed touch and exploration goes on.
          record.update_message = update.message;
        }
      }
      result.contacts += record.contacts_added;
      record.contacts_total = result.contacts;

      const bool touched = probed.success && record.contacts_added > 0;
      consecutive_failures = touched ? 0 : consecutive_failures + 1;
      const Clock::time_point progress_started = Clock::now();
      if (progress) progress(record);
      record.progress_ms = millisecondsSince(progress_started);
      record.action_ms = millisecondsSince(action_started);
      result.records.push_back(record);
      if (budget_full) {
        result.stop_reason = "observation_budget_full";
        return result;
      }
      if (consecutive_failures >= config_.max_consecutive_failures) {
        result.stop_reason = "consecutive_failures";
        return result;
      }
    }
  } catch (const std::exception& e) {
    result.stop_reason = std::string("error: ") + e.what();
  }
  return result;
}

}  // namespace gpatlas_core
