#include "probe_sim/simulation_settings.h"

#include "probe_sim/probe.h"
#include "probe_sim/procedural_objects.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace probe_sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
const std::string kProceduralPrefix = "procedural:";

Eigen::Vector2d vector2(gpatlas_core::ParamReader& r, const std::string& name, const Eigen::Vector2d& fallback) {
  const std::vector<double> v = r.numbers(name, {fallback.x(), fallback.y()});
  if (v.size() != 2) {
    r.invalid(name, "must be a list of 2 numbers");
    return fallback;
  }
  return {v[0], v[1]};
}

// [] or absent: none; [x, y, z]: a point.
std::optional<Eigen::Vector3d> optionalVector3(gpatlas_core::ParamReader& r, const std::string& name,
                                               const std::optional<Eigen::Vector3d>& fallback) {
  std::vector<double> given;
  if (fallback) given = {fallback->x(), fallback->y(), fallback->z()};
  const std::vector<double> v = r.numbers(name, given);
  if (v.empty()) return std::nullopt;
  if (v.size() != 3) {
    r.invalid(name, "must be [] or a list of 3 numbers");
    return fallback;
  }
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

}  // namespace

void readSimulation(gpatlas_core::ParamReader& r, SimulationSettings* s) {
  s->object = r.text("simulation/object", s->object);
  s->object_scale = r.number("simulation/object_scale", s->object_scale, -1e9, 1e9);
  s->procedural_size_m = r.number("simulation/procedural_size_m", s->procedural_size_m, -1e9, 100.0);
  s->object_position_xy_m = vector2(r, "simulation/object_position_xy_m", s->object_position_xy_m);
  s->table = r.flag("simulation/table", s->table);
  s->table_size_xy_m = vector2(r, "simulation/table_size_xy_m", s->table_size_xy_m);
  s->table_centre_xy_m = vector2(r, "simulation/table_centre_xy_m", s->table_centre_xy_m);
  s->table_thickness_m = r.number("simulation/table_thickness_m", s->table_thickness_m, 1e-4, 10.0);
  s->probe = r.text("simulation/probe", s->probe);
  s->probe_radius_m = r.number("simulation/probe_radius_m", s->probe_radius_m, 1e-4, 1.0);
  PatchProbeConfig& patch = s->patch;
  patch.pad_size_m = r.number("simulation/patch/pad_size_m", patch.pad_size_m, 1e-4, 1.0);
  patch.pad_curvature_radius_m = r.number("simulation/patch/pad_curvature_radius_m", patch.pad_curvature_radius_m, 0.0, 100.0);
  patch.indentation_m = r.number("simulation/patch/indentation_m", patch.indentation_m, 0.0, 0.05);
  patch.resolution_m = r.number("simulation/patch/resolution_m", patch.resolution_m, 1e-5, 1.0);
  patch.point_spacing_m = r.number("simulation/patch/point_spacing_m", patch.point_spacing_m, 0.0, 1.0);
  patch.gimbal_range_deg = r.number("simulation/patch/gimbal_range_deg", patch.gimbal_range_deg, 0.0, 90.0);
  patch.depth_noise_m = r.number("simulation/patch/depth_noise_m", patch.depth_noise_m, 0.0, 0.01);
  patch.normal_noise_deg = r.number("simulation/patch/normal_noise_deg", patch.normal_noise_deg, 0.0, 45.0);
  s->slide_step_m = r.number("simulation/slide_step_m", s->slide_step_m, 1e-4, 1.0);
  s->use_arm = r.flag("simulation/use_arm", s->use_arm);
  s->tip_frame = r.text("simulation/tip_frame", s->tip_frame);
  s->joint_states_rate_hz = r.number("simulation/joint_states_rate_hz", s->joint_states_rate_hz, 1e-3, 1e4);
  s->arm_max_joint_speed_rad_s =
      r.number("simulation/arm_max_joint_speed_rad_s", s->arm_max_joint_speed_rad_s, 1e-3, 100.0);
  s->camera_frame = r.text("simulation/camera_frame", s->camera_frame);
  s->camera_eye_m = optionalVector3(r, "simulation/camera_eye_m", s->camera_eye_m);
  s->camera_target_m = optionalVector3(r, "simulation/camera_target_m", s->camera_target_m);
  s->camera_width_px = r.integer("simulation/camera_width_px", s->camera_width_px, 1, 4096);
  s->camera_height_px = r.integer("simulation/camera_height_px", s->camera_height_px, 1, 4096);
  s->camera_fov_deg = r.number("simulation/camera_fov_deg", s->camera_fov_deg, 1e-3, 179.9);
  s->camera_depth_noise_m = r.number("simulation/camera_depth_noise_m", s->camera_depth_noise_m, 0.0, 1.0);
  s->camera_include_table = r.flag("simulation/camera_include_table", s->camera_include_table);
  s->publish_cloud_rate_hz = r.number("simulation/publish_cloud_rate_hz", s->publish_cloud_rate_hz, 0.0, 1000.0);
}

