#include "gpatlas_motion/probe_approach_planner.h"

#include <Eigen/Geometry>
#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/collision_object.h>
#include <octomap/OcTree.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace gpatlas_motion {
namespace {

// Outside the map nothing was seen: a path there would be free only for want of knowledge.
// Empty when `touch_point` lies within the map's known box, else the refusal.
std::string outsideMap(const Eigen::AlignedBox3d& map_bounds, const Eigen::Vector3d& touch_point) {
  if (map_bounds.contains(touch_point)) return "";
  std::ostringstream message;
  message << "the touch (" << touch_point.transpose() << ") is outside the collision map (" << map_bounds.min().transpose()
          << " to " << map_bounds.max().transpose() << " m): nothing is known there";
  return message.str();
}

namespace ob = ompl::base;
namespace og = ompl::geometric;

}  // namespace

struct ProbeApproachPlanner::Impl {
  ApproachConfig config;
  std::shared_ptr<fcl::Sphered> tip;
  std::shared_ptr<fcl::Capsuled> shaft;
  std::shared_ptr<fcl::OcTreed> map;  // null: no map yet
  Eigen::AlignedBox3d map_bounds;      // the map's known voxels, grown by one voxel
  std::unique_ptr<fcl::CollisionObjectd> map_object;
  std::shared_ptr<fcl::OcTreed> unseen;  // null: none
  std::unique_ptr<fcl::CollisionObjectd> unseen_object;
  double unseen_extent_m{0.0};  // the unseen tree's bounding box's diagonal
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> static_obstacles;  // boxes, half-spaces

  bool collides(const fcl::CollisionObjectd& a, const fcl::CollisionObjectd& b) const {
    fcl::CollisionRequestd request;
    fcl::CollisionResultd result;
    fcl::collide(&a, &b, request, result);
    return result.isCollision();
  }

  // Whether the probe's body, its tip at `tip_centre` pointing along `direction`, is clear of the
  // map and the static obstacles (`obstacles`) and of the unseen space (`unseen`: on its way there
  // and back).
  bool isClear(const Eigen::Vector3d& tip_centre, const Eigen::Vector3d& direction, bool obstacles, bool unseen) const {
    fcl::Transform3d tip_pose = fcl::Transform3d::Identity();
    tip_pose.translation() = tip_centre;
    const fcl::CollisionObjectd tip_object(tip, tip_pose);
    // The shaft behind the tip, along -direction; FCL's capsule runs along its z axis.
    fcl::Transform3d shaft_pose = fcl::Transform3d::Identity();
    shaft_pose.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), direction).toRotationMatrix();
    shaft_pose.translation() =
        tip_centre - direction * (config.probe.tip_radius_m + 0.5 * config.probe.shaft_length_m);
    const fcl::CollisionObjectd shaft_object(shaft, shaft_pose);
    const auto hits = [&](const fcl::CollisionObjectd& obstacle) {
      return collides(tip_object, obstacle) || collides(shaft_object, obstacle);
    };
    if (obstacles) {
      if (map_object && hits(*map_object)) return false;
      for (const auto& obstacle : static_obstacles)
        if (hits(*obstacle)) return false;
    }
    return !(unseen && unseen_object && hits(*unseen_object));
  }
  bool isFree(const Eigen::Vector3d& tip_centre, const Eigen::Vector3d& direction) const {
    return isClear(tip_centre, direction, true, false);
  }
  bool isWayFree(const Eigen::Vector3d& tip_centre, const Eigen::Vector3d& direction) const {
    return isClear(tip_centre, direction, true, true);
  }

  // Where the probe, pointing along -normal, comes out of the unseen space going out from the
  // approach pose along the normal (the approach pose itself when it is clear of it), with the
  // line to there free; nullopt when an obstacle or the end of the unseen space's extent comes
  // first.
  std::optional<Eigen::Vector3d> guardedEntry(const Eigen::Vector3d& approach_pose, const Eigen::Vector3d& normal) const {
    const double step = config.check_resolution_m;
    for (double t = 0.0; t <= unseen_extent_m + step; t += step) {
      const Eigen::Vector3d tip_centre = approach_pose + t * normal;
      if (!isFree(tip_centre, -normal)) return std::nullopt;
      if (isWayFree(tip_centre, -normal)) return tip_centre;
    }
    return std::nullopt;
  }

  // Empty when the approach pose in front of the touch and the probing segment, up to the
  // contact zone around the touch, are free; otherwise why not. `normal` is unit.
  std::string approachPoseProblem(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& normal) const {
    const Eigen::Vector3d approach_pose = touch_point + config.approach_distance_m * normal;
    if (!isFree(approach_pose, -normal))
      return "the approach pose, " + std::to_string(config.approach_distance_m) +
             " m out along the normal, is in collision: the touch cannot be approached";
    const double probing_length =
        std::max(0.0, config.approach_distance_m - config.contact_zone_m - config.probe.tip_radius_m);
    if (!segmentClear(approach_pose, approach_pose - probing_length * normal, -normal, /*way=*/false))
      return "the probing segment meets an obstacle before the touch: the touch is occluded";
    return "";
  }

  // Whether every point of the segment, sampled at check_resolution_m, is clear (isClear).
  bool segmentClear(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& direction,
                    bool way) const {
    const double length = (b - a).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / config.check_resolution_m)));
    for (int i = 0; i <= steps; ++i)
      if (!isClear(a + (b - a) * (static_cast<double>(i) / steps), direction, true, way)) return false;
    return true;
  }
};

