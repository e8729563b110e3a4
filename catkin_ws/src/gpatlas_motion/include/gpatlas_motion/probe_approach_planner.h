#pragma once

#include "gpatlas_motion/approach_config.h"

#include <Eigen/Core>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace octomap {
class OcTree;
}

namespace gpatlas_motion {

// Paper Algorithm 2's APPROACHTO and MOVEAWAY for the probe on its own (without the arm): a
// collision-free path of the probe's tip from where it is to an approach pose a safe distance
// out along the touch's normal, the probing segment from there to the touch, and the retreat.
// Obstacles are the collision map's voxels with P(occupied) above occupied_probability and the
// known static world (boxes, the table's half-space). Space outside the map counts as free: the
// map spans the model's domain, outside which the model itself predicts free space. While it
// travels the probe keeps pointing along the touch's approach direction (against the normal).
// The settings: ApproachConfig (config/pipeline.yaml's approach/).

struct ApproachPlan {
  bool ok{false};
  std::string message;  // why not, when !ok
  std::vector<Eigen::Vector3d> approach;  // tip positions: the start, ..., the approach pose
  std::vector<Eigen::Vector3d> probing;   // the approach pose and the touch
  std::vector<Eigen::Vector3d> retreat;   // the approach pose back to the start (the approach reversed)
  Eigen::Vector3d direction{Eigen::Vector3d::Zero()};  // the probe's pointing direction (against the normal)
  // The approach pose lies in the unseen space (setUnseenSpace): the way ends where the touch's
  // line leaves it and the probe comes in along that line, a guarded move on a robot.
  bool guarded_entry{false};
  double planning_ms{0.0};
};

class ProbeApproachPlanner {
 public:
  explicit ProbeApproachPlanner(ApproachConfig config);
  ~ProbeApproachPlanner();
  ProbeApproachPlanner(const ProbeApproachPlanner&) = delete;
  ProbeApproachPlanner& operator=(const ProbeApproachPlanner&) = delete;

  // The probabilistic collision map (the CollisionMap nodelet's octree of P(occupied)).
  void setCollisionMap(std::shared_ptr<const octomap::OcTree> map);
  // The space near the explored object that no sensor observed (occupied voxels; null: none),
  // where the object may have a part its model does not predict. It blocks the way to the
  // approach pose and back, not the approach pose and the probing segment: when the approach
  // pose lies in it, the probe comes in along the touch's line, from where that line leaves it,
  // as it goes on to the touch (a guarded move on a robot), and the way is planned to there.
  void setUnseenSpace(std::shared_ptr<const octomap::OcTree> unseen);
  // A box of the known static world, axis-aligned.
  void addStaticBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& size);
  // Everything below a plane (the table): solid where normal . x + offset < 0. Throws
  // std::invalid_argument for a zero or non-finite normal.
  void addStaticHalfSpace(const Eigen::Vector3d& normal, double offset);

  ApproachPlan plan(const Eigen::Vector3d& start_tip, const Eigen::Vector3d& touch_point,
                    const Eigen::Vector3d& touch_normal) const;

  // The cheap part of plan(): whether the approach pose in front of the touch and the probing
  // segment from there are clear (empty), or why not. Needs a map, like plan(), and refuses a
  // touch outside it (nothing is known there).
  std::string checkApproachPose(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& touch_normal) const;

  // Whether the probe, pointing along `direction` with its tip at `tip`, is clear of every
  // obstacle by clearance_m.
  bool isFree(const Eigen::Vector3d& tip, const Eigen::Vector3d& direction) const;
  // isFree, and the probe clear of the unseen space (setUnseenSpace): a place on the way to a
  // touch and back.
  bool isWayFree(const Eigen::Vector3d& tip, const Eigen::Vector3d& direction) const;
  // Where the probe's way to the approach pose in front of a touch ends: the approach pose when
  // it is clear of the unseen space, else the first place out along the touch's line that is,
  // from which the probe comes in along that line; nullopt when an obstacle comes first.
  std::optional<Eigen::Vector3d> wayEnd(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& touch_normal) const;
  // Whether the probe at the approach pose in front of the touch is clear of the unseen space (the
  // obstacles are checkApproachPose's): if the pose is free, the way ends there, with no guarded
  // entry through space no sensor observed.
  bool approachPoseObserved(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& touch_normal) const;
  // Whether a capsule from a to b of this radius, inflated by clearance_m, is clear of every
  // obstacle (the arm's links).
  bool isCapsuleFree(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius) const;

  const ApproachConfig& config() const;

 private:
  // The tip's way from start to goal, pointing along `direction`, clear of the obstacles and the
  // unseen space: straight when that is, else RRT-Connect's; empty with the problem when none.
  std::vector<Eigen::Vector3d> planWay(const Eigen::Vector3d& start_tip, const Eigen::Vector3d& goal_tip,
                                       const Eigen::Vector3d& direction, std::string* problem) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gpatlas_motion
