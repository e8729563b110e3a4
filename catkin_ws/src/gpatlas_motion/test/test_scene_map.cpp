// The scene map on an analytic scene: a camera above a table looking at the explored object (a
// cube) and a neighbour (a box) beside it. What the camera saw becomes occupied, the rays to it
// free, what it did not see unknown; the explored object's own voxels are left to its model,
// and the approach planner avoids the neighbour, which the model alone does not hold.
#include "gpatlas_motion/scene_map.h"

#include "gpatlas_motion/probe_approach_planner.h"
#include "gpatlas_motion/touch_approach.h"

#include "box_octree.h"

#include <octomap/OcTree.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <tuple>

namespace {

using gpatlas_motion::SceneMap;
using gpatlas_motion::SceneMapConfig;
using gpatlas_motion_test::Box;
using gpatlas_motion_test::kVoxel;
using Eigen::Vector3d;

const Vector3d kSensor(0.0, 0.0, 0.5);
const Box kObject{Vector3d(0.57, -0.03, 0.0), Vector3d(0.63, 0.03, 0.06)};
const Box kNeighbour{Vector3d(0.57, 0.12, 0.0), Vector3d(0.63, 0.18, 0.10)};
const Box kTable{Vector3d(0.3, -0.3, 0.0), Vector3d(0.9, 0.3, 0.0)};  // its top, z = 0

// Whether the segment from a to b enters the box's interior before b (slab test).
bool entersBefore(const Vector3d& a, const Vector3d& b, const Box& box) {
  const Vector3d lower = box.lower.array() + 1e-6, upper = box.upper.array() - 1e-6;
  double t0 = 0.0, t1 = 1.0 - 1e-6;
  for (int i = 0; i < 3; ++i) {
    const double d = b[i] - a[i];
    if (std::abs(d) < 1e-12) {
      if (a[i] <= lower[i] || a[i] >= upper[i]) return false;
      continue;
    }
    double near = (lower[i] - a[i]) / d, far = (upper[i] - a[i]) / d;
    if (near > far) std::swap(near, far);
    t0 = std::max(t0, near);
    t1 = std::min(t1, far);
    if (t0 > t1) return false;
  }
  return true;
}

// Points every 2.5 mm on a box's faces (a flat box: its top) that the sensor sees: those no box
// hides from it.
std::vector<Vector3d> seenPoints(const Box& box, const std::vector<Box>& solids) {
  const double step = 0.0025;
  std::vector<Vector3d> out;
  for (double x = box.lower.x(); x <= box.upper.x() + 1e-9; x += step)
    for (double y = box.lower.y(); y <= box.upper.y() + 1e-9; y += step)
      for (double z = box.lower.z(); z <= box.upper.z() + 1e-9; z += step) {
        const Vector3d p(x, y, z);
        const bool on_face = (p - box.lower).cwiseAbs().minCoeff() < 1e-9 || (p - box.upper).cwiseAbs().minCoeff() < 1e-9;
        if (!on_face) continue;
        bool hidden = false;
        for (const Box& s : solids) hidden = hidden || entersBefore(kSensor, p, s);
        if (!hidden) out.push_back(p);
      }
  return out;
}

SceneMapConfig sceneConfig() {
  SceneMapConfig config;
  config.min_corner_m = Vector3d(-0.2, -0.5, -0.05);
  config.max_corner_m = Vector3d(1.2, 0.5, 0.7);
  return config;
}

struct Scene {
  std::vector<Vector3d> object, neighbour, table;
  std::vector<Vector3d> all() const {
    std::vector<Vector3d> out = object;
    out.insert(out.end(), neighbour.begin(), neighbour.end());
    out.insert(out.end(), table.begin(), table.end());
    return out;
  }
};

Scene scene() {
  const std::vector<Box> solids = {kObject, kNeighbour};
  return Scene{seenPoints(kObject, solids), seenPoints(kNeighbour, solids), seenPoints(kTable, solids)};
}

octomap::point3d at(const Vector3d& p) { return octomap::point3d(float(p.x()), float(p.y()), float(p.z())); }

// The voxels (OctoMap's keys at kVoxel, as the maps compute them from float coordinates)
// holding the points.
std::set<std::tuple<int, int, int>> voxelsOf(const std::vector<Vector3d>& points) {
  static const octomap::OcTree keys(kVoxel);
  std::set<std::tuple<int, int, int>> out;
  for (const Vector3d& p : points) {
    const octomap::OcTreeKey k = keys.coordToKey(at(p));
    out.insert({k[0], k[1], k[2]});
  }
  return out;
}

TEST(SceneMap, WhatTheCameraSawIsOccupiedTheRaysFreeTheRestUnknown) {
  const Scene s = scene();
  ASSERT_GT(s.neighbour.size(), 500u);
  SceneMap map(sceneConfig(), kVoxel);
  const std::vector<Vector3d> points = s.all();
  EXPECT_EQ(map.insertCloud(points, kSensor), points.size());
  const octomap::OcTree& tree = map.tree();
  for (const Vector3d& p : points) {
    const octomap::OcTreeNode* node = tree.search(at(p));
    ASSERT_TRUE(node && tree.isNodeOccupied(node)) << "a seen point's voxel at " << p.transpose();
  }
  // Each voxel holding a point, once: no voxel is occupied that no point lies in.
  EXPECT_EQ(map.occupiedVoxels(), voxelsOf(points).size());
  // The ray to the middle of the neighbour's top is free up to three voxels before it.
  const Vector3d face(0.6, 0.15, 0.1);
  const double length = (face - kSensor).norm();
  for (double t = 0.0; t < length - 3.0 * kVoxel; t += 0.5 * kVoxel) {
    const Vector3d p = kSensor + (face - kSensor) * (t / length);
    const octomap::OcTreeNode* node = tree.search(at(p));
    ASSERT_TRUE(node) << "unknown on the ray at " << p.transpose();
    EXPECT_FALSE(tree.isNodeOccupied(node)) << "occupied on the ray at " << p.transpose();
  }
  // Inside the neighbour, and under the table, the camera saw nothing.
  EXPECT_EQ(tree.search(at(Vector3d(0.6, 0.15, 0.05))), nullptr);
  EXPECT_EQ(tree.search(at(Vector3d(0.5, 0.0, -0.03))), nullptr);
}

// A still camera's next frame changes nothing, so the collision map need not re-merge the scene:
// the revision moves only when the obstacles can have moved.
// The old paths, written out, as the truth for the new ones and their timings' baseline.
namespace reference {

double seconds(const std::chrono::steady_clock::time_point& since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// A plain OctoMap with the scene map's settings, which casts every cloud.
std::unique_ptr<octomap::OcTree> plainTree(const SceneMapConfig& config) {
  auto tree = std::make_unique<octomap::OcTree>(kVoxel);
  tree->setProbHit(config.hit_probability);
  tree->setProbMiss(config.miss_probability);
  octomap::point3d lower = at(config.min_corner_m), upper = at(config.max_corner_m);
  tree->setBBXMin(lower);
  tree->setBBXMax(upper);
  tree->useBBXLimit(true);
  return tree;
}

// SceneMap::obstacles as it was: the tree searched along every caster's ray at every call.
std::set<std::tuple<int, int, int>> obstacles(const octomap::OcTree& tree, const SceneMapConfig& config,
                                              const std::vector<Vector3d>& origins, const std::vector<Vector3d>& object) {
  const auto near = [&](const Vector3d& c) {
    return std::any_of(object.begin(), object.end(), [&](const Vector3d& p) { return (p - c).norm() <= config.object_margin_m; });
  };
  std::vector<Vector3d> casters;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const int side = static_cast<int>(std::lround(it.getSize() / kVoxel));
    const Vector3d corner = Vector3d(it.getX(), it.getY(), it.getZ()) - Vector3d::Constant(0.5 * it.getSize() - 0.5 * kVoxel);
    for (int i = 0; i < side; ++i)
      for (int j = 0; j < side; ++j)
        for (int k = 0; k < side; ++k) {
          const Vector3d c = corner + kVoxel * Vector3d(i, j, k);
          if (!near(c)) casters.push_back(c);
        }
  }
  std::vector<Vector3d> out = casters;
  const int steps = static_cast<int>(std::floor(config.shadow_depth_m / kVoxel + 1e-9));
  for (const Vector3d& origin : origins)
    for (const Vector3d& caster : casters)
      for (int k = 1; k <= steps; ++k) {
        const Vector3d p = caster + k * kVoxel * (caster - origin).normalized();
        octomap::OcTreeKey key;
        if (!tree.coordToKeyChecked(at(p), key) || !tree.inBBX(key)) break;
        const octomap::OcTreeNode* node = tree.search(key);
        if (node && !tree.isNodeOccupied(node)) break;
        if (node) continue;
        const octomap::point3d c = tree.keyToCoord(key);
        if (near(Vector3d(c.x(), c.y(), c.z()))) break;
        out.emplace_back(c.x(), c.y(), c.z());
      }
  return voxelsOf(out);
}

}  // namespace reference

TEST(SceneMap, TheRevisionMovesWhenTheSceneChangesAndOnlyThen) {
  const Scene s = scene();
  SceneMap map(sceneConfig(), kVoxel);
  EXPECT_EQ(map.revision(), 0u);
  map.insertCloud(s.all(), kSensor);
  EXPECT_EQ(map.revision(), 1u);
  // The same cloud again, until OctoMap's clamping leaves every voxel as it was (a hit saturates
  // in a few frames; a voxel may flip on the way there).
  std::uint64_t before = map.revision();
  int frames = 0;
  for (; frames < 20; ++frames) {
    before = map.revision();
    map.insertCloud(s.all(), kSensor);
    if (map.revision() == before) break;
  }
  ASSERT_LT(frames, 20) << "the same cloud kept changing the scene";
  const std::vector<Vector3d> settled = map.obstacles(s.object, {});
  for (int i = 0; i < 3; ++i) {
    map.insertCloud(s.all(), kSensor);
    EXPECT_EQ(map.revision(), before);
  }
  // Unchanged revision, unchanged obstacles, and the old full recompute agrees.
  EXPECT_EQ(voxelsOf(map.obstacles(s.object, {})), voxelsOf(settled));
  EXPECT_EQ(voxelsOf(settled), reference::obstacles(map.tree(), sceneConfig(), {kSensor}, s.object));
  // A new thing in view changes it.
  std::vector<Vector3d> more = s.all();
  more.emplace_back(0.6, -0.3, 0.1);
  map.insertCloud(more, kSensor);
  EXPECT_GT(map.revision(), before);
  // A new sensor origin does (its rays cast other shadows) though its cloud is empty; one within
  // a voxel of a known origin does not.
  before = map.revision();
  map.insertCloud({}, kSensor + Vector3d(0.0, 0.1, 0.0));
  EXPECT_EQ(map.revision(), before + 1);
  map.insertCloud({}, kSensor + Vector3d(0.0, 0.1, 0.3 * kVoxel));
  EXPECT_EQ(map.revision(), before + 1);
  before = map.revision();
  map.clear();
  EXPECT_GT(map.revision(), before);
}

TEST(SceneMap, KeepsToItsBoxAndRange) {
  SceneMapConfig config = sceneConfig();
  config.max_range_m = 1.0;
  SceneMap map(config, kVoxel);
  // Beyond the range, outside the box, and one inside both.
  const std::vector<Vector3d> points = {Vector3d(1.1, 0.0, 0.0), Vector3d(0.5, 0.6, 0.3), Vector3d(0.5, 0.0, 0.2)};
  EXPECT_EQ(map.insertCloud(points, kSensor), 1u);
  EXPECT_EQ(map.occupiedVoxels(), 1u);
  EXPECT_EQ(map.tree().search(at(points[0])), nullptr);
  EXPECT_EQ(map.tree().search(at(points[1])), nullptr);
  map.clear();
  EXPECT_EQ(map.occupiedVoxels(), 0u);
}

TEST(SceneMap, RefusesAnUnusableConfig) {
  SceneMapConfig config = sceneConfig();
  config.max_corner_m.x() = config.min_corner_m.x();
  EXPECT_NE(gpatlas_motion::validate(config).find("scene_max_corner_m"), std::string::npos);
  EXPECT_THROW(SceneMap(config, kVoxel), std::invalid_argument);
  EXPECT_THROW(SceneMap(sceneConfig(), 0.0), std::invalid_argument);
  SceneMap map(sceneConfig(), kVoxel);
  EXPECT_THROW(map.insertCloud({}, Vector3d(std::nan(""), 0.0, 0.0)), std::invalid_argument);
}

TEST(SceneMap, TheExploredObjectIsLeftToItsModelAndTheProbesFreeSpaceWins) {
  const Scene s = scene();
  SceneMap map(sceneConfig(), kVoxel);
  map.insertCloud(s.all(), kSensor);
  const double margin = map.config().object_margin_m;
  // One of the neighbour's voxels the probe went through (above the table's).
  const Vector3d probed = *std::find_if(s.neighbour.begin(), s.neighbour.end(), [](const Vector3d& p) { return p.z() > 0.05; });
  const std::vector<Vector3d> obstacles = map.obstacles(s.object, {probed});
  const auto near_object = [&](const Vector3d& c, double distance) {
    for (const Vector3d& p : s.object)
      if ((p - c).norm() <= distance) return true;
    return false;
  };
  std::set<std::tuple<int, int, int>> kept;
  for (const Vector3d& c : obstacles) {
    EXPECT_FALSE(near_object(c, margin)) << c.transpose();
    kept.merge(voxelsOf({c}));
  }
  // Every seen voxel of the neighbour but the probed one is an obstacle; the probed one is not.
  const auto probed_voxel = *voxelsOf({probed}).begin();
  EXPECT_EQ(kept.count(probed_voxel), 0u);
  for (const auto& v : voxelsOf(s.neighbour))
    if (v != probed_voxel) EXPECT_EQ(kept.count(v), 1u) << std::get<0>(v) << " " << std::get<1>(v) << " " << std::get<2>(v);
  // So is the table away from the object (its voxel's centre too): everything else the camera saw.
  std::size_t far_table = 0;
  for (const Vector3d& p : s.table)
    if (!near_object(p, margin + std::sqrt(3.0) * kVoxel)) far_table += kept.count(*voxelsOf({p}).begin()) ? 0 : 1;
  EXPECT_EQ(far_table, 0u) << "table points away from the object whose voxel is no obstacle";
}

TEST(SceneMap, TheUnknownBehindANeighbourIsAnObstacleAndBehindTheObjectItIsNot) {
  const Scene s = scene();
  SceneMapConfig config = sceneConfig();
  config.shadow_depth_m = 0.1;
  SceneMap map(config, kVoxel);
  map.insertCloud(s.all(), kSensor);
  const std::vector<Vector3d> obstacles = map.obstacles(s.object, {});
  const std::set<std::tuple<int, int, int>> blocked = voxelsOf(obstacles);
  const auto holds = [](const std::set<std::tuple<int, int, int>>& voxels, const Vector3d& p) {
    return voxels.count(*voxelsOf({p}).begin()) == 1;
  };
  // The neighbour's inside, which the camera did not see, and its hidden side facing away.
  EXPECT_TRUE(holds(blocked, Vector3d(0.6, 0.15, 0.05)));
  EXPECT_TRUE(holds(blocked, Vector3d(0.625, 0.175, 0.06)));
  // The explored object's inside is its model's.
  EXPECT_FALSE(holds(blocked, Vector3d(0.6, 0.0, 0.03)));
  // No shadow reaches farther than its depth from what the camera saw (seen points bucketed in
  // cubes of that reach: the nearest lies in one of the 27 around).
  const double reach = config.shadow_depth_m + std::sqrt(3.0) * kVoxel;
  const auto cube = [reach](const Vector3d& p) {
    const Eigen::Vector3i c = (p / reach).array().floor().cast<int>();
    return std::make_tuple(c.x(), c.y(), c.z());
  };
  std::map<std::tuple<int, int, int>, std::vector<Vector3d>> buckets;
  for (const Vector3d& p : s.all()) buckets[cube(p)].push_back(p);
  for (const Vector3d& c : obstacles) {
    const auto [x, y, z] = cube(c);
    double nearest = std::numeric_limits<double>::infinity();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = buckets.find({x + dx, y + dy, z + dz});
          if (it != buckets.end())
            for (const Vector3d& p : it->second) nearest = std::min(nearest, (p - c).norm());
        }
    ASSERT_LE(nearest, reach) << c.transpose();
  }
  // Without shadows the inside stays unknown, so free to the planner.
  config.shadow_depth_m = 0.0;
  SceneMap flat(config, kVoxel);
  flat.insertCloud(s.all(), kSensor);
  EXPECT_FALSE(holds(voxelsOf(flat.obstacles(s.object, {})), Vector3d(0.6, 0.15, 0.05)));
}


