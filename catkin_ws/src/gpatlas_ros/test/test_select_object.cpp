// The user picks the object on the real recorded cloud (select_object.test): ~select_object
// with a point near another cluster switches to it (the GP is reset and refitted on it, the
// collision map then holds the mug as an obstacle), near the mug switches back, and a point far
// from every cluster, a NaN, a frame without tf, or a segmentation that has had no cloud are
// refused with a message while the model stays. The clusters are the nodelet's: the test
// segments the same cloud with the same parameters.

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_geometry/config_readers.h>
#include <gpatlas_geometry/segmentation.h>
#include <gpatlas_msgs/OctomapBinary.h>
#include <gpatlas_msgs/SelectObject.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <gpatlas_ros/ros_params.h>
#include <gpatlas_ros/world_frame.h>

#include "mug_cloud_test.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>

namespace {

using mug_cloud_test::Latest;
using mug_cloud_test::occupiedAt;
using mug_cloud_test::treeOf;

constexpr double kWaitS = 150.0;
const std::string kSelect = "/gpatlas/segmentation/select_object";

gpatlas_msgs::SelectObject::Response select(const std::string& service, const Eigen::Vector3d& p,
                                            const std::string& frame = "world") {
  gpatlas_msgs::SelectObject srv;
  srv.request.point.header.frame_id = frame;
  srv.request.point.point = gpatlas_conversions::toPointMsg(p);
  EXPECT_TRUE(ros::service::call(service, srv)) << service;
  return srv.response;
}

class SelectObject : public ::testing::Test {
 protected:
  void SetUp() override {
    if (mug_cloud_test::recordedCloudAbsent(&pcd_)) GTEST_SKIP() << mug_cloud_test::skipMessage(pcd_);
    cloud_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/camera/points", 1, [this](const sensor_msgs::PointCloud2::ConstPtr& m) { cloud_.set(*m); });
    object_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/gpatlas/segmentation/object_points", 5, [this](const sensor_msgs::PointCloud2::ConstPtr& m) { object_.set(*m); });
    training_sub_ = nh_.subscribe<gpatlas_msgs::TrainingSet>(
        "/gpatlas/gp_model/training_set", 5, [this](const gpatlas_msgs::TrainingSet::ConstPtr& m) { training_.set(*m); });
    map_sub_ = nh_.subscribe<gpatlas_msgs::OctomapBinary>(
        "/gpatlas/collision_map/octomap_binary", 5, [this](const gpatlas_msgs::OctomapBinary::ConstPtr& m) { map_.set(*m); });
    boxes_sub_ = nh_.subscribe<visualization_msgs::MarkerArray>(
        "/gpatlas/segmentation/objects", 5, [this](const visualization_msgs::MarkerArray::ConstPtr& m) { boxes_.set(*m); });
    spinner_.start();
  }

  // The nodelet's clusters: the recorded cloud, in the world frame, through the segmenter with
  // the nodelet's parameters.
  gpatlas_geometry::SegmentationResult segmentAsTheNodelet() {
    const auto cloud = cloud_.waitFor(0, [](const sensor_msgs::PointCloud2&) { return true; }, kWaitS);
    EXPECT_TRUE(cloud) << "no camera cloud";
    if (!cloud) return {};
    std::vector<Eigen::Vector3d> points;
    std::size_t invalid = 0;
    std::string error;
    EXPECT_TRUE(gpatlas_ros::cloudToWorld(*cloud, tf_buffer_, "world", 10.0, &points, &invalid, &error)) << error;
    gpatlas_ros::RosParamReader reader(ros::NodeHandle("/gpatlas/segmentation"));
    gpatlas_geometry::ObjectSegmenter::Config config;
    gpatlas_geometry::readSegmenter(reader, &config);
    return gpatlas_geometry::ObjectSegmenter(config).segment(points);
  }

