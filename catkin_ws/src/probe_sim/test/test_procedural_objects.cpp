#include "probe_sim/procedural_objects.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

using probe_sim::TriangleMesh;

TEST(ProceduralObjects, EveryObjectHasTheRequestedSizeAndRestsOnTheTable) {
  const double size = 0.12;
  for (const std::string& name : probe_sim::proceduralObjectNames()) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = probe_sim::makeProceduralObject(name, size);
    EXPECT_GT(mesh.triangles.size(), 10u);
    const Eigen::AlignedBox3d box = mesh.boundingBox();
    EXPECT_NEAR(box.sizes().maxCoeff(), size, 1e-12);
    EXPECT_NEAR(box.min().z(), 0.0, 1e-12);
    EXPECT_NEAR(box.center().x(), 0.0, 1e-12);
    EXPECT_NEAR(box.center().y(), 0.0, 1e-12);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      ASSERT_GT(mesh.triangleNormal(t).norm(), 0.5) << "degenerate triangle " << t;
    }
  }
}

// Closed and outward wound: every directed edge (vertices compared by position, since the box
// gives each face its own corners) is matched by the opposite one, and the divergence theorem
// gives a positive enclosed volume. Parts that overlap (a handle entering a wall) are each closed.
TEST(ProceduralObjects, EveryObjectIsClosedAndWoundOutwards) {
  using Key = std::array<double, 3>;
  auto key = [](const Eigen::Vector3d& v) { return Key{v.x(), v.y(), v.z()}; };
  for (const std::string& name : probe_sim::proceduralObjectNames()) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = probe_sim::makeProceduralObject(name, 0.3);
    std::map<std::pair<Key, Key>, int> directed_edges;
    double volume = 0.0;
    for (const auto& t : mesh.triangles) {
      for (int corner = 0; corner < 3; ++corner) {
        ++directed_edges[{key(mesh.vertices[t[corner]]), key(mesh.vertices[t[(corner + 1) % 3]])}];
      }
      volume += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]])) / 6.0;
    }
    int unmatched = 0;
    for (const auto& [edge, count] : directed_edges) {
      const auto reverse = directed_edges.find({edge.second, edge.first});
      if (reverse == directed_edges.end() || reverse->second != count) ++unmatched;
    }
    EXPECT_EQ(unmatched, 0);
    EXPECT_GT(volume, 0.0);
  }
}

// The utensils are long and flat, at the bench's size and at twice it: the long side (the size)
// along x, and the bowl or pan narrower and much lower than that.
TEST(ProceduralObjects, SpoonAndPanAreElongatedAlongX) {
  for (const double size : {0.15, 0.30}) {
    for (const std::string name : {"spoon", "pan"}) {
      SCOPED_TRACE(name + " " + std::to_string(size));
      const Eigen::Vector3d extent = probe_sim::makeProceduralObject(name, size).boundingBox().sizes();
      EXPECT_NEAR(extent.x(), size, 1e-12);
      EXPECT_LT(extent.y(), 0.5 * size);
      EXPECT_LT(extent.z(), 0.1 * size);
      EXPECT_FALSE(probe_sim::proceduralSignedDistance(name, size, Eigen::Vector3d::Zero()));
    }
  }
  // Proportions (unscaled, length 1): the spoon's bowl is 0.28 across and 0.08 deep, the pan
  // 0.45 across and 0.06 deep.
  const Eigen::Vector3d spoon = probe_sim::makeProceduralObject("spoon", 1.0).boundingBox().sizes();
  EXPECT_NEAR(spoon.y(), 0.28, 1e-12);
  EXPECT_NEAR(spoon.z(), 0.08, 1e-12);
  const Eigen::Vector3d pan = probe_sim::makeProceduralObject("pan", 1.0).boundingBox().sizes();
  EXPECT_NEAR(pan.y(), 0.45, 1e-12);
  EXPECT_NEAR(pan.z(), 0.06, 1e-12);
}

TEST(ProceduralObjects, AnalyticShapesMatchTheirClosedForms) {
  const double size = 0.1;
  const double r = size / 2;
  for (const std::string name : {"sphere", "box", "cylinder"}) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = probe_sim::makeProceduralObject(name, size);
    for (const auto& v : mesh.vertices) {
      // Closed forms written out here rather than taken from the library.
      double expected = 0.0;
      if (name == std::string("sphere")) {
        expected = (v - Eigen::Vector3d(0, 0, r)).norm() - r;
      } else if (name == std::string("box")) {
        expected = ((v - Eigen::Vector3d(0, 0, r)).cwiseAbs().maxCoeff() - r);
      } else {
        expected = std::max(v.head<2>().norm() - 0.3 * size, std::abs(v.z() - r) - r);
      }
      ASSERT_NEAR(expected, 0.0, 1e-12) << v.transpose();
      ASSERT_NEAR(*probe_sim::proceduralSignedDistance(name, size, v), 0.0, 1e-12);
    }
    // Inside / outside signs of the library's distance.
    EXPECT_LT(*probe_sim::proceduralSignedDistance(name, size, Eigen::Vector3d(0, 0, r)), 0.0);
    EXPECT_NEAR(*probe_sim::proceduralSignedDistance(name, size, Eigen::Vector3d(0, 0, 2 * size)),
                size, 1e-12);
  }
  EXPECT_NEAR(probe_sim::boxSignedDistance(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones(),
                                           Eigen::Vector3d(2, 2, 0)),
              std::sqrt(2.0), 1e-12);
  EXPECT_FALSE(probe_sim::proceduralSignedDistance("torus", size, Eigen::Vector3d::Zero()));
}

TEST(ProceduralObjects, RejectsUnknownNamesAndBadSizesNamingTheObject) {
  const auto error = [](const std::string& name, double size) {
    try {
      probe_sim::makeProceduralObject(name, size);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("teapot", 0.1),
            "procedural object 'teapot': unknown (known: sphere, box, cylinder, torus, bowl, mug, funnel, spoon, pan)");
  EXPECT_EQ(error("sphere", 0.0).rfind("procedural object 'sphere': size must be finite and > 0, got 0", 0), 0u);
  EXPECT_EQ(error("box", std::nan("")).rfind("procedural object 'box': size must be finite and > 0, got ", 0), 0u);
}
