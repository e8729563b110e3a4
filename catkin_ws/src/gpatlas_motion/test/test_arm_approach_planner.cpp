// The arm's approach planner on analytic scenes: the test LWR arm (base at (-0.6, 0, 0)) over a
// table (z < 0), octrees whose occupied voxels are boxes, and every planned motion checked
// against those boxes themselves (the links' and the probe's distances to them), not against
// the octree the planner saw.
#include "gpatlas_motion/arm_approach_planner.h"

#include "box_octree.h"

#include <octomap/OcTree.h>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>

namespace {

using gpatlas_motion::ApproachConfig;
using gpatlas_motion::Arm;
using gpatlas_motion::ArmApproachPlanner;
using gpatlas_motion::ArmMotionPlan;
using gpatlas_motion::ProbeApproachPlanner;
using Eigen::Vector3d;
using Eigen::VectorXd;

using gpatlas_motion_test::Box;
using gpatlas_motion_test::kVoxel;
using gpatlas_motion_test::mapOf;

std::string testUrdfXml() {
  std::ifstream in(std::string(GPATLAS_MOTION_SOURCE_DIR) + "/test/data/lwr4plus_test.urdf");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The arm's clearance from the boxes and the table over a joint path, sampled every 0.002 rad:
// the links' axes (every 5 mm) less the link radius, the probe's tip less its radius.
double pathClearance(const Arm& arm, const ApproachConfig& config, const std::vector<VectorXd>& path,
                     const std::vector<Box>& boxes) {
  double clearance = std::numeric_limits<double>::infinity();
  const auto distance = [&](const Vector3d& p) {
    double d = p.z();  // the table
    for (const Box& b : boxes) d = std::min(d, b.distance(p));
    return d;
  };
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const int steps = std::max(1, static_cast<int>(std::ceil((path[i + 1] - path[i]).norm() / 0.002)));
    for (int s = 0; s <= steps; ++s) {
      const VectorXd q = path[i] + (path[i + 1] - path[i]) * (double(s) / steps);
      for (const auto& link : arm.linkCapsules(q, false)) {
        const int samples = std::max(1, static_cast<int>(std::ceil((link.b - link.a).norm() / 0.005)));
        for (int k = 0; k <= samples; ++k)
          clearance = std::min(clearance, distance(link.a + (link.b - link.a) * (double(k) / samples)) - link.radius);
      }
      clearance = std::min(clearance, distance(arm.forwardKinematics(q).translation()) - config.probe.tip_radius_m);
    }
  }
  return clearance;
}

std::shared_ptr<const Arm> testArm(const std::string& urdf_xml = testUrdfXml()) {
  Arm::Config config;
  config.link_radius_m = 0.04;
  return std::make_shared<const Arm>(Arm::fromUrdfString(urdf_xml, config));
}

ApproachConfig testConfig() {
  ApproachConfig config;
  config.max_planning_time_s = 2.0;
  return config;
}

// The object: a 6 cm cube standing on the table at the origin, touched on its top.
const Box kObject{Vector3d(-0.03, -0.03, 0.0), Vector3d(0.03, 0.03, 0.06)};
const Box kRegion{Vector3d(-0.4, -0.4, 0.0), Vector3d(0.4, 0.4, 0.6)};
const Vector3d kTouch(0.0, 0.0, 0.06), kNormal(0.0, 0.0, 1.0), kRestTip(-0.2, 0.3, 0.35);

struct Scene {
  std::shared_ptr<const Arm> arm;
  std::shared_ptr<ProbeApproachPlanner> world;
  std::unique_ptr<ArmApproachPlanner> planner;
  VectorXd rest;
};

Scene sceneWith(const std::vector<Box>& boxes, const ApproachConfig& config = testConfig(),
                std::shared_ptr<const Arm> arm = testArm()) {
  Scene scene;
  scene.arm = arm;
  scene.world = std::make_shared<ProbeApproachPlanner>(config);
  scene.world->setCollisionMap(mapOf(boxes, kRegion));
  scene.world->addStaticHalfSpace(Vector3d::UnitZ(), 0.0);
  scene.planner = std::make_unique<ArmApproachPlanner>(arm, scene.world);
  scene.rest = gpatlas_motion::armRestConfiguration(*arm, kRestTip);
  return scene;
}

}  // namespace

