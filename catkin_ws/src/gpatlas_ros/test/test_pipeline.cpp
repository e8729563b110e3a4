// Drives pipeline.launch the way a user does: a cloud in, rosservice calls out.

#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/CollisionMapStatus.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/OctomapBinary.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/RemoveObservations.h>
#include <gpatlas_msgs/SaveMap.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <gpatlas_conversions/conversions.h>

#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nodelet/NodeletList.h>
#include <shape_msgs/Mesh.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Geometry>

#include <cstdio>
#include <fstream>
#include <limits>
#include <mutex>
#include <random>

namespace {

const Eigen::Vector3d kCentre(0.7, 0.0, 0.06);
constexpr double kRadius = 0.06;
const Eigen::Vector3d kCameraPosition(1.2, 0.0, 0.45);

// Camera pose in the world: looking from kCameraPosition at the sphere (z forward).
Eigen::Isometry3d cameraPose() {
  const Eigen::Vector3d z = (kCentre - kCameraPosition).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = y;
  pose.linear().col(2) = z;
  pose.translation() = kCameraPosition;
  return pose;
}

// What the camera sees: the sphere's visible side and the table around it, in the world frame.
std::vector<Eigen::Vector3d> syntheticViewInWorld() {
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  std::vector<Eigen::Vector3d> world;
  while (world.size() < 1500) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    const Eigen::Vector3d p = kCentre + kRadius * d;
    if (d.dot(kCameraPosition - p) > 0.0 && p.z() > 0.002) world.push_back(p);
  }
  for (double x = 0.4; x <= 1.0; x += 0.01)
    for (double y = -0.3; y <= 0.3; y += 0.01) {
      const Eigen::Vector3d p(x, y, 0.0);
      if ((p - Eigen::Vector3d(kCentre.x(), kCentre.y(), 0.0)).norm() > kRadius) world.push_back(p);
    }
  return world;
}

// The same in the camera frame, plus a few NaN pixels as real sensors produce.
sensor_msgs::PointCloud2 syntheticView() {
  const Eigen::Isometry3d to_camera = cameraPose().inverse();
  std::vector<Eigen::Vector3d> camera;
  for (const auto& p : syntheticViewInWorld()) camera.push_back(to_camera * p);
  camera.emplace_back(std::nan(""), 0.0, 0.0);
  auto cloud = gpatlas_conversions::pointsToCloud(camera, {}, 1.0, "test_camera");
  return cloud;
}

double sphereError(const geometry_msgs::Point& p) {
  return std::abs((gpatlas_conversions::fromMsg(p) - kCentre).norm() - kRadius);
}

template <typename Srv>
bool call(const std::string& name, Srv& srv) {
  if (!ros::service::waitForService(name, ros::Duration(30.0))) return false;
  return ros::service::call(name, srv);
}

// Bad clouds are refused without a model appearing and without taking the manager down.
TEST(Pipeline, BadCloudsLeaveNoModelAndTheManagerAlive) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<sensor_msgs::PointCloud2>("/test/camera_points", 1, true);
  std::vector<Eigen::Vector3d> nan_points(50, Eigen::Vector3d::Constant(std::nan("")));
  for (const auto& points : {std::vector<Eigen::Vector3d>{}, nan_points,
                             // a table alone: no object cluster
                             [] {
                               std::vector<Eigen::Vector3d> table;
                               for (double x = 0.4; x <= 1.0; x += 0.01)
                                 for (double y = -0.3; y <= 0.3; y += 0.01) table.emplace_back(x, y, 0.0);
                               return table;
                             }()}) {
    auto cloud = gpatlas_conversions::pointsToCloud(points, {}, 1.0, "world");
    cloud.header.stamp = ros::Time::now();
    pub.publish(cloud);
    ros::Duration(1.0).sleep();
  }
  // A good view without a frame: refused, not taken for world coordinates.
  auto frameless = gpatlas_conversions::pointsToCloud(syntheticViewInWorld(), {}, 1.0, "");
  frameless.header.stamp = ros::Time::now();
  pub.publish(frameless);
  ros::Duration(2.0).sleep();
  gpatlas_msgs::GetNextTouch touch;
  touch.request.use_v_max = true;
  touch.request.v_max = 0.1;
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", touch));
  EXPECT_EQ(touch.response.status, gpatlas_msgs::GetNextTouch::Response::NO_MODEL);
  // The pipeline's four nodelets and pipeline.test's collision_map_without_urdf.
  ASSERT_TRUE(ros::service::waitForService("/gpatlas/collision_map_without_urdf/plan_approach", ros::Duration(30.0)));
  nodelet::NodeletList list;
  ASSERT_TRUE(call("/gpatlas/gpatlas_manager/list", list));
  EXPECT_EQ(list.response.nodelets.size(), 5u);
}

TEST(Pipeline, AnswersBeforeTheModelExists) {
  gpatlas_msgs::GetNextTouch touch;
  touch.request.use_v_max = true;
  touch.request.v_max = 0.1;
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", touch));
  EXPECT_EQ(touch.response.status, gpatlas_msgs::GetNextTouch::Response::NO_MODEL);
  EXPECT_FALSE(touch.response.message.empty());

  gpatlas_msgs::AddObservations add;
  add.request.observations.header.frame_id = "world";
  add.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(kCentre));
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", add));
  EXPECT_FALSE(add.response.success);
  EXPECT_NE(add.response.message.find("no model"), std::string::npos) << add.response.message;

  gpatlas_msgs::SaveMap save;
  save.request.path = "/tmp/gpatlas_pipeline_test_early.bt";
  ASSERT_TRUE(call("/gpatlas/collision_map/save_map", save));
  EXPECT_FALSE(save.response.success);

  gpatlas_msgs::PlanApproach approach;
  approach.request.touch.points.push_back(gpatlas_conversions::toPointMsg(kCentre + kRadius * Eigen::Vector3d::UnitX()));
  approach.request.touch.normals.push_back(gpatlas_conversions::toVectorMsg(Eigen::Vector3d::UnitX()));
  ASSERT_TRUE(call("/gpatlas/collision_map/plan_approach", approach));
  EXPECT_FALSE(approach.response.success);
  EXPECT_NE(approach.response.message.find("no collision map"), std::string::npos) << approach.response.message;
}