ProbeApproachPlanner::ProbeApproachPlanner(ApproachConfig config) : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  const ProbeGeometry& probe = config.probe;
  impl_->tip = std::make_shared<fcl::Sphered>(probe.tip_radius_m + config.clearance_m);
  impl_->shaft = std::make_shared<fcl::Capsuled>(probe.shaft_radius_m + config.clearance_m, probe.shaft_length_m);
  // OMPL seeds one process-wide generator once, before its first use: plans are reproducible
  // within a process started the same way.
  static std::once_flag seeded;
  std::call_once(seeded, [] {
    ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
    ompl::RNG::setSeed(1);
  });
}

ProbeApproachPlanner::~ProbeApproachPlanner() = default;

void ProbeApproachPlanner::setCollisionMap(std::shared_ptr<const octomap::OcTree> map) {
  impl_->map_object.reset();
  impl_->map.reset();
  if (!map) return;
  impl_->map = std::make_shared<fcl::OcTreed>(map);
  double lo[3], hi[3];
  map->getMetricMin(lo[0], lo[1], lo[2]);
  map->getMetricMax(hi[0], hi[1], hi[2]);
  const Eigen::Vector3d voxel = Eigen::Vector3d::Constant(map->getResolution());
  impl_->map_bounds = Eigen::AlignedBox3d(Eigen::Vector3d(lo[0], lo[1], lo[2]) - voxel, Eigen::Vector3d(hi[0], hi[1], hi[2]) + voxel);
  // Every node is free or occupied at the one threshold: FCL skips "uncertain" nodes.
  impl_->map->setOccupancyThres(impl_->config.occupied_probability);
  impl_->map->setFreeThres(impl_->config.occupied_probability);
  impl_->map_object = std::make_unique<fcl::CollisionObjectd>(impl_->map, fcl::Transform3d::Identity());
}

void ProbeApproachPlanner::setUnseenSpace(std::shared_ptr<const octomap::OcTree> unseen) {
  impl_->unseen_object.reset();
  impl_->unseen.reset();
  impl_->unseen_extent_m = 0.0;
  if (!unseen || unseen->getRoot() == nullptr) return;
  impl_->unseen = std::make_shared<fcl::OcTreed>(unseen);
  double lo[3], hi[3];
  unseen->getMetricMin(lo[0], lo[1], lo[2]);
  unseen->getMetricMax(hi[0], hi[1], hi[2]);
  impl_->unseen_extent_m = (Eigen::Vector3d(hi[0], hi[1], hi[2]) - Eigen::Vector3d(lo[0], lo[1], lo[2])).norm();
  impl_->unseen->setOccupancyThres(0.5);
  impl_->unseen->setFreeThres(0.5);
  impl_->unseen_object = std::make_unique<fcl::CollisionObjectd>(impl_->unseen, fcl::Transform3d::Identity());
}