  ros::NodeHandle nh_;
  std::string pcd_;
  ros::AsyncSpinner spinner_{1};
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_{tf_buffer_};
  ros::Subscriber cloud_sub_, object_sub_, training_sub_, map_sub_, boxes_sub_;
  Latest<sensor_msgs::PointCloud2> cloud_, object_;
  Latest<gpatlas_msgs::TrainingSet> training_;
  Latest<gpatlas_msgs::OctomapBinary> map_;
  Latest<visualization_msgs::MarkerArray> boxes_;
};

TEST_F(SelectObject, APointPicksAClusterAndBadPointsAreRefused) {
  // Before any cloud: a segmentation nodelet whose camera never publishes.
  ASSERT_TRUE(ros::service::waitForService("/gpatlas/segmentation_without_cloud/select_object", ros::Duration(30.0)));
  const auto early = select("/gpatlas/segmentation_without_cloud/select_object", Eigen::Vector3d(0.7, 0.0, 0.05));
  EXPECT_FALSE(early.success);
  EXPECT_NE(early.message.find("no cloud segmented yet"), std::string::npos) << early.message;

  const gpatlas_geometry::SegmentationResult seen = segmentAsTheNodelet();
  ASSERT_TRUE(seen.ok) << seen.message;
  ASSERT_GE(seen.clusters.size(), 2u) << "the recorded cloud has the mug and more";
  const std::vector<Eigen::Vector3d>& mug = seen.clusters[seen.object_cluster];
  // The model of the mug, and the boxes: the mug's and the others'.
  const auto first = training_.waitFor(0, [](const gpatlas_msgs::TrainingSet& t) { return !t.points.empty(); }, kWaitS);
  ASSERT_TRUE(first) << "no model of the mug";
  const auto boxes = boxes_.waitFor(0, [](const visualization_msgs::MarkerArray& m) { return m.markers.size() == 3; }, 30.0);
  ASSERT_TRUE(boxes) << "no markers of the explored object and the others";
  EXPECT_EQ(boxes->markers[1].ns, "explored_object");
  EXPECT_EQ(boxes->markers[2].points.size(), 24 * (seen.clusters.size() - 1));

  // Refused, the model kept: no cluster within 3 cm (10 cm above the mug), a NaN, a frame
  // tf does not know.
  Eigen::Vector3d top = mug.front();
  for (const auto& p : mug) top = p.z() > top.z() ? p : top;
  const std::size_t trainings = training_.count();
  const auto far = select(kSelect, top + Eigen::Vector3d(0.0, 0.0, 0.1));
  EXPECT_FALSE(far.success);
  EXPECT_NE(far.message.find("no object within 3 cm"), std::string::npos) << far.message;
  EXPECT_GT(far.distance_m, 0.03);
  const auto nan = select(kSelect, Eigen::Vector3d(std::nan(""), 0.0, 0.0));
  EXPECT_FALSE(nan.success);
  EXPECT_NE(nan.message.find("not finite"), std::string::npos) << nan.message;
  const auto no_tf = select(kSelect, top, "no_such_frame");
  EXPECT_FALSE(no_tf.success);
  EXPECT_NE(no_tf.message.find("no transform from the point's frame 'no_such_frame'"), std::string::npos)
      << no_tf.message;
  // On the mug (1 cm above its top point), the explored object: kept.
  const auto keep = select(kSelect, top + Eigen::Vector3d(0.0, 0.0, 0.01));
  EXPECT_TRUE(keep.success) << keep.message;
  EXPECT_FALSE(keep.changed);
  EXPECT_EQ(keep.object_points, mug.size());
  ros::WallDuration(1.0).sleep();
  EXPECT_EQ(training_.count(), trainings) << "a refused or unchanged selection touched the model";

  // Another cluster (the largest other): the GP is reset and refitted on it, and the map holds
  // the mug as an obstacle.
  std::size_t other = seen.object_cluster == 0 ? 1 : 0;
  for (std::size_t i = 0; i < seen.clusters.size(); ++i)
    if (i != seen.object_cluster && seen.clusters[i].size() > seen.clusters[other].size()) other = i;
  const Eigen::Vector3d on_other = seen.clusters[other][seen.clusters[other].size() / 2];
  const std::size_t maps = map_.count();
  const auto change = select(kSelect, on_other + Eigen::Vector3d(0.0, 0.0, 0.01));
  ASSERT_TRUE(change.success) << change.message;
  EXPECT_TRUE(change.changed);
  EXPECT_EQ(change.object_points, seen.clusters[other].size());
  const std::size_t other_size = seen.clusters[other].size();
  const auto refit = training_.waitFor(
      trainings, [&](const gpatlas_msgs::TrainingSet& t) { return t.view_points.size() == other_size; }, kWaitS);
  ASSERT_TRUE(refit) << "no model of the selected cluster";
  const auto mug_blocks = map_.waitFor(
      maps, [&](const gpatlas_msgs::OctomapBinary& m) { return m.training_sequence == refit->sequence && occupiedAt(*treeOf(m), top); },
      60.0);
  EXPECT_TRUE(mug_blocks) << "the mug is no obstacle in the map of the other object's model";

  // And back to the mug.
  const std::size_t before_back = training_.count();
  const auto back = select(kSelect, top);
  EXPECT_TRUE(back.success) << back.message;
  EXPECT_TRUE(back.changed);
  EXPECT_TRUE(training_.waitFor(before_back, [&](const gpatlas_msgs::TrainingSet& t) {
    return t.view_points.size() == mug.size();
  }, kWaitS)) << "no model of the mug again";
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_select_object");
  return RUN_ALL_TESTS();
}