// The static transform of the synthetic cloud's camera frame, test_camera.
geometry_msgs::TransformStamped cameraTransform() {
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = ros::Time::now();
  tf.header.frame_id = "world";
  tf.child_frame_id = "test_camera";
  const Eigen::Isometry3d pose = cameraPose();
  const Eigen::Quaterniond q(pose.linear());
  tf.transform.translation.x = pose.translation().x();
  tf.transform.translation.y = pose.translation().y();
  tf.transform.translation.z = pose.translation().z();
  tf.transform.rotation.x = q.x();
  tf.transform.rotation.y = q.y();
  tf.transform.rotation.z = q.z();
  tf.transform.rotation.w = q.w();
  return tf;
}

// A model fitted with segmentation's support plane has outside points under the table top.
bool withSupportPlane(const gpatlas_msgs::TrainingSet::ConstPtr& m) {
  if (!m) return false;
  for (const auto& p : m->points)
    if (p.z < -0.002) return true;
  return false;
}

bool hasPointAt(const gpatlas_msgs::TrainingSet& set, const Eigen::Vector3d& x) {
  for (const auto& p : set.points)
    if ((gpatlas_conversions::fromMsg(p) - x).norm() < 1e-6) return true;
  return false;
}

// What the pipeline publishes, as the test last received it: the GP's training sets, the atlas,
// the display mesh, the collision map and its status.
class PipelineOutputs {
 public:
  explicit PipelineOutputs(ros::NodeHandle& nh) {
    training_sub_ = nh.subscribe<gpatlas_msgs::TrainingSet>(
        "/gpatlas/gp_model/training_set", 1, [this](const gpatlas_msgs::TrainingSet::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          training_ = m;
        });
    atlas_sub_ = nh.subscribe<visualization_msgs::MarkerArray>(
        "/gpatlas/atlas_planner/atlas", 1, [this](const visualization_msgs::MarkerArray::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          atlas_ = m;
        });
    // The display mesh, made in the GP nodelet's own thread when someone listens.
    shape_sub_ = nh.subscribe<shape_msgs::Mesh>("/gpatlas/gp_model/surface_shape", 1,
                                                [this](const shape_msgs::Mesh::ConstPtr& m) {
                                                  std::lock_guard<std::mutex> lock(mutex_);
                                                  shape_ = m;
                                                });
    octomap_sub_ = nh.subscribe<gpatlas_msgs::OctomapBinary>(
        "/gpatlas/collision_map/octomap_binary", 1, [this](const gpatlas_msgs::OctomapBinary::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          octomap_ = m;
        });
  }

  // Starts listening to the collision map's status.
  void listenToMapStatus(ros::NodeHandle& nh) {
    status_sub_ = nh.subscribe<gpatlas_msgs::CollisionMapStatus>(
        "/gpatlas/collision_map/status", 5, [this](const gpatlas_msgs::CollisionMapStatus::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          status_ = m;
        });
  }

  gpatlas_msgs::TrainingSet::ConstPtr training() const { return get(training_); }
  visualization_msgs::MarkerArray::ConstPtr atlas() const { return get(atlas_); }
  shape_msgs::Mesh::ConstPtr shape() const { return get(shape_); }
  gpatlas_msgs::OctomapBinary::ConstPtr octomap() const { return get(octomap_); }
  gpatlas_msgs::CollisionMapStatus::ConstPtr status() const { return get(status_); }

  // The first training set the GP publishes at or after `since` (null after 5 s).
  gpatlas_msgs::TrainingSet::ConstPtr trainingSince(const ros::Time& since) const {
    for (int i = 0; i < 50; ++i) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (training_ && training_->header.stamp >= since) return training_;
      }
      ros::Duration(0.1).sleep();
    }
    return gpatlas_msgs::TrainingSet::ConstPtr();
  }

  // The map's status once it is in `state`, else after 30 s the latest (null before any).
  gpatlas_msgs::CollisionMapStatus::ConstPtr waitForState(std::uint8_t state) const {
    for (int i = 0; i < 300; ++i) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (status_ && status_->state == state) return status_;
      }
      ros::Duration(0.1).sleep();
    }
    return status();
  }

 private:
  template <typename Ptr>
  Ptr get(const Ptr& member) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return member;
  }

  mutable std::mutex mutex_;
  gpatlas_msgs::TrainingSet::ConstPtr training_;
  visualization_msgs::MarkerArray::ConstPtr atlas_;
  shape_msgs::Mesh::ConstPtr shape_;
  gpatlas_msgs::OctomapBinary::ConstPtr octomap_;
  gpatlas_msgs::CollisionMapStatus::ConstPtr status_;
  ros::Subscriber training_sub_, atlas_sub_, shape_sub_, octomap_sub_, status_sub_;
};

