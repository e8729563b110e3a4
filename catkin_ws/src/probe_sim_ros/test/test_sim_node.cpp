// probe_sim_node end to end (launched by sim_node.test): the depth cloud and the object marker
// against the analytic sphere, touches that succeed and fail, joint_states, and nodes started
// with bad parameters that stay up and give the reason.

#include <gpatlas_msgs/Capture.h>
#include <gpatlas_msgs/Probe.h>
#include <gpatlas_conversions/conversions.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/Marker.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

namespace {

const std::string kProbe = "/probe_sim/probe";
const std::string kCapture = "/probe_sim/capture";
const std::string kWorld = "world";
const std::string kCamera = "camera_optical_frame";
constexpr double kProbeRadius = 0.02;  // the node's sphere probe (default probe_radius_m)

// The sphere the node simulates, from the same launch arguments.
struct Sphere {
  Eigen::Vector3d centre;
  double radius;
  Eigen::Vector3d top() const { return centre + radius * Eigen::Vector3d::UnitZ(); }
};

Sphere expectedSphere() {
  ros::NodeHandle pnh("~");
  double diameter = 0.0, x = 0.0, y = 0.0;
  EXPECT_TRUE(pnh.getParam("diameter_m", diameter));
  EXPECT_TRUE(pnh.getParam("object_x_m", x));
  EXPECT_TRUE(pnh.getParam("object_y_m", y));
  // procedural objects stand on the table (z = 0) with their bounding box centred on (x, y)
  return {Eigen::Vector3d(x, y, diameter / 2.0), diameter / 2.0};
}

gpatlas_msgs::Touch poke(const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  gpatlas_msgs::Touch touch;
  touch.header.frame_id = kWorld;
  touch.kind = gpatlas_msgs::Touch::POKE;
  touch.points.push_back(gpatlas_conversions::toPointMsg(point));
  touch.normals.push_back(gpatlas_conversions::toVectorMsg(normal));
  touch.variances.push_back(0.0);
  return touch;
}

gpatlas_msgs::Probe::Response callProbe(const gpatlas_msgs::Touch& touch) {
  gpatlas_msgs::Probe srv;
  srv.request.touch = touch;
  EXPECT_TRUE(ros::service::call(kProbe, srv)) << "the node did not answer " << kProbe;
  return srv.response;
}

Eigen::Isometry3d lookUp(const tf2_ros::Buffer& buffer, const std::string& frame,
                         const ros::Time& stamp) {
  const geometry_msgs::TransformStamped t =
      buffer.lookupTransform(kWorld, frame, stamp, ros::Duration(5.0));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << t.transform.translation.x, t.transform.translation.y,
      t.transform.translation.z;
  const auto& q = t.transform.rotation;
  pose.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).toRotationMatrix();
  return pose;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class SimNode : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(ros::service::waitForService(kProbe, ros::Duration(30.0)));
    ASSERT_TRUE(ros::service::waitForService(kCapture, ros::Duration(30.0)));
  }
  const Sphere sphere_ = expectedSphere();
};

TEST_F(SimNode, CaptureGivesTheVisibleSideOfTheSphereInTheCameraFrame) {
  ros::NodeHandle nh;
  std::mutex mutex;
  std::vector<sensor_msgs::PointCloud2> published;
  ros::Subscriber sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/probe_sim/points", 1, [&](const sensor_msgs::PointCloud2::ConstPtr& cloud) {
        std::lock_guard<std::mutex> lock(mutex);
        published.push_back(*cloud);
      });
  for (int i = 0; i < 50 && sub.getNumPublishers() == 0; ++i) ros::Duration(0.1).sleep();

  gpatlas_msgs::Capture srv;
  ASSERT_TRUE(ros::service::call(kCapture, srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  const sensor_msgs::PointCloud2& cloud = srv.response.cloud;
  EXPECT_EQ(cloud.header.frame_id, kCamera);
  EXPECT_FALSE(cloud.header.stamp.isZero());

  std::vector<Eigen::Vector3d> points;
  std::size_t invalid = 0;
  std::string error;
  ASSERT_TRUE(gpatlas_conversions::cloudToPoints(cloud, &points, &invalid, &error)) << error;
  EXPECT_EQ(invalid, 0u);
  // About 1200 pixels see a 15 cm sphere 1.1 m away at 320 x 240 and 58.6 degrees.
  EXPECT_GT(points.size(), 500u);

  // The camera pose as robot_state_publisher publishes it from the URDF: an independent check
  // of the pose the node renders from.
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  const Eigen::Isometry3d camera = lookUp(buffer, kCamera, ros::Time(0));
  double worst_m = 0.0;
  int facing_camera = 0;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d world = camera * p;
    worst_m = std::max(worst_m, std::abs((world - sphere_.centre).norm() - sphere_.radius));
    // Only the near side is visible: the outward normal faces the camera.
    if ((world - sphere_.centre).dot(camera.translation() - world) > 0.0) ++facing_camera;
  }
  RecordProperty("cloud_points", static_cast<int>(points.size()));
  RecordProperty("worst_distance_to_sphere_um", static_cast<int>(worst_m * 1e6));
  EXPECT_LT(worst_m, 1e-3);
  EXPECT_EQ(facing_camera, static_cast<int>(points.size()));

  // The same cloud went out on ~points.
  for (int i = 0; i < 50; ++i) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!published.empty()) break;
    }
    ros::Duration(0.1).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_FALSE(published.empty()) << "nothing on /probe_sim/points after ~capture";
  EXPECT_EQ(published.back().width * published.back().height, cloud.width * cloud.height);
}

