#pragma once

// What the rostests on ../shared's real cloud (mug_cloud_camera.launch) share.

#include <gpatlas_msgs/TrainingSet.h>

#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

namespace mug_cloud_test {

// The recorded cloud's path (the test's ~pcd) in *path; true when the file is absent, and the
// test is to skip with skipMessage(*path).
inline bool recordedCloudAbsent(std::string* path) {
  ros::NodeHandle("~").getParam("pcd", *path);
  return !std::filesystem::is_regular_file(*path);
}

inline std::string skipMessage(const std::string& path) {
  return "no recorded cloud at '" + path + "' (../shared/data is absent): skipped";
}

// The camera's clouds (/camera/points) and the GP's models (its training sets) as they arrive.
class Arrivals {
 public:
  explicit Arrivals(ros::NodeHandle nh) {
    cloud_sub_ = nh.subscribe<sensor_msgs::PointCloud2>("/camera/points", 100,
                                                        [this](const sensor_msgs::PointCloud2::ConstPtr&) {
                                                          std::lock_guard<std::mutex> lock(mutex_);
                                                          ++clouds_;
                                                          last_cloud_ = ros::WallTime::now();
                                                        });
    model_sub_ = nh.subscribe<gpatlas_msgs::TrainingSet>("/gpatlas/gp_model/training_set", 100,
                                                         [this](const gpatlas_msgs::TrainingSet::ConstPtr&) {
                                                           std::lock_guard<std::mutex> lock(mutex_);
                                                           models_.push_back(ros::WallTime::now());
                                                         });
  }
  std::size_t clouds() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return clouds_;
  }
  ros::WallTime lastCloud() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_cloud_;
  }
  std::vector<ros::WallTime> models() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return models_;
  }

 private:
  mutable std::mutex mutex_;
  std::size_t clouds_{0};
  ros::WallTime last_cloud_;
  std::vector<ros::WallTime> models_;
  ros::Subscriber cloud_sub_, model_sub_;
};

}  // namespace mug_cloud_test