// A still camera's frames: each is cast until the voxels it touches sit at OctoMap's clamping
// bounds, then skipped, and the map is what casting them all makes it.
TEST(SceneMap, AStillCamerasFramesAreCastUntilTheyCanChangeNothing) {
  const Scene s = scene();
  const std::vector<Vector3d> points = s.all();
  const SceneMapConfig config = sceneConfig();
  SceneMap map(config, kVoxel);
  std::unique_ptr<octomap::OcTree> plain = reference::plainTree(config);
  double cast_s = 0.0, scene_s = 0.0;
  constexpr int kFrames = 20;
  for (int i = 0; i < kFrames; ++i) {
    auto started = std::chrono::steady_clock::now();
    plain->insertPointCloud([&] {
      octomap::Pointcloud cloud;
      for (const Vector3d& p : points) cloud.push_back(at(p));
      return cloud;
    }(), at(kSensor), config.max_range_m, false, true);
    cast_s += reference::seconds(started);
    started = std::chrono::steady_clock::now();
    map.insertCloud(points, kSensor);
    scene_s += reference::seconds(started);
  }
  // Log-odds from 0.12 to 0.97, steps of at least |log(0.4 / 0.6)|: 14 casts reach a bound.
  EXPECT_GE(map.skippedClouds(), 3u);
  EXPECT_LE(map.skippedClouds(), 6u);
  std::size_t leaves = 0;
  for (auto it = plain->begin_leafs(); it != plain->end_leafs(); ++it, ++leaves) {
    const octomap::OcTreeNode* node = map.tree().search(it.getKey(), it.getDepth());
    ASSERT_TRUE(node) << "a voxel the plain map knows is unknown at " << it.getCoordinate();
    ASSERT_NEAR(node->getLogOdds(), it->getLogOdds(), 1e-5) << "at " << it.getCoordinate();
  }
  EXPECT_EQ(map.tree().getNumLeafNodes(), leaves);
  // A new origin casts again.
  map.insertCloud(points, kSensor + Vector3d(0.0, 0.0, 0.05));
  const std::size_t skipped = map.skippedClouds();
  map.insertCloud(points, kSensor);
  EXPECT_EQ(map.skippedClouds(), skipped) << "the first frame after another view was skipped";
  std::printf("[scene] %d frames of %zu points: every one cast %.3f s, the scene map %.3f s (%zu skipped)\n", kFrames,
              points.size(), cast_s, scene_s, skipped);
}

