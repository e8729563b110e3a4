#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <kdl/chain.hpp>
#include <kdl/tree.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_motion {

// A capsule along the segment a-b: one link of the arm in collision checks.
struct LinkCapsule {
  Eigen::Vector3d a{Eigen::Vector3d::Zero()};
  Eigen::Vector3d b{Eigen::Vector3d::Zero()};
  double radius{0.0};
};

struct ArmConfig {
  std::string base_link = "world";
  std::string tip_link = "probe_tip";

  // Link collision model: one capsule per chain segment between consecutive joint frames.
  double link_radius_m = 0.06;
  // Segments after the last movable joint are the probe tool, much thinner than the arm.
  double tool_radius_m = 0.01;
  // The tool capsule stops this far short of the tip frame: the tip touches the object by
  // design and is not a collision.
  double tip_clearance_m = 0.03;
  // The segments up to the second movable joint only turn about the first joint's axis, so
  // they cannot be moved out of a collision (e.g. a base standing on the table): skip them.
  bool skip_base_column = true;
  double collision_tolerance_m = 1e-3;  // the simulation's: penetration below this is not a collision

  // Inverse kinematics: damped least squares with joint-limit clamping and random restarts.
  int ik_restarts = 40;
  int ik_max_iterations = 250;
  double ik_damping = 0.02;
  double ik_max_step_rad = 0.3;
  // A start whose error (metres plus ik_stall_metres_per_rad times the approach angle) has not
  // shrunk by 0.1 % in this many iterations is abandoned.
  int ik_stall_iterations = 10;
  double ik_stall_metres_per_rad = 0.1;
  double position_tolerance_m = 1e-3;
  double approach_tolerance_rad = 1.0 * 3.14159265358979323846 / 180.0;
  std::uint32_t seed = 7;
};

// Serial arm from a URDF (base link -> tip link): forward and inverse kinematics and the links'
// collision capsules, for the approach planner (on the collision map) and the simulation (on
// the true scene). The tip frame's z axis is the approach direction (into the surface). The
// base link's frame is taken to be the world frame.
class Arm {
 public:
  using Config = ArmConfig;

  struct IkResult {
    bool success = false;      // reached within tolerance (and collision-free when checked)
    bool reached = false;      // some configuration reached the pose, possibly colliding
    unsigned collision_kinds = 0;  // the collision check's answer for the best reaching configuration
    Eigen::VectorXd joints;
    double position_error_m = 0.0;
    double approach_error_rad = 0.0;
  };

  // Both throw std::runtime_error when the URDF does not parse or the chain does not exist.
  static Arm fromUrdfFile(const std::string& path, const Config& config = Config());
  static Arm fromUrdfString(const std::string& urdf_xml, const Config& config = Config());

  // The solvers keep a pointer to the chain, which therefore lives with them on the heap; an Arm
  // can be moved but not copied.
  Arm(const KDL::Chain& chain, Eigen::VectorXd lower_limits, Eigen::VectorXd upper_limits,
      std::vector<std::string> joint_names, const Config& config = Config());
  ~Arm();
  Arm(Arm&&) noexcept;
  Arm& operator=(Arm&&) noexcept;

  int jointCount() const;
  const std::vector<std::string>& jointNames() const { return joint_names_; }
  const Eigen::VectorXd& lowerLimits() const { return lower_; }
  const Eigen::VectorXd& upperLimits() const { return upper_; }
  const Config& config() const { return config_; }

  // Tip pose in the base frame. Throws std::runtime_error on a wrong joint count.
  Eigen::Isometry3d forwardKinematics(const Eigen::VectorXd& joints) const;

  // What a configuration collides with, as bits (0: nothing).
  using CollisionCheck = std::function<unsigned(const Eigen::VectorXd& joints)>;

  // Joints that put the tip at tip_position with its z axis along approach_direction (any roll
  // about it). With a collision check, only configurations it answers 0 for count as success.
  // The seed, if given and of the right size, is tried first; `restarts` (if > 0) replaces
  // Config::ik_restarts.
  IkResult solveApproach(const Eigen::Vector3d& tip_position,
                         const Eigen::Vector3d& approach_direction, const CollisionCheck& check = nullptr,
                         const Eigen::VectorXd* seed = nullptr, int restarts = 0) const;

  // Collision capsules of the links (see Config) in the base frame; without the tool (the
  // segments after the last movable joint) when include_tool is false.
  std::vector<LinkCapsule> linkCapsules(const Eigen::VectorXd& joints, bool include_tool = true) const;
  // The sum of the chain's segment lengths after the first joint. No point of the arm is farther
  // than this from a joint's axis, so none moves farther than this times the sum of the joints'
  // motions (rad).
  double chainLength() const;

 private:
  struct Solvers;
  Eigen::VectorXd lower_;
  Eigen::VectorXd upper_;
  std::vector<std::string> joint_names_;
  Config config_;
  std::unique_ptr<Solvers> solvers_;
};

// The arm's rest: the configuration that puts the tip at rest_tip pointing straight down
// (-z), from the middle of the joint ranges. Throws std::runtime_error when none reaches it.
Eigen::VectorXd armRestConfiguration(const Arm& arm, const Eigen::Vector3d& rest_tip);

// A URDF's kinematic tree (urdfdom and KDL, no ROS); throws std::runtime_error when it does
// not parse.
KDL::Tree kinematicTreeFromUrdf(const std::string& urdf_xml);

}  // namespace gpatlas_motion
