#include "gpatlas_motion/arm.h"

#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/tree.hpp>
// urdfdom's parser, not the urdf/kdl_parser packages: those are ROS libraries (urdf/model.h
// includes ros/ros.h and both link libroscpp), and this library stays free of ROS.
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Dense>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

namespace gpatlas_motion {

struct Arm::Solvers {
  explicit Solvers(const KDL::Chain& c) : chain(c), fk(chain), jacobian(chain) {}
  KDL::Chain chain;
  KDL::ChainFkSolverPos_recursive fk;
  KDL::ChainJntToJacSolver jacobian;
};

namespace {

Eigen::Isometry3d toEigen(const KDL::Frame& frame) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pose.linear()(r, c) = frame.M(r, c);
    pose.translation()[r] = frame.p[r];
  }
  return pose;
}

KDL::JntArray toKdl(const Eigen::VectorXd& q) {
  KDL::JntArray array(static_cast<unsigned>(q.size()));
  array.data = q;
  return array;
}

// Rotation vector that turns axis `from` onto `to` (both unit), by the shortest way.
Eigen::Vector3d alignmentRotation(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const Eigen::Vector3d cross = from.cross(to);
  const double sine = cross.norm();
  const double angle = std::atan2(sine, from.dot(to));
  if (sine > 1e-12) return angle * cross / sine;
  if (angle < 1.0) return Eigen::Vector3d::Zero();
  // Opposite axes: any rotation axis perpendicular to `from` works.
  Eigen::Vector3d perpendicular = from.cross(Eigen::Vector3d::UnitX());
  if (perpendicular.norm() < 1e-6) perpendicular = from.cross(Eigen::Vector3d::UnitY());
  return angle * perpendicular.normalized();
}

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

KDL::Vector toKdl(const urdf::Vector3& v) { return KDL::Vector(v.x, v.y, v.z); }

KDL::Frame toKdl(const urdf::Pose& pose) {
  const urdf::Rotation& r = pose.rotation;
  return KDL::Frame(KDL::Rotation::Quaternion(r.x, r.y, r.z, r.w), toKdl(pose.position));
}

// The joint in its parent link's frame, as kdl_parser builds it: the axis of a revolute or
// prismatic joint is given in the joint frame, which sits at the joint origin.
KDL::Joint toKdl(const urdf::Joint& joint) {
  const KDL::Frame parent_to_joint = toKdl(joint.parent_to_joint_origin_transform);
  switch (joint.type) {
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS:
      return KDL::Joint(joint.name, parent_to_joint.p, parent_to_joint.M * toKdl(joint.axis), KDL::Joint::RotAxis);
    case urdf::Joint::PRISMATIC:
      return KDL::Joint(joint.name, parent_to_joint.p, parent_to_joint.M * toKdl(joint.axis), KDL::Joint::TransAxis);
    default:  // fixed; floating and planar joints are not kinematic-chain joints here either
      return KDL::Joint(joint.name, KDL::Joint::None);
  }
}

KDL::RigidBodyInertia toKdl(const urdf::Inertial& inertial) {
  const KDL::Frame origin = toKdl(inertial.origin);
  const KDL::RotationalInertia in_origin_frame(inertial.ixx, inertial.iyy, inertial.izz, inertial.ixy,
                                               inertial.ixz, inertial.iyz);
  // Rotated into the link frame about the centre of mass (a zero-mass body keeps it there).
  const KDL::RigidBodyInertia rotated = origin.M * KDL::RigidBodyInertia(0.0, KDL::Vector::Zero(), in_origin_frame);
  return KDL::RigidBodyInertia(inertial.mass, origin.p, rotated.getRotationalInertia());
}

void addChildren(const urdf::Link& link, KDL::Tree* tree) {
  for (const urdf::LinkSharedPtr& child : link.child_links) {
    const urdf::Joint& joint = *child->parent_joint;
    const KDL::RigidBodyInertia inertia = child->inertial ? toKdl(*child->inertial) : KDL::RigidBodyInertia(0.0);
    const KDL::Segment segment(child->name, toKdl(joint), toKdl(joint.parent_to_joint_origin_transform), inertia);
    if (!tree->addSegment(segment, joint.parent_link_name)) {
      throw std::runtime_error("URDF: cannot add link '" + child->name + "' to the kinematic tree");
    }
    addChildren(*child, tree);
  }
}

KDL::Tree treeFromModel(const urdf::ModelInterface& model) {
  const urdf::LinkConstSharedPtr root = model.getRoot();
  KDL::Tree tree(root->name);
  addChildren(*root, &tree);
  return tree;
}

