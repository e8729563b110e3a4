#include "gpatlas_ros/pipeline_watch.h"

#include "gpatlas_ros/wait_report.h"

namespace gpatlas_ros {

PipelineWatch::PipelineWatch(ros::NodeHandle nh, bool follow_collision_map) : nh_(nh) {
  training_sub_ = nh.subscribe("training_set", 1, &PipelineWatch::onTrainingSet, this);
  if (follow_collision_map)
    map_status_sub_ = nh.subscribe("collision_map_status", 1, &PipelineWatch::onMapStatus, this);
}

void PipelineWatch::onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  training_ = msg;
  training_received_ = ros::WallTime::now();
}

void PipelineWatch::onMapStatus(const gpatlas_msgs::CollisionMapStatus::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  map_status_ = msg;
}

gpatlas_msgs::TrainingSet::ConstPtr PipelineWatch::latestTraining() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return training_;
}

void PipelineWatch::waitForTrainingSetNewerThan(const ros::WallTime& time) const {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(5.0);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (training_received_ >= time) return;
    }
    ros::WallDuration(0.01).sleep();
  }
}

namespace {

std::string publishers(const ros::Subscriber& sub) {
  const std::uint32_t n = sub.getNumPublishers();
  return n == 0 ? "no publisher" : std::to_string(n) + " publisher(s)";
}

std::string stateName(std::uint8_t state) {
  switch (state) {
    case gpatlas_msgs::CollisionMapStatus::NONE: return "NONE";
    case gpatlas_msgs::CollisionMapStatus::CURRENT: return "CURRENT";
    case gpatlas_msgs::CollisionMapStatus::BUILDING: return "BUILDING";
    case gpatlas_msgs::CollisionMapStatus::STALE: return "STALE";
    default: return std::to_string(state);
  }
}

}  // namespace

std::string PipelineWatch::describeTrainingSource() const {
  return "a training set on " + remapHint(nh_, "training_set") + ", which has " + publishers(training_sub_);
}

std::string PipelineWatch::describeMapStatusSource(std::uint32_t sequence, double timeout_s) const {
  std::string last;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last = map_status_ ? "the last status says " + stateName(map_status_->state) + " for training set " +
                             std::to_string(map_status_->map_training_sequence) + " (" + map_status_->message + ")"
                       : "no status has come";
  }
  return "the collision map of training set " + std::to_string(sequence) + " on " +
         remapHint(nh_, "collision_map_status") + ", which has " + publishers(map_status_sub_) + "; " + last +
         "; gives up after call_timeout_s (" + seconds(timeout_s) + ")";
}

bool PipelineWatch::waitForCollisionMapOf(std::uint32_t sequence, double timeout_s) const {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  WaitReport report("exploration", [this, sequence, timeout_s] { return describeMapStatusSource(sequence, timeout_s); });
  while (ros::ok() && ros::WallTime::now() < deadline) {
    report.poll();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto& status = map_status_;
      // Built, or its build failed: STALE (an older map is left) or NONE (none is).
      const bool failed = status && status->latest_training_sequence >= sequence &&
                          (status->state == gpatlas_msgs::CollisionMapStatus::STALE ||
                           status->state == gpatlas_msgs::CollisionMapStatus::NONE);
      if (status && (status->map_training_sequence >= sequence || failed)) return true;
    }
    ros::WallDuration(0.01).sleep();
  }
  return false;
}

}  // namespace gpatlas_ros
