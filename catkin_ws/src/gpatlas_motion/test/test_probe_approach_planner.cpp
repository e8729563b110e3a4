// The probe's approach planner on analytic scenes: octrees whose occupied voxels are boxes, and
// every planned path checked against those boxes themselves (point-to-box distances), not
// against the octree the planner saw.
#include "gpatlas_motion/probe_approach_planner.h"

#include "box_octree.h"

#include <octomap/OcTree.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

namespace {

using gpatlas_motion::ApproachConfig;
using gpatlas_motion::ApproachPlan;
using gpatlas_motion::ProbeApproachPlanner;
using gpatlas_motion::ProbeGeometry;
using Eigen::Vector3d;

using gpatlas_motion_test::Box;
using gpatlas_motion_test::kVoxel;
using gpatlas_motion_test::mapOf;

// The probe's clearance from the boxes over a path, sampled every millimetre: the tip's and the
// shaft's distance minus their radii.
double pathClearance(const std::vector<Vector3d>& path, const Vector3d& direction, const ProbeGeometry& probe,
                     const std::vector<Box>& boxes) {
  double clearance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const int steps = std::max(1, static_cast<int>(std::ceil((path[i + 1] - path[i]).norm() / 0.001)));
    for (int s = 0; s <= steps; ++s) {
      const Vector3d tip = path[i] + (path[i + 1] - path[i]) * (double(s) / steps);
      for (const Box& b : boxes) {
        clearance = std::min(clearance, b.distance(tip) - probe.tip_radius_m);
        for (double t = probe.tip_radius_m; t <= probe.tip_radius_m + probe.shaft_length_m; t += 0.002)
          clearance = std::min(clearance, b.distance(tip - t * direction) - probe.shaft_radius_m);
      }
    }
  }
  return clearance;
}

// The object (a 6 cm cube at the origin), touched on its +x face; a wall between it and the
// probe's start.
const Box kObject{Vector3d(-0.03, -0.03, -0.03), Vector3d(0.03, 0.03, 0.03)};
const Box kWall{Vector3d(0.32, -0.1, -0.1), Vector3d(0.36, 0.1, 0.1)};
const Box kRegion{Vector3d(-0.3, -0.3, -0.3), Vector3d(0.8, 0.3, 0.3)};
const Vector3d kTouch(0.03, 0.0, 0.0), kNormal(1.0, 0.0, 0.0), kStart(0.55, 0.0, 0.0);

TEST(ProbeApproachPlanner, FindsAPathAroundABoxInTheOcTree) {
  ApproachConfig config;
  config.max_planning_time_s = 1.0;
  const ProbeGeometry& probe = config.probe;
  ProbeApproachPlanner planner(config);
  planner.setCollisionMap(mapOf({kObject, kWall}, kRegion));
  const ApproachPlan plan = planner.plan(kStart, kTouch, kNormal);
  ASSERT_TRUE(plan.ok) << plan.message;
  ASSERT_GE(plan.approach.size(), 3u);  // the straight line is blocked: a detour
  EXPECT_TRUE(plan.approach.front().isApprox(kStart));
  EXPECT_TRUE(plan.approach.back().isApprox(kTouch + config.approach_distance_m * kNormal));
  EXPECT_TRUE(plan.direction.isApprox(-kNormal));
  // Clear of the wall and of the object by the clearance (the boxes lie on voxel faces, so the
  // map holds them exactly).
  const double clearance = pathClearance(plan.approach, plan.direction, probe, {kObject, kWall});
  EXPECT_GT(clearance, config.clearance_m - 0.001);  // checked every 2 mm (check_resolution_m)
  std::cout << "detour of " << plan.approach.size() << " waypoints, clearance " << clearance * 1000 << " mm, "
            << plan.planning_ms << " ms\n";
  ASSERT_EQ(plan.retreat.size(), plan.approach.size());
  EXPECT_TRUE(plan.retreat.front().isApprox(plan.approach.back()));
  EXPECT_TRUE(plan.retreat.back().isApprox(kStart));
  ASSERT_EQ(plan.probing.size(), 2u);
  EXPECT_TRUE(plan.probing.back().isApprox(kTouch));

  // Without the wall the approach is the straight line.
  planner.setCollisionMap(mapOf({kObject}, kRegion));
  const ApproachPlan straight = planner.plan(kStart, kTouch, kNormal);
  ASSERT_TRUE(straight.ok) << straight.message;
  EXPECT_EQ(straight.approach.size(), 2u);
}

