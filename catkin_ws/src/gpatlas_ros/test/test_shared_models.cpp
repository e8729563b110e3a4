// SharedModels: a training set finds the snapshot it was published with, only that one, while it
// is the newest or a user still holds it; a training set from elsewhere gets a replica refitted
// from the message.
#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/shared_models.h"

#include <gpatlas_core/model/gpis_model.h>

#include <octomap/OcTree.h>

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

namespace {

std::shared_ptr<const gpatlas_core::SurfaceModel> hemisphereModel(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<gpatlas_core::TrainingPoint> points;
  for (int i = 0; i < 80; ++i) {
    gpatlas_core::TrainingPoint p;
    p.position = Eigen::Vector3d(0.5, 0.0, 0.1) + 0.05 * Eigen::Vector3d(g(rng), g(rng), std::abs(g(rng))).normalized();
    p.noise_sigma = 0.05;
    points.push_back(p);
  }
  auto model = std::make_shared<gpatlas_core::GpisModel>();
  EXPECT_TRUE(model->fit(points).ok);
  return model;
}

gpatlas_msgs::TrainingSet stamped(const gpatlas_core::SurfaceModel& model, std::uint32_t sequence, double stamp_s) {
  gpatlas_msgs::TrainingSet training = gpatlas_conversions::toMsg(model);
  training.sequence = sequence;
  training.header.stamp = ros::Time(stamp_s);
  training.header.frame_id = "world";
  return training;
}

TEST(SharedModels, ATrainingSetFindsItsOwnSnapshotOnly) {
  const std::string topic = "/test/gp_model/training_set";
  auto first = hemisphereModel(1);
  const auto second = hemisphereModel(2);
  const auto third = hemisphereModel(3);
  const auto t1 = stamped(*first, 1, 10.0), t2 = stamped(*second, 2, 11.0), t3 = stamped(*third, 3, 12.0);
  gpatlas_ros::SharedModels::offer(topic, t1, first);
  gpatlas_ros::SharedModels::offer(topic, t2, second);
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, t1), first);
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, t2), second);
  // Another topic, or the same sequence from a GP nodelet that started again (another stamp).
  EXPECT_EQ(gpatlas_ros::SharedModels::find("/other/training_set", t1), nullptr);
  gpatlas_msgs::TrainingSet restarted = t1;
  restarted.header.stamp = ros::Time(20.0);
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, restarted), nullptr);
  // Only the newest is held: an earlier one is found while a user still holds it, and no longer
  // once the last user lets it go (the registry does not keep a superseded model in memory).
  gpatlas_ros::SharedModels::offer(topic, t3, third);
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, t1), first);
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, t3), third);
  const std::weak_ptr<const gpatlas_core::SurfaceModel> watched_first = first;
  first.reset();
  EXPECT_TRUE(watched_first.expired());
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, t1), nullptr);
  EXPECT_TRUE(gpatlas_ros::SharedModels::superseded(topic, t1));
  EXPECT_FALSE(gpatlas_ros::SharedModels::superseded(topic, t3));

  std::shared_ptr<const gpatlas_core::SurfaceModel> model;
  std::string error;
  EXPECT_EQ(gpatlas_ros::modelForTrainingSet(topic, t3, gpatlas_core::SurfaceModelConfig(), &model, &error),
            gpatlas_ros::ModelSource::kShared)
      << error;
  EXPECT_EQ(model, third);
  // A training set whose snapshot is gone and that a newer one follows is not refitted.
  model.reset();
  EXPECT_EQ(gpatlas_ros::modelForTrainingSet(topic, t1, gpatlas_core::SurfaceModelConfig(), &model, &error),
            gpatlas_ros::ModelSource::kSuperseded);
  EXPECT_EQ(model, nullptr);
  // A reset offers its empty training set without a model: everything before it is superseded.
  const auto t4 = stamped(*third, 4, 13.0);
  gpatlas_ros::SharedModels::offer(topic, t4, nullptr);
  EXPECT_TRUE(gpatlas_ros::SharedModels::superseded(topic, t3));
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, t3), third);  // while the test holds it
  gpatlas_ros::SharedModels::withdraw(topic);
  EXPECT_EQ(gpatlas_ros::SharedModels::find(topic, t3), nullptr);
}

TEST(SharedModels, ATrainingSetFromElsewhereIsRefitted) {
  const auto original = hemisphereModel(4);
  const auto training = stamped(*original, 7, 30.0);
  std::shared_ptr<const gpatlas_core::SurfaceModel> replica;
  std::string error;
  ASSERT_EQ(gpatlas_ros::modelForTrainingSet("/nobody/training_set", training, gpatlas_core::SurfaceModelConfig(),
                                             &replica, &error),
            gpatlas_ros::ModelSource::kRefitted)
      << error;
  ASSERT_NE(replica, original);
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(0.5, 0.0, 0.16), Eigen::Vector3d(0.52, 0.03, 0.1),
                                   Eigen::Vector3d(0.5, 0.0, 0.05)}) {
    EXPECT_NEAR(replica->mean(x), original->mean(x), 1e-9);
    EXPECT_NEAR(replica->variance(x), original->variance(x), 1e-9);
  }
  // A message that describes no model is an error, not a model.
  gpatlas_msgs::TrainingSet empty = training;
  empty.points.clear();
  EXPECT_EQ(gpatlas_ros::modelForTrainingSet("/nobody/training_set", empty, gpatlas_core::SurfaceModelConfig(),
                                             &replica, &error),
            gpatlas_ros::ModelSource::kFailed);
}

}  // namespace

namespace {

// The collision maps: a topic attended before its first map says "wait", a failed build is
// offered as none (so nobody waits for it), and a withdrawn topic is no longer attended.
TEST(SharedCollisionMaps, AttendedOfferedAndFailedMapsAreToldApart) {
  const std::string topic = "/test/collision_map/training_set";
  gpatlas_msgs::TrainingSet t1, t2;
  t1.sequence = 1;
  t1.header.stamp = ros::Time(10.0);
  t2.sequence = 2;
  t2.header.stamp = ros::Time(11.0);
  EXPECT_FALSE(gpatlas_ros::SharedCollisionMaps::attended(topic));
  gpatlas_ros::SharedCollisionMaps::attend(topic);
  EXPECT_TRUE(gpatlas_ros::SharedCollisionMaps::attended(topic));
  bool offered = true;
  EXPECT_EQ(gpatlas_ros::SharedCollisionMaps::find(topic, t1, &offered), nullptr);
  EXPECT_FALSE(offered);
  auto map = std::make_shared<const octomap::OcTree>(0.01);
  gpatlas_ros::SharedCollisionMaps::offer(topic, t1, map);
  gpatlas_ros::SharedCollisionMaps::offer(topic, t2, nullptr);
  EXPECT_EQ(gpatlas_ros::SharedCollisionMaps::find(topic, t1, &offered), map);
  EXPECT_TRUE(offered);
  EXPECT_EQ(gpatlas_ros::SharedCollisionMaps::find(topic, t2, &offered), nullptr);
  EXPECT_TRUE(offered);
  gpatlas_ros::SharedCollisionMaps::withdraw(topic);
  EXPECT_FALSE(gpatlas_ros::SharedCollisionMaps::attended(topic));
  EXPECT_EQ(gpatlas_ros::SharedCollisionMaps::find(topic, t1, &offered), nullptr);
  EXPECT_FALSE(offered);
}

}  // namespace