TEST(ArmApproachPlanner, TheRestPutsTheTipThereAndIsFree) {
  const Scene scene = sceneWith({kObject});
  const Eigen::Isometry3d tip = scene.arm->forwardKinematics(scene.rest);
  EXPECT_LT((tip.translation() - kRestTip).norm(), 1e-3);
  EXPECT_GT(tip.linear().col(2).dot(-Vector3d::UnitZ()), 0.999);
  EXPECT_EQ(scene.planner->configurationProblem(scene.rest), "");
  EXPECT_THROW(gpatlas_motion::armRestConfiguration(*scene.arm, Vector3d(3.0, 0.0, 0.3)), std::runtime_error);
}

TEST(ArmApproachPlanner, FindsAPathAroundABoxInTheOcTree) {
  const ApproachConfig config = testConfig();
  // A first scene without the obstacle gives the straight joint motion; a box where its middle
  // puts the probe's tip blocks it.
  const Scene open = sceneWith({kObject});
  const ArmMotionPlan direct = open.planner->plan(open.rest, kTouch, kNormal);
  ASSERT_TRUE(direct.ok) << direct.message;
  ASSERT_EQ(direct.approach.size(), 2u) << "the open scene needs no detour";
  const Vector3d middle = open.arm->forwardKinematics(0.5 * (direct.approach.front() + direct.approach.back())).translation();
  const Box obstacle{middle - Vector3d(0.04, 0.04, 0.04), middle + Vector3d(0.04, 0.04, 0.04)};
  ASSERT_GT(pathClearance(*open.arm, config, {open.rest}, {obstacle}), 0.0) << "the obstacle covers the rest";

  const Scene blocked = sceneWith({kObject, obstacle});
  EXPECT_LT(pathClearance(*blocked.arm, config, direct.approach, {kObject, obstacle}), 0.0);
  const ArmMotionPlan plan = blocked.planner->plan(blocked.rest, kTouch, kNormal);
  ASSERT_TRUE(plan.ok) << plan.message;
  EXPECT_GE(plan.approach.size(), 3u);
  EXPECT_TRUE(plan.approach.front().isApprox(blocked.rest));
  const double clearance = pathClearance(*blocked.arm, config, plan.approach, {kObject, obstacle});
  std::cout << "arm approach around the box: " << plan.approach.size() << " waypoints, clearance "
            << 1000.0 * clearance << " mm, " << plan.planning_ms << " ms" << std::endl;
  // Inflated by clearance_m and checked every arm_check_step_rad: clear by a part of it.
  EXPECT_GT(clearance, 0.0);
  EXPECT_GT(pathClearance(*blocked.arm, config, plan.retreat, {kObject, obstacle}), 0.0);
  // It ends at the approach pose, pointing into the touch, and the probing goes on to the touch.
  const Eigen::Isometry3d end = blocked.arm->forwardKinematics(plan.approach.back());
  EXPECT_LT((end.translation() - (kTouch + config.approach_distance_m * kNormal)).norm(), 2e-3);
  EXPECT_GT(end.linear().col(2).dot(-kNormal), 0.999);
  ASSERT_EQ(plan.probing.size(), 2u);
  EXPECT_LT((blocked.arm->forwardKinematics(plan.probing.back()).translation() - kTouch).norm(), 2e-3);
  ASSERT_EQ(plan.approach_tips.size(), plan.approach.size());
  EXPECT_LT((plan.approach_tips.front() - kRestTip).norm(), 1e-3);
}

TEST(ArmApproachPlanner, RefusesATargetEnclosedByOccupiedVoxels) {
  const Box enclosure{Vector3d(-0.2, -0.2, 0.0), Vector3d(0.2, 0.2, 0.3)};
  const Scene scene = sceneWith({enclosure});
  const ArmMotionPlan plan = scene.planner->plan(scene.rest, kTouch, kNormal);
  EXPECT_FALSE(plan.ok);
  EXPECT_NE(plan.message.find("approach pose"), std::string::npos) << plan.message;
  EXPECT_NE(scene.planner->checkApproachPose(kTouch, kNormal), "");
}

