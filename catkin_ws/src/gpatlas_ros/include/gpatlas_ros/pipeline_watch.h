#pragma once

#include <gpatlas_msgs/CollisionMapStatus.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <ros/ros.h>

#include <cstdint>
#include <mutex>
#include <string>

namespace gpatlas_ros {

// What the exploration node follows of the pipeline's topics: the GP's newest training set
// (`training_set`) and, with approach planning, the collision map's status
// (`collision_map_status`).
class PipelineWatch {
 public:
  PipelineWatch(ros::NodeHandle nh, bool follow_collision_map);

  // Null until the GP has published one.
  gpatlas_msgs::TrainingSet::ConstPtr latestTraining() const;
  std::string trainingTopic() const { return training_sub_.getTopic(); }
  // Waits (at most 5 s) for a training set received at `time` or later: the one an update made.
  void waitForTrainingSetNewerThan(const ros::WallTime& time) const;
  // Waits for the collision map of training set `sequence`, or the news that its build failed
  // (an older map is left, or none is); false when neither came within `timeout_s` (the node's
  // call_timeout_s). Says every kWaitReportPeriodS what it waits for (wait_report.h).
  bool waitForCollisionMapOf(std::uint32_t sequence, double timeout_s) const;
  // What a wait for a training set waits for: the topic, its remap and its publishers.
  std::string describeTrainingSource() const;

 private:
  void onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg);
  void onMapStatus(const gpatlas_msgs::CollisionMapStatus::ConstPtr& msg);

  // What a wait for a map waits for: the status topic, its remap, its publishers, the last status.
  std::string describeMapStatusSource(std::uint32_t sequence, double timeout_s) const;

  ros::NodeHandle nh_;
  mutable std::mutex mutex_;
  gpatlas_msgs::TrainingSet::ConstPtr training_;
  ros::WallTime training_received_;
  gpatlas_msgs::CollisionMapStatus::ConstPtr map_status_;
  ros::Subscriber training_sub_;
  ros::Subscriber map_status_sub_;
};

}  // namespace gpatlas_ros
