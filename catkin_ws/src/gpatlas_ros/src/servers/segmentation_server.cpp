#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/servers.h"

#include <tf2_eigen/tf2_eigen.h>

namespace gpatlas_ros {

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

SegmentationServer::SegmentationServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  ParamReader reader(pnh_);
  gpatlas_core::PipelineFrames frames;
  readFrames(reader, &frames);
  world_frame_ = frames.world_frame;
  tf_timeout_s_ = frames.tf_timeout_s;
  gpatlas_core::ObjectSegmenter::Config config;
  readSegmenter(reader, &config);
  const std::string invalid = gpatlas_core::validate(config);
  reader.report("segmentation");
  if (!invalid.empty()) {
    ROS_ERROR_STREAM("segmentation: inconsistent parameters (" << invalid << "); all segmentation defaults used");
    config = gpatlas_core::ObjectSegmenter::Config();
  }
  segmenter_ = gpatlas_core::ObjectSegmenter(config);
  object_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("object_points", 1, true);
  plane_pub_ = pnh_.advertise<gpatlas_msgs::SupportPlane>("support_plane", 1, true);
  points_sub_ = std::make_unique<TfGatedCloudSubscriber>(
      nh_, "points", &tf_buffer_, world_frame_, "segmentation", kTfWaitWarningS,
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg) { onPoints(msg); });
  ROS_INFO_STREAM("segmentation: listening on " << points_sub_->topic() << ", publishing "
                                                << object_pub_.getTopic() << " in '" << world_frame_ << "'");
}

void SegmentationServer::onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  // roscpp does not catch exceptions thrown by subscription callbacks: one would end the
  // nodelet manager.
  try {
    std::vector<Eigen::Vector3d> points;
    std::size_t invalid = 0;
    std::string error;
    if (!cloudToWorld(*msg, tf_buffer_, world_frame_, tf_timeout_s_, &points, &invalid, &error)) {
      ROS_WARN_STREAM("segmentation: cloud ignored: " << error);
      return;
    }
    const gpatlas_core::SegmentationResult result = segmenter_.segment(points);
    if (!result.ok) {
      ROS_WARN_STREAM("segmentation: " << result.message << " (" << msg->width * msg->height << " points in, "
                                       << invalid << " NaN)");
      return;
    }
    ROS_INFO_STREAM("segmentation: " << result.message << " from " << result.stats.input << " points ("
                                     << result.stats.plane_inliers << " on the table)");
    // The plane first: the GP model uses it with the object cloud (and refits if it comes late).
    if (result.plane_found) {
      gpatlas_core::SupportPlane plane;
      plane.normal = result.plane_normal;
      plane.offset = result.plane_offset;
      gpatlas_msgs::SupportPlane plane_msg = toMsg(plane, world_frame_);
      plane_msg.header.stamp = msg->header.stamp;
      plane_pub_.publish(plane_msg);
    }
    sensor_msgs::PointCloud2 out = pointsToCloud(result.object_points, {}, 1.0, world_frame_);
    out.header.stamp = msg->header.stamp;
    object_pub_.publish(out);
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("segmentation: message ignored: " << e.what());
  }
}

}  // namespace gpatlas_ros
