#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/occupancy_grid.h"
#include "gpatlas_core/model/position_uncertainty.h"
#include "gpatlas_geometry/shape_metrics.h"
#include "gpatlas_geometry/surface_mesher.h"
#include "gpatlas_core/common/triangle_mesh.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <unistd.h>

using namespace gpatlas_core;
using namespace gpatlas_geometry;
using gpatlas_core::testing::AnalyticSphere;

namespace {

// How far an icosphere's faces sink below its sphere: the largest distance from the sphere
// to a face plane, which bounds the tessellation error of any distance measured on it.
double icosphereSag(const TriangleMesh& mesh, const Vector3& centre, double radius) {
  double sag = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Vector3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
    const Vector3 normal = (mesh.vertices[static_cast<std::size_t>(t[1])] - a)
                               .cross(mesh.vertices[static_cast<std::size_t>(t[2])] - a)
                               .normalized();
    sag = std::max(sag, radius - std::abs(normal.dot(a - centre)));
  }
  return sag;
}

TEST(ShapeMetrics, IdenticalMeshesGiveZero) {
  const TriangleMesh mesh = makeIcosphere(Vector3(0.1, 0.2, 0.3), 0.08, 3);
  const ShapeMetricsResult result = ShapeMetrics().compare(mesh, mesh);
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_LT(result.rmse_predicted_to_truth, 1e-12);
  EXPECT_LT(result.rmse_truth_to_predicted, 1e-12);
  EXPECT_LT(result.chamfer_l1, 1e-12);
  EXPECT_DOUBLE_EQ(result.f_score, 1.0);
}

TEST(ShapeMetrics, ConcentricSpheresDifferByTheRadiusGap) {
  const Vector3 centre(0.6, -0.1, 0.12);
  const double radius = 0.1, gap = 0.004;
  const TriangleMesh inner = makeIcosphere(centre, radius, 4);
  const TriangleMesh outer = makeIcosphere(centre, radius + gap, 4);
  // Every point of either mesh is between (radius - sag) and radius from the centre of its
  // own sphere, so each measured distance is gap up to the sum of the two sags (0.23 mm).
  const double tolerance = icosphereSag(inner, centre, radius) + icosphereSag(outer, centre, radius + gap);
  ASSERT_LT(tolerance, 0.1 * gap);

  ShapeMetrics::Config config;
  config.f_score_threshold_m = 0.005;
  const ShapeMetricsResult result = ShapeMetrics(config).compare(inner, outer);
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_NEAR(result.rmse_predicted_to_truth, gap, tolerance);
  EXPECT_NEAR(result.rmse_truth_to_predicted, gap, tolerance);
  EXPECT_NEAR(result.chamfer_l1, gap, tolerance);
  EXPECT_DOUBLE_EQ(result.f_score, 1.0);  // every distance ~4 mm < 5 mm

  config.f_score_threshold_m = 0.002;  // every distance ~4 mm > 2 mm
  EXPECT_DOUBLE_EQ(ShapeMetrics(config).compare(inner, outer).f_score, 0.0);
}

TEST(ShapeMetrics, IndexedDistanceMatchesBruteForce) {
  const TriangleMesh mesh = makeIcosphere(Vector3::Zero(), 0.1, 3);
  const MeshDistanceIndex index(mesh);
  ASSERT_TRUE(index.ok()) << index.message();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> coordinate(-0.15, 0.15);
  for (int q = 0; q < 300; ++q) {
    const Vector3 query(coordinate(rng), coordinate(rng), coordinate(rng));
    double brute = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3i& t : mesh.triangles)
      brute = std::min(brute, pointTriangleDistance(query, mesh.vertices[static_cast<std::size_t>(t[0])],
                                                    mesh.vertices[static_cast<std::size_t>(t[1])],
                                                    mesh.vertices[static_cast<std::size_t>(t[2])]));
    EXPECT_NEAR(index.distance(query), brute, 1e-12) << "query " << q;
  }
}

TEST(ShapeMetrics, BadMeshesGiveAnErrorNotACrash) {
  const TriangleMesh good = makeIcosphere(Vector3::Zero(), 0.1, 1);
  TriangleMesh out_of_range = good;
  out_of_range.triangles.front()[0] = 100000;
  TriangleMesh with_nan = good;
  with_nan.vertices.front().x() = std::numeric_limits<double>::quiet_NaN();
  TriangleMesh flat = good;
  for (Vector3& v : flat.vertices) v.tail<2>().setZero();  // all on a line: zero area
  const TriangleMesh empty;
  for (const TriangleMesh* bad : std::vector<const TriangleMesh*>{&out_of_range, &with_nan, &flat, &empty}) {
    EXPECT_FALSE(ShapeMetrics().compare(*bad, good).ok);
    EXPECT_FALSE(ShapeMetrics().compare(good, *bad).ok);
  }
}

