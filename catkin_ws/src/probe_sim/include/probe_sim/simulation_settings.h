#pragma once

#include <Eigen/Core>

#include <optional>
#include <string>

namespace probe_sim {

// The simulated scene, probe, arm and camera: what probe_sim_node reads from its private
// parameters, with the defaults; gpatlas_bench places its objects and table the same way.
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

}  // namespace probe_sim
