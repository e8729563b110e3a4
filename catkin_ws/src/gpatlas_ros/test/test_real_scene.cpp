// The collision map of the whole scene on the real recorded cloud (real_scene.test): the
// camera's cloud goes into the map, so its occupied voxels cover the table around and under the
// mug and everything else the camera saw off the mug; next_touch, then plan_approach, give a
// path whose tip clears every occupied voxel by the probe's radius.

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/OctomapBinary.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_ros/world_frame.h>

#include "mug_cloud_test.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_listener.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>

namespace {

using mug_cloud_test::fitCircle;
using mug_cloud_test::Latest;
using mug_cloud_test::occupiedAt;
using mug_cloud_test::treeOf;

constexpr double kWaitS = 150.0;

// The occupied voxels of the map as boxes (a pruned leaf is one larger box).
struct Voxel {
  Eigen::Vector3d centre;
  double half;
  double distance(const Eigen::Vector3d& p) const {
    return ((p - centre).cwiseAbs() - Eigen::Vector3d::Constant(half)).cwiseMax(0.0).norm();
  }
};

std::vector<Voxel> occupiedVoxels(const octomap::OcTree& tree) {
  std::vector<Voxel> out;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it)
    if (tree.isNodeOccupied(*it)) out.push_back({Eigen::Vector3d(it.getX(), it.getY(), it.getZ()), 0.5 * it.getSize()});
  return out;
}

// How much of what the camera saw the map holds: the table's cells (1 cm, seen by at least two
// points) around the mug, and the points off the table and away from the mug.
struct Coverage {
  std::size_t table_cells{0}, table_covered{0};
  std::size_t off_table{0}, off_table_covered{0};
  double tableFraction() const { return table_cells ? double(table_covered) / table_cells : 0.0; }
  double offTableFraction() const { return off_table ? double(off_table_covered) / off_table : 0.0; }
};

class RealScene : public ::testing::Test {
 protected:
  void SetUp() override {
    if (mug_cloud_test::recordedCloudAbsent(&pcd_)) GTEST_SKIP() << mug_cloud_test::skipMessage(pcd_);
    // The collision map's own settings.
    ros::param::get("/gpatlas/collision_map/collision_map/scene_object_margin_m", margin_);
    ros::param::get("/gpatlas/collision_map/approach/tip_radius_m", tip_radius_);
    cloud_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/camera/points", 1, [this](const sensor_msgs::PointCloud2::ConstPtr& m) { cloud_.set(*m); });
    object_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/gpatlas/segmentation/object_points", 1, [this](const sensor_msgs::PointCloud2::ConstPtr& m) { object_.set(*m); });
    map_sub_ = nh_.subscribe<gpatlas_msgs::OctomapBinary>(
        "/gpatlas/collision_map/octomap_binary", 5, [this](const gpatlas_msgs::OctomapBinary::ConstPtr& m) { map_.set(*m); });
    spinner_.start();
  }

  // The recorded cloud in the world frame, and the mug's points.
  bool waitForScene(std::string* error) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(kWaitS);
    while (ros::ok() && ros::WallTime::now() < end && !(cloud_.get() && object_.get())) ros::WallDuration(0.05).sleep();
    if (!cloud_.get() || !object_.get()) {
      *error = "no camera cloud or no object points";
      return false;
    }
    std::size_t invalid = 0;
    if (!gpatlas_ros::cloudToWorld(*cloud_.get(), tf_buffer_, "world", 10.0, &scene_, &invalid, error)) return false;
    return gpatlas_conversions::cloudToPoints(*object_.get(), &mug_, &invalid, error);
  }

  double distanceToMug(const Eigen::Vector3d& p) const {
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& q : mug_) best = std::min(best, (p - q).squaredNorm());
    return std::sqrt(best);
  }

  Coverage coverage(const octomap::OcTree& tree) const;

  ros::NodeHandle nh_;
  std::string pcd_;
  double margin_{0.03}, tip_radius_{0.02};
  ros::AsyncSpinner spinner_{1};
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_{tf_buffer_};
  ros::Subscriber cloud_sub_, object_sub_, map_sub_;
  Latest<sensor_msgs::PointCloud2> cloud_, object_;
  Latest<gpatlas_msgs::OctomapBinary> map_;
  std::vector<Eigen::Vector3d> scene_, mug_;
  Eigen::Vector2d axis_{Eigen::Vector2d::Zero()};
  double radius_{0.0};
};

Coverage RealScene::coverage(const octomap::OcTree& tree) const {
  Coverage c;
  // Left to the mug's model: within the margin of its points, and a voxel's diagonal beyond.
  const double model_zone = margin_ + std::sqrt(3.0) * tree.getResolution();
  std::map<std::pair<int, int>, int> table;
  for (std::size_t i = 0; i < scene_.size(); ++i) {
    const Eigen::Vector3d& p = scene_[i];
    const double from_axis = (p.head<2>() - axis_).norm();
    if (std::abs(p.z()) < 0.005) {
      // The table from just outside the model's zone to 15 cm from the mug's axis.
      if (from_axis < 0.15 && from_axis > radius_ + model_zone) ++table[{int(std::floor(p.x() / 0.01)), int(std::floor(p.y() / 0.01))}];
    } else if (p.z() > 0.02 && i % 7 == 0 && from_axis > radius_ + 0.01 && distanceToMug(p) > model_zone) {
      ++c.off_table;
      c.off_table_covered += occupiedAt(tree, p) ? 1 : 0;
    }
  }
  for (const auto& [cell, points] : table) {
    if (points < 2) continue;
    ++c.table_cells;
    bool covered = false;
    for (double z : {-0.005, 0.005})
      covered = covered || occupiedAt(tree, Eigen::Vector3d((cell.first + 0.5) * 0.01, (cell.second + 0.5) * 0.01, z));
    c.table_covered += covered ? 1 : 0;
  }
  return c;
}