void ProbeApproachPlanner::addStaticBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& size) {
  fcl::Transform3d pose = fcl::Transform3d::Identity();
  pose.translation() = centre;
  impl_->static_obstacles.push_back(
      std::make_unique<fcl::CollisionObjectd>(std::make_shared<fcl::Boxd>(size.x(), size.y(), size.z()), pose));
}

void ProbeApproachPlanner::addStaticHalfSpace(const Eigen::Vector3d& normal, double offset) {
  // FCL's half-space is solid where n . x < d.
  const double length = normal.norm();
  if (!normal.allFinite() || !std::isfinite(offset) || !(length > 0.0))
    throw std::invalid_argument("a static half-space needs a finite, non-zero normal and a finite offset");
  impl_->static_obstacles.push_back(std::make_unique<fcl::CollisionObjectd>(
      std::make_shared<fcl::Halfspaced>(normal / length, -offset / length), fcl::Transform3d::Identity()));
}

std::string ProbeApproachPlanner::checkApproachPose(const Eigen::Vector3d& touch_point,
                                                    const Eigen::Vector3d& touch_normal) const {
  if (!impl_->map) return "no collision map yet";
  if (impl_->map->getRoot() == nullptr) return "the collision map is empty";
  if (!touch_point.allFinite() || !touch_normal.allFinite() || touch_normal.norm() < 1e-9)
    return "the touch and its normal must be finite, the normal non-zero";
  if (std::string outside = outsideMap(impl_->map_bounds, touch_point); !outside.empty()) return outside;
  return impl_->approachPoseProblem(touch_point, touch_normal.normalized());
}

bool ProbeApproachPlanner::isFree(const Eigen::Vector3d& tip, const Eigen::Vector3d& direction) const {
  return impl_->isFree(tip, direction.normalized());
}

bool ProbeApproachPlanner::isWayFree(const Eigen::Vector3d& tip, const Eigen::Vector3d& direction) const {
  return impl_->isWayFree(tip, direction.normalized());
}

std::optional<Eigen::Vector3d> ProbeApproachPlanner::wayEnd(const Eigen::Vector3d& touch_point,
                                                            const Eigen::Vector3d& touch_normal) const {
  const Eigen::Vector3d normal = touch_normal.normalized();
  return impl_->guardedEntry(touch_point + impl_->config.approach_distance_m * normal, normal);
}

bool ProbeApproachPlanner::approachPoseObserved(const Eigen::Vector3d& touch_point,
                                                const Eigen::Vector3d& touch_normal) const {
  if (!touch_point.allFinite() || !touch_normal.allFinite() || !(touch_normal.norm() > 1e-9)) return false;
  const Eigen::Vector3d normal = touch_normal.normalized();
  return impl_->isClear(touch_point + impl_->config.approach_distance_m * normal, -normal, /*obstacles=*/false,
                        /*unseen=*/true);
}

bool ProbeApproachPlanner::isCapsuleFree(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius) const {
  const Eigen::Vector3d axis = b - a;
  const double length = axis.norm();
  fcl::Transform3d pose = fcl::Transform3d::Identity();
  pose.translation() = 0.5 * (a + b);
  if (length > 1e-9) pose.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis).toRotationMatrix();
  const fcl::CollisionObjectd capsule(std::make_shared<fcl::Capsuled>(radius + impl_->config.clearance_m, length), pose);
  if (impl_->map_object && impl_->collides(capsule, *impl_->map_object)) return false;
  for (const auto& obstacle : impl_->static_obstacles)
    if (impl_->collides(capsule, *obstacle)) return false;
  return true;
}

const ApproachConfig& ProbeApproachPlanner::config() const { return impl_->config; }