Arm armFromXml(const std::string& urdf_xml, const std::string& source, const Arm::Config& config) {
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model || !model->getRoot()) throw std::runtime_error("URDF " + source + " does not parse");
  const KDL::Tree tree = treeFromModel(*model);
  KDL::Chain chain;
  if (!tree.getChain(config.base_link, config.tip_link, chain)) {
    throw std::runtime_error("URDF " + source + ": no kinematic chain from '" +
                             config.base_link + "' to '" + config.tip_link + "'");
  }
  std::vector<std::string> names;
  std::vector<double> lower, upper;
  for (const KDL::Segment& segment : chain.segments) {
    if (segment.getJoint().getType() == KDL::Joint::None) continue;
    const std::string& name = segment.getJoint().getName();
    names.push_back(name);
    const auto joint = model->getJoint(name);
    const bool limited = joint && joint->type != urdf::Joint::CONTINUOUS && joint->limits &&
                         joint->limits->upper > joint->limits->lower;
    // Unlimited joints get one turn, which covers every orientation.
    lower.push_back(limited ? joint->limits->lower : -M_PI);
    upper.push_back(limited ? joint->limits->upper : M_PI);
  }
  if (names.empty()) {
    throw std::runtime_error("URDF " + source + ": the chain from '" + config.base_link +
                             "' to '" + config.tip_link + "' has no movable joint");
  }
  return Arm(chain, Eigen::Map<Eigen::VectorXd>(lower.data(), static_cast<Eigen::Index>(lower.size())),
             Eigen::Map<Eigen::VectorXd>(upper.data(), static_cast<Eigen::Index>(upper.size())),
             names, config);
}

}  // namespace

KDL::Tree kinematicTreeFromUrdf(const std::string& urdf_xml) {
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model || !model->getRoot()) throw std::runtime_error("the URDF does not parse");
  return treeFromModel(*model);
}

Arm Arm::fromUrdfString(const std::string& urdf_xml, const Config& config) {
  return armFromXml(urdf_xml, "(string)", config);
}

Arm Arm::fromUrdfFile(const std::string& path, const Config& config) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open URDF file '" + path + "'");
  const std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return armFromXml(xml, "'" + path + "'", config);
}

Arm::Arm(const KDL::Chain& chain, Eigen::VectorXd lower_limits, Eigen::VectorXd upper_limits,
         std::vector<std::string> joint_names, const Config& config)
    : lower_(std::move(lower_limits)),
      upper_(std::move(upper_limits)),
      joint_names_(std::move(joint_names)),
      config_(config),
      solvers_(std::make_unique<Solvers>(chain)) {
  const auto n = static_cast<Eigen::Index>(chain.getNrOfJoints());
  if (lower_.size() != n || upper_.size() != n || static_cast<Eigen::Index>(joint_names_.size()) != n) {
    throw std::runtime_error("Arm: joint limits and names do not match the chain's " +
                             std::to_string(n) + " joints");
  }
}

Arm::~Arm() = default;
Arm::Arm(Arm&&) noexcept = default;
Arm& Arm::operator=(Arm&&) noexcept = default;

int Arm::jointCount() const { return static_cast<int>(solvers_->chain.getNrOfJoints()); }

Eigen::Isometry3d Arm::forwardKinematics(const Eigen::VectorXd& joints) const {
  if (joints.size() != jointCount()) {
    throw std::runtime_error("Arm::forwardKinematics: expected " + std::to_string(jointCount()) +
                             " joint values, got " + std::to_string(joints.size()));
  }
  KDL::Frame frame;
  solvers_->fk.JntToCart(toKdl(joints), frame);
  return toEigen(frame);
}

std::vector<LinkCapsule> Arm::linkCapsules(const Eigen::VectorXd& joints, bool include_tool) const {
  const KDL::Chain& chain = solvers_->chain;
  const int segment_count = static_cast<int>(chain.getNrOfSegments());
  const KDL::JntArray q = toKdl(joints);
  // Frame k is the end of segment k, which (as kdl_parser builds chains) is the origin of that
  // segment's joint; frame 0 is the base.
  std::vector<Eigen::Vector3d> frame_origins = {Eigen::Vector3d::Zero()};
  std::vector<int> movable_segments;  // 1-based segment numbers
  for (int k = 1; k <= segment_count; ++k) {
    KDL::Frame frame;
    solvers_->fk.JntToCart(q, frame, k);
    frame_origins.push_back(toEigen(frame).translation());
    if (chain.getSegment(k - 1).getJoint().getType() != KDL::Joint::None) {
      movable_segments.push_back(k);
    }
  }
  const int first_kept = (config_.skip_base_column && movable_segments.size() >= 2)
                             ? movable_segments[1] + 1
                             : 1;
  const int last_movable = movable_segments.back();
  std::vector<LinkCapsule> capsules;
  for (int k = first_kept; k <= segment_count; ++k) {
    const bool is_tool = k - 1 >= last_movable;
    if (is_tool && !include_tool) break;
    capsules.push_back({frame_origins[k - 1], frame_origins[k],
                        is_tool ? config_.tool_radius_m : config_.link_radius_m});
  }
  // Trim the tip clearance off the end of the tool, walking back over short segments.
  double remaining = include_tool ? config_.tip_clearance_m : 0.0;
  while (remaining > 0.0 && !capsules.empty()) {
    LinkCapsule& last = capsules.back();
    const double length = (last.b - last.a).norm();
    if (length <= remaining) {
      remaining -= length;
      capsules.pop_back();
    } else {
      last.b -= remaining * (last.b - last.a) / length;
      remaining = 0.0;
    }
  }
  return capsules;
}