TEST_F(SimNode, ObjectMarkerIsTheSphereOnTheTable) {
  const auto marker = ros::topic::waitForMessage<visualization_msgs::Marker>(
      "/probe_sim/object_marker", ros::Duration(10.0));
  ASSERT_TRUE(marker) << "no latched /probe_sim/object_marker";
  EXPECT_EQ(marker->type, visualization_msgs::Marker::TRIANGLE_LIST);
  EXPECT_EQ(marker->header.frame_id, kWorld);
  ASSERT_GT(marker->points.size(), 300u);
  EXPECT_EQ(marker->points.size() % 3, 0u);
  double worst_m = 0.0, lowest_z = std::numeric_limits<double>::infinity();
  for (const auto& p : marker->points) {
    const Eigen::Vector3d v = gpatlas_conversions::fromMsg(p);
    worst_m = std::max(worst_m, std::abs((v - sphere_.centre).norm() - sphere_.radius));
    lowest_z = std::min(lowest_z, v.z());
  }
  EXPECT_LT(worst_m, 1e-6);  // the vertices lie on the sphere
  EXPECT_NEAR(lowest_z, 0.0, 1e-6);  // standing on the table top
}

TEST_F(SimNode, PokeAtTheTopTouchesTheSphereThereAndTheArmShowsIt) {
  ros::NodeHandle nh;
  std::mutex mutex;
  std::vector<sensor_msgs::JointState> states;
  ros::Subscriber sub = nh.subscribe<sensor_msgs::JointState>(
      "/joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mutex);
        states.push_back(*msg);
      });
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  ros::Duration(1.0).sleep();  // joint_states at 20 Hz: a few messages before the touch

  const gpatlas_msgs::Probe::Response response =
      callProbe(poke(sphere_.top(), Eigen::Vector3d::UnitZ()));
  ASSERT_TRUE(response.success) << response.reason;
  EXPECT_EQ(response.observations.header.frame_id, kWorld);
  ASSERT_EQ(response.observations.contacts.size(), 1u);
  ASSERT_EQ(response.observations.contact_normals.size(), 1u);
  const Eigen::Vector3d contact = gpatlas_conversions::fromMsg(response.observations.contacts[0]);
  const Eigen::Vector3d normal = gpatlas_conversions::fromMsg(response.observations.contact_normals[0]);
  RecordProperty("contact_error_um", static_cast<int>((contact - sphere_.top()).norm() * 1e6));
  EXPECT_LT((contact - sphere_.top()).norm(), 1e-3);
  EXPECT_GT(normal.dot(Eigen::Vector3d::UnitZ()), std::cos(2.0 * M_PI / 180.0));
  // Free space: where the probe's centre passed, above the sphere.
  ASSERT_FALSE(response.observations.free_space.empty());
  for (const auto& p : response.observations.free_space) {
    EXPECT_GT((gpatlas_conversions::fromMsg(p) - sphere_.centre).norm(), sphere_.radius + kProbeRadius - 1e-3);
  }

  // The displayed arm goes to the touch and back: at some published configuration the probe
  // tip (the centre of its 2 cm sphere) is on the touched point, one radius above the contact.
  ros::Duration(5.0).sleep();
  std::vector<sensor_msgs::JointState> seen;
  {
    std::lock_guard<std::mutex> lock(mutex);
    seen = states;
  }
  ASSERT_GT(seen.size(), 40u) << "joint_states is not published at its rate";
  const Eigen::Vector3d touching_tip = sphere_.top() + kProbeRadius * Eigen::Vector3d::UnitZ();
  double closest_m = std::numeric_limits<double>::infinity();
  for (const sensor_msgs::JointState& state : seen) {
    ASSERT_EQ(state.name.size(), 14u);
    ASSERT_EQ(state.position.size(), 14u);
    try {
      const Eigen::Isometry3d tip = lookUp(buffer, "probe_tip", state.header.stamp);
      closest_m = std::min(closest_m, (tip.translation() - touching_tip).norm());
    } catch (const tf2::TransformException&) {
      // a state older than the listener
    }
  }
  RecordProperty("closest_displayed_tip_um", static_cast<int>(closest_m * 1e6));
  EXPECT_LT(closest_m, 3e-3);
  // ... and back at rest afterwards.
  EXPECT_EQ(seen.back().position, seen.front().position);
}

