#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_geometry/surface_mesher.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

using namespace gpatlas_core;
using namespace gpatlas_geometry;
using gpatlas_core::testing::AnalyticSphere;

namespace {

// A capsule along x: a cylinder of `radius` between two hemispherical ends, `length` long in
// all (a 45 cm x 3 cm utensil's handle).
struct AnalyticCapsule {
  Vector3 centre{0.5, 0.1, 0.05};
  double length{0.45};
  double radius{0.015};

  double halfSegment() const { return length / 2 - radius; }
  double signedDistance(const Vector3& x) const {
    Vector3 offset = x - centre;
    offset.x() -= std::clamp(offset.x(), -halfSegment(), halfSegment());
    return offset.norm() - radius;
  }

  // Points uniformly distributed in area over the whole surface.
  std::vector<TrainingPoint> surfacePoints(int count, double noise_sigma, unsigned seed) const {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::normal_distribution<double> gaussian;
    const double cylinder_area = 2.0 * M_PI * radius * 2.0 * halfSegment();
    const double sphere_area = 4.0 * M_PI * radius * radius;
    std::vector<TrainingPoint> points;
    while (static_cast<int>(points.size()) < count) {
      TrainingPoint point;
      if (uniform(rng) * (cylinder_area + sphere_area) < cylinder_area) {
        const double angle = 2.0 * M_PI * uniform(rng);
        point.position = centre + Vector3((2.0 * uniform(rng) - 1.0) * halfSegment(), radius * std::cos(angle),
                                          radius * std::sin(angle));
      } else {
        Vector3 direction(gaussian(rng), gaussian(rng), gaussian(rng));
        if (!(direction.norm() > 1e-9)) continue;
        direction.normalize();
        point.position = centre + radius * direction +
                         Vector3(direction.x() >= 0.0 ? halfSegment() : -halfSegment(), 0.0, 0.0);
      }
      point.noise_sigma = noise_sigma;
      point.source = PointSource::kVision;
      points.push_back(point);
    }
    return points;
  }
};

// Nodes per axis of the grid over the cube enclosing the model's domain ball.
int domainCubeNodesPerAxis(const GpisModel& model, double resolution) {
  return static_cast<int>(std::floor(2.0 * model.domainRadiusWorld() / resolution)) + 1;
}

double nodes(const Eigen::Vector3i& size) { return static_cast<double>(size.x()) * size.y() * size.z(); }

TEST(SurfaceMesher, MeshesAnElongatedObjectWhoseDomainCubeExceedsMaxNodes) {
  const AnalyticCapsule capsule;
  GpisModel model;
  const FitReport report = model.fit(capsule.surfacePoints(300, 0.1, 3));
  ASSERT_TRUE(report.ok) << report.message;

  SurfaceMesher::Config config;  // 5 mm, margin of one data radius
  config.resolution_m = 0.005;
  config.max_nodes = 4'000'000;
  const double domain_cube_nodes = std::pow(domainCubeNodesPerAxis(model, config.resolution_m), 3);
  EXPECT_GT(domain_cube_nodes, static_cast<double>(config.max_nodes));  // too big to mesh whole

  const SurfaceMeshResult meshed = SurfaceMesher(config).mesh(model);
  ASSERT_TRUE(meshed.ok) << meshed.message;
  EXPECT_LT(nodes(meshed.grid_size), domain_cube_nodes / 3.0);
  EXPECT_LE(nodes(meshed.grid_size), static_cast<double>(config.max_nodes));
  RecordProperty("grid_nodes", std::to_string(nodes(meshed.grid_size)));
  RecordProperty("domain_cube_nodes", std::to_string(domain_cube_nodes));

  // Every vertex near the capsule, and the mesh spans its whole length.
  double worst = 0.0, sum_squared = 0.0;
  Eigen::AlignedBox<double, 3> extent;
  for (const Vector3& vertex : meshed.mesh.vertices) {
    const double distance = capsule.signedDistance(vertex);
    worst = std::max(worst, std::abs(distance));
    sum_squared += distance * distance;
    extent.extend(vertex);
  }
  const double rmse = std::sqrt(sum_squared / static_cast<double>(meshed.mesh.vertices.size()));
  RecordProperty("vertex_rmse_m", std::to_string(rmse));
  RecordProperty("worst_vertex_distance_m", std::to_string(worst));
  EXPECT_LT(rmse, 2e-3);
  EXPECT_LT(worst, 5e-3);
  EXPECT_NEAR(extent.sizes().x(), capsule.length, 0.01);
}

// The vertices sorted, so that comparisons do not depend on VTK's order.
// The largest distance from a vertex of either mesh to the nearest vertex of the other: 0 for
// the same vertices in any order (sorting would pair float ties differently).
double worstVertexMismatch(const std::vector<Vector3>& a, const std::vector<Vector3>& b) {
  const auto one_way = [](const std::vector<Vector3>& from, const std::vector<Vector3>& to) {
    double worst = 0.0;
    for (const Vector3& p : from) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const Vector3& q : to) nearest = std::min(nearest, (p - q).squaredNorm());
      worst = std::max(worst, nearest);
    }
    return std::sqrt(worst);
  };
  return std::max(one_way(a, b), one_way(b, a));
}

