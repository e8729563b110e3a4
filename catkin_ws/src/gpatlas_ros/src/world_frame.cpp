#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/world_frame.h"

#include <tf2_eigen/tf2_eigen.h>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

bool transformToWorld(const tf2_ros::Buffer& buffer, const std::string& world_frame, const std::string& frame,
                      const ros::Time& stamp, double timeout_s, std::vector<Eigen::Vector3d>* points,
                      std::string* error) {
  if (frame.empty()) {
    *error = "header.frame_id is empty: say which frame the points are in (e.g. '" + world_frame + "')";
    return false;
  }
  if (frame == world_frame) return true;
  try {
    const geometry_msgs::TransformStamped tf =
        buffer.lookupTransform(world_frame, frame, stamp, ros::Duration(timeout_s));
    const Eigen::Isometry3d pose = tf2::transformToEigen(tf);
    for (auto& p : *points) p = pose * p;
    return true;
  } catch (const tf2::TransformException& e) {
    *error = "no transform from '" + frame + "' to '" + world_frame + "': " + e.what();
    return false;
  }
}

bool cloudToWorld(const sensor_msgs::PointCloud2& cloud, const tf2_ros::Buffer& buffer, const std::string& world_frame,
                  double timeout_s, std::vector<Eigen::Vector3d>* points, std::size_t* num_invalid, std::string* error) {
  return cloudToPoints(cloud, points, num_invalid, error) &&
         transformToWorld(buffer, world_frame, cloud.header.frame_id, cloud.header.stamp, timeout_s, points, error);
}

bool planeToWorld(const gpatlas_msgs::SupportPlane& msg, const tf2_ros::Buffer& buffer, const std::string& world_frame,
                  double timeout_s, gpatlas_core::SupportPlane* plane, std::string* error) {
  if (!fromMsg(msg, plane, error)) return false;
  if (msg.header.frame_id.empty()) {
    *error = "header.frame_id is empty: say which frame the plane is in (e.g. '" + world_frame + "')";
    return false;
  }
  if (msg.header.frame_id == world_frame) return true;
  try {
    const geometry_msgs::TransformStamped tf =
        buffer.lookupTransform(world_frame, msg.header.frame_id, msg.header.stamp, ros::Duration(timeout_s));
    *plane = transformPlane(*plane, tf2::transformToEigen(tf));
    return true;
  } catch (const tf2::TransformException& e) {
    *error = "no transform from '" + msg.header.frame_id + "' to '" + world_frame + "': " + e.what();
    return false;
  }
}

void receiveSupportPlane(const gpatlas_msgs::SupportPlane& msg, const tf2_ros::Buffer& buffer,
                         const std::string& world_frame, double timeout_s, const char* who, std::mutex* mutex,
                         std::optional<gpatlas_core::SupportPlane>* latest) {
  try {
    gpatlas_core::SupportPlane plane;
    std::string error;
    if (!planeToWorld(msg, buffer, world_frame, timeout_s, &plane, &error)) {
      ROS_WARN_STREAM(who << ": support plane ignored: " << error);
      return;
    }
    std::lock_guard<std::mutex> lock(*mutex);
    *latest = plane;
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM(who << ": support plane ignored: " << e.what());
  }
}

}  // namespace gpatlas_ros