ApproachPlan ProbeApproachPlanner::plan(const Eigen::Vector3d& start_tip, const Eigen::Vector3d& touch_point,
                                        const Eigen::Vector3d& touch_normal) const {
  const auto started = std::chrono::steady_clock::now();
  ApproachPlan plan;
  const auto finish = [&](std::string message) {
    plan.message = std::move(message);
    plan.planning_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    return plan;
  };
  const ApproachConfig& c = impl_->config;
  if (const std::string problem = validate(c); !problem.empty()) return finish("invalid config: " + problem);
  if (!impl_->map) return finish("no collision map yet");
  if (impl_->map->getRoot() == nullptr) return finish("the collision map is empty");
  if (!start_tip.allFinite() || !touch_point.allFinite() || !touch_normal.allFinite() || touch_normal.norm() < 1e-9)
    return finish("the start, the touch and its normal must be finite, the normal non-zero");
  if (std::string outside = outsideMap(impl_->map_bounds, touch_point); !outside.empty()) return finish(std::move(outside));
  const Eigen::Vector3d normal = touch_normal.normalized();
  plan.direction = -normal;
  const Eigen::Vector3d approach_pose = touch_point + c.approach_distance_m * normal;
  if (!impl_->isFree(start_tip, plan.direction)) return finish("the probe's start is in collision");
  if (std::string blocked = impl_->approachPoseProblem(touch_point, normal); !blocked.empty())
    return finish(std::move(blocked));
  // The way ends where the probe enters the unseen space along the touch's line, if it must.
  const std::optional<Eigen::Vector3d> entry = impl_->guardedEntry(approach_pose, normal);
  if (!entry)
    return finish("the approach pose lies in space no sensor observed, and the touch's line out of it meets an obstacle");
  if (!impl_->isWayFree(start_tip, plan.direction)) return finish("the probe's start lies in space no sensor observed");
  plan.approach = planWay(start_tip, *entry, plan.direction, &plan.message);
  if (plan.approach.empty()) return finish(plan.message);
  plan.guarded_entry = !entry->isApprox(approach_pose);
  if (plan.guarded_entry) plan.approach.push_back(approach_pose);
  plan.probing = {approach_pose, touch_point};
  plan.retreat.assign(plan.approach.rbegin(), plan.approach.rend());
  plan.ok = true;
  return finish("");
}

std::vector<Eigen::Vector3d> ProbeApproachPlanner::planWay(const Eigen::Vector3d& start_tip, const Eigen::Vector3d& goal_tip,
                                                           const Eigen::Vector3d& direction, std::string* problem) const {
  const ApproachConfig& c = impl_->config;
  std::vector<Eigen::Vector3d> way;
  if (impl_->segmentClear(start_tip, goal_tip, direction, true)) {
    way = {start_tip, goal_tip};
  } else {
    auto space = std::make_shared<ob::RealVectorStateSpace>(3);
    ob::RealVectorBounds bounds(3);
    for (int i = 0; i < 3; ++i) {
      bounds.setLow(i, std::min(start_tip[i], goal_tip[i]) - c.workspace_margin_m);
      bounds.setHigh(i, std::max(start_tip[i], goal_tip[i]) + c.workspace_margin_m);
    }
    space->setBounds(bounds);
    og::SimpleSetup setup(space);
    setup.setStateValidityChecker([this, direction](const ob::State* state) {
      const auto* v = state->as<ob::RealVectorStateSpace::StateType>();
      return impl_->isWayFree(Eigen::Vector3d(v->values[0], v->values[1], v->values[2]), direction);
    });
    setup.getSpaceInformation()->setStateValidityCheckingResolution(c.check_resolution_m / space->getMaximumExtent());
    ob::ScopedState<> start(space), goal(space);
    for (int i = 0; i < 3; ++i) {
      start[i] = start_tip[i];
      goal[i] = goal_tip[i];
    }
    setup.setStartAndGoalStates(start, goal);
    setup.setPlanner(std::make_shared<og::RRTConnect>(setup.getSpaceInformation()));
    const ob::PlannerStatus solved = setup.solve(c.max_planning_time_s);
    if (solved != ob::PlannerStatus::EXACT_SOLUTION) {
      std::ostringstream message;
      message << "no collision-free approach found within " << c.max_planning_time_s << " s (" << solved.asString() << ")";
      *problem = message.str();
      return {};
    }
    setup.simplifySolution(0.25 * c.max_planning_time_s);
    for (const ob::State* state : setup.getSolutionPath().getStates()) {
      const auto* v = state->as<ob::RealVectorStateSpace::StateType>();
      way.emplace_back(v->values[0], v->values[1], v->values[2]);
    }
  }
  return way;
}

}  // namespace gpatlas_motion
