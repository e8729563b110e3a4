#include "gpatlas_motion/arm_approach_planner.h"

#include <Eigen/Geometry>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace gpatlas_motion {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;

std::vector<Eigen::Vector3d> tipPositions(const Arm& arm, const std::vector<Eigen::VectorXd>& path) {
  std::vector<Eigen::Vector3d> tips;
  for (const Eigen::VectorXd& q : path) tips.push_back(arm.forwardKinematics(q).translation());
  return tips;
}

}  // namespace

ArmApproachPlanner::ArmApproachPlanner(std::shared_ptr<const Arm> arm, std::shared_ptr<const ProbeApproachPlanner> world)
    : arm_(std::move(arm)), world_(std::move(world)) {
  if (!arm_ || !world_) throw std::invalid_argument("ArmApproachPlanner: an arm and a world are required");
}

std::string ArmApproachPlanner::configurationProblem(const Eigen::VectorXd& q, bool on_way) const {
  if (q.size() != arm_->jointCount() || !q.allFinite())
    return "a configuration needs " + std::to_string(arm_->jointCount()) + " finite joint values";
  constexpr double kLimitTolerance = 1e-9;
  for (Eigen::Index j = 0; j < q.size(); ++j)
    if (q[j] < arm_->lowerLimits()[j] - kLimitTolerance || q[j] > arm_->upperLimits()[j] + kLimitTolerance)
      return "joint " + arm_->jointNames()[static_cast<std::size_t>(j)] + " is outside its limits";
  // The links; the tool after the last joint is the probe, checked with its own geometry.
  for (const LinkCapsule& link : arm_->linkCapsules(q, false))
    if (!world_->isCapsuleFree(link.a, link.b, link.radius)) return "the arm's links are in collision";
  const Eigen::Isometry3d tip = arm_->forwardKinematics(q);
  // One check where the probe is clear (isWayFree includes isFree); the second only to say why not.
  const Eigen::Vector3d direction = tip.linear().col(2);
  if (on_way ? world_->isWayFree(tip.translation(), direction) : world_->isFree(tip.translation(), direction)) return "";
  return on_way && world_->isFree(tip.translation(), direction) ? "the probe is in space no sensor observed"
                                                               : "the probe is in collision";
}

bool ArmApproachPlanner::motionFree(const Eigen::VectorXd& from, const Eigen::VectorXd& to, bool on_way) const {
  const double step = world_->config().arm_check_step_rad;
  const int steps = std::max(1, static_cast<int>(std::ceil((to - from).norm() / step)));
  for (int i = 1; i <= steps; ++i)
    if (!configurationProblem(from + (to - from) * (static_cast<double>(i) / steps), on_way).empty()) return false;
  return true;
}

Eigen::VectorXd ArmApproachPlanner::wayEndConfiguration(const Eigen::VectorXd& at_approach, const Eigen::Vector3d& touch_point,
                                                        const Eigen::Vector3d& normal, std::string* problem) const {
  const std::optional<Eigen::Vector3d> end = world_->wayEnd(touch_point, normal);
  if (!end) {
    *problem = "the approach pose lies in space no sensor observed, and the touch's line out of it meets an obstacle";
    return {};
  }
  if (end->isApprox(touch_point + world_->config().approach_distance_m * normal)) return at_approach;
  const Arm::IkResult ik = arm_->solveApproach(
      *end, -normal, [&](const Eigen::VectorXd& q) { return configurationProblem(q, true).empty() ? 0u : 1u; },
      &at_approach, world_->config().arm_reachability_ik_restarts);
  if (!ik.success || !motionFree(ik.joints, at_approach, false)) {
    *problem = "no free arm configuration where the touch's line leaves the space no sensor observed";
    return {};
  }
  return ik.joints;
}

