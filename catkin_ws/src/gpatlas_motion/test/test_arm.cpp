#include "gpatlas_motion/arm.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <random>

using gpatlas_motion::Arm;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string testUrdf() { return std::string(GPATLAS_MOTION_SOURCE_DIR) + "/test/data/lwr4plus_test.urdf"; }

std::string vitoUrdf() {
  return std::string(GPATLAS_MOTION_SOURCE_DIR) + "/../vito_description/urdf/vito.urdf";
}

// Written out from the KUKA LWR 4+ data sheet rather than read from the URDF.
constexpr double kBaseToShoulder = 0.3105, kShoulderToElbow = 0.4, kElbowToWrist = 0.39,
                 kWristToFlange = 0.078, kProbeLength = 0.0745;
const Eigen::Vector3d kBasePosition(-0.6, 0.0, 0.0);

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace

TEST(Arm, LoadsTheLwrChainWithLimits) {
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  ASSERT_EQ(arm.jointCount(), 7);
  EXPECT_EQ(arm.jointNames().front(), "lwr_a1_joint");
  EXPECT_EQ(arm.jointNames().back(), "lwr_a7_joint");
  const double limits_deg[7] = {170, 120, 170, 120, 170, 120, 170};
  for (int j = 0; j < 7; ++j) {
    EXPECT_NEAR(arm.upperLimits()[j], limits_deg[j] * kPi / 180.0, 1e-8);
    EXPECT_NEAR(arm.lowerLimits()[j], -limits_deg[j] * kPi / 180.0, 1e-8);
  }
  Arm::Config wrong_tip;
  wrong_tip.tip_link = "no_such_link";
  EXPECT_THROW(Arm::fromUrdfFile(testUrdf(), wrong_tip), std::runtime_error);
  EXPECT_THROW(Arm::fromUrdfFile("/nonexistent/robot.urdf"), std::runtime_error);
  EXPECT_THROW(Arm::fromUrdfString("<robot name='broken'><link name="), std::runtime_error);
}