TEST(ProbeApproachPlanner, RefusesATargetEnclosedByOccupiedVoxels) {
  // A closed shell 2 cm thick around the object, 20 cm out: the approach pose is free, inside it.
  std::vector<Box> shell;
  const double in = 0.2, out = 0.22;
  shell.push_back({Vector3d(in, -out, -out), Vector3d(out, out, out)});
  shell.push_back({Vector3d(-out, -out, -out), Vector3d(-in, out, out)});
  shell.push_back({Vector3d(-out, in, -out), Vector3d(out, out, out)});
  shell.push_back({Vector3d(-out, -out, -out), Vector3d(out, -in, out)});
  shell.push_back({Vector3d(-out, -out, in), Vector3d(out, out, out)});
  shell.push_back({Vector3d(-out, -out, -out), Vector3d(out, out, -in)});
  shell.push_back(kObject);
  ApproachConfig config;
  config.probe.shaft_length_m = 0.02;  // a stub, so that the probe fits inside the shell
  ProbeApproachPlanner planner(config);
  planner.setCollisionMap(mapOf(shell, kRegion));
  EXPECT_TRUE(planner.isFree(kTouch + config.approach_distance_m * kNormal, -kNormal));
  const ApproachPlan plan = planner.plan(kStart, kTouch, kNormal);
  EXPECT_FALSE(plan.ok);
  EXPECT_NE(plan.message.find("no collision-free approach"), std::string::npos) << plan.message;
}

TEST(ProbeApproachPlanner, TheTableIsAnObstacleAndBadInputGetsAReason) {
  const ApproachConfig config;
  ProbeApproachPlanner planner(config);
  EXPECT_NE(planner.plan(kStart, kTouch, kNormal).message.find("no collision map"), std::string::npos);
  planner.setCollisionMap(std::make_shared<octomap::OcTree>(kVoxel));
  EXPECT_NE(planner.plan(kStart, kTouch, kNormal).message.find("empty"), std::string::npos);
  planner.setCollisionMap(mapOf({kObject}, kRegion));
  const double nan = std::nan("");
  EXPECT_NE(planner.plan(kStart, Vector3d(nan, 0, 0), kNormal).message.find("finite"), std::string::npos);
  EXPECT_NE(planner.plan(kStart, kTouch, Vector3d::Zero()).message.find("non-zero"), std::string::npos);
  // A touch far outside the map (issue 51's hostile set: 100 m away was planned as a straight move).
  const ApproachPlan far = planner.plan(kStart, Vector3d(100.0, 0.0, 0.05), kNormal);
  EXPECT_FALSE(far.ok);
  EXPECT_NE(far.message.find("outside the collision map"), std::string::npos) << far.message;
  EXPECT_NE(planner.plan(Vector3d(0.0, 0.0, 0.0), kTouch, kNormal).message.find("start is in collision"),
            std::string::npos);
  // The object's underside, where it stands on a table: the approach pose is in the table (a
  // half-space below its top, 3 cm under the object's centre).
  planner.addStaticHalfSpace(Vector3d(0.0, 0.0, 2.0), 2.0 * 0.03);
  const ApproachPlan under = planner.plan(Vector3d(0.55, 0.0, 0.3), Vector3d(0.0, 0.0, -0.03), Vector3d(0.0, 0.0, -1.0));
  EXPECT_FALSE(under.ok);
  EXPECT_NE(under.message.find("approach pose"), std::string::npos) << under.message;
  // A touch behind another part of the object: the probing segment is blocked.
  planner.setCollisionMap(mapOf({kObject, Box{Vector3d(0.06, -0.02, -0.02), Vector3d(0.08, 0.02, 0.02)}}, kRegion));
  const ApproachPlan occluded = planner.plan(kStart, kTouch, kNormal);
  EXPECT_FALSE(occluded.ok);
  EXPECT_NE(occluded.message.find("occluded"), std::string::npos) << occluded.message;
  // A static box: a touch whose approach pose lies in it.
  planner.addStaticBox(Vector3d(0.13, 0.0, 0.0), Vector3d(0.02, 0.02, 0.02));
  EXPECT_NE(planner.plan(kStart, kTouch, kNormal).message.find("approach pose"), std::string::npos);
  EXPECT_THROW(planner.addStaticHalfSpace(Vector3d::Zero(), 0.0), std::invalid_argument);
  ApproachConfig bad;
  bad.occupied_probability = 1.5;
  EXPECT_FALSE(gpatlas_motion::validate(bad).empty());
  EXPECT_NE(ProbeApproachPlanner(bad).plan(kStart, kTouch, kNormal).message.find("invalid config"), std::string::npos);
  EXPECT_TRUE(gpatlas_motion::validate(config).empty());
}

}  // namespace
