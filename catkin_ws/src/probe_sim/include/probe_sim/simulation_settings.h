#pragma once

#include "probe_sim/depth_camera.h"
#include "probe_sim/object_mesh.h"
#include "probe_sim/probe.h"
#include "probe_sim/scene.h"

#include <gpatlas_motion/approach_config.h>
#include <gpatlas_core/common/parameters.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace probe_sim {

// An object standing near the explored one (simulation/neighbours, gpatlas_bench --neighbour):
// the camera sees it, the probe and the arm can hit it, the exploration leaves it alone.
// Written "OBJECT@DX,DY[,YAW_RAD[,SCALE]]" (parseNeighbour).
struct NeighbourConfig {
  std::string object;  // mesh file (.stl/.ply/.obj) or procedural:NAME
  // Mesh file units to metres; for a procedural object, a factor on procedural_size_m.
  double scale = 1.0;
  // Its bounding box's centre from the explored object's (object_position_xy_m), world frame,
  // so that a scene keeps its layout wherever the object stands.
  Eigen::Vector2d offset_xy_m{0.0, 0.0};
  double yaw_rad = 0.0;  // about the vertical through its centre
};

// "OBJECT@DX,DY[,YAW_RAD[,SCALE]]" (e.g. "procedural:box@0,0.2" or
// "meshes/jug.stl@0.18,0,1.57,0.001"); nullopt with the reason in `error` when malformed.
std::optional<NeighbourConfig> parseNeighbour(const std::string& text, std::string* error);
std::string formatNeighbour(const NeighbourConfig& neighbour);

// The simulated scene, probe, arm and camera, with the defaults: probe_sim's
// config/simulation.yaml, which probe_sim_node and gpatlas_bench read alike (readSimulation).
struct SimulationSettings {
  std::string object = "procedural:mug";  // mesh file (.stl/.ply/.obj) or procedural:NAME
  double object_scale = 1.0;                 // mesh file units -> metres (0.001 for mm)
  double procedural_size_m = 0.15;
  Eigen::Vector2d object_position_xy_m{0.7, 0.0};
  // The pipeline's world frame (config/pipeline.yaml's world_frame, gpatlas_core::PipelineFrames),
  // set by the caller: the scene's, the arm's base and the camera's reference.
  std::string world_frame = "world";

  // The table the object stands on (false: the object alone, as in the paper's simulated
  // protocol, where rays are cast on the object mesh); the defaults are vito.urdf's `table` link (0.8 x 1.2 m
  // top, 4 cm thick, centred at x = 0.75), whose top is the plane z = 0 like the Scene's.
  bool table = true;
  Eigen::Vector2d table_size_xy_m{0.8, 1.2};
  Eigen::Vector2d table_centre_xy_m{0.75, 0.0};
  double table_thickness_m = 0.04;

  std::string probe = "ray";  // "ray" (the paper's validation protocol) | "sphere" | "patch"
  double probe_radius_m = 0.02;  // vito.urdf's probe tip sphere
  // probe "patch": the tactile pad (its start offset is the approach's, as for the others).
  PatchProbeConfig patch;
  double slide_step_m = 0.005;

  bool use_arm = false;
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
  // Objects around the explored one: in the camera's cloud and in the probe's and the arm's way.
  std::vector<NeighbourConfig> neighbours;
};

// Reads simulation/... (all but world_frame); every problem goes to the reader.
void readSimulation(gpatlas_core::ParamReader& reader, SimulationSettings* settings);
// Empty when the settings are usable; otherwise every problem, by parameter name.
std::string validate(const SimulationSettings& settings);

// The object as the settings place it (on the table at object_position_xy_m); throws
// std::runtime_error with the reason when the mesh cannot be read, the name is unknown, or the
// object is larger than the table (a mesh in millimetres without its scale).
TriangleMesh loadSimulatedObject(const SimulationSettings& settings);
SceneConfig sceneConfig(const SimulationSettings& settings);
// The neighbours as the settings place them around `object` (loadSimulatedObject's), each on
// the table; throws std::runtime_error with the reason when one cannot be loaded, leaves the
// table, or its footprint (bounding box in x, y) overlaps the object's or another's.
std::vector<TriangleMesh> loadNeighbours(const SimulationSettings& settings, const TriangleMesh& object);
// The scene probe_sim_node and gpatlas_bench simulate: the object, the table, the neighbours
// (SurfaceKind::kObstacle). Throws as loadNeighbours.
std::shared_ptr<Scene> makeSimulatedScene(const SimulationSettings& settings, const TriangleMesh& object);
// The scene's objects: the object, then its neighbours as loadNeighbours places them around it.
// Throws as loadNeighbours.
std::vector<TriangleMesh> sceneObjects(const SimulationSettings& settings, const TriangleMesh& object);
// The same table and objects (`objects`, as sceneObjects gives them), with objects[explored] the one the probe's contacts and the ground truth are of,
// the others obstacles: the scene after a user picked another object to explore.
std::shared_ptr<Scene> makeSimulatedScene(const SimulationSettings& settings, const std::vector<TriangleMesh>& objects,
                                          std::size_t explored);
// The index of the object in `objects` whose bounding box is nearest to `point` (0 inside
// one), and that distance in *distance_m; `objects` must not be empty.
std::size_t nearestObject(const std::vector<TriangleMesh>& objects, const Eigen::Vector3d& point, double* distance_m);
// The simulated probe of probe_sim_node and gpatlas_bench: the probe model the settings name,
// their slide step, and the judge of the way to each touch and back with the approach
// planner's probe body and rest (`approach`). Throws std::runtime_error for an unknown probe.
std::unique_ptr<SimulatedProber> makeSimulatedProber(std::shared_ptr<const Scene> scene,
                                                     const SimulationSettings& settings,
                                                     const gpatlas_motion::ApproachConfig& approach);
// The camera's intrinsics and noise; `seed` draws its noise.
DepthCamera::Config cameraConfig(const SimulationSettings& settings, std::uint32_t seed);
// The camera's pose: camera_eye_m looking at camera_target_m when given, otherwise the fixed
// pose of camera_frame in the URDF (relative to world_frame). nullopt with the reason when
// there is none.
std::optional<Eigen::Isometry3d> cameraPose(const SimulationSettings& settings, const std::string& urdf_xml,
                                            std::string* error);
// The pose of `frame` relative to `base` in a URDF, when every joint between them is fixed.
std::optional<Eigen::Isometry3d> fixedFramePose(const std::string& urdf_xml, const std::string& base,
                                                const std::string& frame, std::string* error);

}  // namespace probe_sim
