// reset.test: after gp_model's ~reset, a subscriber that comes late to any latched output of the
// pipeline's nodelets gets an empty one (issue 51: rviz kept showing the shape that was gone).
// Each output is first seen holding the mug's model, then, from a new subscriber after the reset,
// empty: no surface points or triangles, DELETEALL markers, an OctoMap without a node, no
// charts, no touch, an empty training set and a map status of NONE.

#include "mug_cloud_test.h"

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_msgs/Atlas.h>
#include <gpatlas_msgs/CollisionMapStatus.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/OctomapBinary.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/SaveMap.h>
#include <gpatlas_msgs/Touch.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <shape_msgs/Mesh.h>
#include <std_srvs/Trigger.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <functional>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>

namespace {

using visualization_msgs::Marker;

// The first message a new subscriber to `topic` gets that satisfies `accept` (any message by
// default), within timeout_s. A latched topic gives a new subscriber its last message at once.
template <typename Msg>
std::optional<Msg> lateMessage(const std::string& topic, double timeout_s,
                               const std::function<bool(const Msg&)>& accept = [](const Msg&) { return true; }) {
  std::mutex mutex;
  std::optional<Msg> got;
  ros::NodeHandle nh;
  ros::Subscriber sub = nh.subscribe<Msg>(topic, 10, [&](const typename Msg::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex);
    if (!got && accept(*msg)) got = *msg;
  });
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < end) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (got) return got;
    }
    ros::WallDuration(0.05).sleep();
  }
  return std::nullopt;
}

std::size_t cloudPoints(const sensor_msgs::PointCloud2& cloud) { return std::size_t(cloud.width) * cloud.height; }

bool onlyDeleteAll(const visualization_msgs::MarkerArray& array) {
  if (array.markers.empty()) return false;
  for (const Marker& m : array.markers)
    if (m.action != Marker::DELETEALL) return false;
  return true;
}

bool showsSomething(const visualization_msgs::MarkerArray& array) {
  for (const Marker& m : array.markers)
    if (m.action == Marker::ADD && !m.points.empty()) return true;
  return false;
}

const std::string kGp = "/gpatlas/gp_model/";
const std::string kMap = "/gpatlas/collision_map/";
const std::string kPlanner = "/gpatlas/atlas_planner/";

class Reset : public ::testing::Test {
 protected:
  void SetUp() override {
    if (mug_cloud_test::recordedCloudAbsent(&pcd_)) GTEST_SKIP() << mug_cloud_test::skipMessage(pcd_);
    spinner_.start();
  }

  // A touch on the mug and its approach, so that the planner's and the map's plan outputs hold
  // something before the reset.
  void planATouchAndItsApproach() {
    ASSERT_TRUE(ros::service::waitForService(kPlanner + "next_touch", ros::Duration(30.0)));
    for (std::uint32_t seed = 1; seed <= 5; ++seed) {
      gpatlas_msgs::GetNextTouch touch;
      touch.request.use_seed = true;
      touch.request.seed = seed;
      ASSERT_TRUE(ros::service::call(kPlanner + "next_touch", touch));
      ASSERT_EQ(touch.response.status, gpatlas_msgs::GetNextTouch::Response::TOUCH) << touch.response.message;
      gpatlas_msgs::PlanApproach approach;
      approach.request.touch = touch.response.touch;
      // From 30 cm above the target: above the mug (10 cm tall) and the table.
      approach.request.start = touch.response.touch.points.back();
      approach.request.start.z += 0.3;
      ASSERT_TRUE(ros::service::call(kMap + "plan_approach", approach));
      if (approach.response.success) return;
    }
    FAIL() << "no approach planned to any of 5 touches";
  }

  std::string pcd_;
  ros::AsyncSpinner spinner_{2};
};