// Only object points reach the GP: every surface point is on the sphere, none on or under
// the table top (z = 0). The camera's free space (sensor_frame test_camera, see
// pipeline.test) adds outside points in front of the sphere, each labelled with a distance to
// the view that is at least its true distance to the sphere, inside points behind it, and
// outside points under the table.
void expectTrainingFromTheView(const gpatlas_msgs::TrainingSet& training) {
  ASSERT_EQ(training.labels.size(), training.points.size());
  ASSERT_EQ(training.surface_distances_m.size(), training.points.size());
  std::size_t view_free_space = 0, occluded_interior = 0, below_table = 0;
  for (std::size_t i = 0; i < training.points.size(); ++i) {
    const auto& p = training.points[i];
    if (p.z < -0.002) {
      // Segmentation's support plane (the table top, z = 0): outside points under it, labelled
      // with their depth.
      EXPECT_EQ(training.labels[i], 1);
      EXPECT_NEAR(training.surface_distances_m[i], -p.z, 0.003);
      ++below_table;
      continue;
    }
    if (training.labels[i] == 0) {
      EXPECT_LT(sphereError(p), 0.004);
    } else if (training.labels[i] == 1) {
      const double distance = (gpatlas_conversions::fromMsg(p) - kCentre).norm() - kRadius;
      EXPECT_GT(distance, 0.0);
      EXPECT_GE(training.surface_distances_m[i] + 0.004, distance);
      ++view_free_space;
    } else {
      // The view's occluded interior (occluded_interior/*): inside the sphere, labelled with a
      // distance to the view at least its true depth, and clear of the table (clearance_m).
      EXPECT_GE(p.z, 0.005 - 0.002);
      const double depth = kRadius - (gpatlas_conversions::fromMsg(p) - kCentre).norm();
      EXPECT_GT(depth, 0.0);
      EXPECT_GE(training.surface_distances_m[i] + 0.004, depth);
      ++occluded_interior;
    }
  }
  EXPECT_GT(view_free_space, 100u);
  EXPECT_GT(occluded_interior, 10u);
  // The view itself travels with it, for atlas_frontier's shadow: the camera's origin and the
  // object's points, every one on the sphere's side facing the camera.
  EXPECT_LT((gpatlas_conversions::fromMsg(training.view_origin) - kCameraPosition).norm(), 1e-6);
  EXPECT_GT(training.view_points.size(), 100u);
  for (const auto& q : training.view_points) {
    const Eigen::Vector3d p(q.x, q.y, q.z);
    EXPECT_LT(std::abs((p - kCentre).norm() - kRadius), 0.004);
    EXPECT_GT((p - kCentre).dot(kCameraPosition - kCentre), 0.0);
  }
  // Two layers (below_support/depth_fractions) of the 8 x 8 grid, each cut to the sphere's disc.
  EXPECT_GE(below_table, 2u * 40u);
}

// The first touch, planned on the model of the view.
void planTheFirstTouch(gpatlas_msgs::GetNextTouch& touch) {
  // The planner needs the latched training set too; retry while it reports no model.
  for (int attempt = 0; attempt < 20; ++attempt) {
    touch.request.use_v_max = true;
    touch.request.v_max = 0.1;
    // The paper's rule: the touch the approach test below is laid out for.
    touch.request.stop_rule = gpatlas_msgs::GetNextTouch::Request::STOP_RULE_V_MAX_ONLY;
    touch.request.strategy = "atlas_poke";
    ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", touch));
    if (touch.response.status != gpatlas_msgs::GetNextTouch::Response::NO_MODEL) break;
    ros::Duration(0.5).sleep();
  }
  ASSERT_EQ(touch.response.status, gpatlas_msgs::GetNextTouch::Response::TOUCH) << touch.response.message;
  ASSERT_FALSE(touch.response.touch.points.empty());
  ASSERT_EQ(touch.response.touch.points.size(), touch.response.touch.normals.size());
  EXPECT_EQ(touch.response.touch.header.frame_id, "world");
  // A poke touches the path's end, where the model extrapolates into the unseen side: it lies
  // within half the radius of the true sphere (the ray probe starts 10 cm out along the normal,
  // so such a touch still reaches the object).
  EXPECT_EQ(touch.response.touch.kind, gpatlas_msgs::Touch::POKE);
  for (const auto& p : touch.response.touch.points) EXPECT_LT(sphereError(p), 0.5 * kRadius);
  // It ends where the model needs evidence: above V_max, or where no measurement vouches for the
  // surface. A view point vouches within evidence/view_max_distance (0.2) of the model's scale,
  // at least the sphere's radius for a view of its half, and segmentation's 2 mm voxels keep a
  // point within a voxel's diagonal (3.5 mm) of every one the camera saw: an unsupported end
  // lies more than 0.2 * kRadius - 3.5 mm from the view.
  const Eigen::Vector3d touch_end = gpatlas_conversions::fromMsg(touch.response.touch.points.back());
  double view_distance = std::numeric_limits<double>::infinity();
  for (const auto& v : syntheticViewInWorld()) view_distance = std::min(view_distance, (v - touch_end).norm());
  EXPECT_TRUE(touch.response.touch.variances.back() > 0.1 || view_distance > 0.2 * kRadius - 0.0035)
      << "variance " << touch.response.touch.variances.back() << ", " << view_distance << " m from the view";
}

// The atlas, the collision map and the predicted surface are published.
void expectAtlasMapAndShape(const PipelineOutputs& outputs) {
  // The map is built in the collision map's own thread: allow for a loaded machine.
  for (int i = 0; i < 300 && !(outputs.atlas() && outputs.octomap()); ++i) {
    ros::Duration(0.1).sleep();
  }
  const visualization_msgs::MarkerArray::ConstPtr atlas = outputs.atlas();
  const gpatlas_msgs::OctomapBinary::ConstPtr octomap = outputs.octomap();
  ASSERT_TRUE(atlas);
  EXPECT_GT(atlas->markers.size(), 2u);
  ASSERT_TRUE(octomap);
  EXPECT_FALSE(octomap->data.empty());
  for (int i = 0; i < 100 && !outputs.shape(); ++i) ros::Duration(0.1).sleep();
  const shape_msgs::Mesh::ConstPtr shape = outputs.shape();
  ASSERT_TRUE(shape) << "no predicted surface on ~surface_shape";
  EXPECT_GT(shape->triangles.size(), 100u);
  for (const auto& v : shape->vertices) EXPECT_LT(sphereError(v), 0.5 * kRadius);
  EXPECT_EQ(octomap->id, "OcTree");
}

