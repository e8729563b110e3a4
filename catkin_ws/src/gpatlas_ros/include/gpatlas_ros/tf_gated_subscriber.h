#pragma once

#include <message_filters/subscriber.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>

#include <functional>
#include <mutex>
#include <string>

namespace gpatlas_ros {

// A cloud subscription that delivers each cloud only once tf can move it into `target_frame`.
// A camera's first cloud often arrives before the robot's transforms (robot_state_publisher
// still starting): a single-shot capture must wait for them, not be dropped after a fixed
// timeout. A cloud that has waited `warn_after_s` is reported, with its topic and frame, and
// again every kWaitReportPeriodS while it waits; a cloud
// without a frame is delivered at once (the converters take it to be in target_frame).
class TfGatedCloudSubscriber {
 public:
  using Callback = std::function<void(const sensor_msgs::PointCloud2::ConstPtr&)>;

  TfGatedCloudSubscriber(ros::NodeHandle nh, const std::string& topic, tf2_ros::Buffer* buffer,
                         const std::string& target_frame, const std::string& owner, double warn_after_s,
                         Callback callback);
  TfGatedCloudSubscriber(const TfGatedCloudSubscriber&) = delete;
  TfGatedCloudSubscriber& operator=(const TfGatedCloudSubscriber&) = delete;

  std::string topic() const { return subscriber_.getTopic(); }

 private:
  void onArrived(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void onReady(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void onDropped(const sensor_msgs::PointCloud2::ConstPtr& msg, tf2_ros::FilterFailureReason reason);
  void checkWaiting(const ros::SteadyTimerEvent&);

  std::string target_frame_, owner_;
  double warn_after_s_;
  Callback callback_;
  message_filters::Subscriber<sensor_msgs::PointCloud2> subscriber_;
  tf2_ros::MessageFilter<sensor_msgs::PointCloud2> filter_;
  ros::SteadyTimer watchdog_;

  std::mutex mutex_;  // guards the wait record below
  bool waiting_{false};
  bool warned_{false};
  ros::SteadyTime next_warning_;
  ros::SteadyTime waiting_since_;
  std::string waiting_frame_;
};

}  // namespace gpatlas_ros