// obstacles() keeps what it takes from the tree for a revision, and the object's margin for
// the same object points: each call is the old computation's answer, whatever came between.
TEST(SceneMap, ObstaclesKeptForARevisionAreTheOnesComputedAfresh) {
  const Scene s = scene();
  SceneMapConfig config = sceneConfig();
  config.shadow_depth_m = 0.1;
  SceneMap map(config, kVoxel);
  std::vector<Vector3d> origins{kSensor};
  map.insertCloud(s.all(), kSensor);
  const std::vector<Vector3d> no_object;
  for (int round = 0; round < 2; ++round) {
    std::vector<double> times;
    for (const std::vector<Vector3d>* object : {&s.object, &s.object, &no_object, &s.object}) {
      const auto started = std::chrono::steady_clock::now();
      const std::vector<Vector3d> obstacles = map.obstacles(*object, {});
      times.push_back(reference::seconds(started));
      EXPECT_EQ(voxelsOf(obstacles).size(), obstacles.size()) << "a voxel twice";
      ASSERT_EQ(voxelsOf(obstacles), reference::obstacles(map.tree(), config, origins, *object)) << "round " << round;
    }
    auto started = std::chrono::steady_clock::now();
    reference::obstacles(map.tree(), config, origins, s.object);
    std::printf("[scene] obstacles (%zu occupied voxels): first %.4f s, same object %.4f s, another %.4f s; "
                "the reference %.4f s\n", map.occupiedVoxels(), times[0], times[1], times[2], reference::seconds(started));
    // A second view, from elsewhere: a new revision, more shadows.
    const Vector3d second(0.0, 0.4, 0.5);
    map.insertCloud(seenPoints(kNeighbour, {kObject, kNeighbour}), second);
    origins.push_back(second);
  }
}

