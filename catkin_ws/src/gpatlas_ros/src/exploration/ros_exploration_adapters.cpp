#include "gpatlas_ros/ros_exploration_adapters.h"

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/Probe.h>
#include <gpatlas_ros/wait_report.h>

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
  WaitReport report("exploration", [this, &srv] {
    return "the planner's model of the newest training set: " + services_.client.resolveName("next_touch") +
           " answers STALE_MODEL (" + srv.response.message + "); gives up after call_timeout_s (" +
           seconds(services_.call_timeout_s) + ")";
  });
  while (true) {
    if (!services_.client.call("next_touch", srv)) throw std::runtime_error("next_touch did not answer");
    if (srv.response.status != gpatlas_msgs::GetNextTouch::Response::STALE_MODEL) break;
    if ((ros::WallTime::now() - asked).toSec() > services_.call_timeout_s)
      throw std::runtime_error("next_touch: " + srv.response.message);
    report.poll();
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
  services_.observations_header = srv.response.observations.header;
  return fromMsg(srv.response);
}

gpatlas_core::TouchUpdate ServiceUpdater::update(const gpatlas_core::ProbeResult& probed) {
  gpatlas_msgs::AddObservations srv;
  srv.request.observations = toMsg(probed);
  srv.request.observations.header = services_.observations_header;
  const ros::WallTime started = ros::WallTime::now();
  if (!services_.client.call("add_observations", srv)) throw std::runtime_error("add_observations did not answer");
  const gpatlas_core::TouchUpdate update = fromMsg(srv.response);
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
  std::string why;
  if (!fromMsg(srv.response, &result, &services_.arm_joint_names, &why))
    throw std::runtime_error("plan_approach answered a malformed joint trajectory: " + why);
  return result;
}

}  // namespace gpatlas_ros