std::vector<Eigen::VectorXd> ArmApproachPlanner::planJointPath(const Eigen::VectorXd& from, const Eigen::VectorXd& to,
                                                               std::string* problem) const {
  if (motionFree(from, to, true)) return {from, to};
  const ApproachConfig& c = world_->config();
  const unsigned n = static_cast<unsigned>(arm_->jointCount());
  auto space = std::make_shared<ob::RealVectorStateSpace>(n);
  ob::RealVectorBounds bounds(n);
  for (unsigned j = 0; j < n; ++j) {
    bounds.setLow(j, arm_->lowerLimits()[j]);
    bounds.setHigh(j, arm_->upperLimits()[j]);
  }
  space->setBounds(bounds);
  og::SimpleSetup setup(space);
  const auto toJoints = [n](const ob::State* state) {
    const auto* v = state->as<ob::RealVectorStateSpace::StateType>();
    return Eigen::Map<const Eigen::VectorXd>(v->values, n).eval();
  };
  setup.setStateValidityChecker(
      [this, toJoints](const ob::State* state) { return configurationProblem(toJoints(state), true).empty(); });
  setup.getSpaceInformation()->setStateValidityCheckingResolution(c.arm_check_step_rad / space->getMaximumExtent());
  ob::ScopedState<> start(space), goal(space);
  for (unsigned j = 0; j < n; ++j) {
    start[j] = from[j];
    goal[j] = to[j];
  }
  setup.setStartAndGoalStates(start, goal);
  setup.setPlanner(std::make_shared<og::RRTConnect>(setup.getSpaceInformation()));
  const ob::PlannerStatus solved = setup.solve(c.max_planning_time_s);
  if (solved != ob::PlannerStatus::EXACT_SOLUTION) {
    std::ostringstream message;
    message << "no collision-free arm motion found within " << c.max_planning_time_s << " s (" << solved.asString()
            << ")";
    *problem = message.str();
    return {};
  }
  setup.simplifySolution(0.25 * c.max_planning_time_s);
  std::vector<Eigen::VectorXd> path;
  for (const ob::State* state : setup.getSolutionPath().getStates()) path.push_back(toJoints(state));
  return path;
}

ArmReachMemory::Key ArmReachMemory::key(const Eigen::Vector3d& position, const Eigen::Vector3d& direction) const {
  Key k;
  for (int i = 0; i < 3; ++i) {
    k[static_cast<std::size_t>(i)] = std::lround(position[i] / cell_m_);
    k[static_cast<std::size_t>(i + 3)] = std::lround(direction[i] / direction_cell_);
  }
  return k;
}

std::optional<ArmReachMemory::Verdict> ArmReachMemory::find(const Eigen::Vector3d& position,
                                                            const Eigen::Vector3d& direction) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = verdicts_.find(key(position, direction));
  if (it == verdicts_.end()) return std::nullopt;
  return it->second;
}

void ArmReachMemory::remember(const Eigen::Vector3d& position, const Eigen::Vector3d& direction, Verdict verdict) {
  std::lock_guard<std::mutex> lock(mutex_);
  verdicts_[key(position, direction)] = std::move(verdict);
}

std::string ArmApproachPlanner::checkApproachPose(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& touch_normal,
                                                  ArmReachMemory* memory) const {
  if (std::string problem = world_->checkApproachPose(touch_point, touch_normal); !problem.empty()) return problem;
  const Eigen::Vector3d normal = touch_normal.normalized();
  const Eigen::Vector3d pose = touch_point + world_->config().approach_distance_m * normal;
  const std::optional<ArmReachMemory::Verdict> known = memory ? memory->find(pose, -normal) : std::nullopt;
  if (known && !known->reached) return "the arm does not reach the approach pose";
  const Arm::IkResult ik = solveApproachPose(touch_point, normal, known ? &known->joints : nullptr,
                                             world_->config().arm_reachability_ik_restarts, nullptr);
  if (memory && !known) memory->remember(pose, -normal, {ik.reached, ik.reached ? ik.joints : Eigen::VectorXd()});
  if (!ik.reached) return "the arm does not reach the approach pose";
  if (!ik.success)
    return "no arm configuration found at the approach pose is free with a clear probing segment (" +
           approachConfigurationProblem(ik.joints, touch_point, normal, nullptr) + ")";
  return "";
}

std::string ArmApproachPlanner::approachConfigurationProblem(const Eigen::VectorXd& at_approach,
                                                             const Eigen::Vector3d& touch_point,
                                                             const Eigen::Vector3d& normal,
                                                             Eigen::VectorXd* at_touch) const {
  if (std::string problem = configurationProblem(at_approach); !problem.empty()) return problem;
  // The probing segment: the tip goes on along -normal to the touch, where it meets the surface
  // by design; the links must stay clear of the object on the way.
  const Arm::IkResult touching = arm_->solveApproach(touch_point, -normal, nullptr, &at_approach, 1);
  if (!touching.reached) return "the arm does not reach the touch along its normal from there";
  const Eigen::VectorXd& a = at_approach;
  const Eigen::VectorXd& b = touching.joints;
  const int steps = std::max(1, static_cast<int>(std::ceil((b - a).norm() / world_->config().arm_check_step_rad)));
  for (int i = 0; i <= steps; ++i)
    for (const LinkCapsule& link : arm_->linkCapsules(a + (b - a) * (static_cast<double>(i) / steps), false))
      if (!world_->isCapsuleFree(link.a, link.b, link.radius)) return "the arm's links meet an obstacle on the probing segment";
  if (at_touch) *at_touch = b;
  return "";
}

