// The default surface model on the procedural mug, seen by the head camera and then slid over
// with the ray probe: its handle and its 8 mm wall must survive in the predicted surface. The
// truth is the mesh the scene is built from.
#include "probe_sim/depth_camera.h"
#include "probe_sim/object_mesh.h"
#include "probe_sim/procedural_objects.h"
#include "probe_sim/probe.h"
#include "probe_sim/scene.h"

#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/model/multiscale_gpis_model.h>
#include <gpatlas_geometry/shape_metrics.h>
#include <gpatlas_geometry/surface_mesher.h>
#include <gpatlas_core/observations/view_training.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace {

using Eigen::Vector3d;

constexpr double kSize = 0.15;
// makeMugMesh's proportions (unscaled: the mug with its handle is 0.945 long along x).
constexpr double kUnscaledLength = 0.35 + 0.35 - 0.025 + 0.24 + 0.03;
constexpr double kScale = kSize / kUnscaledLength;
constexpr double kOuterRadius = 0.35 * kScale;
constexpr double kWall = 0.05 * kScale;  // 7.9 mm

struct MugScene {
  probe_sim::TriangleMesh mesh;
  Vector3d axis;  // a point of the mug's axis on the table
};

MugScene makeMug() {
  MugScene s;
  s.mesh = probe_sim::makeProceduralObject("mug", kSize);
  probe_sim::placeOnTable(s.mesh, Eigen::Vector2d(0.7, 0.0));
  const Eigen::AlignedBox3d box = s.mesh.boundingBox();
  s.axis = Vector3d(box.min().x() + kOuterRadius, box.center().y(), 0.0);
  return s;
}

double radialDistance(const MugScene& s, const Vector3d& x) { return (x - s.axis).head<2>().norm(); }

// One slide: strokes of the ray probe through the waypoints, as a touch's contacts and free space.
void slide(probe_sim::Scene& scene, probe_sim::RayProbe& probe, const std::vector<Vector3d>& points,
           const Vector3d& normal_or_zero, const MugScene& s, std::vector<gpatlas_core::Contact>* contacts,
           std::vector<Vector3d>* free_space) {
  for (const Vector3d& p : points) {
    Vector3d n = normal_or_zero;
    if (n.isZero()) n = Vector3d(p.x() - s.axis.x(), p.y() - s.axis.y(), 0.0).normalized();
    const probe_sim::ProbeStroke stroke = probe.stroke(scene, p, n);
    if (stroke.touched == probe_sim::SurfaceKind::kObject) contacts->push_back(stroke.contact);
    free_space->insert(free_space->end(), stroke.free_space.begin(), stroke.free_space.end());
  }
}

// The head camera's view of the mug (pipeline.yaml's camera: from the robot's side, above and in
// front), object points above the table only.
std::vector<gpatlas_core::Vector3> headCameraView(const probe_sim::Scene& scene, const MugScene& mug, const Vector3d& eye) {
  probe_sim::DepthCamera::Config camera_config;
  camera_config.depth_noise_sigma_m = 0.001;
  probe_sim::DepthCamera camera(camera_config, probe_sim::lookAt(eye, mug.axis + Vector3d(0, 0, 0.07)));
  const probe_sim::DepthCloud cloud = camera.capture(scene);
  std::vector<gpatlas_core::Vector3> view;
  for (Eigen::Index i = 0; i < cloud.points_world.cols(); ++i)
    if (cloud.labels[static_cast<std::size_t>(i)] == probe_sim::SurfaceKind::kObject && cloud.points_world(2, i) > 0.004)
      view.push_back(cloud.points_world.col(i));
  return view;
}

// Slides over the back half, where the camera saw nothing: rows around the mug every 4 mm of
// height, strokes every 4 mm along each row, towards the axis; then rows across the handle
// from both sides. Each row is one touch applied to the model; returns the contacts' count.
std::size_t slideOverTheBackAndTheHandle(probe_sim::Scene& scene, const MugScene& mug,
                                         gpatlas_core::MultiscaleGpisModel& model) {
  probe_sim::RayProbe probe;
  const gpatlas_core::TouchObservationConfig touch;
  const double step = 0.004;
  std::size_t num_contacts = 0;
  const auto slideRow = [&](const std::vector<Vector3d>& row, const Vector3d& normal_or_zero) {
    std::vector<gpatlas_core::Contact> contacts;
    std::vector<Vector3d> free_space;
    slide(scene, probe, row, normal_or_zero, mug, &contacts, &free_space);
    num_contacts += contacts.size();
    const gpatlas_core::TouchUpdate update = gpatlas_core::applyTouch(model, contacts, free_space, touch);
    ASSERT_TRUE(update.ok) << update.message;
  };
  for (double z = 0.006; z < 0.85 * kScale; z += step) {
    std::vector<Vector3d> row;
    for (double angle = -1.4; angle <= 1.4; angle += step / kOuterRadius)
      row.push_back(mug.axis + Vector3d(kOuterRadius * std::cos(angle), kOuterRadius * std::sin(angle), z));
    slideRow(row, Vector3d::Zero());
    if (::testing::Test::HasFatalFailure()) return num_contacts;
  }
  for (const double side : {-1.0, 1.0}) {
    for (double z = 0.01; z < 0.85 * kScale; z += step) {
      std::vector<Vector3d> row;
      for (double x = kOuterRadius - 0.005; x < kOuterRadius + 0.05; x += step)
        row.push_back(mug.axis + Vector3d(x, 0.0, z));
      slideRow(row, Vector3d(0.0, side, 0.0));
      if (::testing::Test::HasFatalFailure()) return num_contacts;
    }
  }
  return num_contacts;
}