std::string validate(const SimulationSettings& s) {
  std::vector<std::string> problems;
  const auto require = [&](bool ok, const std::string& what) {
    if (!ok) problems.push_back(what);
  };
  require(!s.object.empty(), "simulation/object must name a mesh file or procedural:NAME");
  require(s.object_scale > 0.0, "simulation/object_scale must be > 0 (0.001 for a mesh in mm)");
  require(s.procedural_size_m > 0.0, "simulation/procedural_size_m must be > 0");
  require(!s.world_frame.empty(), "world_frame must not be empty");
  require((s.table_size_xy_m.array() > 0.0).all(), "simulation/table_size_xy_m must be > 0");
  const std::vector<std::string> probes = probeModelNames();
  require(std::find(probes.begin(), probes.end(), s.probe) != probes.end(),
          "simulation/probe must be 'ray', 'sphere' or 'patch', got '" + s.probe + "'");
  require(s.patch.resolution_m <= s.patch.pad_size_m && s.patch.pad_size_m / s.patch.resolution_m <= 2000.0,
          "simulation/patch/resolution_m must be at most pad_size_m and give at most 2000 pixels across the pad");
  require(s.patch.pad_curvature_radius_m == 0.0 || s.patch.pad_curvature_radius_m > s.patch.pad_size_m / std::sqrt(2.0),
          "simulation/patch/pad_curvature_radius_m must be 0 (flat) or exceed half the pad's diagonal");
  require(!s.tip_frame.empty(), "simulation/tip_frame must not be empty");
  require(!s.camera_frame.empty(), "simulation/camera_frame must not be empty");
  require(s.camera_eye_m.has_value() == s.camera_target_m.has_value(),
          "simulation/camera_eye_m and camera_target_m must be given together (or neither: the pose from the URDF)");
  require(!s.camera_eye_m || !s.camera_target_m || (*s.camera_eye_m - *s.camera_target_m).norm() > 1e-6,
          "simulation/camera_eye_m must differ from camera_target_m");
  std::string joined;
  for (const std::string& p : problems) joined += (joined.empty() ? "" : "; ") + p;
  return joined;
}

TriangleMesh loadSimulatedObject(const SimulationSettings& s) {
  TriangleMesh mesh = s.object.rfind(kProceduralPrefix, 0) == 0
                          ? makeProceduralObject(s.object.substr(kProceduralPrefix.size()), s.procedural_size_m)
                          : loadMesh(s.object, s.object_scale);
  // A mesh in millimetres read as metres is a thousand times too large; without this check it
  // fails much later, in a grid that does not fit in memory.
  const double across = mesh.vertices.empty() ? 0.0 : mesh.boundingBox().sizes().maxCoeff();
  if (s.table && across > s.table_size_xy_m.maxCoeff()) {
    std::ostringstream message;
    message << "object '" << s.object << "' is " << across << " m across at simulation/object_scale "
            << s.object_scale << ", larger than the table (" << s.table_size_xy_m.maxCoeff()
            << " m): a mesh in millimetres needs object_scale 0.001 (gpatlas_bench --scale 0.001, make demo SCALE=0.001)";
    throw std::runtime_error(message.str());
  }
  placeOnTable(mesh, s.object_position_xy_m);
  return mesh;
}