TEST(SurfaceMesher, RecoversADenselyObservedSphereAndWritesPly) {
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(400, -1.0, 0.316, 2)).ok);
  SurfaceMesher::Config config;
  config.resolution_m = 0.006;
  const SurfaceMeshResult meshed = SurfaceMesher(config).mesh(model);
  ASSERT_TRUE(meshed.ok) << meshed.message;
  ASSERT_EQ(meshed.mesh.vertex_variances.size(), meshed.mesh.vertices.size());
  const ShapeMetricsResult metrics =
      ShapeMetrics().compare(meshed.mesh, makeIcosphere(sphere.centre, sphere.radius, 4));
  ASSERT_TRUE(metrics.ok) << metrics.message;
  EXPECT_LT(metrics.rmse_predicted_to_truth, 3e-3);
  EXPECT_LT(metrics.rmse_truth_to_predicted, 3e-3);

  char path[] = "/tmp/gpatlas_mesh_XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  close(fd);
  ASSERT_EQ(writePly(meshed.mesh, path), "");
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::remove(path);
  EXPECT_NE(text.find("element vertex " + std::to_string(meshed.mesh.vertices.size())), std::string::npos);
  EXPECT_NE(text.find("element face " + std::to_string(meshed.mesh.triangles.size())), std::string::npos);
  EXPECT_NE(text.find("property double variance"), std::string::npos);

  // The collision map agrees: occupied at the centre, free well outside, in between near
  // the surface.
  OccupancyGridBuilder::Config grid_config;
  grid_config.resolution_m = 0.02;
  grid_config.variance_stride = 1;  // the exact map (the lattice's error: test_multiscale_gpis_model)
  grid_config.min_corner = sphere.centre - Vector3::Constant(0.14);
  grid_config.max_corner = sphere.centre + Vector3::Constant(0.14);
  const OccupancyGrid grid = OccupancyGridBuilder(grid_config).build(model);
  ASSERT_TRUE(grid.ok) << grid.message;
  EXPECT_GT(grid.probabilities[grid.index(7, 7, 7)], 0.9f);  // the centre node
  EXPECT_LT(grid.probabilities[grid.index(0, 0, 0)], 0.1f);  // a corner, 24 cm from the centre

  EXPECT_FALSE(SurfaceMesher().mesh(GpisModel()).ok);
  config.resolution_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(SurfaceMesher(config).mesh(model).ok);
}

// A PLY file as written by writePly: the vertex properties' names and each vertex's values.
struct PlyVertices {
  std::vector<std::string> properties;
  std::vector<std::vector<double>> rows;
};

PlyVertices readPlyVertices(const std::string& path) {
  PlyVertices ply;
  std::ifstream in(path);
  std::string line;
  std::size_t count = 0;
  bool in_vertex = false;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string word, type, name;
    words >> word;
    if (word == "element") {
      words >> name >> count;
      in_vertex = name == "vertex";
      if (!in_vertex) continue;
      ply.rows.resize(count);
    } else if (word == "property" && in_vertex) {
      words >> type >> name;
      ply.properties.push_back(name);
    }
  }
  for (std::vector<double>& row : ply.rows) {
    row.resize(ply.properties.size());
    for (double& value : row) in >> value;
  }
  return ply;
}

// The saved mesh's position sd is the model's, calibration scale included, at the very vertices
// the file holds; and it says where the data were: a sphere seen from above is known to within
// its noise on top and far less well underneath.
TEST(SurfaceMesher, WritesEachVertexPositionSdToPly) {
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(300, 0.2, 0.316, 5)).ok);
  ASSERT_TRUE(model.setPositionSdScale(0.5));
  SurfaceMesher::Config config;
  config.resolution_m = 0.008;
  config.vertex_position_sd = true;
  const SurfaceMeshResult meshed = SurfaceMesher(config).mesh(model);
  ASSERT_TRUE(meshed.ok) << meshed.message;

  char path[] = "/tmp/gpatlas_mesh_sd_XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  close(fd);
  ASSERT_EQ(writePly(meshed.mesh, path), "");
  const PlyVertices ply = readPlyVertices(path);
  std::remove(path);
  ASSERT_EQ(ply.properties, (std::vector<std::string>{"x", "y", "z", "variance", "position_sd_m"}));
  ASSERT_EQ(ply.rows.size(), meshed.mesh.vertices.size());
  Points3 vertices(3, static_cast<Eigen::Index>(ply.rows.size()));
  for (std::size_t i = 0; i < ply.rows.size(); ++i)
    vertices.col(static_cast<Eigen::Index>(i)) = Vector3(ply.rows[i][0], ply.rows[i][1], ply.rows[i][2]);
  const Eigen::VectorXd expected = positionSd(model, vertices);
  std::vector<double> top, bottom;
  for (std::size_t i = 0; i < ply.rows.size(); ++i) {
    const double written = ply.rows[i][4];
    ASSERT_TRUE(std::isfinite(written) && written > 0.0) << i;
    ASSERT_NEAR(written, expected[static_cast<Eigen::Index>(i)], 1e-9 * expected[static_cast<Eigen::Index>(i)]) << i;
    const double height = (vertices.col(static_cast<Eigen::Index>(i)) - sphere.centre).normalized().z();
    if (height > 0.6) top.push_back(written);
    if (height < -0.6) bottom.push_back(written);
  }
  ASSERT_FALSE(top.empty());
  ASSERT_FALSE(bottom.empty());
  EXPECT_LT(quantile(top, 0.5), 0.5 * quantile(bottom, 0.5));
}

}  // namespace
