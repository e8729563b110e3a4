#include "gpatlas_ros/pipeline_watch.h"

namespace gpatlas_ros {

PipelineWatch::PipelineWatch(ros::NodeHandle nh, bool follow_collision_map) {
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

bool PipelineWatch::waitForCollisionMapOf(std::uint32_t sequence, double timeout_s) const {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline) {
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
