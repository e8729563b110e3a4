#include "gpatlas_motion/touch_approach.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace gpatlas_motion {

std::unique_ptr<octomap::OcTree> collisionOctree(const gpatlas_core::OccupancyGrid& grid, double occupied_probability,
                                                 std::size_t* occupied) {
  if (!grid.ok || grid.resolution <= 0.0)
    throw std::invalid_argument("no collision octree from a grid that was not built: " + grid.message);
  auto tree = std::make_unique<octomap::OcTree>(grid.resolution);
  tree->setOccupancyThres(occupied_probability);
  // OctoMap's default clamping (0.12 to 0.97, for sensor updates that must stay revisable)
  // would flatten the model's probabilities: the map is rebuilt, never updated.
  tree->setClampingThresMin(1e-3);
  tree->setClampingThresMax(1.0 - 1e-3);
  std::size_t above = 0;
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j)
      for (int i = 0; i < grid.size.x(); ++i) {
        // Clamped away from 0 and 1, whose log-odds are infinite.
        const double p = std::clamp(static_cast<double>(grid.probabilities[grid.index(i, j, k)]), 1e-3, 1.0 - 1e-3);
        const Eigen::Vector3d x = grid.position(i, j, k);
        tree->setNodeValue(octomap::point3d(static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())),
                           static_cast<float>(std::log(p / (1.0 - p))));
        above += p > occupied_probability ? 1 : 0;
      }
  tree->updateInnerOccupancy();
  tree->prune();
  if (occupied) *occupied = above;
  return tree;
}

std::vector<Eigen::Vector3d> occupiedCentres(const gpatlas_core::OccupancyGrid& grid, double occupied_probability) {
  std::vector<Eigen::Vector3d> out;
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j)
      for (int i = 0; i < grid.size.x(); ++i)
        if (grid.probabilities[grid.index(i, j, k)] > occupied_probability) out.push_back(grid.position(i, j, k));
  return out;
}

TouchMotion planTouchMotion(const ProbeApproachPlanner& planner, const gpatlas_core::Touch& touch,
                            const Eigen::Vector3d& rest) {
  TouchMotion motion;
  if (touch.points.empty() || touch.normals.size() != touch.points.size()) {
    motion.message = "the touch needs at least one waypoint and a normal for each";
    return motion;
  }
  const std::size_t first = gpatlas_core::approachTarget(touch);
  const std::size_t last = gpatlas_core::retreatTarget(touch);
  const ApproachPlan there = planner.plan(rest, touch.points[first], touch.normals[first]);
  motion.planning_ms = there.planning_ms;
  if (!there.ok) {
    motion.message = there.message;
    return motion;
  }
  motion.approach = there.approach;
  motion.probing = there.probing;
  motion.direction = there.direction;
  motion.guarded_entry = there.guarded_entry;
  if (last == first) {
    motion.retreat = there.retreat;
  } else {
    const ApproachPlan back = planner.plan(rest, touch.points[last], touch.normals[last]);
    motion.planning_ms += back.planning_ms;
    if (!back.ok) {
      motion.message = "no way back from the slide's end: " + back.message;
      return motion;
    }
    motion.retreat = back.retreat;
    motion.guarded_entry = motion.guarded_entry || back.guarded_entry;
  }
  motion.ok = true;
  return motion;
}

TouchMotionPlanner::TouchMotionPlanner(const ApproachConfig& config, std::shared_ptr<const octomap::OcTree> map,
                                       const std::optional<gpatlas_core::SupportPlane>& table,
                                       std::shared_ptr<const Arm> arm, std::shared_ptr<ArmReachMemory> reach,
                                       std::shared_ptr<const octomap::OcTree> unseen)
    : config_(config), probe_(std::make_shared<ProbeApproachPlanner>(config)), reach_(std::move(reach)) {
  probe_->setCollisionMap(std::move(map));
  probe_->setUnseenSpace(std::move(unseen));
  if (table) {
    probe_->addStaticHalfSpace(table->normal, table->offset);
    up_ = table->normal.normalized();
  }
  if (!config_.use_arm) return;
  if (!arm) throw std::invalid_argument("approach/use_arm is set but there is no arm");
  arm_rest_ = armRestConfiguration(*arm, config_.rest_tip_position_m);
  arm_ = std::make_unique<ArmApproachPlanner>(std::move(arm), probe_);
}

std::string TouchMotionPlanner::check(const Eigen::Vector3d& point, const Eigen::Vector3d& outward_normal) const {
  return arm_ ? arm_->checkApproachPose(point, outward_normal, reach_.get())
              : probe_->checkApproachPose(point, outward_normal);
}

std::optional<Eigen::Vector3d> TouchMotionPlanner::approachDirection(const Eigen::Vector3d& point,
                                                                    const Eigen::Vector3d& outward_normal) const {
  if (!point.allFinite() || !outward_normal.allFinite() || !(outward_normal.norm() > 1e-9)) return std::nullopt;
  // A part nobody saw may stand anywhere in the unseen space, the approach pose included: a
  // direction whose pose lies in seen space is worth the tilt. Only the first acceptable
  // direction into the unseen space is kept (the last resort), so each direction is checked once.
  std::optional<Eigen::Vector3d> guarded;
  for (const Eigen::Vector3d& direction : approachDirections(outward_normal, up_, config_)) {
    const bool observed = probe_->approachPoseObserved(point, direction);
    if (!observed && guarded) continue;
    if (!check(point, direction).empty()) continue;
    if (observed) return direction;
    guarded = direction;
  }
  return guarded;
}

