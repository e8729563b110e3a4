// Prints recorded_cloud.launch's camera_pose for a recorded cloud: the table (the largest plane
// facing the camera's up, RANSAC) becomes the world's z = 0 (gpatlas_geometry/camera_pose.h).
//   estimate_camera_pose cloud.pcd [--plane-distance-m 0.01] [--max-tilt-deg 60]
// The cloud (.pcd or .ply) must be in the camera's optical frame (z along the view, y down), as
// a depth camera records it.
#include "gpatlas_geometry/camera_pose.h"
#include "gpatlas_geometry/cloud_file.h"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

int usage(const char* error) {
  std::fprintf(stderr,
               "%s\nusage: estimate_camera_pose CLOUD.pcd|CLOUD.ply [--plane-distance-m M] [--max-tilt-deg DEG]\n",
               error);
  return 2;
}

bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// The file's points, or an error.
std::string readPoints(const std::string& path, std::vector<gpatlas_core::Vector3>* points) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  if (endsWith(path, ".pcd")) {
    // PCL's reader crashes on a truncated or empty file: its header is checked first.
    const std::string problem = gpatlas_geometry::checkPcdFile(path);
    if (!problem.empty()) return problem;
    if (pcl::io::loadPCDFile(path, cloud) != 0) return path + ": PCL cannot read it";
  } else if (endsWith(path, ".ply")) {
    if (pcl::io::loadPLYFile(path, cloud) != 0) return path + ": PCL cannot read it";
  } else {
    return path + ": not a .pcd or .ply file";
  }
  for (const auto& p : cloud) points->emplace_back(p.x, p.y, p.z);
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage("no cloud file given");
  gpatlas_geometry::CameraPoseConfig config;
  for (int i = 2; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) return usage(("no value after " + flag).c_str());
    char* end = nullptr;
    const double value = std::strtod(argv[++i], &end);
    if (!end || *end != '\0' || !(value > 0.0)) return usage((flag + " needs a positive number").c_str());
    if (flag == "--plane-distance-m") config.plane_distance_m = value;
    else if (flag == "--max-tilt-deg") config.max_tilt_deg = value;
    else return usage(("unknown flag " + flag).c_str());
  }
  std::vector<gpatlas_core::Vector3> points;
  const std::string error = readPoints(argv[1], &points);
  if (!error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  const gpatlas_geometry::CameraPose pose = gpatlas_geometry::estimateCameraPose(points, config);
  if (!pose.ok) {
    std::fprintf(stderr, "%s: %s\n", argv[1], pose.message.c_str());
    return 1;
  }
  std::printf("table: n = (%.5f, %.5f, %.5f), d = %.5f in the cloud's frame (%zu inliers at %.3f m); the camera is "
              "%.3f m above it, looking %.1f degrees down\n",
              pose.table_normal.x(), pose.table_normal.y(), pose.table_normal.z(), pose.table_offset, pose.inliers,
              config.plane_distance_m, pose.table_offset, pose.looking_down_deg);
  std::printf("camera_pose:=\"%s\"\n", gpatlas_geometry::cameraPoseArgument(pose).c_str());
  return 0;
}
