#include "gpatlas_ros/tf_gated_subscriber.h"

#include "gpatlas_ros/wait_report.h"

namespace gpatlas_ros {

namespace {
// Latest wins: a cloud that arrives while the previous one still waits (for its transform, or for
// a busy callback) replaces it, so a streaming camera is never worked through from a backlog.
constexpr std::uint32_t kQueueSize = 1;
}  // namespace

TfGatedCloudSubscriber::TfGatedCloudSubscriber(ros::NodeHandle nh, const std::string& topic, tf2_ros::Buffer* buffer,
                                               const std::string& target_frame, const std::string& owner,
                                               double warn_after_s, Callback callback)
    : target_frame_(target_frame),
      owner_(owner),
      warn_after_s_(warn_after_s),
      callback_(std::move(callback)),
      subscriber_(nh, topic, kQueueSize),
      filter_(*buffer, target_frame, kQueueSize, nh) {
  // onArrived first: the filter may deliver (onReady) on another thread right after its input.
  subscriber_.registerCallback(&TfGatedCloudSubscriber::onArrived, this);
  filter_.connectInput(subscriber_);
  filter_.registerCallback(&TfGatedCloudSubscriber::onReady, this);
  filter_.registerFailureCallback(
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg, tf2_ros::FilterFailureReason reason) {
        onDropped(msg, reason);
      });
  watchdog_ = nh.createSteadyTimer(ros::WallDuration(0.5), &TfGatedCloudSubscriber::checkWaiting, this);
}

void TfGatedCloudSubscriber::onArrived(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  if (msg->header.frame_id.empty()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (waiting_) return;  // the oldest waiting cloud sets the clock
  waiting_ = true;
  warned_ = false;
  waiting_since_ = ros::SteadyTime::now();
  waiting_frame_ = msg->header.frame_id;
}

void TfGatedCloudSubscriber::onReady(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  bool was_reported = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    was_reported = warned_;
    waiting_ = false;
    warned_ = false;
  }
  if (was_reported)
    ROS_INFO_STREAM(owner_ << ": the transform from '" << msg->header.frame_id << "' to '" << target_frame_
                           << "' is here; cloud processed");
  callback_(msg);
}

void TfGatedCloudSubscriber::onDropped(const sensor_msgs::PointCloud2::ConstPtr& msg,
                                       tf2_ros::FilterFailureReason reason) {
  if (reason == tf2_ros::filter_failure_reasons::EmptyFrameID) {
    callback_(msg);
    return;
  }
  ROS_WARN_STREAM_THROTTLE(5.0, owner_ << ": cloud in '" << msg->header.frame_id << "' (stamp "
                                       << msg->header.stamp << ") dropped: "
                                       << (reason == tf2_ros::filter_failure_reasons::OutTheBack
                                               ? "older than the transforms tf still keeps"
                                               : "newer clouds came while it waited for a transform")
                                       << " to '" << target_frame_ << "'");
  std::lock_guard<std::mutex> lock(mutex_);
  waiting_ = false;
}

void TfGatedCloudSubscriber::checkWaiting(const ros::SteadyTimerEvent&) {
  std::string frame;
  double waited = 0.0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!waiting_) return;
    const ros::SteadyTime now = ros::SteadyTime::now();
    waited = (now - waiting_since_).toSec();
    if (warned_ ? now < next_warning_ : waited < warn_after_s_) return;
    warned_ = true;
    next_warning_ = now + ros::WallDuration(kWaitReportPeriodS);
    frame = waiting_frame_;
  }
  ROS_WARN_STREAM(owner_ << ": a cloud on " << topic() << " in '" << frame << "' has waited " << waited
                         << " s for a transform to '" << target_frame_
                         << "' (is robot_state_publisher or the camera driver's tf running?)");
}

}  // namespace gpatlas_ros
