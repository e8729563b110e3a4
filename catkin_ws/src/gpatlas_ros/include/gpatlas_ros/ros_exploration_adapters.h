#pragma once

// Algorithm 2's steps as the pipeline's services, for gpatlas_core::Explorer (which runs the
// loop): next_touch plans, probe touches, add_observations updates the model and plan_approach
// finds the way. A service that is missing or does not answer throws, which ends the run
// ("error: ...").

#include <gpatlas_motion/approach_config.h>
#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_msgs/Touch.h>
#include <gpatlas_ros/pipeline_watch.h>
#include <gpatlas_ros/timed_service_client.h>
#include <std_msgs/Header.h>

#include <string>
#include <vector>

namespace gpatlas_ros {

// What the four adapters share: the services and topics, the node's settings, and what one step
// hands the next.
struct ExplorationServices {
  TimedServiceClient& client;
  const PipelineWatch& watch;
  std::string world_frame;
  std::string strategy;                     // asked of next_touch
  gpatlas_motion::ApproachConfig approach;    // enabled: plan on reachable candidates, plan_approach
  double call_timeout_s{600.0};             // also how long a stale model or map is waited for
  // The joint names of plan_approach's trajectories, when it planned for the arm: the probe's
  // touch carries the trajectories by these names.
  std::vector<std::string> arm_joint_names;
  // The frame of the last probe's observations, in which add_observations gets them.
  std_msgs::Header observations_header;

  // A touch for the services: in the world frame, stamped now, with the arm's trajectories.
  gpatlas_msgs::Touch touchMsg(const gpatlas_core::Touch& touch) const;
};

class ServicePlanner : public gpatlas_core::TouchPlanner {
 public:
  explicit ServicePlanner(ExplorationServices& services) : services_(services) {}
  gpatlas_core::PlanResult plan(const gpatlas_core::PlanRequest& request) override;
  std::size_t modelSize() const override;

 private:
  ExplorationServices& services_;
};

class ServiceProber : public gpatlas_core::Prober {
 public:
  explicit ServiceProber(ExplorationServices& services) : services_(services) {}
  gpatlas_core::ProbeResult probe(const gpatlas_core::Touch& touch) override;

 private:
  ExplorationServices& services_;
};

class ServiceUpdater : public gpatlas_core::ModelUpdater {
 public:
  explicit ServiceUpdater(ExplorationServices& services) : services_(services) {}
  gpatlas_core::TouchUpdate update(const gpatlas_core::ProbeResult& probed) override;

 private:
  ExplorationServices& services_;
};

// Approach planning on the collision map nodelet (plan_approach), on the map of the newest
// training set this node has seen: after a touch the map is rebuilt from the updated model,
// and the approach waits for it.
class ServiceApproacher : public gpatlas_core::TouchApproacher {
 public:
  explicit ServiceApproacher(ExplorationServices& services) : services_(services) {}
  // Waits for the collision map of the newest training set (or the news that it failed), so
  // that neither the planner's reachability test nor plan_approach waits for it.
  void prepare() override;
  gpatlas_core::ApproachResult plan(const gpatlas_core::Touch& touch) override;

 private:
  ExplorationServices& services_;
};

}  // namespace gpatlas_ros