double Arm::chainLength() const {
  // From the first joint on: the fixed offsets before it do not turn.
  double length = 0.0;
  bool after_first_joint = false;
  for (const KDL::Segment& segment : solvers_->chain.segments) {
    if (after_first_joint) length += segment.getFrameToTip().p.Norm();
    after_first_joint = after_first_joint || segment.getJoint().getType() != KDL::Joint::None;
  }
  return length;
}

Arm::IkResult Arm::solveApproach(const Eigen::Vector3d& tip_position,
                                 const Eigen::Vector3d& approach_direction, const CollisionCheck& check,
                                 const Eigen::VectorXd* seed, int restarts) const {
  IkResult best;
  const int n = jointCount();
  if (!tip_position.allFinite() || !approach_direction.allFinite() ||
      approach_direction.norm() < 1e-12) {
    return best;
  }
  const Eigen::Vector3d approach = approach_direction.normalized();
  std::mt19937 rng(config_.seed);
  KDL::Jacobian jacobian(static_cast<unsigned>(n));
  best.position_error_m = std::numeric_limits<double>::infinity();
  best.approach_error_rad = M_PI;

  const int attempts = restarts > 0 ? restarts : config_.ik_restarts;
  for (int attempt = 0; attempt < attempts; ++attempt) {
    Eigen::VectorXd q(n);
    if (attempt == 0 && seed && seed->size() == n && seed->allFinite()) {
      q = seed->cwiseMax(lower_).cwiseMin(upper_);
    } else if (attempt == 0) {
      q = (0.5 * (lower_ + upper_));
    } else {
      for (int j = 0; j < n; ++j) {
        q[j] = std::uniform_real_distribution<double>(lower_[j], upper_[j])(rng);
      }
    }
    double position_error = 0.0, approach_error = 0.0;
    // A start that stops getting closer is left for the next: where the pose is out of reach,
    // damped least squares settles at a configuration with an error that no longer shrinks.
    double best_error = std::numeric_limits<double>::infinity();
    int since_best = 0;
    for (int iteration = 0; iteration <= config_.ik_max_iterations; ++iteration) {
      const KDL::JntArray kdl_q = toKdl(q);
      KDL::Frame frame;
      solvers_->fk.JntToCart(kdl_q, frame);
      const Eigen::Isometry3d pose = toEigen(frame);
      const Eigen::Vector3d z = pose.linear().col(2);
      Eigen::Matrix<double, 6, 1> error;
      error.head<3>() = tip_position - pose.translation();
      error.tail<3>() = alignmentRotation(z, approach);
      position_error = error.head<3>().norm();
      approach_error = angleBetween(z, approach);
      const double error_now = position_error + config_.ik_stall_metres_per_rad * approach_error;
      if (error_now < best_error * (1.0 - 1e-3)) {
        best_error = error_now;
        since_best = 0;
      } else if (++since_best >= config_.ik_stall_iterations) {
        break;
      }
      if ((position_error < 1e-6 && approach_error < 1e-6) || iteration == config_.ik_max_iterations) {
        break;
      }
      solvers_->jacobian.JntToJac(kdl_q, jacobian);
      Eigen::MatrixXd task = jacobian.data;
      // Roll about the approach axis is free: drop the angular velocity component along z.
      const Eigen::Matrix3d no_roll = Eigen::Matrix3d::Identity() - z * z.transpose();
      task.bottomRows<3>() = no_roll * task.bottomRows<3>();
      const Eigen::Matrix<double, 6, 6> damped =
          task * task.transpose() +
          config_.ik_damping * config_.ik_damping * Eigen::Matrix<double, 6, 6>::Identity();
      Eigen::VectorXd step = task.transpose() * damped.ldlt().solve(error);
      const double largest = step.cwiseAbs().maxCoeff();
      if (largest > config_.ik_max_step_rad) step *= config_.ik_max_step_rad / largest;
      q = (q + step).cwiseMax(lower_).cwiseMin(upper_);
    }
    const bool reached = position_error < config_.position_tolerance_m &&
                         approach_error < config_.approach_tolerance_rad;
    if (!reached) {
      if (!best.reached && position_error < best.position_error_m) {
        best.joints = q;
        best.position_error_m = position_error;
        best.approach_error_rad = approach_error;
      }
      continue;
    }
    const unsigned kinds = check ? check(q) : 0u;
    if (!best.reached) best.collision_kinds = kinds;
    best.reached = true;
    best.joints = q;
    best.position_error_m = position_error;
    best.approach_error_rad = approach_error;
    if (kinds == 0) {
      best.success = true;
      best.collision_kinds = 0;
      return best;
    }
  }
  return best;
}

Eigen::VectorXd armRestConfiguration(const Arm& arm, const Eigen::Vector3d& rest_tip) {
  const Arm::IkResult ik = arm.solveApproach(rest_tip, -Eigen::Vector3d::UnitZ());
  if (!ik.reached) {
    std::ostringstream message;
    message << "the arm does not reach its rest, the tip at (" << rest_tip.transpose() << ") pointing down";
    throw std::runtime_error(message.str());
  }
  return ik.joints;
}

}  // namespace gpatlas_motion