// A strategy of one's own, bad requests, a request for a newer model, and earlier touches'
// targets as evidence.
void expectPlannerAnswers() {
  // A strategy from a library named in strategy_libraries answers like the built-in ones.
  gpatlas_msgs::GetNextTouch own;
  own.request.use_v_max = true;
  own.request.v_max = 0.1;
  own.request.strategy = "farthest_from_evidence";
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", own));
  ASSERT_EQ(own.response.status, gpatlas_msgs::GetNextTouch::Response::TOUCH) << own.response.message;
  EXPECT_EQ(own.response.touch.strategy, "farthest_from_evidence");
  ASSERT_EQ(own.response.touch.points.size(), 1u);
  EXPECT_LT(sphereError(own.response.touch.points[0]), 0.5 * kRadius);

  // Bad requests get a status and a message, and the nodelets keep answering.
  gpatlas_msgs::GetNextTouch bad;
  bad.request.use_v_max = true;
  bad.request.v_max = -1.0;
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", bad));
  EXPECT_EQ(bad.response.status, gpatlas_msgs::GetNextTouch::Response::ERROR);
  EXPECT_NE(bad.response.message.find("use_v_max"), std::string::npos) << bad.response.message;
  // A position sd bound that is not a number, or 0: the refusal names the stop rules as
  // GetNextTouch.srv does.
  bad.request.v_max = 0.1;
  bad.request.stop_rule = gpatlas_msgs::GetNextTouch::Request::STOP_RULE_POSITION_SD;
  for (const double bound : {std::numeric_limits<double>::quiet_NaN(), 0.0}) {
    bad.request.max_position_sd_m = bound;
    ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", bad));
    EXPECT_EQ(bad.response.status, gpatlas_msgs::GetNextTouch::Response::ERROR);
    EXPECT_NE(bad.response.message.find("STOP_RULE_V_MAX_ONLY: the V_max rule alone"), std::string::npos)
        << bad.response.message;
    EXPECT_NE(bad.response.message.find("STOP_RULE_PARAMETER: the parameter exploration/max_position_sd_m"),
              std::string::npos) << bad.response.message;
  }
  bad.request.stop_rule = 7;
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", bad));
  EXPECT_EQ(bad.response.status, gpatlas_msgs::GetNextTouch::Response::ERROR);
  EXPECT_NE(bad.response.message.find("stop_rule must be"), std::string::npos) << bad.response.message;
  bad.request.stop_rule = gpatlas_msgs::GetNextTouch::Request::STOP_RULE_PARAMETER;
  bad.request.strategy = "no_such_strategy";
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", bad));
  EXPECT_EQ(bad.response.status, gpatlas_msgs::GetNextTouch::Response::ERROR);
  EXPECT_NE(bad.response.message.find("atlas_poke"), std::string::npos) << bad.response.message;

  // A request for a model newer than the planner's (its training set not rebuilt yet) is told so,
  // and one for the model it holds is planned.
  gpatlas_msgs::GetNextTouch fresh;
  fresh.request.use_v_max = true;
  fresh.request.v_max = 0.1;
  fresh.request.model_stamp = ros::Time::now() + ros::Duration(3600.0);
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", fresh));
  EXPECT_EQ(fresh.response.status, gpatlas_msgs::GetNextTouch::Response::STALE_MODEL) << fresh.response.message;
  EXPECT_NE(fresh.response.message.find("older"), std::string::npos) << fresh.response.message;
  fresh.request.model_stamp = ros::Time(1.0);
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", fresh));
  EXPECT_EQ(fresh.response.status, gpatlas_msgs::GetNextTouch::Response::TOUCH) << fresh.response.message;

  // Where earlier touches aimed counts as evidence: with the variance out of the way (V_max
  // 1e9, the V_max rule alone), the unseen side still needs a touch (max_evidence_distance),
  // until the request says that touches aimed all over the sphere.
  gpatlas_msgs::GetNextTouch evidence_only;
  evidence_only.request.use_v_max = true;
  evidence_only.request.v_max = 1e9;
  evidence_only.request.stop_rule = gpatlas_msgs::GetNextTouch::Request::STOP_RULE_V_MAX_ONLY;
  evidence_only.request.strategy = "atlas_poke";
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", evidence_only));
  EXPECT_EQ(evidence_only.response.status, gpatlas_msgs::GetNextTouch::Response::TOUCH) << evidence_only.response.message;
  for (const Eigen::Vector3d& direction : gpatlas_core::fibonacciSphere(400))
    evidence_only.request.attempted_targets.push_back(gpatlas_conversions::toPointMsg(kCentre + kRadius * direction));
  ASSERT_TRUE(call("/gpatlas/atlas_planner/next_touch", evidence_only));
  EXPECT_EQ(evidence_only.response.status, gpatlas_msgs::GetNextTouch::Response::CONVERGED)
      << evidence_only.response.message;
}