TEST_F(Reset, LateSubscribersGetEmptyOutputs) {
  using gpatlas_msgs::CollisionMapStatus;
  // The mug's model, its surface and its map.
  ASSERT_TRUE(lateMessage<gpatlas_msgs::TrainingSet>(kGp + "training_set", 120.0,
                                                     [](const auto& m) { return !m.points.empty(); }))
      << "no model of the recorded cloud";
  ASSERT_TRUE(lateMessage<CollisionMapStatus>(kMap + "status", 120.0,
                                              [](const auto& m) { return m.state == CollisionMapStatus::CURRENT; }))
      << "the collision map was not built";
  planATouchAndItsApproach();
  // save_map computes the map's probabilities: a subscriber after it must still get them (it got
  // none when their having been computed was taken for their having been published).
  gpatlas_msgs::SaveMap save;
  save.request.path = "/no_such_dir/reset_test.bt";
  ASSERT_TRUE(ros::service::call(kMap + "save_map", save));
  EXPECT_FALSE(save.response.success);
  EXPECT_NE(save.response.message.find("/no_such_dir/reset_test.bt"), std::string::npos) << save.response.message;

  // Before the reset: each output, to a late subscriber, shows the model (the checks below can fail).
  EXPECT_TRUE(lateMessage<sensor_msgs::PointCloud2>(kGp + "surface", 60.0, [](const auto& m) { return cloudPoints(m) > 0; }));
  EXPECT_TRUE(lateMessage<Marker>(kGp + "surface_mesh", 60.0,
                                  [](const auto& m) { return m.action == Marker::ADD && !m.points.empty(); }));
  EXPECT_TRUE(lateMessage<shape_msgs::Mesh>(kGp + "surface_shape", 60.0, [](const auto& m) { return !m.triangles.empty(); }));
  EXPECT_TRUE(lateMessage<gpatlas_msgs::OctomapBinary>(kMap + "octomap_binary", 60.0,
                                                       [](const auto& m) { return mug_cloud_test::treeOf(m)->size() > 0; }));
  EXPECT_TRUE(lateMessage<visualization_msgs::MarkerArray>(kMap + "occupied_voxels", 60.0, showsSomething));
  EXPECT_TRUE(lateMessage<Marker>(kMap + "approach_path", 10.0, [](const auto& m) { return !m.points.empty(); }));
  EXPECT_TRUE(lateMessage<visualization_msgs::MarkerArray>(kPlanner + "atlas", 10.0, showsSomething));
  EXPECT_TRUE(lateMessage<gpatlas_msgs::Atlas>(kPlanner + "atlas_charts", 10.0, [](const auto& m) { return !m.charts.empty(); }));
  EXPECT_TRUE(lateMessage<gpatlas_msgs::Touch>(kPlanner + "touch", 10.0, [](const auto& m) { return !m.points.empty(); }));

  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call(kGp + "reset", reset));
  ASSERT_TRUE(reset.response.success) << reset.response.message;
  // The planner and the map hear of the reset on the training set topic: given a moment for
  // it, then every output is asked for by a new subscriber, whose first message must be empty.
  ASSERT_TRUE(lateMessage<CollisionMapStatus>(kMap + "status", 10.0,
                                              [](const auto& m) { return m.state == CollisionMapStatus::NONE; }))
      << "the map's status does not say NONE after the reset";
  ros::WallDuration(1.0).sleep();

  const auto training = lateMessage<gpatlas_msgs::TrainingSet>(kGp + "training_set", 5.0);
  ASSERT_TRUE(training);
  EXPECT_TRUE(training->points.empty());
  const auto surface = lateMessage<sensor_msgs::PointCloud2>(kGp + "surface", 5.0);
  ASSERT_TRUE(surface);
  EXPECT_EQ(cloudPoints(*surface), 0u);
  const auto mesh = lateMessage<Marker>(kGp + "surface_mesh", 5.0);
  ASSERT_TRUE(mesh);
  EXPECT_EQ(mesh->action, Marker::DELETEALL);
  const auto shape = lateMessage<shape_msgs::Mesh>(kGp + "surface_shape", 5.0);
  ASSERT_TRUE(shape);
  EXPECT_TRUE(shape->triangles.empty());
  EXPECT_TRUE(shape->vertices.empty());
  const auto octomap = lateMessage<gpatlas_msgs::OctomapBinary>(kMap + "octomap_binary", 5.0);
  ASSERT_TRUE(octomap);
  EXPECT_EQ(mug_cloud_test::treeOf(*octomap)->size(), 0u);
  EXPECT_EQ(octomap->id, "OcTree");
  EXPECT_GT(octomap->resolution, 0.0);
  EXPECT_EQ(octomap->training_sequence, training->sequence);
  const auto voxels = lateMessage<visualization_msgs::MarkerArray>(kMap + "occupied_voxels", 5.0);
  ASSERT_TRUE(voxels);
  EXPECT_TRUE(onlyDeleteAll(*voxels));
  const auto approach = lateMessage<Marker>(kMap + "approach_path", 5.0);
  ASSERT_TRUE(approach);
  EXPECT_EQ(approach->action, Marker::DELETEALL);
  const auto atlas = lateMessage<visualization_msgs::MarkerArray>(kPlanner + "atlas", 5.0);
  ASSERT_TRUE(atlas);
  EXPECT_TRUE(onlyDeleteAll(*atlas));
  const auto charts = lateMessage<gpatlas_msgs::Atlas>(kPlanner + "atlas_charts", 5.0);
  ASSERT_TRUE(charts);
  EXPECT_TRUE(charts->charts.empty());
  const auto touch = lateMessage<gpatlas_msgs::Touch>(kPlanner + "touch", 5.0);
  ASSERT_TRUE(touch);
  EXPECT_TRUE(touch->points.empty());
  const auto status = lateMessage<CollisionMapStatus>(kMap + "status", 5.0);
  ASSERT_TRUE(status);
  EXPECT_EQ(status->state, CollisionMapStatus::NONE);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_reset");
  return RUN_ALL_TESTS();
}