TEST(ArmApproachPlanner, RespectsTheJointLimits) {
  const ApproachConfig config = testConfig();
  const Scene scene = sceneWith({kObject});
  const ArmMotionPlan plan = scene.planner->plan(scene.rest, kTouch, kNormal);
  ASSERT_TRUE(plan.ok) << plan.message;
  for (const auto* path : {&plan.approach, &plan.probing, &plan.retreat})
    for (const VectorXd& q : *path) {
      EXPECT_TRUE((q.array() >= scene.arm->lowerLimits().array() - 1e-9).all()) << q.transpose();
      EXPECT_TRUE((q.array() <= scene.arm->upperLimits().array() + 1e-9).all()) << q.transpose();
    }
  VectorXd beyond = scene.rest;
  beyond[3] = scene.arm->upperLimits()[3] + 0.1;
  EXPECT_NE(scene.planner->configurationProblem(beyond).find("outside its limits"), std::string::npos);

  // A1, A3 and A5 (the first three of the four joints about their links' axes, A7 the last)
  // held within +-0.1 rad: the arm moves in its x-z plane and cannot reach a touch to its side.
  std::string urdf = testUrdfXml();
  const std::string full_turn = "<limit lower=\"-2.967059728\" upper=\"2.967059728\"";
  for (int joint = 0; joint < 3; ++joint) {
    ASSERT_NE(urdf.find(full_turn), std::string::npos);
    urdf.replace(urdf.find(full_turn), full_turn.size(), "<limit lower=\"-0.1\" upper=\"0.1\"");
  }
  const Box side_object{Vector3d(-0.63, 0.57, 0.0), Vector3d(-0.57, 0.63, 0.06)};
  const auto narrow = testArm(urdf);
  ApproachConfig config_narrow = config;
  auto world = std::make_shared<ProbeApproachPlanner>(config_narrow);
  world->setCollisionMap(mapOf({side_object}, Box{Vector3d(-0.9, 0.3, 0.0), Vector3d(-0.3, 0.9, 0.3)}));
  const ArmApproachPlanner limited(narrow, world);
  const VectorXd rest = gpatlas_motion::armRestConfiguration(*narrow, Vector3d(-0.1, 0.0, 0.4));
  const ArmMotionPlan side = limited.plan(rest, Vector3d(-0.6, 0.6, 0.06), kNormal);
  EXPECT_FALSE(side.ok);
  EXPECT_NE(side.message.find("does not reach"), std::string::npos) << side.message;
  // With the full range it does.
  const ArmApproachPlanner full(testArm(), world);
  const ArmMotionPlan reached = full.plan(gpatlas_motion::armRestConfiguration(*testArm(), Vector3d(-0.1, 0.0, 0.4)),
                                          Vector3d(-0.6, 0.6, 0.06), kNormal);
  EXPECT_TRUE(reached.ok) << reached.message;
}

TEST(ArmApproachPlanner, BadInputGetsAReason) {
  const Scene scene = sceneWith({kObject});
  const double nan = std::nan("");
  const ArmMotionPlan nan_touch = scene.planner->plan(scene.rest, Vector3d(nan, 0, 0), kNormal);
  EXPECT_FALSE(nan_touch.ok);
  EXPECT_NE(nan_touch.message.find("finite"), std::string::npos) << nan_touch.message;
  // Beyond the map nothing is known: refused before the arm is asked (the arm's reach is
  // RespectsTheJointLimits').
  const ArmMotionPlan far = scene.planner->plan(scene.rest, Vector3d(2.5, 0.0, 0.06), kNormal);
  EXPECT_FALSE(far.ok);
  EXPECT_NE(far.message.find("outside the collision map"), std::string::npos) << far.message;
  const ArmMotionPlan short_start = scene.planner->plan(VectorXd::Zero(6), kTouch, kNormal);
  EXPECT_FALSE(short_start.ok);
  EXPECT_NE(short_start.message.find("the arm's start"), std::string::npos) << short_start.message;
  // A start with the arm through the table.
  VectorXd down = VectorXd::Zero(7);
  down[1] = -115.0 * M_PI / 180.0;
  const ArmMotionPlan in_table = scene.planner->plan(down, kTouch, kNormal);
  EXPECT_FALSE(in_table.ok);
  EXPECT_NE(in_table.message.find("in collision"), std::string::npos) << in_table.message;

  auto no_map_world = std::make_shared<ProbeApproachPlanner>(testConfig());
  const ArmApproachPlanner no_map(scene.arm, no_map_world);
  EXPECT_EQ(no_map.plan(scene.rest, kTouch, kNormal).message, "no collision map yet");
  no_map_world->setCollisionMap(std::make_shared<octomap::OcTree>(kVoxel));
  EXPECT_EQ(no_map.plan(scene.rest, kTouch, kNormal).message, "the collision map is empty");
  EXPECT_THROW(ArmApproachPlanner(nullptr, no_map_world), std::invalid_argument);
}