// Touch results go into the model; bad ones are refused with the reason. `mixed`: the last
// request, a good contact next to a NaN one.
void addTouchResults(gpatlas_msgs::AddObservations& mixed) {
  // A touch result goes back into the model.
  gpatlas_msgs::AddObservations add;
  add.request.observations.header.frame_id = "world";
  add.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(kCentre + kRadius * Eigen::Vector3d(0, 0, 1)));
  add.request.observations.free_space.push_back(gpatlas_conversions::toPointMsg(kCentre + 1.2 * kRadius * Eigen::Vector3d(0, 0, 1)));
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", add));
  EXPECT_TRUE(add.response.success) << add.response.message;
  EXPECT_EQ(add.response.num_added, 2u);
  add.request.observations.contact_normals.resize(3);  // mismatched: refused with a reason
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", add));
  EXPECT_FALSE(add.response.success);

  // One outlier contact half a metre off the sphere: refused by the gate, and the model keeps its
  // frame (the training sets below have no surface point off the sphere).
  gpatlas_msgs::AddObservations outlier;
  outlier.request.observations.header.frame_id = "world";
  outlier.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(kCentre + Eigen::Vector3d(0.5, 0.0, 0.0)));
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", outlier));
  EXPECT_FALSE(outlier.response.success);
  EXPECT_EQ(outlier.response.num_refused, 1u);
  EXPECT_EQ(outlier.response.num_added, 0u);
  EXPECT_NE(outlier.response.message.find("inconsistent with the model"), std::string::npos) << outlier.response.message;
  // Without a frame: refused with the reason.
  outlier.request.observations.header.frame_id = "";
  outlier.request.observations.contacts = {gpatlas_conversions::toPointMsg(kCentre + kRadius * Eigen::Vector3d(1, 0, 0))};
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", outlier));
  EXPECT_FALSE(outlier.response.success);
  EXPECT_NE(outlier.response.message.find("frame_id is empty"), std::string::npos) << outlier.response.message;
  // A NaN contact next to a good one: the good one is added and the NaN counted.
  mixed.request.observations.header.frame_id = "world";
  mixed.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(kCentre + kRadius * Eigen::Vector3d(1, 0, 0)));
  mixed.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(Eigen::Vector3d(std::nan(""), 0.0, 0.0)));
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", mixed));
  EXPECT_TRUE(mixed.response.success) << mixed.response.message;
  EXPECT_EQ(mixed.response.num_contacts_added, 1u);
  EXPECT_EQ(mixed.response.num_refused, 1u);
  EXPECT_NE(mixed.response.message.find("1 not finite"), std::string::npos) << mixed.response.message;
  EXPECT_GT(mixed.response.batch_id, 0u);
}

// A wrong touch, its contact 2 cm inside the sphere, is taken back out by its batch id: the
// training set no longer has it, and the other touches stay.
void removeAWrongTouch(const PipelineOutputs& outputs, std::uint32_t last_batch_id) {
  const Eigen::Vector3d wrong_contact = kCentre + (kRadius - 0.02) * Eigen::Vector3d(0, -1, 0);
  gpatlas_msgs::AddObservations wrong;
  wrong.request.observations.header.frame_id = "world";
  wrong.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(wrong_contact));
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", wrong));
  ASSERT_TRUE(wrong.response.success) << wrong.response.message;
  ASSERT_GT(wrong.response.batch_id, last_batch_id);
  gpatlas_msgs::RemoveObservations remove;
  remove.request.batch_ids.push_back(wrong.response.batch_id);
  const ros::Time before_remove = ros::Time::now();
  ASSERT_TRUE(call("/gpatlas/gp_model/remove_observations", remove));
  ASSERT_TRUE(remove.response.success) << remove.response.message;
  EXPECT_EQ(remove.response.removed_batch_ids, std::vector<std::uint32_t>{wrong.response.batch_id});
  const gpatlas_msgs::TrainingSet::ConstPtr after_remove = outputs.trainingSince(before_remove);
  ASSERT_TRUE(after_remove) << "no training set after remove_observations";
  EXPECT_FALSE(hasPointAt(*after_remove, wrong_contact)) << "the removed contact is still there";
  EXPECT_TRUE(hasPointAt(*after_remove, kCentre + kRadius * Eigen::Vector3d(1, 0, 0))) << "a kept touch was lost";
  // Again: that batch is gone; and a request that names nothing is refused.
  ASSERT_TRUE(call("/gpatlas/gp_model/remove_observations", remove));
  EXPECT_FALSE(remove.response.success);
  EXPECT_NE(remove.response.message.find("no batch"), std::string::npos) << remove.response.message;
  gpatlas_msgs::RemoveObservations nothing;
  ASSERT_TRUE(call("/gpatlas/gp_model/remove_observations", nothing));
  EXPECT_FALSE(nothing.response.success);
}