TEST_F(SimNode, JointStatesNameAllFourteenArmJoints) {
  const auto state =
      ros::topic::waitForMessage<sensor_msgs::JointState>("/joint_states", ros::Duration(5.0));
  ASSERT_TRUE(state);
  ASSERT_EQ(state->name.size(), 14u);
  ASSERT_EQ(state->position.size(), 14u);
  for (const std::string side : {"left", "right"}) {
    for (int j = 1; j <= 7; ++j) {
      const std::string name = side + "_arm_a" + std::to_string(j) + "_joint";
      EXPECT_NE(std::find(state->name.begin(), state->name.end(), name), state->name.end())
          << name;
    }
  }
  for (double q : state->position) EXPECT_TRUE(std::isfinite(q));
}

TEST_F(SimNode, TouchWithNaNFailsWithTheReasonAndTheNodeCarriesOn) {
  const gpatlas_msgs::Probe::Response nan_response = callProbe(
      poke(Eigen::Vector3d(std::nan(""), 0.0, 0.1), Eigen::Vector3d::UnitZ()));
  EXPECT_FALSE(nan_response.success);
  EXPECT_TRUE(contains(nan_response.reason, "NaN")) << nan_response.reason;
  EXPECT_TRUE(nan_response.observations.contacts.empty());

  const gpatlas_msgs::Probe::Response after =
      callProbe(poke(sphere_.top(), Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE(after.success) << after.reason;
}

TEST_F(SimNode, MalformedTouchesFailWithAReason) {
  gpatlas_msgs::Touch mismatched = poke(sphere_.top(), Eigen::Vector3d::UnitZ());
  mismatched.normals.clear();
  gpatlas_msgs::Probe::Response response = callProbe(mismatched);
  EXPECT_FALSE(response.success);
  EXPECT_FALSE(response.reason.empty());

  gpatlas_msgs::Touch empty = poke(sphere_.top(), Eigen::Vector3d::UnitZ());
  empty.points.clear();
  empty.normals.clear();
  empty.variances.clear();
  response = callProbe(empty);
  EXPECT_FALSE(response.success);
  EXPECT_FALSE(response.reason.empty());

  gpatlas_msgs::Touch other_frame = poke(sphere_.top(), Eigen::Vector3d::UnitZ());
  other_frame.header.frame_id = kCamera;
  response = callProbe(other_frame);
  EXPECT_FALSE(response.success);
  EXPECT_TRUE(contains(response.reason, kCamera)) << response.reason;

  response = callProbe(poke(sphere_.top(), Eigen::Vector3d::Zero()));
  EXPECT_FALSE(response.success);
  EXPECT_TRUE(contains(response.reason, "normal")) << response.reason;
}

TEST_F(SimNode, TouchesTheArmCannotReachFail) {
  // 3 m in front of the robot, far beyond the arm's 1.2 m reach.
  gpatlas_msgs::Probe::Response response =
      callProbe(poke(Eigen::Vector3d(3.0, 0.0, 0.1), Eigen::Vector3d::UnitZ()));
  EXPECT_FALSE(response.success);
  EXPECT_TRUE(contains(response.reason, "unreachable")) << response.reason;
  // Behind the robot's back (and the camera's): the arm cannot get there either.
  response = callProbe(poke(Eigen::Vector3d(-0.8, 0.0, 0.1), Eigen::Vector3d::UnitZ()));
  EXPECT_FALSE(response.success);
  EXPECT_FALSE(response.reason.empty());
}

// Nodes started with a missing mesh and a negative scale stay up and answer with the reason.
TEST(BrokenNodes, AnswerEveryServiceWithTheReason) {
  struct Case {
    std::string node;
    std::vector<std::string> reason_parts;
  };
  for (const Case& c : {Case{"/broken/missing_mesh", {"no object loaded", "missing_object.stl"}},
                        Case{"/broken/negative_scale", {"object_scale", "> 0"}}}) {
    SCOPED_TRACE(c.node);
    ASSERT_TRUE(ros::service::waitForService(c.node + "/capture", ros::Duration(30.0)));
    gpatlas_msgs::Capture capture;
    ASSERT_TRUE(ros::service::call(c.node + "/capture", capture));
    EXPECT_FALSE(capture.response.success);
    gpatlas_msgs::Probe probe;
    probe.request.touch = poke(Eigen::Vector3d(0.7, 0.0, 0.1), Eigen::Vector3d::UnitZ());
    ASSERT_TRUE(ros::service::call(c.node + "/probe", probe));
    EXPECT_FALSE(probe.response.success);
    for (const std::string& part : c.reason_parts) {
      EXPECT_TRUE(contains(capture.response.message, part)) << capture.response.message;
      EXPECT_TRUE(contains(probe.response.reason, part)) << probe.response.reason;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_node");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
