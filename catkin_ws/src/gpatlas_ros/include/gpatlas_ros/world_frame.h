#pragma once

// Clouds and support planes moved into the world frame with tf2, for every server.

#include <gpatlas_core/observations/support_plane.h>
#include <gpatlas_msgs/SupportPlane.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace gpatlas_ros {

// A cloud that waits this long for its transform is reported (it is still processed when the
// transform comes).
constexpr double kTfWaitWarningS = 3.0;

// Transforms points stamped in `frame` into `world_frame` with tf2 (waiting up to timeout_s).
bool transformToWorld(const tf2_ros::Buffer& buffer, const std::string& world_frame, const std::string& frame,
                      const ros::Time& stamp, double timeout_s, std::vector<Eigen::Vector3d>* points,
                      std::string* error);

// A support plane message moved to world_frame (tf2 for another frame; an empty frame is taken
// to be world_frame); false with the reason when it is malformed or there is no transform.
bool planeToWorld(const gpatlas_msgs::SupportPlane& msg, const tf2_ros::Buffer& buffer, const std::string& world_frame,
                  double timeout_s, gpatlas_core::SupportPlane* plane, std::string* error);

// A `support_plane` callback's work: the plane moved to world_frame and stored in `*latest`
// under `mutex`, or a warning from `who` with the reason. Never throws (roscpp does not catch
// exceptions from callbacks, and one would end the nodelet manager).
void receiveSupportPlane(const gpatlas_msgs::SupportPlane& msg, const tf2_ros::Buffer& buffer,
                         const std::string& world_frame, double timeout_s, const char* who, std::mutex* mutex,
                         std::optional<gpatlas_core::SupportPlane>* latest);

// The finite points of a cloud, in world_frame; false with the reason when the cloud has no
// x/y/z or there is no transform.
bool cloudToWorld(const sensor_msgs::PointCloud2& cloud, const tf2_ros::Buffer& buffer, const std::string& world_frame,
                  double timeout_s, std::vector<Eigen::Vector3d>* points, std::size_t* num_invalid, std::string* error);

}  // namespace gpatlas_ros
