#include "gpatlas_ros/ros_exploration_adapters.h"

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/Probe.h>

#include <stdexcept>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

gpatlas_msgs::Touch ExplorationServices::touchMsg(const gpatlas_core::Touch& touch) const {
  gpatlas_msgs::Touch msg = toMsg(touch, arm_joint_names, approach.arm_joint_speed_rad_s);
  msg.header.frame_id = world_frame;
  msg.header.stamp = ros::Time::now();
  return msg;
}

gpatlas_core::PlanResult ServicePlanner::plan(const gpatlas_core::PlanRequest& request) {
  gpatlas_msgs::GetNextTouch srv;
  srv.request = toMsg(request);
  srv.request.strategy = services_.strategy;
  // The planner's side of the loop's reachability test (PlanRequest::reachable).
  srv.request.reachable_only = services_.approach.enabled;
  // Plan on the model that holds the last update: the planner rebuilds its replica from the
  // training set this node has seen, which can take it longer than this node took to see it.
  if (const auto training = services_.watch.latestTraining()) srv.request.model_stamp = training->header.stamp;
  const ros::WallTime asked = ros::WallTime::now();
  while (true) {
    if (!services_.client.call("next_touch", srv)) throw std::runtime_error("next_touch did not answer");
    if (srv.response.status != gpatlas_msgs::GetNextTouch::Response::STALE_MODEL) break;
    if ((ros::WallTime::now() - asked).toSec() > services_.call_timeout_s)
      throw std::runtime_error("next_touch: " + srv.response.message);
    ros::WallDuration(0.02).sleep();
  }
  return fromMsg(srv.response);
}

std::size_t ServicePlanner::modelSize() const {
  const auto training = services_.watch.latestTraining();
  return training ? training->points.size() : 0;
}

gpatlas_core::ProbeResult ServiceProber::probe(const gpatlas_core::Touch& touch) {
  gpatlas_msgs::Probe srv;
  srv.request.touch = services_.touchMsg(touch);
  if (!services_.client.call("probe", srv)) throw std::runtime_error("probe did not answer");
  gpatlas_core::ProbeResult result;
  std::string error;
  if (!fromMsg(srv.response.observations, &result, &error)) {
    result = gpatlas_core::ProbeResult();
    result.reason = "malformed observations: " + error;
    return result;
  }
  result.success = srv.response.success;
  result.reason = srv.response.reason;
  result.approach_collisions = srv.response.approach_collisions;
  result.retreat_collisions = srv.response.retreat_collisions;
  services_.observations_header = srv.response.observations.header;
  return result;
}

gpatlas_core::TouchUpdate ServiceUpdater::update(const gpatlas_core::ProbeResult& probed) {
  gpatlas_msgs::AddObservations srv;
  srv.request.observations = toMsg(probed);
  srv.request.observations.header = services_.observations_header;
  const ros::WallTime started = ros::WallTime::now();
  if (!services_.client.call("add_observations", srv)) throw std::runtime_error("add_observations did not answer");
  gpatlas_core::TouchUpdate update;
  update.ok = srv.response.success;
  update.message = srv.response.message;
  update.contacts_added = static_cast<int>(srv.response.num_contacts_added);
  update.free_points_added = static_cast<int>(srv.response.num_added) - update.contacts_added;
  update.budget_full = srv.response.observation_budget_full;
  if (update.ok) services_.watch.waitForTrainingSetNewerThan(started);
  return update;
}

void ServiceApproacher::prepare() {
  const auto training = services_.watch.latestTraining();
  if (!training) return;
  if (!services_.watch.waitForCollisionMapOf(training->sequence, services_.call_timeout_s))
    throw std::runtime_error("no collision map of training set " + std::to_string(training->sequence) + " within " +
                             std::to_string(services_.call_timeout_s) + " s (collision_map_status)");
}

gpatlas_core::ApproachResult ServiceApproacher::plan(const gpatlas_core::Touch& touch) {
  gpatlas_msgs::PlanApproach srv;
  srv.request.touch = services_.touchMsg(touch);
  srv.request.start = toPointMsg(services_.approach.rest_tip_position_m);
  // prepare() waited for the map of the newest training set, or for the news that it failed:
  // then the answer comes from the older map and says so (map_stale).
  if (!services_.client.call("plan_approach", srv)) throw std::runtime_error("plan_approach did not answer");
  gpatlas_core::ApproachResult result;
  result.ok = srv.response.success;
  result.message = srv.response.message;
  if (srv.response.map_stale) result.message += " (on the map of an older model: its rebuild failed)";
  result.planning_ms = 1000.0 * srv.response.planning_time_s;
  for (const auto& p : srv.response.approach) result.approach_path.push_back(fromMsg(p));
  for (const auto& p : srv.response.retreat) result.retreat_path.push_back(fromMsg(p));
  const auto& approach = srv.response.approach_trajectory;
  if (result.ok && !approach.points.empty()) {
    services_.arm_joint_names = approach.joint_names;
    std::string why;
    if (!fromJointTrajectoryMsg(approach, approach.joint_names, &result.approach_joints, &why) ||
        !fromJointTrajectoryMsg(srv.response.retreat_trajectory, approach.joint_names, &result.retreat_joints, &why))
      throw std::runtime_error("plan_approach answered a malformed joint trajectory: " + why);
  }
  return result;
}

}  // namespace gpatlas_ros