TouchMotion TouchMotionPlanner::plan(const gpatlas_core::Touch& touch, const Eigen::Vector3d* probe_start,
                                     const Eigen::VectorXd* arm_start) const {
  if (!arm_) return planTouchMotion(*probe_, touch, probe_start ? *probe_start : config_.rest_tip_position_m);
  ArmMotionPlan arm_plan = planArmTouchMotion(*arm_, touch, arm_start ? *arm_start : arm_rest_);
  TouchMotion motion;
  motion.ok = arm_plan.ok;
  motion.message = std::move(arm_plan.message);
  motion.planning_ms = arm_plan.planning_ms;
  motion.guarded_entry = arm_plan.guarded_entry;
  if (!motion.ok) return motion;
  motion.approach = std::move(arm_plan.approach_tips);
  motion.retreat = std::move(arm_plan.retreat_tips);
  for (const Eigen::VectorXd& q : arm_plan.probing) motion.probing.push_back(arm_->arm().forwardKinematics(q).translation());
  motion.direction = arm_->arm().forwardKinematics(arm_plan.approach.back()).linear().col(2);
  motion.approach_joints = std::move(arm_plan.approach);
  motion.probing_joints = std::move(arm_plan.probing);
  motion.retreat_joints = std::move(arm_plan.retreat);
  return motion;
}

ModelTouchApproacher::ModelTouchApproacher(const gpatlas_core::SurfaceModel& model, ApproachConfig config,
                                           gpatlas_core::OccupancyGridBuilder::Config grid,
                                           std::optional<gpatlas_core::SupportPlane> table,
                                           std::shared_ptr<const Arm> arm)
    : model_(model),
      config_(std::move(config)),
      grid_(std::move(grid)),
      table_(std::move(table)),
      arm_(std::move(arm)),
      reach_(std::make_shared<ArmReachMemory>()) {
  if (config_.use_arm && !arm_) throw std::invalid_argument("approach/use_arm is set but there is no arm");
  // The arm's rest is checked now rather than at the first plan.
  if (config_.use_arm) armRestConfiguration(*arm_, config_.rest_tip_position_m);
}

ModelTouchApproacher::~ModelTouchApproacher() = default;

std::string ModelTouchApproacher::ensureMap() {
  if (planner_) return "";
  const auto started = std::chrono::steady_clock::now();
  // The planner asks only whether a voxel is above approach/occupied_probability: at 0.5 that
  // needs no variance.
  const gpatlas_core::OccupancyGrid grid =
      gpatlas_core::OccupancyGridBuilder(grid_).buildOccupancy(model_, config_.occupied_probability);
  if (!grid.ok) return "no collision map: " + grid.message;
  std::unique_ptr<octomap::OcTree> map = collisionOctree(grid, config_.occupied_probability);
  last_scene_obstacles_ = 0;
  std::shared_ptr<const octomap::OcTree> unseen;
  if (scene_) {
    const std::vector<Eigen::Vector3d> obstacles = sceneObstacles(*scene_, model_.observations(), object_view_points_);
    addObstacles(map.get(), obstacles);
    last_scene_obstacles_ = obstacles.size();
    const std::vector<Eigen::Vector3d> voxels =
        sceneUnseen(*scene_, model_.observations(), object_view_points_,
                    occupiedCentres(grid, config_.occupied_probability));
    if (!voxels.empty()) unseen = voxelOctree(voxels, grid.resolution);
  }
  planner_ = std::make_unique<TouchMotionPlanner>(config_, std::move(map), table_, arm_, reach_, std::move(unseen));
  last_map_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
  return "";
}

void ModelTouchApproacher::setScene(std::shared_ptr<const SceneMap> scene, std::vector<Eigen::Vector3d> object_view_points) {
  scene_ = std::move(scene);
  object_view_points_ = std::move(object_view_points);
  planner_.reset();
}

std::optional<Eigen::Vector3d> ModelTouchApproacher::approachDirection(const Eigen::Vector3d& point,
                                                                      const Eigen::Vector3d& outward_normal) {
  // Without a map nothing can be told: the full plan will say why.
  if (!ensureMap().empty()) return outward_normal;
  return planner_->approachDirection(point, outward_normal);
}

gpatlas_core::ApproachResult ModelTouchApproacher::plan(const gpatlas_core::Touch& touch) {
  gpatlas_core::ApproachResult result;
  result.message = ensureMap();
  if (!result.message.empty()) return result;
  TouchMotion motion = planner_->plan(touch);
  result.ok = motion.ok;
  result.message = std::move(motion.message);
  result.planning_ms = motion.planning_ms;
  if (motion.ok) {
    result.approach_path = std::move(motion.approach);
    result.retreat_path = std::move(motion.retreat);
    result.approach_joints = std::move(motion.approach_joints);
    result.retreat_joints = std::move(motion.retreat_joints);
    result.guarded_entry = motion.guarded_entry;
  }
  return result;
}

}  // namespace gpatlas_motion