TEST(Arm, ZeroConfigurationIsStretchedStraightUp) {
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  const Eigen::Isometry3d tip = arm.forwardKinematics(Eigen::VectorXd::Zero(7));
  const double height =
      kBaseToShoulder + kShoulderToElbow + kElbowToWrist + kWristToFlange + kProbeLength;
  EXPECT_TRUE(tip.translation().isApprox(kBasePosition + Eigen::Vector3d(0, 0, height), 1e-12))
      << tip.translation().transpose();
  EXPECT_TRUE(tip.linear().col(2).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  EXPECT_THROW(arm.forwardKinematics(Eigen::VectorXd::Zero(6)), std::runtime_error);
}

TEST(Arm, ElbowBentNinetyDegreesMovesTheForearmSideways) {
  // Independent check of an axis sign: A4 turns about +y, so +90 degrees swings the forearm
  // (wrist, flange, probe) towards +x and the tool then points along +x.
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  q[3] = kPi / 2;
  const Eigen::Isometry3d tip = arm.forwardKinematics(q);
  const double elbow_height = kBaseToShoulder + kShoulderToElbow;
  const double reach = kElbowToWrist + kWristToFlange + kProbeLength;
  EXPECT_TRUE(tip.translation().isApprox(kBasePosition + Eigen::Vector3d(reach, 0, elbow_height),
                                         1e-12))
      << tip.translation().transpose();
  EXPECT_TRUE(tip.linear().col(2).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
}

TEST(Arm, InverseKinematicsReachesPointsInFrontWithinTolerance) {
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(-0.15, 0.15), y(-0.2, 0.2), z(0.02, 0.25);
  int solved = 0;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d target(x(rng), y(rng), z(rng));
    // Approach from above and somewhat from the robot's side, as touches on an object do.
    const Eigen::Vector3d approach = Eigen::Vector3d(0.3 * x(rng), 0.3 * y(rng), -1.0).normalized();
    const Arm::IkResult ik = arm.solveApproach(target, approach);
    if (!ik.success) continue;
    ++solved;
    // Check with forward kinematics rather than trusting the solver's own errors.
    const Eigen::Isometry3d tip = arm.forwardKinematics(ik.joints);
    EXPECT_LT((tip.translation() - target).norm(), 1e-3);
    EXPECT_LT(angleBetween(tip.linear().col(2), approach), kPi / 180.0);
    EXPECT_TRUE((ik.joints.array() >= arm.lowerLimits().array() - 1e-12).all());
    EXPECT_TRUE((ik.joints.array() <= arm.upperLimits().array() + 1e-12).all());
  }
  EXPECT_EQ(solved, 20);
}

TEST(Arm, InverseKinematicsRoundTripsRandomConfigurations) {
  // Any pose produced by forward kinematics within the limits is reachable by construction.
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  std::mt19937 rng(11);
  for (int i = 0; i < 10; ++i) {
    Eigen::VectorXd q(7);
    for (int j = 0; j < 7; ++j) {
      q[j] = std::uniform_real_distribution<double>(0.8 * arm.lowerLimits()[j],
                                                    0.8 * arm.upperLimits()[j])(rng);
    }
    const Eigen::Isometry3d pose = arm.forwardKinematics(q);
    const Arm::IkResult ik = arm.solveApproach(pose.translation(), pose.linear().col(2));
    ASSERT_TRUE(ik.success) << "configuration " << q.transpose();
    EXPECT_LT((arm.forwardKinematics(ik.joints).translation() - pose.translation()).norm(), 1e-3);
  }
}

TEST(Arm, InverseKinematicsRefusesUnreachablePoints) {
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  const Arm::IkResult far = arm.solveApproach(Eigen::Vector3d(3.0, 0.0, 0.3), -Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(far.success);
  EXPECT_FALSE(far.reached);
  // The full reach is ~1.25 m from the shoulder; 1.5 m away straight up is out of reach too.
  const Arm::IkResult high = arm.solveApproach(kBasePosition + Eigen::Vector3d(0, 0, 1.9),
                                               Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(high.success);
  const Arm::IkResult nan = arm.solveApproach(Eigen::Vector3d(std::nan(""), 0, 0), Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(nan.success);
}

TEST(Arm, ProjectUrdfHasTheLeftArmChain) {
  if (!std::filesystem::exists(vitoUrdf())) GTEST_SKIP() << "no " << vitoUrdf() << " yet";
  const Arm arm = Arm::fromUrdfFile(vitoUrdf());
  ASSERT_EQ(arm.jointCount(), 7);
  for (int j = 0; j < 7; ++j) {
    EXPECT_EQ(arm.jointNames()[j], "left_arm_a" + std::to_string(j + 1) + "_joint");
  }
  // Round trip of a configuration in the middle of the workspace.
  Eigen::VectorXd q(7);
  q << 0.3, -0.5, 0.2, 1.0, -0.3, 0.6, 0.1;
  const Eigen::Isometry3d pose = arm.forwardKinematics(q);
  const Arm::IkResult ik = arm.solveApproach(pose.translation(), pose.linear().col(2));
  EXPECT_TRUE(ik.success);
}

TEST(Arm, ToolCapsulesAreLeftOutOnRequest) {
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  const auto with_tool = arm.linkCapsules(q);
  const auto links = arm.linkCapsules(q, false);
  ASSERT_FALSE(links.empty());
  ASSERT_LT(links.size(), with_tool.size());
  for (const auto& link : links) EXPECT_EQ(link.radius, arm.config().link_radius_m);
  // Stretched straight up: the links end at the last joint, below the flange and the probe.
  const double last_joint_height = kBaseToShoulder + kShoulderToElbow + kElbowToWrist;
  EXPECT_NEAR(links.back().b.z(), last_joint_height, 1e-9);
  // The tool stops tip_clearance_m short of the tip.
  EXPECT_NEAR(with_tool.back().b.z(), last_joint_height + kWristToFlange + kProbeLength - arm.config().tip_clearance_m, 1e-9);
  // The chain's length after A1 (whose axis sits 0.1105 m above the base) bounds every point's
  // distance from the joints' axes.
  EXPECT_NEAR(arm.chainLength(), last_joint_height + kWristToFlange + kProbeLength - 0.1105, 1e-9);
}

// What the Vito left arm reaches around an object at the simulation's place, (0.7, 0) on the
// table, with the probe along a horizontal normal: the front and the sides, not the back, where
// the probe would have to point back at the robot (design.md section 7.1).
TEST(Arm, ProjectLeftArmReachesTheFrontAndSidesOfTheObjectButNotItsBack) {
  if (!std::filesystem::exists(vitoUrdf())) GTEST_SKIP() << "no " << vitoUrdf() << " yet";
  const Arm arm = Arm::fromUrdfFile(vitoUrdf());
  const auto reaches = [&](double azimuth_deg) {
    const double a = azimuth_deg * kPi / 180.0;
    const Eigen::Vector3d normal(std::cos(a), std::sin(a), 0.0);
    // The approach pose 0.1 m out from a surface 7.5 cm from the object's axis, 7 cm up.
    return arm.solveApproach(Eigen::Vector3d(0.7, 0.0, 0.07) + 0.175 * normal, -normal, nullptr, nullptr, 40).reached;
  };
  EXPECT_TRUE(reaches(180.0));  // the front, facing the robot
  EXPECT_TRUE(reaches(90.0));   // the left side
  EXPECT_TRUE(reaches(60.0));
  EXPECT_FALSE(reaches(30.0));
  EXPECT_FALSE(reaches(0.0));   // the back
}
