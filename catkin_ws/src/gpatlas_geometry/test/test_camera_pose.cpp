// The camera's pose from its cloud: an analytic table scene seen from a known pose (with a
// larger wall behind the table that must not be taken for it), and ../shared's real cloud
// through the estimate_camera_pose tool, against the pose measured by hand for the rostests
// (gpatlas_ros/test/mug_cloud_camera.launch).
#include "gpatlas_geometry/camera_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>
#include <sstream>

namespace {

using gpatlas_core::Vector3;

// A camera 0.6 m above the table at the world's origin, looking along +x and 25 degrees down:
// its optical frame's axes (x right, y down, z forward) in the world.
Eigen::Matrix3d cameraAxes(double down_deg) {
  const double a = down_deg * M_PI / 180.0;
  const Eigen::Vector3d forward(std::cos(a), 0.0, -std::sin(a)), right(0.0, -1.0, 0.0);
  Eigen::Matrix3d axes;
  axes << right, forward.cross(right), forward;
  return axes;
}

const Eigen::Vector3d kCamera(0.0, 0.0, 0.6);

// World points: the table (1.1 x 1.0 m), a box on it, and a wall behind it with more points than
// the table; with 3 mm of noise.
std::vector<Vector3> worldScene() {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::vector<Vector3> out;
  const auto add = [&](const Vector3& p) { out.push_back(p + Vector3(noise(rng), noise(rng), noise(rng))); };
  for (double x = 0.3; x < 1.4; x += 0.01)
    for (double y = -0.5; y < 0.5; y += 0.01) add(Vector3(x, y, 0.0));
  for (double x = 0.7; x < 0.8; x += 0.005)
    for (double y = -0.05; y < 0.05; y += 0.005) add(Vector3(x, y, 0.1));
  for (double y = -1.0; y < 1.0; y += 0.01)
    for (double z = 0.0; z < 1.5; z += 0.01) add(Vector3(1.6, y, z));
  return out;
}

std::vector<Vector3> inCamera(const std::vector<Vector3>& world, const Eigen::Matrix3d& axes) {
  std::vector<Vector3> out;
  for (const Vector3& p : world) out.push_back(axes.transpose() * (p - kCamera));
  return out;
}

TEST(CameraPose, TheTableIsZEqualsZeroUnderTheCamera) {
  const Eigen::Matrix3d axes = cameraAxes(25.0);
  const std::vector<Vector3> world = worldScene();
  std::vector<Vector3> seen = inCamera(world, axes);
  seen.emplace_back(std::nan(""), 0.0, 0.0);  // a depth camera's holes
  const gpatlas_geometry::CameraPose pose = gpatlas_geometry::estimateCameraPose(seen);
  ASSERT_TRUE(pose.ok) << pose.message;
  EXPECT_NEAR(pose.looking_down_deg, 25.0, 0.5);
  EXPECT_NEAR(pose.table_offset, 0.6, 0.003);
  // The world it gives is the scene's: the camera above the origin, x along its view.
  EXPECT_LT((pose.translation - kCamera).norm(), 0.003);
  EXPECT_LT(Eigen::AngleAxisd(pose.rotation.toRotationMatrix() * axes.transpose()).angle(), 0.5 * M_PI / 180.0);
  for (std::size_t i = 0; i < world.size(); i += 997)
    EXPECT_LT((pose.rotation * seen[i] + pose.translation - world[i]).norm(), 0.01) << world[i].transpose();
  std::istringstream argument(gpatlas_geometry::cameraPoseArgument(pose));
  std::array<double, 7> v{};
  for (double& x : v) argument >> x;
  ASSERT_FALSE(argument.fail());
  EXPECT_NEAR(v[2], 0.6, 0.003);
  EXPECT_NEAR(std::abs(Eigen::Quaterniond(v[6], v[3], v[4], v[5]).dot(pose.rotation)), 1.0, 1e-6);

  // Allowed to lean as far as the wall (65 degrees from the camera's up), RANSAC takes the wall.
  gpatlas_geometry::CameraPoseConfig lenient;
  lenient.max_tilt_deg = 80.0;
  const gpatlas_geometry::CameraPose wall = gpatlas_geometry::estimateCameraPose(seen, lenient);
  EXPECT_FALSE(wall.ok && std::abs(wall.looking_down_deg - 25.0) < 5.0) << "the wall is larger than the table";
}

TEST(CameraPose, NoTableIsAClearError) {
  gpatlas_geometry::CameraPose pose = gpatlas_geometry::estimateCameraPose({});
  EXPECT_FALSE(pose.ok);
  EXPECT_NE(pose.message.find("finite points"), std::string::npos) << pose.message;
  // Only the wall, 65 degrees from the camera's up: no table.
  std::vector<Vector3> only_wall;
  const Eigen::Matrix3d axes = cameraAxes(25.0);
  for (double y = -1.0; y < 1.0; y += 0.01)
    for (double z = 0.0; z < 1.5; z += 0.01) only_wall.push_back(axes.transpose() * (Vector3(1.6, y, z) - kCamera));
  pose = gpatlas_geometry::estimateCameraPose(only_wall);
  EXPECT_FALSE(pose.ok);
  EXPECT_NE(pose.message.find("no table"), std::string::npos) << pose.message;
}

// The tool on the real cloud, against mug_cloud_camera.launch's pose (measured by hand).
TEST(CameraPose, TheToolFindsTheRealCloudsTable) {
  if (!std::filesystem::is_regular_file(MUG_CLOUD_PCD))
    GTEST_SKIP() << "no recorded cloud at '" << MUG_CLOUD_PCD << "' (../shared/data is absent): skipped";
  std::unique_ptr<FILE, int (*)(FILE*)> tool(popen(ESTIMATE_CAMERA_POSE " " MUG_CLOUD_PCD " 2>&1", "r"), pclose);
  ASSERT_TRUE(tool);
  std::string output;
  std::array<char, 512> buffer{};
  while (fgets(buffer.data(), buffer.size(), tool.get())) output += buffer.data();
  std::printf("%s", output.c_str());
  const std::size_t at = output.find("camera_pose:=\"");
  ASSERT_NE(at, std::string::npos) << output;
  std::istringstream argument(output.substr(at + 14));
  std::array<double, 7> v{};
  for (double& x : v) argument >> x;
  ASSERT_FALSE(argument.fail()) << output;
  const Eigen::Quaterniond found(v[6], v[3], v[4], v[5]);
  const Eigen::Quaterniond measured(0.333600, -0.627695, 0.615650, -0.340126);
  // The table's normal (world z in the cloud's frame) within 1 degree, the height within 5 mm.
  const Eigen::Vector3d up_found = found.conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_measured = measured.normalized().conjugate() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(std::acos(std::min(1.0, up_found.dot(up_measured))) * 180.0 / M_PI, 1.0);
  EXPECT_NEAR(v[2], 0.528868, 0.005);
  EXPECT_NEAR(v[0], 0.0, 1e-9);
  EXPECT_NEAR(v[1], 0.0, 1e-9);
  EXPECT_LT(Eigen::AngleAxisd(found.normalized() * measured.normalized().conjugate()).angle() * 180.0 / M_PI, 1.0);
}

}  // namespace