// A contact with its normal, in the camera's frame: the model adds it, an inside point 3 mm
// behind it (touch/contact_inside_depth_m) and two slopes across the normal
// (touch/contact_tangent_noise_sigma), all moved to the world frame. `updated`: the training set
// after it.
void addAContactWithItsNormal(const PipelineOutputs& outputs, gpatlas_msgs::TrainingSet::ConstPtr& updated) {
  const Eigen::Vector3d side_normal = Eigen::Vector3d(0.0, 1.0, 1.0).normalized();
  const Eigen::Vector3d side_contact = kCentre + kRadius * side_normal;
  const Eigen::Isometry3d world_to_camera = cameraPose().inverse();
  gpatlas_msgs::AddObservations with_normal;
  with_normal.request.observations.header.frame_id = "test_camera";
  with_normal.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(world_to_camera * side_contact));
  with_normal.request.observations.contact_normals.push_back(
      gpatlas_conversions::toVectorMsg(world_to_camera.linear() * side_normal));
  const ros::Time before_add = ros::Time::now();
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", with_normal));
  EXPECT_TRUE(with_normal.response.success) << with_normal.response.message;
  EXPECT_EQ(with_normal.response.num_added, 4u);
  updated = outputs.trainingSince(before_add);
  ASSERT_TRUE(updated) << "no training set after add_observations";
  std::size_t surface_points = 0;
  for (std::size_t i = 0; i < updated->points.size(); ++i)
    if (updated->labels[i] == 0) {
      ++surface_points;
      EXPECT_LT(sphereError(updated->points[i]), 0.01) << "a surface point off the sphere";
    }
  EXPECT_GT(surface_points, 0u);
  const Eigen::Vector3d expected_inside = side_contact - 0.003 * side_normal;
  bool found_inside = false;
  for (std::size_t i = 0; i < updated->points.size(); ++i)
    if (updated->labels[i] == -1 && (gpatlas_conversions::fromMsg(updated->points[i]) - expected_inside).norm() < 1e-6) {
      found_inside = true;
      EXPECT_NEAR(updated->surface_distances_m[i], 0.003, 1e-9);
    }
  EXPECT_TRUE(found_inside) << "no inside point 3 mm behind the contact";
  int tangents = 0;
  for (std::size_t i = 0; i < updated->slope_directions.size(); ++i) {
    const Eigen::Vector3d direction(updated->slope_directions[i].x, updated->slope_directions[i].y,
                                    updated->slope_directions[i].z);
    if (direction.norm() == 0.0 || (gpatlas_conversions::fromMsg(updated->points[i]) - side_contact).norm() > 1e-6) continue;
    EXPECT_NEAR(direction.dot(side_normal), 0.0, 1e-9) << "a slope not across the world-frame normal";
    ++tangents;
  }
  EXPECT_EQ(tangents, 2);
}

// Free space 1 mm from the deepest occluded-interior guess contradicts its claim (a solid
// ball of its depth around it): the model drops it (occluded_interior/retract_on_touch).
void contradictTheDeepestGuess(const PipelineOutputs& outputs, const gpatlas_msgs::TrainingSet& training,
                               const gpatlas_msgs::TrainingSet& updated) {
  Eigen::Vector3d deepest_guess = Eigen::Vector3d::Zero();
  double deepest = 0.0;
  for (std::size_t i = 0; i < training.points.size(); ++i)
    if (training.labels[i] == -1 && training.surface_distances_m[i] > deepest) {
      deepest = training.surface_distances_m[i];
      deepest_guess = gpatlas_conversions::fromMsg(training.points[i]);
    }
  ASSERT_GT(deepest, 0.01);
  gpatlas_msgs::AddObservations contradicting;
  contradicting.request.observations.header.frame_id = "world";
  contradicting.request.observations.free_space.push_back(
      gpatlas_conversions::toPointMsg(deepest_guess + Eigen::Vector3d(0.001, 0.0, 0.0)));
  const ros::Time before_contradiction = ros::Time::now();
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", contradicting));
  EXPECT_TRUE(contradicting.response.success) << contradicting.response.message;
  EXPECT_NE(contradicting.response.message.find("(1 dropped"), std::string::npos) << contradicting.response.message;
  const gpatlas_msgs::TrainingSet::ConstPtr retracted = outputs.trainingSince(before_contradiction);
  ASSERT_TRUE(retracted) << "no training set after the contradicting observation";
  EXPECT_EQ(retracted->points.size(), updated.points.size());  // one guess out, one free point in
  for (std::size_t i = 0; i < retracted->points.size(); ++i)
    EXPECT_GT((gpatlas_conversions::fromMsg(retracted->points[i]) - deepest_guess).norm(), 1e-6) << "the guess is still there";
}

