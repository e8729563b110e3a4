// stream.test: a 30 Hz stream of a real cloud for 20 s leaves no backlog of fits: after the last
// cloud, at most the fit under way and one more publish a model.

#include "mug_cloud_test.h"

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <algorithm>
#include <cstdio>

namespace {

using mug_cloud_test::Arrivals;

TEST(Stream, AFastCameraLeavesAtMostOneFitQueued) {
  std::string pcd;
  if (mug_cloud_test::recordedCloudAbsent(&pcd)) GTEST_SKIP() << mug_cloud_test::skipMessage(pcd);
  const Arrivals arrivals{ros::NodeHandle()};
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // The stream: until no cloud has come for 2 s (after the first).
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(120.0);
  for (;;) {
    ros::WallDuration(0.1).sleep();
    ASSERT_LT(ros::WallTime::now(), give_up) << "the stream did not start and end";
    if (arrivals.clouds() > 0 && (ros::WallTime::now() - arrivals.lastCloud()).toSec() > 2.0) break;
  }
  // Then long enough for a backlog to show: 20 s with no new model, or 90 s in all.
  const ros::WallTime stream_end = arrivals.lastCloud();
  const ros::WallTime quiet_limit = ros::WallTime::now() + ros::WallDuration(90.0);
  for (;;) {
    ros::WallDuration(0.2).sleep();
    const std::vector<ros::WallTime> models = arrivals.models();
    const ros::WallTime latest = models.empty() ? stream_end : std::max(stream_end, models.back());
    if ((ros::WallTime::now() - latest).toSec() > 20.0 || ros::WallTime::now() > quiet_limit) break;
  }
  const std::vector<ros::WallTime> models = arrivals.models();
  const std::size_t clouds = arrivals.clouds();
  const auto after_end = static_cast<std::size_t>(
      std::count_if(models.begin(), models.end(), [&](const ros::WallTime& t) { return t > stream_end; }));
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