// A compact object, seen whole or only from above (its bottom then predicted, not seen): the
// mesh is the one over the whole domain cube, vertex for vertex, with the default margin and
// with a margin far too small to hold the unseen bottom, where the mesher must move the box's
// low side out.
TEST(SurfaceMesher, TheBoundDoesNotClipACompactObject) {
  const AnalyticSphere sphere;
  for (const double min_z : {-1.0, 0.3}) {
    GpisModel model;
    ASSERT_TRUE(model.fit(sphere.view(200, min_z, 0.1, 5)).ok);
    SurfaceMesher::Config whole_domain;
    whole_domain.min_corner = model.centroid() - Vector3::Constant(model.domainRadiusWorld());
    whole_domain.max_corner = model.centroid() + Vector3::Constant(model.domainRadiusWorld());
    const SurfaceMeshResult expected = SurfaceMesher(whole_domain).mesh(model);
    ASSERT_TRUE(expected.ok) << expected.message;
    double lowest_seen = std::numeric_limits<double>::infinity();
    for (const TrainingPoint& point : model.observations()) lowest_seen = std::min(lowest_seen, point.position.z());

    for (const double margin_fraction : {SurfaceMesher::Config().margin_fraction_of_data_radius, 0.05}) {
      SCOPED_TRACE("view min_z " + std::to_string(min_z) + ", margin " + std::to_string(margin_fraction));
      SurfaceMesher::Config config;
      config.margin_fraction_of_data_radius = margin_fraction;
      const SurfaceMeshResult bounded = SurfaceMesher(config).mesh(model);
      ASSERT_TRUE(bounded.ok) << bounded.message;
      EXPECT_LE(nodes(bounded.grid_size), nodes(expected.grid_size));

      double lowest = std::numeric_limits<double>::infinity();
      for (const Vector3& vertex : bounded.mesh.vertices) lowest = std::min(lowest, vertex.z());
      if (min_z < 0.0) EXPECT_NEAR(lowest, sphere.centre.z() - sphere.radius, 0.005);
      const double margin_m = margin_fraction * model.config().data_radius * model.scale();
      if (min_z > 0.0 && margin_fraction < 0.1) EXPECT_LT(lowest, lowest_seen - margin_m);  // the moved side

      ASSERT_EQ(bounded.mesh.vertices.size(), expected.mesh.vertices.size());
      ASSERT_EQ(bounded.mesh.triangles.size(), expected.mesh.triangles.size());
      // VTK stores its points as floats: 6e-8 m is their resolution here.
      EXPECT_LT(worstVertexMismatch(bounded.mesh.vertices, expected.mesh.vertices), 1e-6);
    }
  }
}

// The coarse lattice skips only blocks the surface cannot enter: the mesh is the full grid's.
TEST(SurfaceMesher, TheCoarseLatticeGivesTheFullGridsMesh) {
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(300, 0.2, 0.1, 5)).ok);  // a partial view: an uneven surface
  SurfaceMesher::Config full_config;
  full_config.resolution_m = 0.006;
  full_config.coarse_stride = 1;
  SurfaceMesher::Config coarse_config = full_config;
  coarse_config.coarse_stride = 4;
  const SurfaceMeshResult full = SurfaceMesher(full_config).mesh(model);
  const SurfaceMeshResult coarse = SurfaceMesher(coarse_config).mesh(model);
  ASSERT_TRUE(full.ok && coarse.ok) << full.message << " / " << coarse.message;
  ASSERT_EQ(full.mesh.triangles.size(), coarse.mesh.triangles.size());
  ASSERT_EQ(full.mesh.vertices.size(), coarse.mesh.vertices.size());
  EXPECT_LT(worstVertexMismatch(full.mesh.vertices, coarse.mesh.vertices), 1e-6);
}

TEST(SurfaceMesher, ExplicitBoundsOverrideAndMaxNodesIsReported) {
  const AnalyticSphere sphere;
  GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(200, -1.0, 0.1, 5)).ok);
  SurfaceMesher::Config config;
  config.min_corner = sphere.centre - Vector3::Constant(0.2);
  config.max_corner = sphere.centre + Vector3::Constant(0.2);
  config.resolution_m = 0.01;
  const SurfaceMeshResult meshed = SurfaceMesher(config).mesh(model);
  ASSERT_TRUE(meshed.ok) << meshed.message;
  EXPECT_EQ(meshed.grid_size, Eigen::Vector3i::Constant(41));

  config.max_nodes = 1000;
  const SurfaceMeshResult too_fine = SurfaceMesher(config).mesh(model);
  EXPECT_FALSE(too_fine.ok);
  EXPECT_NE(too_fine.message.find("exceeds max_nodes = 1000"), std::string::npos) << too_fine.message;
  config = SurfaceMesher::Config();
  config.max_nodes = 1000;
  EXPECT_NE(SurfaceMesher(config).mesh(model).message.find("exceeds max_nodes"), std::string::npos);
  config = SurfaceMesher::Config();
  config.margin_fraction_of_data_radius = -1.0;
  EXPECT_FALSE(SurfaceMesher(config).mesh(model).ok);
}

}  // namespace