// Obstacles added in bulk make the map that adding them voxel by voxel made, inner nodes too
// (what FCL and search at a coarser depth read).
TEST(SceneMap, ObstaclesAddedInBulkAreTheVoxelByVoxelMap) {
  const Scene s = scene();
  SceneMapConfig config = sceneConfig();
  config.shadow_depth_m = 0.1;
  SceneMap scene_map(config, kVoxel);
  scene_map.insertCloud(s.all(), kSensor);
  const std::vector<Vector3d> obstacles = scene_map.obstacles(s.object, {});
  const std::shared_ptr<octomap::OcTree> model = gpatlas_motion_test::mapOf(
      {kObject}, Box{Vector3d(0.45, -0.15, 0.0), Vector3d(0.75, 0.15, 0.2)});
  octomap::OcTree bulk(*model), one_by_one(*model);
  auto started = std::chrono::steady_clock::now();
  const std::size_t added = gpatlas_motion::addObstacles(&bulk, obstacles);
  const double bulk_s = reference::seconds(started);
  started = std::chrono::steady_clock::now();
  std::size_t expected_added = 0;
  for (const Vector3d& c : obstacles) {
    const octomap::OcTreeNode* before = one_by_one.search(at(c));
    if (!before || !one_by_one.isNodeOccupied(before)) ++expected_added;
    one_by_one.setNodeValue(at(c), one_by_one.getClampingThresMaxLog());
  }
  const double one_by_one_s = reference::seconds(started);
  EXPECT_EQ(added, expected_added);
  EXPECT_GT(added, 1000u);
  for (unsigned depth = 10; depth <= 16; depth += 2) {
    std::size_t nodes = 0;
    for (auto it = one_by_one.begin_leafs(depth); it != one_by_one.end_leafs(); ++it, ++nodes) {
      const octomap::OcTreeNode* node = bulk.search(it.getKey(), depth);
      ASSERT_TRUE(node) << "depth " << depth << " at " << it.getCoordinate();
      ASSERT_NEAR(node->getLogOdds(), it->getLogOdds(), 1e-6) << "depth " << depth << " at " << it.getCoordinate();
    }
    EXPECT_GT(nodes, 0u);
  }
  EXPECT_EQ(bulk.size(), one_by_one.size());
  std::printf("[scene] %zu obstacles into the model's map: in bulk %.4f s, voxel by voxel %.4f s\n", obstacles.size(),
              bulk_s, one_by_one_s);
}

