#include "probe_sim/probe.h"
#include "probe_sim/procedural_objects.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <random>

using probe_sim::Arm;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string testUrdf() {
  return std::string(PROBE_SIM_SOURCE_DIR) + "/../gpatlas_motion/test/data/lwr4plus_test.urdf";
}

}  // namespace

// A check of configurations against the true scene, as the solver takes it.
Arm::CollisionCheck against(const Arm& arm, const probe_sim::Scene& scene) {
  return [&arm, &scene](const Eigen::VectorXd& q) { return probe_sim::armCollisions(arm, scene, q); };
}

TEST(Arm, LinkCapsulesDetectTableAndObjectCollisions) {
  const Arm arm = Arm::fromUrdfFile(testUrdf());
  probe_sim::Scene scene(probe_sim::makeProceduralObject("box", 0.1));
  // Stretched straight up, nothing touches (the base column standing on the table is skipped).
  EXPECT_EQ(probe_sim::armCollisions(arm, scene, Eigen::VectorXd::Zero(7)), 0u);
  // Shoulder bent forward by 115 degrees drives the stretched arm down through the table top.
  Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  q[1] = -115.0 * kPi / 180.0;  // A2 turns about -y: negative swings the arm towards +x
  const Eigen::Isometry3d tip = arm.forwardKinematics(q);
  ASSERT_LT(tip.translation().z(), 0.0) << "test configuration does not reach below the table";
  EXPECT_NE(probe_sim::armCollisions(arm, scene, q) & static_cast<unsigned>(probe_sim::SurfaceKind::kTable), 0u);

  // Poking the top of the box from above: reachable and collision-free.
  const Arm::IkResult top =
      arm.solveApproach(Eigen::Vector3d(0, 0, 0.1), -Eigen::Vector3d::UnitZ(), against(arm, scene));
  EXPECT_TRUE(top.success);
  EXPECT_EQ(top.collision_kinds, 0u);
  // Touching the table right next to the box, approaching horizontally towards it, would put
  // the arm through the table or the box: reached, but never collision-free.
  const Arm::IkResult low =
      arm.solveApproach(Eigen::Vector3d(0.0, 0.12, 0.01), -Eigen::Vector3d::UnitY(), against(arm, scene));
  EXPECT_FALSE(low.success);
  EXPECT_TRUE(low.reached);
}

namespace {

probe_sim::SimulatedProber::Config proberAboveTheBox() {
  probe_sim::SimulatedProber::Config config;
  config.rest_tip_position = Eigen::Vector3d(-0.2, 0.2, 0.4);  // within the test arm's reach
  return config;
}

}  // namespace

TEST(SimulatedProberWithArm, MovesTheArmThereAndBackAndCountsWhatItMeets) {
  auto scene = std::make_shared<probe_sim::Scene>(probe_sim::makeProceduralObject("box", 0.1));
  probe_sim::SimulatedProber prober(scene, probe_sim::makeProbeModel("ray"), proberAboveTheBox());
  const auto arm = std::make_shared<Arm>(Arm::fromUrdfFile(testUrdf()));
  prober.setArm(arm);

  gpatlas_core::Touch touch;
  touch.points = {Eigen::Vector3d(0.0, 0.0, 0.1)};
  touch.normals = {Eigen::Vector3d::UnitZ()};
  const gpatlas_core::ProbeResult top = prober.probe(touch);
  EXPECT_TRUE(top.success) << top.reason;
  EXPECT_EQ(top.approach_collisions, 0);
  EXPECT_EQ(top.retreat_collisions, 0);
  // From the rest to the approach pose, the poke, and back to the rest.
  const std::vector<Eigen::VectorXd>& motion = prober.lastArmSolutions();
  ASSERT_EQ(motion.size(), 5u);
  EXPECT_LT((arm->forwardKinematics(motion.front()).translation() - Eigen::Vector3d(-0.2, 0.2, 0.4)).norm(), 2e-3);
  EXPECT_LT((arm->forwardKinematics(motion[1]).translation() - Eigen::Vector3d(0.0, 0.0, 0.2)).norm(), 2e-3);
  const Eigen::Isometry3d at_touch = arm->forwardKinematics(motion[2]);
  EXPECT_LT((at_touch.translation() - touch.points[0]).norm(), 2e-3);
  EXPECT_GT(at_touch.linear().col(2).dot(-Eigen::Vector3d::UnitZ()), 0.999);
  EXPECT_TRUE(motion.back().isApprox(motion.front()));

  touch.points = {Eigen::Vector3d(2.5, 0.0, 0.1)};
  const gpatlas_core::ProbeResult far = prober.probe(touch);
  EXPECT_FALSE(far.success);
  EXPECT_EQ(far.reason, "unreachable");
  EXPECT_TRUE(prober.lastArmSolutions().empty());

  // The box's side facing away from the robot at the table height: the arm reaches it, down
  // through the table, and the judge says so (the robot does not know the scene).
  touch.points = {Eigen::Vector3d(0.0, 0.12, 0.01)};
  touch.normals = {Eigen::Vector3d::UnitY()};
  const gpatlas_core::ProbeResult low = prober.probe(touch);
  EXPECT_TRUE(low.success) << low.reason;
  EXPECT_GE(low.approach_collisions, 1);
  EXPECT_GE(low.retreat_collisions, 1);
}

TEST(SimulatedProberWithArm, JudgesAPlannedJointPath) {
  auto scene = std::make_shared<probe_sim::Scene>(probe_sim::makeProceduralObject("box", 0.1));
  probe_sim::SimulatedProber prober(scene, probe_sim::makeProbeModel("ray"), proberAboveTheBox());
  const auto arm = std::make_shared<Arm>(Arm::fromUrdfFile(testUrdf()));
  prober.setArm(arm);
  const Eigen::VectorXd rest = gpatlas_motion::armRestConfiguration(*arm, Eigen::Vector3d(-0.2, 0.2, 0.4));
  const Arm::IkResult above = arm->solveApproach(Eigen::Vector3d(0, 0, 0.2), -Eigen::Vector3d::UnitZ(), nullptr, &rest);
  ASSERT_TRUE(above.reached);

  gpatlas_core::Touch touch;
  touch.points = {Eigen::Vector3d(0.0, 0.0, 0.1)};
  touch.normals = {Eigen::Vector3d::UnitZ()};
  // By way of a configuration with the arm through the table: contacts there and back.
  Eigen::VectorXd down = Eigen::VectorXd::Zero(7);
  down[1] = -115.0 * kPi / 180.0;
  touch.approach_joints = {rest, down, above.joints};
  touch.retreat_joints = {above.joints, down, rest};
  const gpatlas_core::ProbeResult detour = prober.probe(touch);
  EXPECT_TRUE(detour.success) << detour.reason;
  EXPECT_GE(detour.approach_collisions, 1);
  EXPECT_GE(detour.retreat_collisions, 1);
  EXPECT_TRUE(prober.lastArmSolutions()[1].isApprox(down));

  touch.approach_joints = {rest, above.joints};
  touch.retreat_joints = {above.joints, rest};
  const gpatlas_core::ProbeResult direct = prober.probe(touch);
  EXPECT_EQ(direct.approach_collisions, 0);
  EXPECT_EQ(direct.retreat_collisions, 0);

  touch.approach_joints = {Eigen::VectorXd::Zero(6)};
  const gpatlas_core::ProbeResult wrong = prober.probe(touch);
  EXPECT_FALSE(wrong.success);
  EXPECT_NE(wrong.reason.find("joint path"), std::string::npos) << wrong.reason;
}
