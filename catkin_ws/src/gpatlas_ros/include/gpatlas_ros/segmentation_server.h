#pragma once

#include <geometry_msgs/PointStamped.h>
#include <gpatlas_geometry/segmentation.h>
#include <gpatlas_msgs/SelectObject.h>
#include <gpatlas_msgs/SupportPlane.h>
#include <gpatlas_ros/ros_params.h>
#include <gpatlas_ros/tf_gated_subscriber.h>
#include <gpatlas_ros/world_frame.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
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
// The user picks the object: `~select_object` (gpatlas_msgs/SelectObject) or a point on
// `clicked_point` (rviz's Publish Point) selects the cluster of the latest cloud nearest to the
// point, within segmentation/select_max_distance_m; later clouds keep the cluster nearest to its
// centroid, until the next selection or `~reset` (std_srvs/Trigger), which goes back to
// segmentation/object_hint_m. A change of object resets the GP (`reset_model`,
// `fit_next_model`: gp_model's ~reset and ~fit_next_cloud) and publishes the new object's
// points, so that the model is refitted on it. `~objects` (markers) shows the explored object's
// box and the other clusters'.
class SegmentationServer {
 public:
  SegmentationServer(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg);
  bool onSelectObject(gpatlas_msgs::SelectObject::Request& req, gpatlas_msgs::SelectObject::Response& res);
  void onClickedPoint(const geometry_msgs::PointStamped::ConstPtr& msg);
  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  // With mutex_ held: the selection's work; `res` says what happened.
  void select(const geometry_msgs::PointStamped& point, gpatlas_msgs::SelectObject::Response* res);
  // With mutex_ held: makes cluster `index` of the latest cloud the object: the GP reset (when
  // it is another object than before) and the object's points published. Returns what the GP
  // said, or that it could not be reached.
  std::string switchObject(std::size_t index);
  // With mutex_ held: the latest cloud's plane, object points and boxes.
  void publishLatest();
  // An error naming both frames when the cloud's frame is not sensor_frame and sensor_frame has
  // no transform: the GP would fit the view without its free space.
  void checkSensorFrame(const sensor_msgs::PointCloud2& msg);
  // An error naming the frames, the box and where the cloud is, when no point is in the crop box.
  void reportOutsideCropBox(const sensor_msgs::PointCloud2& msg, const std::vector<Eigen::Vector3d>& points);

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  std::string sensor_frame_;
  double tf_timeout_s_{0.5};
  gpatlas_geometry::ObjectSegmenter::Config config_;

  // One cloud's segmentation at a time, and no selection during one: a cloud segmented with the
  // hint from before a selection must not replace the selected object.
  std::mutex mutex_;
  std::optional<gpatlas_core::Vector3> selection_;  // the picked cluster's centroid; none: config_'s hint
  struct Latest {
    std::vector<std::vector<gpatlas_core::Vector3>> clusters;
    std::size_t object{0};
    std::optional<gpatlas_msgs::SupportPlane> plane;
    ros::Time stamp;
  };
  std::optional<Latest> latest_;  // the latest cloud that gave clusters
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::unique_ptr<TfGatedCloudSubscriber> points_sub_;
  ros::Publisher object_pub_, plane_pub_, objects_pub_;
  ros::Subscriber clicked_sub_;
  ros::ServiceServer select_srv_, reset_srv_;
};

}  // namespace gpatlas_ros