// The model's map (the object's voxels) with the scene's obstacles added.
std::shared_ptr<octomap::OcTree> mergedMap(const Scene& s, double object_margin_m) {
  const Box region{Vector3d(0.45, -0.15, 0.0), Vector3d(0.75, 0.15, 0.2)};  // the model's domain
  std::shared_ptr<octomap::OcTree> merged = gpatlas_motion_test::mapOf({kObject}, region);
  SceneMapConfig config = sceneConfig();
  config.object_margin_m = object_margin_m;
  SceneMap map(config, kVoxel);
  map.insertCloud(s.all(), kSensor);
  gpatlas_motion::addObstacles(merged.get(), map.obstacles(s.object, {}));
  return merged;
}

TEST(SceneMap, MergedIntoTheModelsMapTheNeighbourBlocksAndTheObjectDoesNot) {
  const Scene s = scene();
  const std::shared_ptr<octomap::OcTree> model_only = gpatlas_motion_test::mapOf(
      {kObject}, Box{Vector3d(0.45, -0.15, 0.0), Vector3d(0.75, 0.15, 0.2)});
  const std::shared_ptr<octomap::OcTree> merged = mergedMap(s, sceneConfig().object_margin_m);
  // Where the model governs (within the margin of the object), the merged map is the model's.
  for (double x = 0.545; x < 0.66; x += kVoxel)
    for (double z = 0.005; z < 0.1; z += kVoxel) {
      const Vector3d p(x, 0.005, z);
      EXPECT_EQ(merged->isNodeOccupied(merged->search(at(p))), model_only->isNodeOccupied(model_only->search(at(p))))
          << p.transpose();
    }
  // The neighbour's seen faces are occupied, in the model's domain and out of it.
  for (const Vector3d& p : s.neighbour) {
    const octomap::OcTreeNode* node = merged->search(at(p));
    ASSERT_TRUE(node && merged->isNodeOccupied(node)) << p.transpose();
  }

  gpatlas_motion::ApproachConfig config;
  config.max_planning_time_s = 1.0;
  gpatlas_motion::ProbeApproachPlanner with_scene(config), model_alone(config);
  with_scene.setCollisionMap(merged);
  model_alone.setCollisionMap(model_only);
  // The object's +y side faces the neighbour, 9 cm away: the approach pose 10 cm out lies in it.
  const Vector3d side(0.6, 0.03, 0.04), side_normal(0.0, 1.0, 0.0);
  EXPECT_EQ(model_alone.checkApproachPose(side, side_normal), "");
  EXPECT_NE(with_scene.checkApproachPose(side, side_normal), "");
  // The face toward the camera is touched as before: its own seen voxels do not block it.
  const Vector3d front(0.57, 0.0, 0.04), front_normal(-1.0, 0.0, 0.0);
  EXPECT_EQ(with_scene.checkApproachPose(front, front_normal), "");
  EXPECT_TRUE(model_alone.isFree(Vector3d(0.6, 0.11, 0.05), Vector3d::UnitX()));
  EXPECT_FALSE(with_scene.isFree(Vector3d(0.6, 0.11, 0.05), Vector3d::UnitX()));

  // From beyond the neighbour, the way to the front face goes around it: every tip position
  // clears the neighbour's box by the tip's radius.
  const gpatlas_motion::ApproachPlan plan = with_scene.plan(Vector3d(0.7, 0.35, 0.05), front, front_normal);
  ASSERT_TRUE(plan.ok) << plan.message;
  double clearance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < plan.approach.size(); ++i)
    for (int k = 0; k <= 100; ++k) {
      const Vector3d tip = plan.approach[i] + (plan.approach[i + 1] - plan.approach[i]) * (k / 100.0);
      clearance = std::min(clearance, kNeighbour.distance(tip) - config.probe.tip_radius_m);
    }
  EXPECT_GE(clearance, 0.0);
}

