#include "gpatlas_geometry/segmentation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

using gpatlas_geometry::ObjectSegmenter;
using gpatlas_core::Vector3;

namespace {

const Vector3 kSphereCentre(0.6, 0.0, 0.05);
constexpr double kSphereRadius = 0.05;
const Vector3 kBoxCentre(0.3, 0.3, 0.015);  // a smaller distractor object, 3 cm cube

// A table (z = 0, with millimetre noise), the upper half of a sphere resting on it, a small
// cube, a few far outliers and NaN points: what a depth camera sees of a table-top scene.
std::vector<Vector3> tableTopScene(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.001);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vector3> pts;
  for (double x = 0.0; x <= 1.0; x += 0.005)
    for (double y = -0.5; y <= 0.5; y += 0.005) {
      const Vector3 p(x, y, noise(rng));
      if ((Vector3(p.x(), p.y(), kSphereCentre.z()) - kSphereCentre).norm() > kSphereRadius) pts.push_back(p);
    }
  for (int i = 0; i < 3000; ++i) {
    const double z = u(rng), phi = 2 * M_PI * u(rng);
    const double r = std::sqrt(1 - z * z);
    pts.push_back(kSphereCentre + kSphereRadius * Vector3(r * std::cos(phi), r * std::sin(phi), z));
  }
  for (int i = 0; i < 800; ++i) {
    Vector3 p(u(rng) - 0.5, u(rng) - 0.5, 1.0);  // top face of the cube
    p = kBoxCentre + 0.03 * Vector3(p.x(), p.y(), 0.5);
    pts.push_back(p);
  }
  for (int i = 0; i < 5; ++i) pts.emplace_back(u(rng), u(rng) - 0.5, 0.3 + 0.5 * u(rng));
  pts.emplace_back(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
  pts.emplace_back(0.0, std::numeric_limits<double>::infinity(), 0.0);
  return pts;
}

TEST(ObjectSegmenter, KeepsTheSphereAndDropsTableAndOutliers) {
  const auto scene = tableTopScene(1);
  const auto result = ObjectSegmenter().segment(scene);
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_TRUE(result.plane_found);
  EXPECT_GT(result.plane_normal.z(), 0.999);
  EXPECT_NEAR(result.plane_offset, 0.0, 0.002);
  EXPECT_EQ(result.stats.finite, scene.size() - 2);
  EXPECT_GE(result.stats.clusters, 2u);
  ASSERT_GT(result.object_points.size(), 300u);
  for (const auto& p : result.object_points) {
    // Voxel centroids of sphere points lie within half a voxel diagonal of the surface.
    EXPECT_NEAR((p - kSphereCentre).norm(), kSphereRadius, 0.003);
    EXPECT_GT(p.z(), ObjectSegmenter::Config().plane_distance_m);
  }
}

TEST(ObjectSegmenter, HintSelectsTheClosestCluster) {
  ObjectSegmenter::Config config;
  config.object_hint_m = kBoxCentre;
  config.cluster_min_points = 10;
  const auto result = ObjectSegmenter(config).segment(tableTopScene(2));
  ASSERT_TRUE(result.ok) << result.message;
  for (const auto& p : result.object_points) EXPECT_LT((p - kBoxCentre).norm(), 0.03);
}

TEST(ObjectSegmenter, EveryClusterIsKeptAndAPointPicksOne) {
  ObjectSegmenter::Config config;
  config.cluster_min_points = 10;
  const auto result = ObjectSegmenter(config).segment(tableTopScene(3));
  ASSERT_TRUE(result.ok) << result.message;
  // The sphere (the largest, the object) and the cube: each point in one cluster, the object's
  // cluster its points.
  ASSERT_EQ(result.clusters.size(), 2u);
  EXPECT_EQ(result.clusters[result.object_cluster], result.object_points);
  const std::size_t cube = 1 - result.object_cluster;
  for (const auto& p : result.clusters[cube]) EXPECT_LT((p - kBoxCentre).norm(), 0.03);
  EXPECT_LT((gpatlas_geometry::centroidOf(result.clusters[cube]) - kBoxCentre).norm(), 0.016);

  // A point 1 cm above the cube's top picks the cube; one on the sphere's top the sphere.
  double nearest = 0.0;
  const auto on_cube = gpatlas_geometry::clusterNear(result.clusters, kBoxCentre + Vector3(0, 0, 0.025), 0.03, &nearest);
  ASSERT_TRUE(on_cube);
  EXPECT_EQ(*on_cube, cube);
  EXPECT_NEAR(nearest, 0.01, 0.003);
  const auto on_sphere = gpatlas_geometry::clusterNear(result.clusters, kSphereCentre + Vector3(0, 0, kSphereRadius), 0.03);
  ASSERT_TRUE(on_sphere);
  EXPECT_EQ(*on_sphere, result.object_cluster);
  // 5 cm from every cluster point, a NaN, no clusters: none, with the distance said.
  EXPECT_FALSE(gpatlas_geometry::clusterNear(result.clusters, kBoxCentre + Vector3(0, 0, 0.065), 0.03, &nearest));
  EXPECT_NEAR(nearest, 0.05, 0.003);
  EXPECT_FALSE(gpatlas_geometry::clusterNear(result.clusters, Vector3(std::nan(""), 0, 0), 0.03, &nearest));
  EXPECT_FALSE(std::isfinite(nearest));
  EXPECT_FALSE(gpatlas_geometry::clusterNear({}, kBoxCentre, 0.03));
  EXPECT_EQ(gpatlas_geometry::centroidOf({}), Vector3::Zero());
}

TEST(ObjectSegmenter, ObjectOnlyCloudKeepsItsHorizontalFaces) {
  // A cube seen from above without a table: its top face is a large horizontal plane, but the
  // rest of the cube lies below it, so it is not a support plane and nothing is removed.
  std::vector<Vector3> cube;
  for (double u = -0.05; u <= 0.05; u += 0.004)
    for (double v = -0.05; v <= 0.05; v += 0.004) {
      cube.emplace_back(0.6 + u, v, 0.1);         // top
      cube.emplace_back(0.65, v, 0.05 + u);       // front side
      cube.emplace_back(0.6 + u, -0.05, 0.05 + v);  // left side
    }
  const auto result = ObjectSegmenter().segment(cube);
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_FALSE(result.plane_found);
  double min_z = 1.0;
  for (const auto& p : result.object_points) min_z = std::min(min_z, p.z());
  EXPECT_LT(min_z, 0.01);  // the lower part of the sides survived
}

TEST(ObjectSegmenter, BadInputGivesClearErrors) {
  ObjectSegmenter segmenter;
  auto r = segmenter.segment({});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.message, "empty cloud");
  r = segmenter.segment({Vector3::Constant(std::numeric_limits<double>::quiet_NaN())});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("no finite point"), std::string::npos);

  // Only a table: nothing is left once the plane is removed.
  std::vector<Vector3> table;
  for (double x = 0.0; x <= 0.5; x += 0.005)
    for (double y = 0.0; y <= 0.5; y += 0.005) table.emplace_back(x, y, 0.0);
  r = segmenter.segment(table);
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.message.empty());

  ObjectSegmenter::Config broken;
  broken.cluster_tolerance_m = 0.0;
  r = ObjectSegmenter(broken).segment(tableTopScene(3));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("cluster_tolerance_m"), std::string::npos);
}

}  // namespace