Arm::IkResult ArmApproachPlanner::solveApproachPose(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& normal,
                                                   const Eigen::VectorXd* seed, int restarts,
                                                   Eigen::VectorXd* at_touch) const {
  return arm_->solveApproach(
      touch_point + world_->config().approach_distance_m * normal, -normal,
      [&](const Eigen::VectorXd& q) { return approachConfigurationProblem(q, touch_point, normal, at_touch).empty() ? 0u : 1u; },
      seed, restarts);
}

ArmMotionPlan ArmApproachPlanner::plan(const Eigen::VectorXd& start, const Eigen::Vector3d& touch_point,
                                       const Eigen::Vector3d& touch_normal) const {
  const auto started = std::chrono::steady_clock::now();
  ArmMotionPlan plan;
  const auto finish = [&](std::string message) {
    plan.message = std::move(message);
    plan.planning_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    return plan;
  };
  const ApproachConfig& c = world_->config();
  if (const std::string problem = validate(c); !problem.empty()) return finish("invalid config: " + problem);
  if (std::string problem = world_->checkApproachPose(touch_point, touch_normal); !problem.empty())
    return finish(std::move(problem));
  if (std::string problem = configurationProblem(start, true); !problem.empty())
    return finish("the arm's start: " + problem);
  const Eigen::Vector3d normal = touch_normal.normalized();
  Eigen::VectorXd at_touch;
  const Arm::IkResult at_approach = solveApproachPose(touch_point, normal, &start, 0, &at_touch);
  if (!at_approach.reached) return finish("the arm does not reach the approach pose");
  if (!at_approach.success)
    return finish("no arm configuration found at the approach pose is free with a clear probing segment (" +
                  approachConfigurationProblem(at_approach.joints, touch_point, normal, nullptr) + ")");
  const Eigen::VectorXd& a = at_approach.joints;
  const Eigen::VectorXd& b = at_touch;
  std::string problem;
  const Eigen::VectorXd way_end = wayEndConfiguration(a, touch_point, normal, &problem);
  if (way_end.size() == 0) return finish(problem);
  plan.approach = planJointPath(start, way_end, &problem);
  if (plan.approach.empty()) return finish(problem);
  plan.guarded_entry = !way_end.isApprox(a);
  if (plan.guarded_entry) plan.approach.push_back(a);
  plan.probing = {a, b};
  plan.retreat.assign(plan.approach.rbegin(), plan.approach.rend());
  plan.approach_tips = tipPositions(*arm_, plan.approach);
  plan.retreat_tips = tipPositions(*arm_, plan.retreat);
  plan.ok = true;
  return finish("");
}

ArmMotionPlan planArmTouchMotion(const ArmApproachPlanner& planner, const gpatlas_core::Touch& touch,
                                 const Eigen::VectorXd& rest) {
  ArmMotionPlan motion;
  if (touch.points.empty() || touch.normals.size() != touch.points.size()) {
    motion.message = "the touch needs at least one waypoint and a normal for each";
    return motion;
  }
  const std::size_t first = gpatlas_core::approachTarget(touch);
  const std::size_t last = gpatlas_core::retreatTarget(touch);
  motion = planner.plan(rest, touch.points[first], touch.normals[first]);
  if (!motion.ok || last == first) return motion;
  const ArmMotionPlan back = planner.plan(rest, touch.points[last], touch.normals[last]);
  motion.planning_ms += back.planning_ms;
  if (!back.ok) {
    motion.ok = false;
    motion.message = "no way back from the slide's end: " + back.message;
    return motion;
  }
  motion.retreat = back.retreat;
  motion.retreat_tips = back.retreat_tips;
  motion.guarded_entry = motion.guarded_entry || back.guarded_entry;
  return motion;
}

}  // namespace gpatlas_motion