// A tall body the camera sees, and a handle behind it the camera cannot see and its model does not
// predict: the case of a scanned jug, whose hidden parts the probe's way used to cross.
const Box kBody{Vector3d(0.55, -0.05, 0.0), Vector3d(0.65, 0.05, 0.2)};
const Box kHiddenHandle{Vector3d(0.66, 0.02, 0.04), Vector3d(0.70, 0.05, 0.10)};
const Box kDomain{Vector3d(0.45, -0.2, 0.0), Vector3d(0.85, 0.2, 0.3)};  // the model's

struct HiddenPartScene {
  std::vector<Vector3d> cloud, body;
};

HiddenPartScene hiddenPartScene() {
  const std::vector<Box> solids = {kBody, kHiddenHandle};
  HiddenPartScene s;
  s.body = seenPoints(kBody, solids);
  s.cloud = s.body;
  const std::vector<Vector3d> handle = seenPoints(kHiddenHandle, solids), table = seenPoints(kTable, solids);
  EXPECT_TRUE(handle.empty()) << "the handle must be hidden from the camera";
  s.cloud.insert(s.cloud.end(), table.begin(), table.end());
  return s;
}

// The body's voxels' centres, as its model's map holds them (mapOf).
std::vector<Vector3d> bodyVoxels() {
  std::vector<Vector3d> out;
  for (double x = kDomain.lower.x() + 0.5 * kVoxel; x < kDomain.upper.x(); x += kVoxel)
    for (double y = kDomain.lower.y() + 0.5 * kVoxel; y < kDomain.upper.y(); y += kVoxel)
      for (double z = kDomain.lower.z() + 0.5 * kVoxel; z < kDomain.upper.z(); z += kVoxel)
        if (kBody.distance(Vector3d(x, y, z)) == 0.0) out.emplace_back(x, y, z);
  return out;
}

bool holdsVoxelOf(const std::vector<Vector3d>& centres, const Vector3d& p) {
  return voxelsOf(centres).count(*voxelsOf({p}).begin()) == 1;
}

TEST(SceneMap, TheUnseenSpaceIsWhatNoRayReachedAndNoProbeStrokeWentThrough) {
  const HiddenPartScene s = hiddenPartScene();
  SceneMapConfig config = sceneConfig();
  config.unseen_reach_m = 0.045;  // no voxel centre at exactly that distance from another
  SceneMap map(config, kVoxel);
  map.insertCloud(s.cloud, kSensor);
  const std::vector<Vector3d> object = bodyVoxels();
  const double reach = config.unseen_reach_m;
  const Vector3d behind(0.685, 0.035, 0.07);  // in the handle, in the body's shadow
  const Vector3d probed(0.68, -0.03, 0.05);  // in the shadow too, where a stroke went
  const std::vector<Vector3d> unseen = map.unseen(object, {});
  EXPECT_TRUE(holdsVoxelOf(unseen, behind));
  EXPECT_TRUE(holdsVoxelOf(unseen, probed));
  EXPECT_FALSE(holdsVoxelOf(map.unseen(object, {probed}), probed));
  // Each one is unknown to the scene and within the reach of the object; a voxel a ray crossed
  // is not one, nor the shadow's far part.
  const auto distance = [&](const Vector3d& c) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vector3d& p : object) nearest = std::min(nearest, (p - c).norm());
    return nearest;
  };
  for (const Vector3d& c : unseen) {
    ASSERT_EQ(map.tree().search(at(c)), nullptr) << c.transpose();
    ASSERT_LE(distance(c), reach + 1e-6) << c.transpose();
  }
  EXPECT_FALSE(holdsVoxelOf(unseen, Vector3d(0.6, 0.0, 0.215)));  // above the body
  EXPECT_FALSE(holdsVoxelOf(unseen, Vector3d(0.5, 0.0, 0.05)));   // in front of it
  EXPECT_FALSE(holdsVoxelOf(unseen, Vector3d(0.8, 0.0, 0.05)));   // in the shadow, out of reach
  // Every unknown voxel within the reach is one (the voxels around the body counted one by one).
  std::size_t unknown = 0;
  for (double x = 0.455; x < 0.8; x += kVoxel)
    for (double y = -0.145; y < 0.15; y += kVoxel)
      for (double z = -0.045; z < 0.3; z += kVoxel) {
        const Vector3d c(x, y, z);
        unknown += map.tree().search(at(c)) == nullptr && distance(c) <= reach ? 1 : 0;
      }
  EXPECT_EQ(voxelsOf(unseen).size(), unknown);
  config.unseen_reach_m = 0.0;
  SceneMap without(config, kVoxel);
  without.insertCloud(s.cloud, kSensor);
  EXPECT_TRUE(without.unseen(object, {}).empty());
}