SceneConfig sceneConfig(const SimulationSettings& s) {
  SceneConfig config;
  config.add_table = s.table;
  config.table_size_xy = s.table_size_xy_m;
  config.table_centre_xy = s.table_centre_xy_m;
  config.table_thickness = s.table_thickness_m;
  return config;
}

DepthCamera::Config cameraConfig(const SimulationSettings& s, std::uint32_t seed) {
  DepthCamera::Config config;
  config.width = s.camera_width_px;
  config.height = s.camera_height_px;
  config.horizontal_fov_rad = s.camera_fov_deg * kPi / 180.0;
  config.depth_noise_sigma_m = s.camera_depth_noise_m;
  config.include_table = s.table && s.camera_include_table;
  config.include_obstacles = false;
  config.seed = seed;
  return config;
}

std::optional<Eigen::Isometry3d> fixedFramePose(const std::string& urdf_xml, const std::string& base,
                                                const std::string& frame, std::string* error) {
  if (urdf_xml.empty()) {
    if (error) *error = "no URDF";
    return std::nullopt;
  }
  KDL::Tree tree;
  try {
    tree = gpatlas_motion::kinematicTreeFromUrdf(urdf_xml);
  } catch (const std::exception& e) {
    if (error) *error = e.what();
    return std::nullopt;
  }
  KDL::Chain chain;
  if (!tree.getChain(base, frame, chain)) {
    if (error) *error = "the URDF has no chain from '" + base + "' to '" + frame + "'";
    return std::nullopt;
  }
  if (chain.getNrOfJoints() != 0) {
    if (error)
      *error = "'" + frame + "' moves with " + std::to_string(chain.getNrOfJoints()) + " joint(s); a fixed frame is expected";
    return std::nullopt;
  }
  KDL::Frame pose = KDL::Frame::Identity();
  for (const KDL::Segment& segment : chain.segments) pose = pose * segment.pose(0.0);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    out.translation()[r] = pose.p(r);
    for (int c = 0; c < 3; ++c) out.linear()(r, c) = pose.M(r, c);
  }
  return out;
}

std::optional<Eigen::Isometry3d> cameraPose(const SimulationSettings& s, const std::string& urdf_xml,
                                            std::string* error) {
  if (s.camera_eye_m && s.camera_target_m) return lookAt(*s.camera_eye_m, *s.camera_target_m);
  std::string why;
  const auto pose = fixedFramePose(urdf_xml, s.world_frame, s.camera_frame, &why);
  if (!pose && error)
    *error = "no camera pose: " + why + "; or set simulation/camera_eye_m and simulation/camera_target_m";
  return pose;
}

std::unique_ptr<SimulatedProber> makeSimulatedProber(std::shared_ptr<const Scene> scene,
                                                     const SimulationSettings& settings,
                                                     const gpatlas_motion::ApproachConfig& approach) {
  ProbeModelConfig model_config;
  model_config.sphere.radius_m = settings.probe_radius_m;
  // Strokes start at the approach planner's approach pose.
  model_config.patch = settings.patch;
  model_config.ray.start_offset_m = approach.approach_distance_m;
  model_config.sphere.start_offset_m = approach.approach_distance_m;
  model_config.patch.start_offset_m = approach.approach_distance_m;
  // The judge (and the approach planner) move the probe's body: its tip sphere stands for the pad.
  if (settings.probe == "patch" && approach.probe.tip_radius_m < settings.patch.pad_size_m / std::sqrt(2.0))
    throw std::runtime_error("the patch probe's pad (" + std::to_string(settings.patch.pad_size_m) +
                             " m square) does not fit in the probe body's tip sphere (approach/tip_radius_m " +
                             std::to_string(approach.probe.tip_radius_m) + "): raise tip_radius_m to half the pad's diagonal");
  SimulatedProber::Config config;
  config.slide_step_m = settings.slide_step_m;
  config.body = approach.probe;
  config.rest_tip_position = approach.rest_tip_position_m;
  return std::make_unique<SimulatedProber>(std::move(scene), makeProbeModel(settings.probe, model_config), config);
}

}  // namespace probe_sim
