// The loop's service answers: probe, add_observations, plan_approach (conversions.h).
#include "gpatlas_conversions/conversions.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_conversions {

namespace {

std::uint32_t count(int n) { return static_cast<std::uint32_t>(std::max(0, n)); }

}  // namespace

gpatlas_msgs::Probe::Response toProbeResponseMsg(const gpatlas_core::ProbeResult& result) {
  gpatlas_msgs::Probe::Response msg;
  msg.success = result.success;
  msg.reason = result.reason;
  msg.observations = toMsg(result);
  msg.approach_collisions = result.approach_collisions;
  msg.retreat_collisions = result.retreat_collisions;
  return msg;
}

gpatlas_core::ProbeResult fromMsg(const gpatlas_msgs::Probe::Response& msg) {
  gpatlas_core::ProbeResult result;
  std::string error;
  if (!fromMsg(msg.observations, &result, &error)) {
    result = gpatlas_core::ProbeResult();
    result.reason = "malformed observations: " + error;
    return result;
  }
  result.success = msg.success;
  result.reason = msg.reason;
  result.approach_collisions = msg.approach_collisions;
  result.retreat_collisions = msg.retreat_collisions;
  return result;
}

gpatlas_msgs::AddObservations::Response toMsg(const gpatlas_core::TouchUpdate& update) {
  gpatlas_msgs::AddObservations::Response msg;
  msg.success = update.ok;
  msg.message = update.message;
  msg.num_added = count(update.points_added);
  msg.num_contacts_added = count(update.contacts_added);
  for (const gpatlas_core::Vector3& p : update.contact_positions) msg.contacts_added.push_back(toPointMsg(p));
  msg.num_free_space_added = count(update.free_points_added);
  msg.num_refused = static_cast<std::uint32_t>(update.contacts_refused.total() + update.free_space_refused.total());
  msg.observation_budget_full = update.budget_full;
  return msg;
}

gpatlas_core::TouchUpdate fromMsg(const gpatlas_msgs::AddObservations::Response& msg) {
  gpatlas_core::TouchUpdate update;
  update.ok = msg.success;
  update.message = msg.message;
  update.points_added = static_cast<int>(msg.num_added);
  update.contacts_added = static_cast<int>(msg.num_contacts_added);
  for (const auto& p : msg.contacts_added) update.contact_positions.push_back(fromMsg(p));
  update.free_points_added = static_cast<int>(msg.num_free_space_added);
  update.budget_full = msg.observation_budget_full;
  return update;
}

bool fromMsg(const gpatlas_msgs::PlanApproach::Response& msg, gpatlas_core::ApproachResult* result,
             std::vector<std::string>* joint_names, std::string* error) {
  gpatlas_core::ApproachResult out;
  out.ok = msg.success;
  out.message = msg.message;
  if (msg.map_stale) out.message += " (on the map of an older model: its rebuild failed)";
  out.planning_ms = 1000.0 * msg.planning_time_s;
  out.guarded_entry = msg.guarded_entry;
  for (const auto& p : msg.approach) out.approach_path.push_back(fromMsg(p));
  for (const auto& p : msg.retreat) out.retreat_path.push_back(fromMsg(p));
  const auto& approach = msg.approach_trajectory;
  if (out.ok && !approach.points.empty()) {
    if (!fromJointTrajectoryMsg(approach, approach.joint_names, &out.approach_joints, error) ||
        !fromJointTrajectoryMsg(msg.retreat_trajectory, approach.joint_names, &out.retreat_joints, error))
      return false;
    *joint_names = approach.joint_names;
  }
  *result = std::move(out);
  return true;
}

}  // namespace gpatlas_conversions
