#include "probe_sim/depth_camera.h"
#include "probe_sim/procedural_objects.h"

#include "tessellated_sphere.h"

#include <gtest/gtest.h>

#include <cmath>

using probe_sim::DepthCamera;
using probe_sim::Scene;
using probe_sim::SurfaceKind;

namespace {

using probe_sim_test::kCentre;
using probe_sim_test::kRadius;
using probe_sim_test::kSize;
using probe_sim_test::sagittaBound;

Scene sphereScene() {
  probe_sim::ProceduralConfig tessellation;
  tessellation.segments = 180;
  tessellation.rings = 90;
  return Scene(probe_sim::makeProceduralObject("sphere", kSize, tessellation));
}

}  // namespace

TEST(LookAt, BuildsAnOpticalFrameLookingAtTheTarget) {
  const Eigen::Vector3d eye(1.0, 0.5, 0.8), target(0.0, 0.0, 0.1);
  const Eigen::Isometry3d pose = probe_sim::lookAt(eye, target);
  EXPECT_TRUE(pose.linear().isUnitary(1e-12));
  EXPECT_NEAR(pose.linear().determinant(), 1.0, 1e-12);
  // The target is straight ahead on the optical axis.
  const Eigen::Vector3d in_camera = pose.inverse() * target;
  EXPECT_NEAR(in_camera.x(), 0.0, 1e-12);
  EXPECT_NEAR(in_camera.y(), 0.0, 1e-12);
  EXPECT_NEAR(in_camera.z(), (target - eye).norm(), 1e-12);
  // Image "down" (+y) points down in the world.
  EXPECT_LT(pose.linear().col(1).z(), 0.0);
  EXPECT_THROW(probe_sim::lookAt(eye, eye), std::runtime_error);
  EXPECT_THROW(probe_sim::lookAt(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::Zero()),
               std::runtime_error);
}

TEST(DepthCamera, SeesOnlyTheFrontOfASphere) {
  const Scene scene = sphereScene();
  const Eigen::Vector3d eye(0.6, 0.2, 0.4);
  DepthCamera::Config config;
  config.width = 160;
  config.height = 120;
  DepthCamera camera(config, probe_sim::lookAt(eye, kCentre));
  const probe_sim::DepthCloud cloud = camera.capture(scene);
  const double sagitta = sagittaBound(scene.objectMesh());
  ASSERT_LT(sagitta, 1e-4);

  ASSERT_GT(cloud.points_world.cols(), 200);
  ASSERT_EQ(cloud.points_camera.cols(), cloud.points_world.cols());
  ASSERT_EQ(cloud.labels.size(), static_cast<std::size_t>(cloud.points_world.cols()));
  int facing_points = 0;
  for (Eigen::Index i = 0; i < cloud.points_world.cols(); ++i) {
    const Eigen::Vector3d p = cloud.points_world.col(i);
    EXPECT_EQ(cloud.labels[i], SurfaceKind::kObject);
    EXPECT_NEAR((p - kCentre).norm(), kRadius, sagitta + 1e-6);
    // Visible from the eye: the outward normal at p faces the camera.
    EXPECT_GT((p - kCentre).dot(eye - p), -1e-6);
    if ((p - kCentre).dot(eye - p) > 0.0) ++facing_points;
    // Same point in both frames.
    EXPECT_TRUE((camera.pose() * Eigen::Vector3d(cloud.points_camera.col(i))).isApprox(p, 1e-9));
  }
  EXPECT_EQ(facing_points, cloud.points_world.cols());
  // The far side is not returned: no point on the hemisphere facing away from the camera.
  const Eigen::Vector3d view = (eye - kCentre).normalized();
  for (Eigen::Index i = 0; i < cloud.points_world.cols(); ++i) {
    EXPECT_GT((cloud.points_world.col(i) - kCentre).dot(view), 0.0);
  }
}

TEST(DepthCamera, TableOccludesAndIsLabelledWhenRequested) {
  const Scene scene = sphereScene();
  const Eigen::Vector3d eye(0.5, 0.0, 0.5);
  DepthCamera::Config config;
  config.width = 64;
  config.height = 48;
  config.include_table = true;
  DepthCamera camera(config, probe_sim::lookAt(eye, kCentre));
  const probe_sim::DepthCloud cloud = camera.capture(scene);
  int table_points = 0, object_points = 0;
  for (Eigen::Index i = 0; i < cloud.points_world.cols(); ++i) {
    const Eigen::Vector3d p = cloud.points_world.col(i);
    if (cloud.labels[i] == SurfaceKind::kTable) {
      ++table_points;
      EXPECT_NEAR(p.z(), 0.0, 1e-4);
    } else {
      ASSERT_EQ(cloud.labels[i], SurfaceKind::kObject);
      ++object_points;
    }
  }
  EXPECT_GT(table_points, 100);
  EXPECT_GT(object_points, 20);
  // Without the table, exactly the object pixels remain.
  config.include_table = false;
  DepthCamera object_only(config, camera.pose());
  EXPECT_EQ(object_only.capture(scene).points_world.cols(), object_points);
}

TEST(DepthCamera, NoiseRangeAndStride) {
  const Scene scene = sphereScene();
  const Eigen::Vector3d eye(0.0, -0.5, 0.05);
  DepthCamera::Config config;
  config.width = 80;
  config.height = 60;
  DepthCamera exact(config, probe_sim::lookAt(eye, kCentre));
  config.depth_noise_sigma_m = 0.002;
  DepthCamera noisy(config, exact.pose());
  const auto a = exact.capture(scene);
  const auto b = noisy.capture(scene);
  ASSERT_EQ(a.points_camera.cols(), b.points_camera.cols());
  // Noise is along the optical axis only: pixels keep their rays.
  const Eigen::ArrayXd depth_error = (b.points_camera.row(2) - a.points_camera.row(2)).array();
  const double sigma = std::sqrt(depth_error.square().mean());
  EXPECT_NEAR(sigma, 0.002, 0.0005);
  for (Eigen::Index i = 0; i < a.points_camera.cols(); ++i) {
    const Eigen::Vector3d ra = a.points_camera.col(i) / a.points_camera(2, i);
    const Eigen::Vector3d rb = b.points_camera.col(i) / b.points_camera(2, i);
    EXPECT_TRUE(ra.isApprox(rb, 1e-9));
  }
  // A range that ends before the sphere returns nothing.
  config.depth_noise_sigma_m = 0.0;
  config.max_range_m = 0.4;
  EXPECT_EQ(DepthCamera(config, exact.pose()).capture(scene).points_world.cols(), 0);
  // Stride 2 casts a quarter of the rays.
  config.max_range_m = 3.0;
  config.pixel_stride = 2;
  const auto strided = DepthCamera(config, exact.pose()).capture(scene);
  EXPECT_NEAR(static_cast<double>(strided.points_world.cols()), a.points_world.cols() / 4.0,
              0.15 * a.points_world.cols() / 4.0);
}
