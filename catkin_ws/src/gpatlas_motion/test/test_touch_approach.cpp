// Approach planning on a model: the collision octree against the grid it comes from, and the
// probe's way to touches on a GP fitted to a sphere, checked against the analytic sphere itself.
#include "gpatlas_motion/touch_approach.h"

#include <gpatlas_core/model/gpis_model.h>

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
                       const gpatlas_motion::ProbeGeometry& probe) {
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
  gpatlas_motion::ApproachConfig config;
  config.rest_tip_position_m = kCentre + Vector3d(0.0, 0.0, 0.3);
  gpatlas_core::OccupancyGridBuilder::Config grid;
  grid.resolution_m = 0.01;
  gpatlas_motion::ModelTouchApproacher approacher(model, config, grid, std::nullopt);
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
  gpatlas_motion::ApproachConfig config;
  config.rest_tip_position_m = kCentre + Vector3d(0.0, 0.0, 0.3);
  gpatlas_core::OccupancyGridBuilder::Config grid;
  gpatlas_motion::ModelTouchApproacher approacher(model, config, grid, std::nullopt);
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
  gpatlas_motion::ApproachConfig config;
  config.rest_tip_position_m = kCentre;
  gpatlas_motion::ModelTouchApproacher approacher(model, config, {}, std::nullopt);
  Touch touch;
  touch.points = {kCentre + Vector3d(kRadius, 0.0, 0.0)};
  touch.normals = {Vector3d::UnitX()};
  const gpatlas_core::ApproachResult result = approacher.plan(touch);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("start is in collision"), std::string::npos) << result.message;
}

}  // namespace

namespace {

// The directions a blocked touch is tried along: the normal first, then rings at the configured
// tilts, each starting toward up, all distinct unit vectors.
TEST(ApproachDirections, RingsOfTiltedDirectionsStartTowardUp) {
  gpatlas_motion::ApproachConfig config;
  config.max_tilt_deg = 45.0;
  config.tilt_step_deg = 15.0;
  config.tilt_azimuths = 6;
  const Vector3d normal = Vector3d(1.0, 0.0, -1.0).normalized();
  const std::vector<Vector3d> directions = gpatlas_motion::approachDirections(normal, Vector3d::UnitZ(), config);
  ASSERT_EQ(directions.size(), 1u + 3u * 6u);
  EXPECT_LT((directions.front() - normal).norm(), 1e-12);
  for (std::size_t i = 1; i < directions.size(); ++i) {
    const int ring = static_cast<int>((i - 1) / 6) + 1;
    EXPECT_NEAR(directions[i].norm(), 1.0, 1e-12);
    EXPECT_NEAR(std::acos(std::clamp(directions[i].dot(normal), -1.0, 1.0)) * 180.0 / M_PI, 15.0 * ring, 1e-9) << i;
    for (std::size_t j = 0; j < i; ++j) EXPECT_GT((directions[i] - directions[j]).norm(), 1e-6) << i << " " << j;
  }
  // Each ring's first direction lies in the plane of the normal and up, turned toward up.
  for (int ring = 0; ring < 3; ++ring) {
    const Vector3d& first = directions[1 + 6 * ring];
    EXPECT_NEAR(first.y(), 0.0, 1e-12);
    EXPECT_GT(first.z(), normal.z());
  }
  // A normal along up has no direction toward it: any tangent will do, and nothing is NaN.
  for (const Vector3d& d : gpatlas_motion::approachDirections(Vector3d::UnitZ(), Vector3d::UnitZ(), config))
    EXPECT_TRUE(d.allFinite());
  config.max_tilt_deg = 0.0;
  EXPECT_EQ(gpatlas_motion::approachDirections(normal, Vector3d::UnitZ(), config).size(), 1u);
  EXPECT_THROW(gpatlas_motion::approachDirections(Vector3d::Zero(), Vector3d::UnitZ(), config), std::invalid_argument);
}

// The cheap test the strategies use: a touch whose approach pose lies under the table is
// approached along a direction tilted from the normal, one behind another part of the object
// is refused, one in the open is approached along its normal.
TEST(ModelTouchApproacher, TheCheapTestTiltsOutOfTheTableAndRefusesApproachesFromInside) {
  const gpatlas_core::GpisModel model = sphereModel();
  gpatlas_motion::ApproachConfig config;
  config.rest_tip_position_m = kCentre + Vector3d(0.0, 0.0, 0.3);
  const double table_height = kCentre.z() - kRadius;
  const gpatlas_core::SupportPlane table{Vector3d::UnitZ(), -table_height};
  gpatlas_motion::ModelTouchApproacher approacher(model, config, {}, table);
  for (const Vector3d& open : {Vector3d::UnitZ(), Vector3d::UnitX()}) {
    const std::optional<Vector3d> direction = approacher.approachDirection(kCentre + kRadius * open, open);
    ASSERT_TRUE(direction.has_value());
    EXPECT_LT((*direction - open).norm(), 1e-12);
  }
  // Low on the side, facing down: the approach pose along the normal is under the table.
  const Vector3d low = Vector3d(1.0, 0.0, -0.8).normalized();
  const Vector3d low_point = kCentre + kRadius * low;
  ASSERT_LT((low_point + config.approach_distance_m * low).z(), table_height);
  const std::optional<Vector3d> tilted = approacher.approachDirection(low_point, low);
  ASSERT_TRUE(tilted.has_value());
  const double tilt_deg = std::acos(tilted->dot(low)) * 180.0 / M_PI;
  EXPECT_GT(tilt_deg, 1.0);
  EXPECT_LE(tilt_deg, config.max_tilt_deg + 1e-9);
  // The way there along it clears the true sphere and the table.
  Touch touch;
  touch.points = {low_point};
  touch.normals = {*tilted};
  const gpatlas_core::ApproachResult planned = approacher.plan(touch);
  ASSERT_TRUE(planned.ok) << planned.message;
  EXPECT_GT(sphereClearance(planned.approach_path, -*tilted, config.probe), 0.0);
  for (const Vector3d& tip : planned.approach_path) EXPECT_GT(tip.z() - config.probe.tip_radius_m, table_height);
  // Along the normal only, it is refused, and so is its full plan.
  gpatlas_motion::ApproachConfig normal_only = config;
  normal_only.max_tilt_deg = 0.0;
  gpatlas_motion::ModelTouchApproacher strict(model, normal_only, {}, table);
  EXPECT_FALSE(strict.approachDirection(low_point, low).has_value());
  touch.normals = {low};
  EXPECT_FALSE(strict.plan(touch).ok);
  // A point on the far side, probed from inside the sphere: every direction within 60 degrees
  // of the inward normal starts in the object.
  EXPECT_FALSE(approacher.approachDirection(kCentre + kRadius * Vector3d::UnitY(), -Vector3d::UnitY()).has_value());
}

}  // namespace