namespace {

// A table whose front face the camera sees (more of it than plane_max_fraction_below of the
// cloud) is still the support: its side projects onto the edge of the top, not under it.
TEST(ObjectSegmenter, ATableWhoseSideIsSeenIsStillTheSupport) {
  std::vector<Vector3> pts;
  for (double x = 0.3; x <= 1.0; x += 0.005)
    for (double y = -0.4; y <= 0.4; y += 0.005) {
      const Vector3 p(x, y, 0.0);
      if ((Vector3(x, y, kSphereCentre.z()) - kSphereCentre).norm() > kSphereRadius) pts.push_back(p);
    }
  const std::size_t top = pts.size();
  for (double y = -0.4; y <= 0.4; y += 0.002)
    for (double z = -0.04; z < -0.002; z += 0.002) pts.emplace_back(0.3, y, z);  // the front face
  const std::size_t side = pts.size() - top;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 30; ++j) {
      const double phi = 2 * M_PI * i / 60.0, z = (j + 0.5) / 30.0, r = std::sqrt(1 - z * z);
      pts.push_back(kSphereCentre + kSphereRadius * Vector3(r * std::cos(phi), r * std::sin(phi), z));
    }
  ObjectSegmenter::Config config;
  ASSERT_GT(static_cast<double>(side), config.plane_max_fraction_below * static_cast<double>(pts.size()));
  const auto result = ObjectSegmenter(config).segment(pts);
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_TRUE(result.plane_found);
  EXPECT_NEAR(result.plane_offset, 0.0, 0.002);
  for (const auto& p : result.object_points) EXPECT_NEAR((p - kSphereCentre).norm(), kSphereRadius, 0.003);
}

}  // namespace

namespace {

// The funnel's view: a body, and a rim seen edge-on, a line of points a few millimetres apart,
// separated from the body by a gap where the rays graze the surface. Both are the object.
TEST(ObjectSegmenter, ARimSeenEdgeOnBeyondAGapStaysWithTheObject) {
  std::vector<Vector3> pts = tableTopScene(4);
  std::size_t body = 0;
  for (const Vector3& p : pts) body += (p - kSphereCentre).norm() < kSphereRadius + 0.002 && p.z() > 0.01 ? 1 : 0;
  // An arc 15 mm from the sphere, 3 mm between points.
  const double gap = 0.015, rim_radius = 0.03;
  const double rim_height = kSphereCentre.z() + std::sqrt(std::pow(kSphereRadius + gap, 2) - rim_radius * rim_radius);
  std::vector<Vector3> rim;
  for (double angle = 0.0; angle < M_PI; angle += 0.003 / rim_radius)
    rim.emplace_back(kSphereCentre.x() + rim_radius * std::cos(angle), kSphereCentre.y() + rim_radius * std::sin(angle),
                     rim_height);
  ASSERT_GT(rim.size(), 25u);
  pts.insert(pts.end(), rim.begin(), rim.end());

  const ObjectSegmenter::Config defaults;
  const auto result = ObjectSegmenter(defaults).segment(pts);
  ASSERT_TRUE(result.ok) << result.message;
  std::size_t kept_rim = 0, kept_body = 0;
  for (const Vector3& p : result.object_points) {
    if (std::abs(p.z() - rim_height) < 0.002 && std::abs((p - kSphereCentre).head<2>().norm() - rim_radius) < 0.002)
      ++kept_rim;
    else if (std::abs((p - kSphereCentre).norm() - kSphereRadius) < 0.003)
      ++kept_body;
  }
  // Voxels of 2 mm hold one rim point each, so the count is the rim's.
  EXPECT_GE(kept_rim, rim.size() - 2);
  EXPECT_GT(kept_body, body / 4);  // the body is still there (its points are voxel-thinned)
  EXPECT_EQ(kept_rim + kept_body, result.object_points.size());
}

}  // namespace
