// Approach planning on a model: the collision octree against the grid it comes from, and the
// probe's way to touches on a GP fitted to a sphere, checked against the analytic sphere itself.
#include "gpatlas_motion/touch_approach.h"

#include <gpatlas_core/gpis_model.h>

#include <octomap/OcTree.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <optional>
#include <stdexcept>

namespace {

using Eigen::Vector3d;
using gpatlas_core::Touch;

const Vector3d kCentre(0.7, 0.0, 0.15);
constexpr double kRadius = 0.05;

// A GP fitted to points all over the sphere.
gpatlas_core::GpisModel sphereModel() {
  std::vector<gpatlas_core::TrainingPoint> points;
  for (const Vector3d& direction : gpatlas_core::fibonacciSphere(300)) {
    gpatlas_core::TrainingPoint p;
    p.position = kCentre + kRadius * direction;
    p.label = gpatlas_core::PointLabel::kSurface;
    p.noise_sigma = 0.3162;
    points.push_back(p);
  }
  gpatlas_core::GpisModel model(gpatlas_core::GpisModel::Config::thinPlateReference());
  const gpatlas_core::FitReport fit = model.fit(points);
  EXPECT_TRUE(fit.ok) << fit.message;
  return model;
}

// The probe's clearance from the true sphere along a path of tip positions, sampled every
// millimetre: the tip's and the shaft's distance from the sphere minus their radii.
double sphereClearance(const std::vector<Vector3d>& path, const Vector3d& direction,
                       const gpatlas_core::ProbeGeometry& probe) {
  double clearance = std::numeric_limits<double>::infinity();
  const auto segmentDistance = [](const Vector3d& a, const Vector3d& b, const Vector3d& p) {
    const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    return (a + t * (b - a) - p).norm();
  };
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const int steps = std::max(1, static_cast<int>(std::ceil((path[i + 1] - path[i]).norm() / 0.001)));
    for (int s = 0; s <= steps; ++s) {
      const Vector3d tip = path[i] + (path[i + 1] - path[i]) * (double(s) / steps);
      clearance = std::min(clearance, (tip - kCentre).norm() - kRadius - probe.tip_radius_m);
      const Vector3d a = tip - probe.tip_radius_m * direction;
      const Vector3d b = tip - (probe.tip_radius_m + probe.shaft_length_m) * direction;
      clearance = std::min(clearance, segmentDistance(a, b, kCentre) - kRadius - probe.shaft_radius_m);
    }
  }
  return clearance;
}

TEST(CollisionOctree, EveryNodeKeepsItsProbability) {
  gpatlas_core::OccupancyGrid grid;
  grid.ok = true;
  grid.resolution = 0.01;
  grid.origin = Vector3d(0.005, -0.095, 0.005);
  grid.size = Eigen::Vector3i(12, 20, 8);
  grid.probabilities.resize(static_cast<std::size_t>(grid.size.prod()));
  std::size_t expected_occupied = 0;
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j)
      for (int i = 0; i < grid.size.x(); ++i) {
        const float p = static_cast<float>(0.5 + 0.45 * std::sin(0.7 * i + 0.3 * j - 0.5 * k));
        grid.probabilities[grid.index(i, j, k)] = p;
        expected_occupied += p > 0.6f ? 1 : 0;
      }
  std::size_t occupied = 0;
  const std::unique_ptr<octomap::OcTree> tree = gpatlas_motion::collisionOctree(grid, 0.6, &occupied);
  EXPECT_EQ(occupied, expected_occupied);
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j)
      for (int i = 0; i < grid.size.x(); ++i) {
        const Vector3d x = grid.position(i, j, k);
        const octomap::OcTreeNode* node = tree->search(x.x(), x.y(), x.z());
        ASSERT_NE(node, nullptr) << i << " " << j << " " << k;
        EXPECT_NEAR(node->getOccupancy(), grid.probabilities[grid.index(i, j, k)], 2e-3);
        EXPECT_EQ(tree->isNodeOccupied(node), grid.probabilities[grid.index(i, j, k)] > 0.6f);
      }
  gpatlas_core::OccupancyGrid failed;
  failed.message = "too many nodes";
  EXPECT_THROW(gpatlas_motion::collisionOctree(failed, 0.5), std::invalid_argument);
}

