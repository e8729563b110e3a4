// one_shot.test: with fit_every_cloud false, a streaming camera's clouds are not fitted until
// ~fit_next_cloud is called; then exactly one is.

#include "mug_cloud_test.h"

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

namespace {

using mug_cloud_test::Arrivals;

TEST(OneShot, OnlyTheCloudAfterFitNextCloudIsFitted) {
  std::string pcd;
  if (mug_cloud_test::recordedCloudAbsent(&pcd)) GTEST_SKIP() << mug_cloud_test::skipMessage(pcd);
  const Arrivals arrivals{ros::NodeHandle()};
  ros::AsyncSpinner spinner(2);
  spinner.start();
  // The stream runs; segmentation works on it; the GP waits.
  const ros::WallTime started = ros::WallTime::now();
  while (arrivals.clouds() < 20 && (ros::WallTime::now() - started).toSec() < 60.0) ros::WallDuration(0.1).sleep();
  ASSERT_GE(arrivals.clouds(), 20u) << "the camera does not stream";
  ros::WallDuration(5.0).sleep();
  EXPECT_EQ(arrivals.models().size(), 0u) << "a cloud was fitted before fit_next_cloud";

  std_srvs::Trigger trigger;
  ASSERT_TRUE(ros::service::waitForService("/gpatlas/gp_model/fit_next_cloud", ros::Duration(10.0)));
  ASSERT_TRUE(ros::service::call("/gpatlas/gp_model/fit_next_cloud", trigger));
  EXPECT_TRUE(trigger.response.success) << trigger.response.message;
  const ros::WallTime asked = ros::WallTime::now();
  while (arrivals.models().empty() && (ros::WallTime::now() - asked).toSec() < 60.0) ros::WallDuration(0.1).sleep();
  ASSERT_EQ(arrivals.models().size(), 1u) << "fit_next_cloud gave no model";
  // The stream goes on: nothing more is fitted.
  ros::WallDuration(10.0).sleep();
  EXPECT_EQ(arrivals.models().size(), 1u) << "clouds after the one-shot were fitted too";
  EXPECT_LT((ros::WallTime::now() - arrivals.lastCloud()).toSec(), 2.0) << "the stream ended before the check";
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_one_shot");
  return RUN_ALL_TESTS();
}