// The probe's way to the planned touch on that map and the table, from the far side of the
// sphere, so that the straight line runs through it: the path ends at the approach pose 10 cm
// out along the touch's normal, and the tip's centre stays out of the true sphere and above
// the table. Bad requests are refused with the reason. `approach`: the good request.
void planTheApproach(const gpatlas_msgs::GetNextTouch& touch, const gpatlas_msgs::CollisionMapStatus& first_map,
                     gpatlas_msgs::PlanApproach& approach) {
  const Eigen::Vector3d target = gpatlas_conversions::fromMsg(touch.response.touch.points.front());
  const Eigen::Vector3d target_normal = gpatlas_conversions::fromMsg(touch.response.touch.normals.front()).normalized();
  const Eigen::Vector3d across = Eigen::Vector3d(target_normal.x(), target_normal.y(), 0.0).normalized();
  ASSERT_TRUE(across.allFinite()) << "the touch is on top of the sphere";
  approach.request.touch = touch.response.touch;
  approach.request.start = gpatlas_conversions::toPointMsg(kCentre - 0.25 * across + Eigen::Vector3d(0.0, 0.0, 0.03));
  ASSERT_TRUE(call("/gpatlas/collision_map/plan_approach", approach));
  ASSERT_TRUE(approach.response.success) << approach.response.message;
  EXPECT_EQ(approach.response.map_training_sequence, first_map.map_training_sequence);
  EXPECT_GE(approach.response.approach.size(), 3u);  // a detour around the sphere
  EXPECT_LT((gpatlas_conversions::fromMsg(approach.response.approach.back()) - (target + 0.1 * target_normal)).norm(), 1e-6);
  ASSERT_EQ(approach.response.probing.size(), 2u);
  EXPECT_LT((gpatlas_conversions::fromMsg(approach.response.probing.back()) - target).norm(), 1e-6);
  EXPECT_EQ(approach.response.retreat.size(), approach.response.approach.size());
  double closest = 1.0, lowest = 1.0;
  for (std::size_t i = 0; i + 1 < approach.response.approach.size(); ++i) {
    const Eigen::Vector3d a = gpatlas_conversions::fromMsg(approach.response.approach[i]);
    const Eigen::Vector3d b = gpatlas_conversions::fromMsg(approach.response.approach[i + 1]);
    for (int s = 0; s <= 100; ++s) {
      const Eigen::Vector3d p = a + (b - a) * (s / 100.0);
      closest = std::min(closest, (p - kCentre).norm() - kRadius);
      lowest = std::min(lowest, p.z());
    }
  }
  std::cout << "approach: " << approach.response.approach.size() << " waypoints in "
            << approach.response.planning_time_s * 1000 << " ms, the tip's centre at least " << closest * 1000
            << " mm from the sphere and " << lowest * 1000 << " mm above the table\n";
  EXPECT_GT(closest, 0.02);  // the tip's radius: the tip itself stays out of the sphere
  EXPECT_GT(lowest, 0.02);   // and off the table
  // Bad requests: another frame, a touch without waypoints, a NaN start.
  gpatlas_msgs::PlanApproach bad_approach = approach;
  bad_approach.request.touch.header.frame_id = "test_camera";
  ASSERT_TRUE(call("/gpatlas/collision_map/plan_approach", bad_approach));
  EXPECT_FALSE(bad_approach.response.success);
  EXPECT_NE(bad_approach.response.message.find("frame"), std::string::npos) << bad_approach.response.message;
  bad_approach = approach;
  bad_approach.request.touch.points.clear();
  bad_approach.request.touch.normals.clear();
  bad_approach.request.touch.variances.clear();
  ASSERT_TRUE(call("/gpatlas/collision_map/plan_approach", bad_approach));
  EXPECT_FALSE(bad_approach.response.success);
  bad_approach = approach;
  bad_approach.request.start.x = std::nan("");
  ASSERT_TRUE(call("/gpatlas/collision_map/plan_approach", bad_approach));
  EXPECT_FALSE(bad_approach.response.success);
  EXPECT_NE(bad_approach.response.message.find("finite"), std::string::npos) << bad_approach.response.message;
  // Asked to plan for an arm without a URDF: why, and the manager's other nodelets still answer.
  bad_approach = approach;
  ASSERT_TRUE(call("/gpatlas/collision_map_without_urdf/plan_approach", bad_approach));
  EXPECT_FALSE(bad_approach.response.success);
  EXPECT_NE(bad_approach.response.message.find("robot_description"), std::string::npos) << bad_approach.response.message;
}

