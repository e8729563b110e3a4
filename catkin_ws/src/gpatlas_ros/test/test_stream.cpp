// stream.test: a 30 Hz stream of a real cloud for 20 s leaves no backlog of fits: after the last
// cloud, at most the fit under way and one more publish a model.

#include <gpatlas_msgs/TrainingSet.h>

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <filesystem>
#include <mutex>
#include <vector>

namespace {

TEST(Stream, AFastCameraLeavesAtMostOneFitQueued) {
  std::string pcd;
  ros::NodeHandle("~").getParam("pcd", pcd);
  if (!std::filesystem::is_regular_file(pcd))
    GTEST_SKIP() << "no recorded cloud at '" << pcd << "' (../shared/data is absent): skipped";
  ros::NodeHandle nh;
  std::mutex mutex;
  std::size_t clouds = 0;
  ros::WallTime last_cloud;
  std::vector<ros::WallTime> models;
  ros::Subscriber cloud_sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/camera/points", 100, [&](const sensor_msgs::PointCloud2::ConstPtr&) {
        std::lock_guard<std::mutex> lock(mutex);
        ++clouds;
        last_cloud = ros::WallTime::now();
      });
  ros::Subscriber model_sub = nh.subscribe<gpatlas_msgs::TrainingSet>(
      "/gpatlas/gp_model/training_set", 100, [&](const gpatlas_msgs::TrainingSet::ConstPtr&) {
        std::lock_guard<std::mutex> lock(mutex);
        models.push_back(ros::WallTime::now());
      });
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // The stream: until no cloud has come for 2 s (after the first).
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(120.0);
  for (;;) {
    ros::WallDuration(0.1).sleep();
    std::lock_guard<std::mutex> lock(mutex);
    ASSERT_LT(ros::WallTime::now(), give_up) << "the stream did not start and end";
    if (clouds > 0 && (ros::WallTime::now() - last_cloud).toSec() > 2.0) break;
  }
  // Then long enough for a backlog to show: 20 s with no new model, or 90 s in all.
  const ros::WallTime stream_end = last_cloud;
  const ros::WallTime quiet_limit = ros::WallTime::now() + ros::WallDuration(90.0);
  for (;;) {
    ros::WallDuration(0.2).sleep();
    std::lock_guard<std::mutex> lock(mutex);
    const ros::WallTime latest = models.empty() ? stream_end : std::max(stream_end, models.back());
    if ((ros::WallTime::now() - latest).toSec() > 20.0 || ros::WallTime::now() > quiet_limit) break;
  }
  std::lock_guard<std::mutex> lock(mutex);
  std::size_t after_end = 0;
  for (const ros::WallTime& t : models)
    if (t > stream_end) ++after_end;
  std::printf("[stream] %zu clouds in, %zu models out, %zu of them after the last cloud (%.1f s after it)\n", clouds,
              models.size(), after_end, models.empty() ? 0.0 : (models.back() - stream_end).toSec());
  ASSERT_GT(clouds, 300u) << "the camera streamed too little to test anything";
  ASSERT_FALSE(models.empty()) << "no model from the stream";
  EXPECT_LE(after_end, 2u) << "a backlog of fits ran on after the stream";
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_stream");
  return RUN_ALL_TESTS();
}