// The tip's clearance from the voxels along a path (every millimetre), less the tip's radius.
double pathClearance(const std::vector<geometry_msgs::Point>& path, const std::vector<Voxel>& voxels, double radius) {
  double clearance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector3d a = gpatlas_conversions::fromMsg(path[i]), b = gpatlas_conversions::fromMsg(path[i + 1]);
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.001)));
    for (int s = 0; s <= steps; ++s) {
      const Eigen::Vector3d tip = a + (b - a) * (double(s) / steps);
      for (const Voxel& v : voxels) clearance = std::min(clearance, v.distance(tip) - radius);
    }
  }
  return clearance;
}

TEST_F(RealScene, TheMapHoldsWhatTheCameraSawAndTheApproachClearsIt) {
  std::string error;
  ASSERT_TRUE(waitForScene(&error)) << error;
  ASSERT_GT(mug_.size(), 500u);
  std::tie(axis_, radius_) = fitCircle(mug_);

  // The map comes with the scene in it (after a re-merge if the model's map came first).
  Coverage c;
  std::unique_ptr<octomap::OcTree> tree;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(kWaitS);
  std::size_t seen = 0;
  while (ros::ok() && ros::WallTime::now() < end) {
    std::size_t count = 0;
    const std::optional<gpatlas_msgs::OctomapBinary> msg = map_.get(&count);
    if (msg && count != seen) {
      seen = count;
      tree = treeOf(*msg);
      c = coverage(*tree);
      if (c.tableFraction() >= 0.95 && c.offTableFraction() >= 0.99) break;
    }
    ros::WallDuration(0.2).sleep();
  }
  ASSERT_TRUE(tree) << "no collision map";
  const std::vector<Voxel> voxels = occupiedVoxels(*tree);
  std::printf("[real scene] %zu occupied voxels; table around the mug: %zu of %zu cells covered; off the table "
              "and the mug: %zu of %zu points in occupied voxels\n",
              voxels.size(), c.table_covered, c.table_cells, c.off_table_covered, c.off_table);
  RecordProperty("occupied_voxels", std::to_string(voxels.size()));
  EXPECT_GT(c.table_cells, 100u);
  EXPECT_GE(c.tableFraction(), 0.95);
  EXPECT_GE(c.offTableFraction(), 0.99) << c.off_table << " points off the table and the mug";

  gpatlas_msgs::GetNextTouch next;
  next.request.use_v_max = true;
  next.request.v_max = 0.1;
  ASSERT_TRUE(ros::service::waitForService("/gpatlas/atlas_planner/next_touch", ros::Duration(30.0)));
  ASSERT_TRUE(ros::service::call("/gpatlas/atlas_planner/next_touch", next));
  ASSERT_EQ(next.response.status, gpatlas_msgs::GetNextTouch::Response::TOUCH) << next.response.message;
  gpatlas_msgs::PlanApproach approach;
  approach.request.touch = next.response.touch;
  // Low over the table beside the mug, across the touch's side (the probe keeps pointing along
  // the touch's direction, its shaft behind it): the way there passes between the mug, the
  // table's voxels and whatever else stands there.
  const Eigen::Vector2d touch_xy(next.response.touch.points.back().x, next.response.touch.points.back().y);
  const Eigen::Vector2d towards = (touch_xy - axis_).normalized(), beside(-towards.y(), towards.x());
  const Eigen::Vector2d start_xy = axis_ + 0.12 * beside;
  approach.request.start = gpatlas_conversions::toPointMsg(Eigen::Vector3d(start_xy.x(), start_xy.y(), 0.08));
  ASSERT_TRUE(ros::service::call("/gpatlas/collision_map/plan_approach", approach));
  ASSERT_TRUE(approach.response.success) << approach.response.message;
  EXPECT_FALSE(approach.response.map_stale);
  const double there = pathClearance(approach.response.approach, voxels, tip_radius_);
  const double back = pathClearance(approach.response.retreat, voxels, tip_radius_);
  std::printf("[real scene] touch at (%.3f, %.3f, %.3f); approach of %zu points clears the voxels by %.1f mm beyond "
              "the tip's radius, the retreat by %.1f mm; planned in %.3f s\n",
              next.response.touch.points.back().x, next.response.touch.points.back().y,
              next.response.touch.points.back().z, approach.response.approach.size(), 1000.0 * there, 1000.0 * back,
              approach.response.planning_time_s);
  RecordProperty("approach_clearance_mm", std::to_string(1000.0 * there));
  EXPECT_GE(there, 0.0);
  EXPECT_GE(back, 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_real_scene");
  return RUN_ALL_TESTS();
}