// The smallest distance from the box to the probe's body (its tip sphere and its shaft's axis,
// less their radii) along a polyline of tip positions, the probe pointing along `direction`.
double bodyClearance(const std::vector<Vector3d>& path, const Vector3d& direction, const Box& box,
                     const gpatlas_motion::ProbeGeometry& probe) {
  double clearance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path.size(); ++i)
    for (int k = 0; k <= 200; ++k) {
      const Vector3d tip = path[i] + (path[i + 1] - path[i]) * (k / 200.0);
      clearance = std::min(clearance, box.distance(tip) - probe.tip_radius_m);
      for (double t = probe.tip_radius_m; t <= probe.tip_radius_m + probe.shaft_length_m; t += 0.002)
        clearance = std::min(clearance, box.distance(tip - t * direction) - probe.shaft_radius_m);
    }
  return clearance;
}

TEST(SceneMap, TheWayToATouchAvoidsTheObjectsUnseenSpaceAndTheStrokeGoesIn) {
  const HiddenPartScene s = hiddenPartScene();
  SceneMap map(sceneConfig(), kVoxel);
  map.insertCloud(s.cloud, kSensor);
  // The model's map knows the body only, and predicts the handle's place free.
  const std::shared_ptr<octomap::OcTree> model = gpatlas_motion_test::mapOf({kBody}, kDomain);
  gpatlas_motion::addObstacles(model.get(), map.obstacles(s.body, {}));
  gpatlas_motion::ApproachConfig config;
  config.max_planning_time_s = 1.0;
  config.approach_distance_m = 0.05;
  // A touch on the body's hidden back face, beside the handle; the probe rests to its left,
  // where the camera saw, and the straight way there crosses the handle.
  const Vector3d touch(0.65, -0.03, 0.07), normal(1.0, 0.0, 0.0), rest(0.70, 0.3, 0.07);
  gpatlas_motion::ProbeApproachPlanner model_only(config), with_unseen(config);
  model_only.setCollisionMap(model);
  with_unseen.setCollisionMap(model);
  with_unseen.setUnseenSpace(gpatlas_motion::voxelOctree(map.unseen(bodyVoxels(), {}), kVoxel));
  const gpatlas_motion::ApproachPlan blind = model_only.plan(rest, touch, normal);
  ASSERT_TRUE(blind.ok) << blind.message;
  EXPECT_LT(bodyClearance(blind.approach, -normal, kHiddenHandle, config.probe), 0.0) << "the test's way must cross the handle";

  const gpatlas_motion::ApproachPlan plan = with_unseen.plan(rest, touch, normal);
  ASSERT_TRUE(plan.ok) << plan.message;
  EXPECT_GE(bodyClearance(plan.approach, -normal, kHiddenHandle, config.probe), 0.0);
  EXPECT_GE(bodyClearance(plan.retreat, -normal, kHiddenHandle, config.probe), 0.0);
  // It ends at the same approach pose, the last stretch along the touch's line (the guarded
  // move in), and the probing segment is the same.
  const Vector3d approach_pose = touch + config.approach_distance_m * normal;
  ASSERT_GE(plan.approach.size(), 3u);
  EXPECT_TRUE(plan.approach.back().isApprox(approach_pose));
  const Vector3d entry = plan.approach[plan.approach.size() - 2];
  EXPECT_GT((entry - approach_pose).dot(normal), 0.0);
  EXPECT_LT((entry - approach_pose).cross(normal).norm(), 1e-9);
  EXPECT_EQ(plan.probing, blind.probing);
  // The cheap test does not see the unseen space: the touch stays a candidate.
  EXPECT_EQ(with_unseen.checkApproachPose(touch, normal), "");
}

// The voxels' centres of a box aligned with the voxel grid, as SceneMap::unseen lists them.
std::vector<Vector3d> voxelCentres(const Box& box) {
  std::vector<Vector3d> out;
  for (double x = box.lower.x() + 0.5 * kVoxel; x < box.upper.x(); x += kVoxel)
    for (double y = box.lower.y() + 0.5 * kVoxel; y < box.upper.y(); y += kVoxel)
      for (double z = box.lower.z() + 0.5 * kVoxel; z < box.upper.z(); z += kVoxel) out.emplace_back(x, y, z);
  return out;
}

