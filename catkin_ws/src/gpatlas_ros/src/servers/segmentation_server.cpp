#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/segmentation_server.h"

#include <tf2_eigen/tf2_eigen.h>

#include <sstream>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

SegmentationServer::SegmentationServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  RosParamReader reader(pnh_);
  gpatlas_core::PipelineFrames frames;
  readFrames(reader, &frames);
  world_frame_ = frames.world_frame;
  sensor_frame_ = frames.sensor_frame;
  tf_timeout_s_ = frames.tf_timeout_s;
  gpatlas_geometry::ObjectSegmenter::Config config;
  readSegmenter(reader, &config);
  const std::string invalid = gpatlas_geometry::validate(config);
  reader.report("segmentation");
  if (!invalid.empty()) {
    ROS_ERROR_STREAM("segmentation: inconsistent parameters (" << invalid << "); all segmentation defaults used");
    config = gpatlas_geometry::ObjectSegmenter::Config();
  }
  segmenter_ = gpatlas_geometry::ObjectSegmenter(config);
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
    checkSensorFrame(*msg);
    const gpatlas_geometry::SegmentationResult result = segmenter_.segment(points);
    if (!result.ok && result.stats.after_crop == 0 && !points.empty()) {
      reportOutsideCropBox(*msg, points);
      return;
    }
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

namespace {

std::string span(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::ostringstream out;
  out.precision(3);
  out << "x [" << lo.x() << ", " << hi.x() << "], y [" << lo.y() << ", " << hi.y() << "], z [" << lo.z() << ", "
      << hi.z() << "] m";
  return out.str();
}

}  // namespace

void SegmentationServer::reportOutsideCropBox(const sensor_msgs::PointCloud2& msg,
                                              const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const Eigen::Vector3d& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const auto& c = segmenter_.config();
  ROS_ERROR_STREAM_THROTTLE(10.0, "segmentation: none of the cloud's "
                                      << points.size() << " points (frame '" << msg.header.frame_id << "'; in '"
                                      << world_frame_ << "' they span " << span(lo, hi)
                                      << ") lies in the crop box " << span(c.crop_min_m, c.crop_max_m) << " of '"
                                      << world_frame_
                                      << "' (segmentation/crop_min_m, crop_max_m). The workspace is given in "
                                         "world_frame, z up with the table near z = 0: check the camera's pose in "
                                         "tf, or move the box");
}

void SegmentationServer::checkSensorFrame(const sensor_msgs::PointCloud2& msg) {
  if (sensor_frame_.empty() || msg.header.frame_id == sensor_frame_) return;
  // A frame tf has never heard of is reported at once; a known one gets the usual wait.
  if (tf_buffer_._frameExists(sensor_frame_) &&
      tf_buffer_.canTransform(world_frame_, sensor_frame_, msg.header.stamp, ros::Duration(tf_timeout_s_)))
    return;
  // The GP places the view's free space and occluded interior from sensor_frame's origin; without
  // it they are gone, and a smooth fit closes every opening the camera looked into.
  ROS_ERROR_STREAM_THROTTLE(10.0, "segmentation: the camera's cloud is in frame '"
                                      << msg.header.frame_id << "', but sensor_frame is '" << sensor_frame_
                                      << "', which has no transform to '" << world_frame_
                                      << "': the model loses the view's free space (a mug gets a lid). Set the "
                                         "parameter sensor_frame: "
                                      << msg.header.frame_id << " (or publish '" << sensor_frame_ << "' in tf)");
}

}  // namespace gpatlas_ros
