// frame_mismatch.test: a cloud in a frame other than sensor_frame, whose transform is missing,
// gets an error that names both frames, within a second of the cloud.

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/PointCloud2.h>

#include <filesystem>
#include <mutex>
#include <optional>

namespace {

TEST(FrameMismatch, AnErrorNamesTheCloudsFrameAndSensorFrameWithinASecond) {
  std::string pcd;
  ros::NodeHandle("~").getParam("pcd", pcd);
  if (!std::filesystem::is_regular_file(pcd))
    GTEST_SKIP() << "no recorded cloud at '" << pcd << "' (../shared/data is absent): skipped";
  ros::NodeHandle nh;
  std::mutex mutex;
  std::optional<ros::Time> cloud_stamp;
  std::optional<rosgraph_msgs::Log> error;
  ros::Subscriber cloud_sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/camera/points", 1, [&](const sensor_msgs::PointCloud2::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        cloud_stamp = m->header.stamp;
      });
  ros::Subscriber log_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 100, [&](const rosgraph_msgs::Log::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    if (!error && m->level == rosgraph_msgs::Log::ERROR && m->msg.find("camera_depth_optical_frame") != std::string::npos &&
        m->msg.find("camera_optical_frame") != std::string::npos)
      error = *m;
  });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(60.0);
  while (ros::ok() && ros::WallTime::now() < end) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (error && cloud_stamp) break;
    }
    ros::WallDuration(0.05).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_TRUE(cloud_stamp.has_value()) << "no cloud on /camera/points";
  ASSERT_TRUE(error.has_value()) << "no error naming camera_depth_optical_frame and camera_optical_frame";
  const double latency_s = (error->header.stamp - *cloud_stamp).toSec();
  std::printf("[frame mismatch] %s\n[frame mismatch] %.3f s after the cloud\n", error->msg.c_str(), latency_s);
  EXPECT_NE(error->msg.find("sensor_frame"), std::string::npos) << "the message must name the parameter";
  EXPECT_LT(latency_s, 1.0);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_frame_mismatch");
  return RUN_ALL_TESTS();
}
