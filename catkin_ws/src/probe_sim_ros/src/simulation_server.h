#pragma once

// ROS interface of the simulated probe and depth camera: a thin shim over the ROS-free
// probe_sim library (Scene, DepthCamera, SimulatedProber, Arm). See the package README for the
// parameters, topics and services.

#include "probe_sim/arm.h"
#include "probe_sim/depth_camera.h"
#include "probe_sim/probe.h"
#include "probe_sim/scene.h"

#include <gpatlas_msgs/Capture.h>
#include <gpatlas_msgs/GetMesh.h>
#include <gpatlas_msgs/Probe.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace probe_sim {

// Everything the server reads from its private parameters, with the defaults.
struct SimulationSettings {
  std::string object = "procedural:sphere";  // mesh file (.stl/.ply/.obj) or procedural:NAME
  double object_scale = 1.0;                 // mesh file units -> metres (0.001 for mm)
  double procedural_size_m = 0.15;
  Eigen::Vector2d object_position_xy_m{0.7, 0.0};
  std::string world_frame = "world";

  // The table the object stands on; the defaults are vito.urdf's `table` link (0.8 x 1.2 m
  // top, 4 cm thick, centred at x = 0.75), whose top is the plane z = 0 like the Scene's.
  Eigen::Vector2d table_size_xy_m{0.8, 1.2};
  Eigen::Vector2d table_centre_xy_m{0.75, 0.0};
  double table_thickness_m = 0.04;

  std::string probe = "sphere";  // "ray" | "sphere"
  double probe_radius_m = 0.02;  // vito.urdf's probe tip sphere
  double slide_step_m = 0.005;

  bool use_arm = true;
  std::string tip_frame = "probe_tip";
  double joint_states_rate_hz = 20.0;
  double arm_max_joint_speed_rad_s = 1.0;  // of the displayed motion only

  std::string camera_frame = "camera_optical_frame";
  // When both are given the camera is placed there (and its frame broadcast as a static
  // transform); otherwise camera_frame's pose is taken from robot_description.
  std::optional<Eigen::Vector3d> camera_eye_m;
  std::optional<Eigen::Vector3d> camera_target_m;
  int camera_width_px = 320;
  int camera_height_px = 240;
  double camera_fov_deg = 58.6;  // horizontal
  double camera_depth_noise_m = 0.001;
  // The table in the depth cloud too, as a real camera sees it (the pipeline segments it away);
  // false gives the object's points only.
  bool camera_include_table = true;
  double publish_cloud_rate_hz = 0.0;  // 0: only on ~capture
};

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
  bool onCapture(gpatlas_msgs::Capture::Request& request,
                 gpatlas_msgs::Capture::Response& response);
  void onCloudTimer(const ros::TimerEvent& event);
  void onJointStateTimer(const ros::TimerEvent& event);

  // Renders the depth cloud (camera frame); false with *message when there is nothing to send.
  bool renderCloud(sensor_msgs::PointCloud2* cloud, std::string* message);
  void publishObjectMarker();
  // Queues the displayed arm motion: from where it is now through the waypoint solutions of
  // the left arm and back to the ready pose.
  void animateArm(const std::vector<Eigen::VectorXd>& arm_solutions);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  SimulationSettings settings_;
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
  std::shared_ptr<const Arm> arm_;
  std::unique_ptr<DepthCamera> camera_;
  std::unique_ptr<SimulatedProber> prober_;

  std::mutex joint_state_mutex_;
  Eigen::VectorXd displayed_positions_;
  std::deque<Eigen::VectorXd> pending_positions_;

  ros::ServiceServer probe_service_;
  ros::ServiceServer capture_service_;
  ros::ServiceServer ground_truth_service_;
  ros::Publisher cloud_publisher_;
  ros::Publisher marker_publisher_;
  ros::Publisher joint_state_publisher_;
  ros::Timer cloud_timer_;
  ros::Timer joint_state_timer_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
};

}  // namespace probe_sim