// The handle: the truth's triangles outside the cup's radius, sampled by area (about one sample
// per square millimetre), and their RMS distance to the predicted surface.
struct HandleError {
  double area{0.0};
  double rmse{0.0};
  std::size_t samples{0};
};

HandleError handleError(const MugScene& mug, const gpatlas_core::TriangleMesh& predicted) {
  const gpatlas_geometry::MeshDistanceIndex onto_predicted(predicted);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  HandleError error;
  double sum_squared = 0.0;
  for (std::size_t t = 0; t < mug.mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mug.mesh.triangles[t];
    const Vector3d a = mug.mesh.vertices[tri[0]], b = mug.mesh.vertices[tri[1]], c = mug.mesh.vertices[tri[2]];
    if (radialDistance(mug, (a + b + c) / 3.0) < kOuterRadius + 0.001) continue;
    const double area = gpatlas_core::triangleArea(mug.mesh, t);
    error.area += area;
    for (int k = 0; k < std::max(1, static_cast<int>(area / 1e-6)); ++k) {
      double u = uniform(rng), v = uniform(rng);
      if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
      const double d = onto_predicted.distance(a + u * (b - a) + v * (c - a));
      sum_squared += d * d;
      ++error.samples;
    }
  }
  error.rmse = std::sqrt(sum_squared / static_cast<double>(error.samples));
  return error;
}

// The wall, away from the handle at 40 degrees, where the camera saw its inside and the slides
// its outside: walking out from the axis, f changes sign at the inner face and at the outer one.
void expectTheWall(const gpatlas_core::SurfaceModel& model, const MugScene& mug) {
  for (const double z : {0.08, 0.11}) {
    const Vector3d direction(std::cos(0.7), std::sin(0.7), 0.0);
    std::vector<double> crossings;
    double previous = 0.0;
    for (double r = 0.01; r < kOuterRadius + 0.02; r += 0.0002) {
      const double f = model.mean(mug.axis + Vector3d(0, 0, z) + r * direction);
      if (r > 0.01 && (f > 0.0) != (previous > 0.0)) crossings.push_back(r);
      previous = f;
    }
    ASSERT_EQ(crossings.size(), 2u) << "z " << z;
    EXPECT_NEAR(crossings[0], kOuterRadius - kWall, 0.0015) << "z " << z;
    EXPECT_NEAR(crossings[1], kOuterRadius, 0.0015) << "z " << z;
    EXPECT_NEAR(crossings[1] - crossings[0], kWall, 0.002) << "z " << z;
  }
}

TEST(MugReconstruction, SeenAndSlidOverKeepsItsHandleAndItsWall) {
  const MugScene mug = makeMug();
  probe_sim::SceneConfig table;  // pipeline.yaml's table
  table.table_size_xy = Eigen::Vector2d(0.8, 1.2);
  table.table_centre_xy = Eigen::Vector2d(0.75, 0.0);
  probe_sim::Scene scene(mug.mesh, table);

  const Vector3d eye(-0.11, 0.0, 0.75);
  const std::vector<gpatlas_core::Vector3> view = headCameraView(scene, mug, eye);
  ASSERT_GT(view.size(), 500u);
  const gpatlas_core::ViewTraining training =
      gpatlas_core::buildViewTraining(view, eye, gpatlas_core::SupportPlane{}, gpatlas_core::ViewTrainingConfig(), 0);
  ASSERT_TRUE(training.ok) << training.message;
  gpatlas_core::MultiscaleGpisModel model;
  const gpatlas_core::FitReport fit = model.fit(training.points);
  ASSERT_TRUE(fit.ok) << fit.message;

  std::size_t num_contacts = 0;
  ASSERT_NO_FATAL_FAILURE(num_contacts = slideOverTheBackAndTheHandle(scene, mug, model));
  ASSERT_GT(num_contacts, 1000u);

  gpatlas_geometry::SurfaceMesher::Config mesher_config;
  mesher_config.vertex_variances = false;
  const gpatlas_geometry::SurfaceMeshResult predicted = gpatlas_geometry::SurfaceMesher(mesher_config).mesh(model);
  ASSERT_TRUE(predicted.ok) << predicted.message;
  const HandleError handle = handleError(mug, predicted.mesh);
  ASSERT_GT(handle.area, 1e-3);  // the handle is there in the truth: about 20 cm^2
  EXPECT_LT(handle.rmse, 0.002) << handle.samples << " samples";
  expectTheWall(model, mug);
}

}  // namespace