// A touch under the sphere, from a rest above it: the straight way runs through the object, the
// planned one around it, clear of the true sphere.
TEST(ModelTouchApproacher, GoesAroundTheModelledObjectToATouchBeneathIt) {
  const gpatlas_core::GpisModel model = sphereModel();
  gpatlas_core::ApproachConfig config;
  config.rest_tip_position_m = kCentre + Vector3d(0.0, 0.0, 0.3);
  gpatlas_core::OccupancyGridBuilder::Config grid;
  grid.resolution_m = 0.01;
  gpatlas_motion::ModelTouchApproacher approacher(model, config, grid, 0.5, std::nullopt);
  Touch touch;
  touch.points = {kCentre - Vector3d(0.0, 0.0, kRadius)};
  touch.normals = {-Vector3d::UnitZ()};
  const gpatlas_core::ApproachResult result = approacher.plan(touch);
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_GT(approacher.lastMapBuildMs(), 0.0);
  ASSERT_GE(result.approach_path.size(), 3u) << "the straight way through the sphere was taken";
  EXPECT_TRUE(result.approach_path.front().isApprox(config.rest_tip_position_m));
  EXPECT_TRUE(result.approach_path.back().isApprox(touch.points[0] - config.approach_distance_m * Vector3d::UnitZ()));
  const double clearance = sphereClearance(result.approach_path, Vector3d::UnitZ(), config.probe);
  std::cout << "approach around the sphere: " << result.approach_path.size() << " waypoints, clearance "
            << 1000.0 * clearance << " mm, " << result.planning_ms << " ms (map " << approacher.lastMapBuildMs()
            << " ms)" << std::endl;
  EXPECT_GT(clearance, 0.0);
  EXPECT_GT(sphereClearance(result.retreat_path, Vector3d::UnitZ(), config.probe), 0.0);
  // The straight way would have hit it.
  EXPECT_LT(sphereClearance({config.rest_tip_position_m, result.approach_path.back()}, Vector3d::UnitZ(), config.probe),
            0.0);
}

// A slide's retreat leaves from its last waypoint, with the probe along that waypoint's normal.
TEST(ModelTouchApproacher, ASlideRetreatsFromItsLastWaypoint) {
  const gpatlas_core::GpisModel model = sphereModel();
  gpatlas_core::ApproachConfig config;
  config.rest_tip_position_m = kCentre + Vector3d(0.0, 0.0, 0.3);
  gpatlas_core::OccupancyGridBuilder::Config grid;
  gpatlas_motion::ModelTouchApproacher approacher(model, config, grid, 0.5, std::nullopt);
  Touch slide;
  slide.kind = Touch::Kind::kSlide;
  for (double angle : {0.2, 0.5, 0.8}) {
    const Vector3d normal(std::sin(angle), 0.0, std::cos(angle));
    slide.points.push_back(kCentre + kRadius * normal);
    slide.normals.push_back(normal);
  }
  const gpatlas_core::ApproachResult result = approacher.plan(slide);
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_TRUE(result.approach_path.back().isApprox(slide.points.front() + config.approach_distance_m * slide.normals.front()));
  EXPECT_TRUE(result.retreat_path.front().isApprox(slide.points.back() + config.approach_distance_m * slide.normals.back()));
  EXPECT_TRUE(result.retreat_path.back().isApprox(config.rest_tip_position_m));

  Touch empty;
  const gpatlas_core::ApproachResult refused = approacher.plan(empty);
  EXPECT_FALSE(refused.ok);
  EXPECT_NE(refused.message.find("waypoint"), std::string::npos) << refused.message;
}

// The rest inside the modelled object: every approach is refused with the reason, not planned.
TEST(ModelTouchApproacher, ARestInsideTheObjectIsRefused) {
  const gpatlas_core::GpisModel model = sphereModel();
  gpatlas_core::ApproachConfig config;
  config.rest_tip_position_m = kCentre;
  gpatlas_motion::ModelTouchApproacher approacher(model, config, {}, 0.5, std::nullopt);
  Touch touch;
  touch.points = {kCentre + Vector3d(kRadius, 0.0, 0.0)};
  touch.normals = {Vector3d::UnitX()};
  const gpatlas_core::ApproachResult result = approacher.plan(touch);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("start is in collision"), std::string::npos) << result.message;
}

}  // namespace

namespace {

// The cheap test the strategies use: a touch whose approach pose lies under the table, or
// behind another part of the object, is refused; one in the open is not.
TEST(ModelTouchApproacher, TheCheapTestRefusesApproachPosesInTheTableOrTheObject) {
  const gpatlas_core::GpisModel model = sphereModel();
  gpatlas_core::ApproachConfig config;
  config.rest_tip_position_m = kCentre + Vector3d(0.0, 0.0, 0.3);
  const double table_height = kCentre.z() - kRadius;
  gpatlas_motion::ModelTouchApproacher approacher(model, config, {}, 0.5,
                                                  gpatlas_core::SupportPlane{Vector3d::UnitZ(), -table_height});
  EXPECT_TRUE(approacher.reachable(kCentre + kRadius * Vector3d::UnitZ(), Vector3d::UnitZ()));
  EXPECT_TRUE(approacher.reachable(kCentre + kRadius * Vector3d::UnitX(), Vector3d::UnitX()));
  // Low on the side, facing down: the approach pose is under the table.
  const Vector3d low = Vector3d(1.0, 0.0, -0.8).normalized();
  EXPECT_FALSE(approacher.reachable(kCentre + kRadius * low, low));
  // A point on the far side, probed from inside the sphere: the approach pose is in the object
  // (the normal is turned inward).
  EXPECT_FALSE(approacher.reachable(kCentre + kRadius * Vector3d::UnitY(), -Vector3d::UnitY()));
  // What the cheap test refuses, the full plan refuses too.
  Touch touch;
  touch.points = {kCentre + kRadius * low};
  touch.normals = {low};
  EXPECT_FALSE(approacher.plan(touch).ok);
}

}  // namespace
