// Reachability from outside, checked on shapes whose answer is known exactly: a box nested in
// another (the inner one is sealed off), a box resting on the table (its bottom face is
// covered by the table), and single points inside and outside a closed box.
#include "probe_sim/reachability.h"

#include <gtest/gtest.h>

#include <cmath>

using probe_sim::ReachabilityConfig;
using probe_sim::Scene;
using probe_sim::TriangleMesh;

namespace {

// A closed axis-aligned box, outward winding, two triangles per face.
TriangleMesh makeBox(const Eigen::Vector3d& min_corner, const Eigen::Vector3d& max_corner) {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i)
    mesh.vertices.emplace_back(i & 1 ? max_corner.x() : min_corner.x(), i & 2 ? max_corner.y() : min_corner.y(),
                               i & 4 ? max_corner.z() : min_corner.z());
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    mesh.triangles.emplace_back(f[0], f[1], f[2]);
    mesh.triangles.emplace_back(f[0], f[2], f[3]);
  }
  return mesh;
}

Scene::Config noTable() {
  Scene::Config config;
  config.add_table = false;
  return config;
}

}  // namespace

TEST(Reachability, ABoxSealedInsideAnotherIsUnreachableAndTheOuterOneIsReachable) {
  TriangleMesh nested = makeBox({-0.05, -0.05, 0.0}, {0.05, 0.05, 0.1});
  nested.append(makeBox({-0.025, -0.025, 0.025}, {0.025, 0.025, 0.075}));
  const Scene scene(nested, noTable());
  const probe_sim::ReachableSurface split = probe_sim::splitReachableSurface(scene);
  EXPECT_EQ(split.triangles_tested, 24u);
  ASSERT_EQ(split.triangle_reachable.size(), 24u);
  for (std::size_t t = 0; t < 24; ++t) EXPECT_EQ(split.triangle_reachable[t], t < 12) << "triangle " << t;
  ASSERT_EQ(split.reachable.triangles.size(), 12u);
  // Areas 6 * 0.1^2 and 6 * 0.05^2: the outer box is 0.06 / 0.075 of the whole.
  EXPECT_NEAR(split.reachable_area_fraction, 0.8, 1e-9);
  for (const Eigen::Vector3i& t : split.reachable.triangles)
    for (int corner = 0; corner < 3; ++corner)
      EXPECT_NEAR(split.reachable.vertices[t[corner]].cwiseAbs().x(), 0.05, 1e-12) << "an inner box's triangle";
}

TEST(Reachability, TheTableCoversTheFaceAnObjectRestsOn) {
  const TriangleMesh box = makeBox({-0.05, -0.05, 0.0}, {0.05, 0.05, 0.1});
  Scene::Config with_table;
  with_table.add_table = true;
  const Scene on_table(box, with_table);
  const probe_sim::ReachableSurface covered = probe_sim::splitReachableSurface(on_table);
  EXPECT_EQ(covered.reachable.triangles.size(), 10u);
  EXPECT_NEAR(covered.reachable_area_fraction, 5.0 / 6.0, 1e-9);
  for (const Eigen::Vector3i& t : covered.reachable.triangles) {
    const double z = (covered.reachable.vertices[t[0]] + covered.reachable.vertices[t[1]] +
                      covered.reachable.vertices[t[2]]).z() / 3.0;
    EXPECT_GT(z, 1e-9) << "a bottom triangle counted as reachable";
  }
  // The table only blocks when asked to.
  ReachabilityConfig object_only;
  object_only.blocking_kinds = static_cast<unsigned>(probe_sim::SurfaceKind::kObject);
  EXPECT_NEAR(probe_sim::splitReachableSurface(on_table, object_only).reachable_area_fraction, 1.0, 1e-12);
  EXPECT_NEAR(probe_sim::splitReachableSurface(Scene(box, noTable())).reachable_area_fraction, 1.0, 1e-12);
}

TEST(Reachability, PointsInsideAClosedBoxAreNotReachableAndBadInputIsRejected) {
  const Scene scene(makeBox({-0.05, -0.05, 0.0}, {0.05, 0.05, 0.1}), noTable());
  const std::vector<Eigen::Vector3d> points = {
      {0.0, 0.0, 0.05},                       // the box's centre
      {0.049, 0.049, 0.001},                  // inside, in a corner
      {0.2, 0.0, 0.05},                       // outside
      {0.0, 0.0, 0.1},                        // on the top face
      {std::nan(""), 0.0, 0.0}};              // not finite
  const std::vector<bool> reachable = probe_sim::reachableFromOutside(scene, points);
  ASSERT_EQ(reachable.size(), points.size());
  EXPECT_FALSE(reachable[0]);
  EXPECT_FALSE(reachable[1]);
  EXPECT_TRUE(reachable[2]);
  EXPECT_TRUE(reachable[3]);
  EXPECT_FALSE(reachable[4]);
  ReachabilityConfig invalid;
  invalid.directions = 0;
  EXPECT_THROW(probe_sim::reachableFromOutside(scene, points, invalid), std::invalid_argument);
  invalid = ReachabilityConfig();
  invalid.start_offset_m = -1.0;
  EXPECT_THROW(probe_sim::reachableFromOutside(scene, points, invalid), std::invalid_argument);
}