// A touch on the body's back face whose approach pose along the normal lies in space nobody saw,
// where a part nobody saw stands (the kettle's case): the cheap test tilts the approach until its
// pose lies in seen space, and the way there and back clears that part; only when every
// acceptable direction's pose is unseen is the normal kept, entered along its line (guarded).
TEST(TouchMotionPlanner, AnApproachPoseInSpaceNobodySawIsTiltedOutOfItAndGuardedOnlyAsTheLastResort) {
  const Box unseen_region{Vector3d(0.65, -0.06, 0.06), Vector3d(0.80, 0.06, 0.12)};
  const Box hidden_knob{Vector3d(0.73, -0.01, 0.09), Vector3d(0.77, 0.01, 0.11)};
  gpatlas_motion::ApproachConfig config;
  config.max_planning_time_s = 1.0;
  config.rest_tip_position_m = Vector3d(0.75, 0.0, 0.45);
  const std::shared_ptr<octomap::OcTree> model = gpatlas_motion_test::mapOf({kBody}, kDomain);
  const gpatlas_motion::TouchMotionPlanner planner(config, model, std::nullopt, nullptr, nullptr,
                                                   gpatlas_motion::voxelOctree(voxelCentres(unseen_region), kVoxel));
  const Vector3d point(0.65, 0.0, 0.10), normal = Vector3d::UnitX();
  gpatlas_core::Touch touch;
  touch.points = {point};
  touch.normals = {normal};
  // Along the normal the approach pose is in the knob, and the guarded entry meets it.
  const gpatlas_motion::TouchMotion along_normal = planner.plan(touch);
  ASSERT_TRUE(along_normal.ok) << along_normal.message;
  EXPECT_TRUE(along_normal.guarded_entry);
  EXPECT_LT(bodyClearance(along_normal.approach, -normal, hidden_knob, config.probe), 0.0)
      << "the test's knob must stand in the guarded entry's way";

  const std::optional<Vector3d> direction = planner.approachDirection(point, normal);
  ASSERT_TRUE(direction.has_value());
  const double tilt_deg = std::acos(std::clamp(direction->dot(normal), -1.0, 1.0)) * 180.0 / M_PI;
  EXPECT_GT(tilt_deg, 1.0);
  EXPECT_LE(tilt_deg, config.max_tilt_deg + 1e-9);
  // Its approach pose is clear of the unseen region by the tip's inflated radius.
  const Vector3d pose = point + config.approach_distance_m * *direction;
  EXPECT_GT(unseen_region.distance(pose), config.probe.tip_radius_m + config.clearance_m) << pose.transpose();
  touch.normals = {*direction};
  const gpatlas_motion::TouchMotion tilted = planner.plan(touch);
  ASSERT_TRUE(tilted.ok) << tilted.message;
  EXPECT_FALSE(tilted.guarded_entry);
  EXPECT_TRUE(tilted.approach.back().isApprox(pose));
  EXPECT_GE(bodyClearance(tilted.approach, -*direction, hidden_knob, config.probe), 0.0);
  EXPECT_GE(bodyClearance(tilted.retreat, -*direction, hidden_knob, config.probe), 0.0);

  // Without unseen space, or with every direction's approach pose in it, the normal.
  const gpatlas_motion::TouchMotionPlanner all_seen(config, model, std::nullopt, nullptr);
  ASSERT_EQ(all_seen.approachDirection(point, normal), std::optional<Vector3d>(normal));
  const Box around{Vector3d(0.65, -0.2, 0.0), Vector3d(0.85, 0.2, 0.3)};
  const gpatlas_motion::TouchMotionPlanner all_unseen(config, model, std::nullopt, nullptr, nullptr,
                                                      gpatlas_motion::voxelOctree(voxelCentres(around), kVoxel));
  EXPECT_EQ(all_unseen.approachDirection(point, normal), std::optional<Vector3d>(normal));
  // A direction the cheap test refuses is not the last resort: from inside the body, none.
  EXPECT_FALSE(all_unseen.approachDirection(point, -normal).has_value());
}

TEST(SceneMap, AMovingCameraKeepsAtMostItsNewestSensorOrigins) {
  SceneMapConfig config = sceneConfig();
  config.max_sensor_origins = 4;
  SceneMap map(config, kVoxel);
  for (int i = 0; i < 10; ++i) map.insertCloud({}, kSensor + Vector3d(0.0, 0.05 * i, 0.0));
  ASSERT_EQ(map.sensorOrigins().size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_TRUE(map.sensorOrigins()[k].isApprox(kSensor + Vector3d(0.0, 0.05 * (6 + k), 0.0)));
  // An origin within a voxel of a kept one is that one.
  map.insertCloud({}, kSensor + Vector3d(0.0, 0.45, 0.3 * kVoxel));
  EXPECT_EQ(map.sensorOrigins().size(), 4u);
  EXPECT_TRUE(map.sensorOrigins().front().isApprox(kSensor + Vector3d(0.0, 0.3, 0.0)));
  config.max_sensor_origins = 0;
  EXPECT_NE(gpatlas_motion::validate(config).find("max_sensor_origins"), std::string::npos);
}

}  // namespace
