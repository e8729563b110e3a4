#pragma once

#include "gpatlas_motion/arm_approach_planner.h"
#include "gpatlas_motion/probe_approach_planner.h"
#include "gpatlas_motion/scene_map.h"

#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/model/occupancy_grid.h>
#include <gpatlas_core/observations/support_plane.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

namespace octomap {
class OcTree;
}

namespace gpatlas_motion {

// The centres of a grid's nodes above `occupied_probability`: the object as its model predicts it.
std::vector<Eigen::Vector3d> occupiedCentres(const gpatlas_core::OccupancyGrid& grid, double occupied_probability);

// The collision map as an octree of P(occupied): every grid node becomes a leaf holding its
// log-odds (P clamped to [0.001, 0.999]), the tree's occupancy threshold is `occupied_probability`. `occupied` (optional)
// gets the number of nodes above it. Throws std::invalid_argument for a grid that is not ok.
std::unique_ptr<octomap::OcTree> collisionOctree(const gpatlas_core::OccupancyGrid& grid, double occupied_probability,
                                                 std::size_t* occupied = nullptr);

// A touch's way there and back: the approach from `rest` to the approach pose in front of
// gpatlas_core::approachTarget(touch), the probing segment from there to the target, and the
// retreat from the approach pose in front of retreatTarget back to `rest` (for a poke the
// approach reversed, for a slide planned on its own).
struct TouchMotion {
  bool ok{false};
  std::string message;  // why not, when !ok
  std::vector<Eigen::Vector3d> approach;  // the tip's positions
  std::vector<Eigen::Vector3d> probing;
  std::vector<Eigen::Vector3d> retreat;
  Eigen::Vector3d direction{Eigen::Vector3d::Zero()};  // the probe's, on the approach
  // Planned for the arm: its configurations along the same motions (the tip positions above
  // are theirs); empty for the probe on its own.
  std::vector<Eigen::VectorXd> approach_joints;
  std::vector<Eigen::VectorXd> probing_joints;
  std::vector<Eigen::VectorXd> retreat_joints;
  bool guarded_entry{false};  // the way there or back enters the unseen space (ApproachPlan's)
  double planning_ms{0.0};
};
TouchMotion planTouchMotion(const ProbeApproachPlanner& planner, const gpatlas_core::Touch& touch,
                            const Eigen::Vector3d& rest);

// The approach planning on one collision map, for the probe on its own or for the arm that
// holds it: what the bench's approacher, the collision map nodelet's plan_approach and the
// planner nodelet's cheap test share. The table (optional) is a static half-space.
class TouchMotionPlanner {
 public:
  // With an arm (config.use_arm), its rest is armRestConfiguration(config.rest_tip_position_m),
  // which throws std::runtime_error when the arm does not reach it; use_arm without an arm
  // throws std::invalid_argument.
  // `reach` (optional) keeps what the cheap test learns of the arm's reach for the next map.
  // `unseen` (optional): the space no sensor observed near the object, which the probe's way
  // there and back avoids (ProbeApproachPlanner::setUnseenSpace).
  TouchMotionPlanner(const ApproachConfig& config, std::shared_ptr<const octomap::OcTree> map,
                     const std::optional<gpatlas_core::SupportPlane>& table, std::shared_ptr<const Arm> arm,
                     std::shared_ptr<ArmReachMemory> reach = nullptr,
                     std::shared_ptr<const octomap::OcTree> unseen = nullptr);

  // The cheap test of a candidate (ProbeApproachPlanner's or ArmApproachPlanner's
  // checkApproachPose): empty when it may be approached, else why not.
  std::string check(const Eigen::Vector3d& point, const Eigen::Vector3d& outward_normal) const;
  // The first of approachDirections (the normal, then the directions tilted from
  // it, the first of each ring toward the table's normal, or +z without a table) that check()
  // accepts and whose approach pose lies clear of the unseen space
  // (ProbeApproachPlanner::approachPoseObserved); when none does, the first that check() accepts,
  // whose way will end in a guarded entry along its line; nullopt when check() accepts none.
  std::optional<Eigen::Vector3d> approachDirection(const Eigen::Vector3d& point,
                                                   const Eigen::Vector3d& outward_normal) const;

