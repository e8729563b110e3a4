#pragma once

#include <gpatlas_geometry/segmentation.h>
#include <gpatlas_msgs/SupportPlane.h>
#include <gpatlas_ros/ros_params.h>
#include <gpatlas_ros/tf_gated_subscriber.h>
#include <gpatlas_ros/world_frame.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace gpatlas_ros {

// PCL segmentation of the camera cloud: `points` (sensor_msgs/PointCloud2, any frame) in,
// `~object_points` (world_frame) out.
class SegmentationServer {
 public:
  SegmentationServer(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg);
  // An error naming both frames when the cloud's frame is not sensor_frame and sensor_frame has
  // no transform: the GP would fit the view without its free space.
  void checkSensorFrame(const sensor_msgs::PointCloud2& msg);
  // An error naming the frames, the box and where the cloud is, when no point is in the crop box.
  void reportOutsideCropBox(const sensor_msgs::PointCloud2& msg, const std::vector<Eigen::Vector3d>& points);

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  std::string sensor_frame_;
  double tf_timeout_s_{0.5};
  gpatlas_geometry::ObjectSegmenter segmenter_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::unique_ptr<TfGatedCloudSubscriber> points_sub_;
  ros::Publisher object_pub_, plane_pub_;
};

}  // namespace gpatlas_ros