// save_map writes the map, to an absolute path, to a relative one (answered with the absolute
// path it became), and refuses an unwritable one with the reason.
void saveTheMap() {
  gpatlas_msgs::SaveMap save;
  save.request.path = "/tmp/gpatlas_pipeline_test.bt";
  ASSERT_TRUE(call("/gpatlas/collision_map/save_map", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  std::ifstream written(save.request.path, std::ios::binary | std::ios::ate);
  EXPECT_GT(static_cast<long>(written.tellg()), 100L);
  std::remove(save.request.path.c_str());
  // A relative path is answered with the absolute one it became; an unwritable one with the reason.
  save.request.path = "gpatlas_pipeline_test_relative.bt";
  ASSERT_TRUE(call("/gpatlas/collision_map/save_map", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  const std::string prefix = "wrote /";
  ASSERT_EQ(save.response.message.rfind(prefix, 0), 0u) << save.response.message;
  const std::string written_path =
      save.response.message.substr(prefix.size() - 1, save.response.message.find(" (") - (prefix.size() - 1));
  EXPECT_TRUE(std::ifstream(written_path).good()) << written_path;
  std::remove(written_path.c_str());
  save.request.path = "/nonexistent_gpatlas_directory/map.bt";
  ASSERT_TRUE(call("/gpatlas/collision_map/save_map", save));
  EXPECT_FALSE(save.response.success);
  EXPECT_NE(save.response.message.find("No such file or directory"), std::string::npos) << save.response.message;
}

// The map says which training set it shows. Once it is current, a training set whose map
// cannot be built (here a malformed one) leaves the old map published, reported STALE with the
// reason, and save_map says so.
void keepTheMapOfABadTrainingSet(ros::NodeHandle& nh, const PipelineOutputs& outputs,
                                 const gpatlas_msgs::TrainingSet& updated) {
  const auto current = outputs.waitForState(gpatlas_msgs::CollisionMapStatus::CURRENT);
  ASSERT_TRUE(current);
  ASSERT_EQ(current->state, gpatlas_msgs::CollisionMapStatus::CURRENT) << current->message;
  EXPECT_EQ(current->map_training_sequence, current->latest_training_sequence);
  ros::Publisher bad_training = nh.advertise<gpatlas_msgs::TrainingSet>("/gpatlas/gp_model/training_set", 1, true);
  for (int i = 0; i < 50 && bad_training.getNumSubscribers() < 3; ++i) ros::Duration(0.1).sleep();  // planner, map, this test
  gpatlas_msgs::TrainingSet malformed = updated;
  malformed.sequence = current->latest_training_sequence + 100;
  malformed.labels.resize(3);
  bad_training.publish(malformed);
  const auto stale = outputs.waitForState(gpatlas_msgs::CollisionMapStatus::STALE);
  ASSERT_TRUE(stale);
  ASSERT_EQ(stale->state, gpatlas_msgs::CollisionMapStatus::STALE) << stale->message;
  EXPECT_EQ(stale->latest_training_sequence, malformed.sequence);
  EXPECT_EQ(stale->map_training_sequence, current->map_training_sequence);
  EXPECT_NE(stale->message.find("failed"), std::string::npos) << stale->message;
  gpatlas_msgs::SaveMap save;
  save.request.path = "/tmp/gpatlas_pipeline_test_stale.bt";
  ASSERT_TRUE(call("/gpatlas/collision_map/save_map", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  EXPECT_TRUE(save.response.stale);
  EXPECT_EQ(save.response.training_sequence, current->map_training_sequence);
  EXPECT_NE(save.response.message.find("STALE"), std::string::npos) << save.response.message;
  std::remove(save.request.path.c_str());
}

// add_observations does not wait for the map: a touch is answered within a second while the
// map of the touch before it is still being built (pipeline.test makes a rebuild take seconds).
void addWhileTheMapIsBuilt(const PipelineOutputs& outputs) {
  const auto touchAt = [](const Eigen::Vector3d& direction) {
    gpatlas_msgs::AddObservations touch;
    touch.request.observations.header.frame_id = "world";
    touch.request.observations.contacts.push_back(gpatlas_conversions::toPointMsg(kCentre + kRadius * direction.normalized()));
    return touch;
  };
  gpatlas_msgs::AddObservations first_touch = touchAt(Eigen::Vector3d(0.3, 0.9, 0.2));
  const ros::Time before_first_touch = ros::Time::now();
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", first_touch));
  ASSERT_TRUE(first_touch.response.success) << first_touch.response.message;
  const gpatlas_msgs::TrainingSet::ConstPtr first_set = outputs.trainingSince(before_first_touch);
  ASSERT_TRUE(first_set);
  gpatlas_msgs::AddObservations second_touch = touchAt(Eigen::Vector3d(-0.3, 0.9, 0.2));
  const ros::WallTime asked = ros::WallTime::now();
  ASSERT_TRUE(call("/gpatlas/gp_model/add_observations", second_touch));
  const double answered_s = (ros::WallTime::now() - asked).toSec();
  EXPECT_TRUE(second_touch.response.success) << second_touch.response.message;
  EXPECT_LT(answered_s, 1.0);
  const gpatlas_msgs::CollisionMapStatus::ConstPtr status = outputs.status();
  ASSERT_TRUE(status);
  EXPECT_LT(status->map_training_sequence, first_set->sequence)
      << "the first touch's map was done before the second touch was answered: the rebuild was too quick to tell";
}

TEST(Pipeline, PlansATouchOnTheSphereFromACameraCloud) {
  ros::NodeHandle nh;
  tf2_ros::StaticTransformBroadcaster broadcaster;
  PipelineOutputs outputs(nh);
  ros::Publisher cloud_pub = nh.advertise<sensor_msgs::PointCloud2>("/test/camera_points", 1, true);

  // One capture, published before the camera's transform exists (as when the camera driver
  // starts before robot_state_publisher): the pipeline must wait for tf, not drop the cloud
  // after tf_timeout_s (0.5 s).
  sensor_msgs::PointCloud2 cloud = syntheticView();
  cloud.header.stamp = ros::Time::now();
  cloud_pub.publish(cloud);
  ros::Duration(2.0).sleep();
  broadcaster.sendTransform(cameraTransform());
  gpatlas_msgs::TrainingSet::ConstPtr training;
  const ros::Time deadline = ros::Time::now() + ros::Duration(60.0);
  while (ros::ok() && !withSupportPlane(training) && ros::Time::now() < deadline) {
    ros::Duration(0.2).sleep();
    training = outputs.training();
  }
  ASSERT_TRUE(training) << "the GP never published a training set";
  ASSERT_TRUE(withSupportPlane(training)) << "no training set used segmentation's support plane";
  ASSERT_NO_FATAL_FAILURE(expectTrainingFromTheView(*training));

  gpatlas_msgs::GetNextTouch touch;
  ASSERT_NO_FATAL_FAILURE(planTheFirstTouch(touch));
  ASSERT_NO_FATAL_FAILURE(expectAtlasMapAndShape(outputs));
  ASSERT_NO_FATAL_FAILURE(expectPlannerAnswers());

  gpatlas_msgs::AddObservations mixed;
  ASSERT_NO_FATAL_FAILURE(addTouchResults(mixed));
  ASSERT_NO_FATAL_FAILURE(removeAWrongTouch(outputs, mixed.response.batch_id));
  gpatlas_msgs::TrainingSet::ConstPtr updated;
  ASSERT_NO_FATAL_FAILURE(addAContactWithItsNormal(outputs, updated));
  ASSERT_NO_FATAL_FAILURE(contradictTheDeepestGuess(outputs, *training, *updated));

  outputs.listenToMapStatus(nh);
  // A map of the model as it is now, before it is saved (pipeline.test makes rebuilds slow).
  const auto first_map = outputs.waitForState(gpatlas_msgs::CollisionMapStatus::CURRENT);
  ASSERT_TRUE(first_map && first_map->state == gpatlas_msgs::CollisionMapStatus::CURRENT);
  gpatlas_msgs::PlanApproach approach;
  ASSERT_NO_FATAL_FAILURE(planTheApproach(touch, *first_map, approach));
  ASSERT_NO_FATAL_FAILURE(saveTheMap());
  ASSERT_NO_FATAL_FAILURE(keepTheMapOfABadTrainingSet(nh, outputs, *updated));
  ASSERT_NO_FATAL_FAILURE(addWhileTheMapIsBuilt(outputs));

  // After all of this the manager still runs every nodelet.
  nodelet::NodeletList list;
  ASSERT_TRUE(call("/gpatlas/gpatlas_manager/list", list));
  EXPECT_EQ(list.response.nodelets.size(), 5u);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_pipeline");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
