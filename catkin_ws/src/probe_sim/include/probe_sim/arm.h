#pragma once

#include "probe_sim/scene.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <kdl/chain.hpp>
#include <kdl/tree.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace probe_sim {

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
  double collision_tolerance_m = 1e-3;  // penetration below this is not a collision

  // Inverse kinematics: damped least squares with joint-limit clamping and random restarts.
  int ik_restarts = 40;
  int ik_max_iterations = 250;
  double ik_damping = 0.02;
  double ik_max_step_rad = 0.3;
  double position_tolerance_m = 1e-3;
  double approach_tolerance_rad = 1.0 * 3.14159265358979323846 / 180.0;
  std::uint32_t seed = 7;
};

// Serial arm from a URDF (base link -> tip link), for reachability and link collision checks of
// simulated touches. The tip frame's z axis is the approach direction (into the surface). The
// base link's frame is taken to be the scene's world frame.
class Arm {
 public:
  using Config = ArmConfig;

  struct IkResult {
    bool success = false;      // reached within tolerance (and collision-free when checked)
    bool reached = false;      // some configuration reached the pose, possibly colliding
    unsigned collision_kinds = 0;  // SurfaceKind bits hit by the best reaching configuration
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

  // Joints that put the tip at tip_position with its z axis along approach_direction (any roll
  // about it). With a scene, only collision-free configurations count as success. The seed, if
  // given and of the right size, is tried first.
  IkResult solveApproach(const Eigen::Vector3d& tip_position,
                         const Eigen::Vector3d& approach_direction, const Scene* scene = nullptr,
                         const Eigen::VectorXd* seed = nullptr) const;

  // Collision capsules of the links (see Config) in the base frame.
  std::vector<Capsule> linkCapsules(const Eigen::VectorXd& joints) const;
  // SurfaceKind bits of scene surfaces that any link capsule penetrates.
  unsigned collisions(const Scene& scene, const Eigen::VectorXd& joints) const;

 private:
  struct Solvers;
  Eigen::VectorXd lower_;
  Eigen::VectorXd upper_;
  std::vector<std::string> joint_names_;
  Config config_;
  std::unique_ptr<Solvers> solvers_;
};

// A URDF's kinematic tree (urdfdom and KDL, no ROS); throws std::runtime_error when it does
// not parse.
KDL::Tree kinematicTreeFromUrdf(const std::string& urdf_xml);

}  // namespace probe_sim