  // The touch's way there and back from the rest (the probe's tip at rest_tip_position_m, or
  // the arm's rest configuration); a start given for the one planned for replaces its rest.
  TouchMotion plan(const gpatlas_core::Touch& touch, const Eigen::Vector3d* probe_start = nullptr,
                   const Eigen::VectorXd* arm_start = nullptr) const;

 private:
  ApproachConfig config_;
  std::shared_ptr<ProbeApproachPlanner> probe_;
  std::unique_ptr<ArmApproachPlanner> arm_;
  Eigen::VectorXd arm_rest_;
  std::shared_ptr<ArmReachMemory> reach_;
  Eigen::Vector3d up_{Eigen::Vector3d::UnitZ()};
};

// Approach planning in one process (the bench): a collision map built from the model, occupied
// where P(occupied) exceeds ApproachConfig::occupied_probability, with the scene (setScene),
// rebuilt after every touch the model took, with the table as a static half-space, and the probe's rest at
// ApproachConfig::rest_tip_position_m. With an arm (ApproachConfig::use_arm), the arm's
// joint path is planned (ArmApproachPlanner) from its rest, armRestConfiguration.
class ModelTouchApproacher : public gpatlas_core::TouchApproacher {
 public:
  // Throws std::invalid_argument when use_arm is set without an arm, std::runtime_error when
  // the arm does not reach its rest.
  ModelTouchApproacher(const gpatlas_core::SurfaceModel& model, ApproachConfig config,
                       gpatlas_core::OccupancyGridBuilder::Config grid,
                       std::optional<gpatlas_core::SupportPlane> table, std::shared_ptr<const Arm> arm = nullptr);
  ~ModelTouchApproacher() override;

  gpatlas_core::ApproachResult plan(const gpatlas_core::Touch& touch) override;
  // TouchMotionPlanner::approachDirection.
  std::optional<Eigen::Vector3d> approachDirection(const Eigen::Vector3d& point,
                                                   const Eigen::Vector3d& outward_normal) override;
  void modelChanged() override { planner_.reset(); }
  // Builds the map of the model as it is now (a failure is reported by plan()).
  void prepare() override { ensureMap(); }
  // The camera's scene in every map, as the collision map nodelet merges it: its occupied voxels
  // but the explored object's (its view's points `object_view_points` and the model's surface
  // points) and those the probe went through are obstacles (sceneObstacles), and the unobserved
  // voxels near the object (SceneMapConfig::unseen_reach_m) block the way there and back
  // (sceneUnseen). Null: none.
  void setScene(std::shared_ptr<const SceneMap> scene, std::vector<Eigen::Vector3d> object_view_points);

  // The last map's build time (ms) and size.
  double lastMapBuildMs() const { return last_map_ms_; }
  // The scene's voxels in the last map.
  std::size_t lastSceneObstacles() const { return last_scene_obstacles_; }

 private:
  const gpatlas_core::SurfaceModel& model_;
  ApproachConfig config_;
  gpatlas_core::OccupancyGridBuilder::Config grid_;
  std::optional<gpatlas_core::SupportPlane> table_;
  std::shared_ptr<const Arm> arm_;
  std::shared_ptr<ArmReachMemory> reach_;
  std::unique_ptr<TouchMotionPlanner> planner_;  // null: the map must be (re)built
  std::shared_ptr<const SceneMap> scene_;
  std::vector<Eigen::Vector3d> object_view_points_;
  double last_map_ms_{0.0};
  std::size_t last_scene_obstacles_{0};

  // The planner on a map of the model as it is now; empty with why when the map fails.
  std::string ensureMap();
};

}  // namespace gpatlas_motion
