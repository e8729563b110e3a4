#pragma once

// ROS interface of the simulated probe and depth camera: a thin shim over the ROS-free
// probe_sim library (Scene, DepthCamera, SimulatedProber, Arm). See the package README for the
// parameters, topics and services.

#include "probe_sim/depth_camera.h"
#include "probe_sim/probe.h"
#include "probe_sim/scene.h"
#include "probe_sim/simulation_settings.h"

#include <gpatlas_msgs/Capture.h>
#include <gpatlas_msgs/GetMesh.h>
#include <gpatlas_msgs/Probe.h>
#include <gpatlas_msgs/SelectObject.h>
#include <geometry_msgs/PointStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace probe_sim {


class SimulationServer {
 public:
  // Never throws on bad parameters or a bad object: it logs the problem and stays up, every
  // service answering success = false with the reason (see unavailableReason()), so that a
  // launch file or nodelet manager keeps running and the caller sees why.
  SimulationServer(ros::NodeHandle nh, ros::NodeHandle pnh);

  // Empty when the simulation is ready, else why it is not.
  const std::string& unavailableReason() const { return unavailable_reason_; }

 private:
  // Each returns an empty string on success, else the reason; they are called in this order.
  std::string readSettings();
  std::string loadRobot();
  std::string loadObject();
  std::string setUpCamera();
  std::string setUpProber();

  bool onProbe(gpatlas_msgs::Probe::Request& request, gpatlas_msgs::Probe::Response& response);
  bool onGroundTruth(gpatlas_msgs::GetMesh::Request& request, gpatlas_msgs::GetMesh::Response& response);
  // The user's pick, told to the simulation: the object nearest the point becomes the one the
  // probe's contacts and the ground truth are of, the others obstacles (segmentation's
  // ~select_object picks it for the pipeline).
  bool onSelectObject(gpatlas_msgs::SelectObject::Request& request, gpatlas_msgs::SelectObject::Response& response);
  // rviz's "Publish Point" (clicked_point), as segmentation takes it: the same pick.
  void onClickedPoint(const geometry_msgs::PointStamped::ConstPtr& point);
  bool onCapture(gpatlas_msgs::Capture::Request& request,
                 gpatlas_msgs::Capture::Response& response);
  void onCloudTimer(const ros::TimerEvent& event);
  void onJointStateTimer(const ros::TimerEvent& event);

  // Renders the depth cloud (camera frame); false with *message when there is nothing to send.
  bool renderCloud(sensor_msgs::PointCloud2* cloud, std::string* message);
  void publishObjectMarker();
  // The scene now; a pick may replace scene_ while the caller still uses this one.
  std::shared_ptr<const Scene> currentScene();
  // Queues the displayed arm motion: from where it is now through the waypoint solutions of
  // the left arm and back to the ready pose.
  void animateArm(const std::vector<Eigen::VectorXd>& arm_solutions);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  SimulationSettings settings_;
  gpatlas_motion::ApproachConfig approach_;  // the judged probe body and its rest (approach/)
  double select_max_distance_m_{0.0};  // segmentation/select_max_distance_m: a pick's reach
  std::uint64_t seed_{0};  // the run's seed (config/pipeline.yaml `seed`): the camera's noise
  std::string unavailable_reason_;

  // The robot as described by robot_description (empty when there is none and use_arm is off).
  std::string urdf_xml_;
  std::vector<std::string> joint_names_;  // all movable joints, for joint_states
  Eigen::VectorXd ready_positions_;       // from ~zeros, else 0 clamped into the limits
  std::vector<int> arm_joint_indices_;    // arm joint i -> index in joint_names_

  // The Bullet scene is not thread-safe and a nodelet manager may run callbacks in parallel:
  // everything below is used under simulation_mutex_.
  std::mutex simulation_mutex_;
  std::shared_ptr<Scene> scene_;
  std::vector<TriangleMesh> objects_;  // the object, then its neighbours
  std::size_t explored_{0};            // objects_[explored_] is the scene's object
  std::shared_ptr<const Arm> arm_;
  std::unique_ptr<DepthCamera> camera_;
  std::unique_ptr<SimulatedProber> prober_;

  std::mutex joint_state_mutex_;
  Eigen::VectorXd displayed_positions_;
  std::deque<Eigen::VectorXd> pending_positions_;

  ros::ServiceServer probe_service_;
  ros::ServiceServer capture_service_;
  ros::ServiceServer ground_truth_service_;
  ros::ServiceServer select_object_service_;
  ros::Subscriber clicked_point_subscriber_;
  ros::Publisher cloud_publisher_;
  ros::Publisher marker_publisher_;
  // The tactile pad's last press (probe: patch): its square and its patch's points.
  ros::Publisher patch_publisher_;
  ros::Publisher joint_state_publisher_;
  ros::Timer cloud_timer_;
  ros::Timer joint_state_timer_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
};

}  // namespace probe_sim
