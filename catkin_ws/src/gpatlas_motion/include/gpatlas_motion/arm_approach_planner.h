#pragma once

#include "gpatlas_motion/arm.h"
#include "gpatlas_motion/probe_approach_planner.h"

#include <gpatlas_core/common/types.h>

#include <Eigen/Core>

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_motion {

// One touch's motion for the arm that holds the probe, in joint space (the arm's joint order):
// from the start to the approach pose, the probing segment from there to the touch, and the
// retreat from the approach pose back to the start. `*_tips` are the probe tip's positions at
// those configurations (forward kinematics), for the probe's judge and for display.
struct ArmMotionPlan {
  bool ok{false};
  std::string message;  // why not, when !ok
  std::vector<Eigen::VectorXd> approach;
  std::vector<Eigen::VectorXd> probing;
  std::vector<Eigen::VectorXd> retreat;
  std::vector<Eigen::Vector3d> approach_tips;
  std::vector<Eigen::Vector3d> retreat_tips;
  bool guarded_entry{false};  // as ApproachPlan's: the last stretch in enters the unseen space
  double planning_ms{0.0};
};

// What the arm's kinematics reach, remembered across collision maps (which do not change it)
// for the cheap test of candidates, which meets the same places again in every plan. Approach
// poses in one cell (cell_m of position, cell of the direction's components) share a verdict:
// out of reach, or the configuration that reached one of them, the solver's first start for
// the next. Thread-safe.
class ArmReachMemory {
 public:
  explicit ArmReachMemory(double cell_m = 0.005, double direction_cell = 0.05)
      : cell_m_(cell_m), direction_cell_(direction_cell) {}
  struct Verdict {
    bool reached{false};
    Eigen::VectorXd joints;  // when reached
  };
  std::optional<Verdict> find(const Eigen::Vector3d& position, const Eigen::Vector3d& direction) const;
  void remember(const Eigen::Vector3d& position, const Eigen::Vector3d& direction, Verdict verdict);

 private:
  using Key = std::array<long, 6>;
  Key key(const Eigen::Vector3d& position, const Eigen::Vector3d& direction) const;
  double cell_m_, direction_cell_;
  mutable std::mutex mutex_;
  std::map<Key, Verdict> verdicts_;
};

// Paper Algorithm 2's APPROACHTO and MOVEAWAY for the arm: OMPL's RRT-Connect in the arm's
// joint space (within its joint limits), with path simplification, where the straight joint
// motion is blocked. A configuration is free when the links' capsules (ApproachConfig's
// arm_link_radius_m) and the probe (tip and shaft at the tip frame) are clear, by clearance_m,
// of the collision map's occupied voxels and the static world of `world`. The approach pose is
// the tip approach_distance_m out along the touch's normal, its z axis along -normal (any roll);
// its configuration comes from inverse kinematics.
class ArmApproachPlanner {
 public:
  // The world (map, static obstacles, probe geometry, settings) is shared, not copied.
  ArmApproachPlanner(std::shared_ptr<const Arm> arm, std::shared_ptr<const ProbeApproachPlanner> world);

  const Arm& arm() const { return *arm_; }

  // Empty when the configuration is within the limits and free; otherwise why not. `on_way`:
  // on the way to a touch or back, where the probe keeps out of the unseen space too
  // (ProbeApproachPlanner::isWayFree).
  std::string configurationProblem(const Eigen::VectorXd& joints, bool on_way = false) const;

  // The approach from `start` (joints) to the touch's approach pose, the probing segment, and
  // the approach reversed as the retreat.
  ArmMotionPlan plan(const Eigen::VectorXd& start, const Eigen::Vector3d& touch_point,
                     const Eigen::Vector3d& touch_normal) const;

  // The cheap test: the probe's approach pose and probing segment are clear
  // (ProbeApproachPlanner::checkApproachPose) and a free configuration puts the tip there,
  // found with ApproachConfig::arm_reachability_ik_restarts starts (and what `memory` knows of
  // the place). Empty when so.
  std::string checkApproachPose(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& touch_normal,
                                ArmReachMemory* memory = nullptr) const;

 private:
  std::shared_ptr<const Arm> arm_;
  std::shared_ptr<const ProbeApproachPlanner> world_;
  // On the way (configurationProblem's on_way).
  std::vector<Eigen::VectorXd> planJointPath(const Eigen::VectorXd& from, const Eigen::VectorXd& to,
                                             std::string* problem) const;
  bool motionFree(const Eigen::VectorXd& from, const Eigen::VectorXd& to, bool on_way) const;
  // The configuration where the way to the touch ends (ProbeApproachPlanner::wayEnd) when the
  // approach pose lies in the unseen space: the tip out along the touch's line, found from the
  // one at the approach pose, and free to move to it; the approach pose's own otherwise. Empty
  // with the problem when there is none.
  Eigen::VectorXd wayEndConfiguration(const Eigen::VectorXd& at_approach, const Eigen::Vector3d& touch_point,
                                      const Eigen::Vector3d& normal, std::string* problem) const;
  // Empty when the configuration at the approach pose is free and the probing segment from it
  // to the touch point is clear for the links; its configuration at the touch to *at_touch.
  std::string approachConfigurationProblem(const Eigen::VectorXd& at_approach, const Eigen::Vector3d& touch_point,
                                           const Eigen::Vector3d& normal, Eigen::VectorXd* at_touch) const;
  // Inverse kinematics at the approach pose, with approachConfigurationProblem as its check.
  Arm::IkResult solveApproachPose(const Eigen::Vector3d& touch_point, const Eigen::Vector3d& normal,
                                  const Eigen::VectorXd* seed, int restarts, Eigen::VectorXd* at_touch) const;
};

// A touch's way there and back for the arm (planTouchMotion's for the probe): the approach to
// approachTarget(touch), the probing segment, and the retreat from retreatTarget(touch) (for a
// slide planned on its own).
ArmMotionPlan planArmTouchMotion(const ArmApproachPlanner& planner, const gpatlas_core::Touch& touch,
                                 const Eigen::VectorXd& rest);

}  // namespace gpatlas_motion
