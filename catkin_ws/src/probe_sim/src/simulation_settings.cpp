#include "probe_sim/simulation_settings.h"

#include "probe_sim/probe.h"
#include "probe_sim/procedural_objects.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <limits>
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

std::vector<NeighbourConfig> readNeighbours(gpatlas_core::ParamReader& r, const std::vector<NeighbourConfig>& fallback) {
  const std::string name = "simulation/neighbours";
  std::vector<std::string> given;
  for (const NeighbourConfig& n : fallback) given.push_back(formatNeighbour(n));
  std::vector<NeighbourConfig> out;
  for (const std::string& text : r.texts(name, given)) {
    std::string error;
    if (const std::optional<NeighbourConfig> n = parseNeighbour(text, &error)) out.push_back(*n);
    else r.invalid(name, error);
  }
  return out;
}

// The mesh of an object spec: a file at `scale`, or procedural:NAME of that size.
TriangleMesh loadSpec(const std::string& spec, double scale, double procedural_size_m) {
  return spec.rfind(kProceduralPrefix, 0) == 0 ? makeProceduralObject(spec.substr(kProceduralPrefix.size()), procedural_size_m)
                                                : loadMesh(spec, scale);
}

std::string describeBox(const Eigen::AlignedBox2d& box) {
  std::ostringstream out;
  out << "x " << box.min().x() << ".." << box.max().x() << ", y " << box.min().y() << ".." << box.max().y() << " m";
  return out.str();
}

Eigen::AlignedBox2d footprint(const TriangleMesh& mesh) {
  const Eigen::AlignedBox3d box = mesh.boundingBox();
  return Eigen::AlignedBox2d(box.min().head<2>(), box.max().head<2>());
}

}  // namespace

std::optional<NeighbourConfig> parseNeighbour(const std::string& text, std::string* error) {
  const std::string usage = "neighbour '" + text + "' must be OBJECT@DX,DY[,YAW_RAD[,SCALE]] (metres, radians; SCALE > 0)";
  const std::size_t at = text.rfind('@');
  if (at == std::string::npos || at == 0) {
    if (error) *error = usage;
    return std::nullopt;
  }
  std::vector<double> numbers;
  std::stringstream parts(text.substr(at + 1));
  for (std::string part; std::getline(parts, part, ',');) {
    char* end = nullptr;
    const double v = std::strtod(part.c_str(), &end);
    if (part.empty() || end == part.c_str() || *end != '\0' || !std::isfinite(v)) {
      if (error) *error = usage;
      return std::nullopt;
    }
    numbers.push_back(v);
  }
  if (numbers.size() < 2 || numbers.size() > 4 || (numbers.size() == 4 && !(numbers[3] > 0.0))) {
    if (error) *error = usage;
    return std::nullopt;
  }
  NeighbourConfig n;
  n.object = text.substr(0, at);
  n.offset_xy_m = {numbers[0], numbers[1]};
  if (numbers.size() > 2) n.yaw_rad = numbers[2];
  if (numbers.size() > 3) n.scale = numbers[3];
  return n;
}

std::string formatNeighbour(const NeighbourConfig& n) {
  std::ostringstream out;
  out << std::setprecision(12) << n.object << '@' << n.offset_xy_m.x() << ',' << n.offset_xy_m.y() << ',' << n.yaw_rad
      << ',' << n.scale;
  return out.str();
}

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
  s->neighbours = readNeighbours(r, s->neighbours);
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
  for (const NeighbourConfig& n : s.neighbours)
    require(!n.object.empty() && n.scale > 0.0 && n.offset_xy_m.allFinite() && std::isfinite(n.yaw_rad),
            "simulation/neighbours: '" + formatNeighbour(n) + "' needs an object, a finite place and a scale > 0");
  std::string joined;
  for (const std::string& p : problems) joined += (joined.empty() ? "" : "; ") + p;
  return joined;
}

TriangleMesh loadSimulatedObject(const SimulationSettings& s) {
  TriangleMesh mesh = loadSpec(s.object, s.object_scale, s.procedural_size_m);
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

std::vector<TriangleMesh> loadNeighbours(const SimulationSettings& s, const TriangleMesh& object) {
  const Eigen::AlignedBox2d table(s.table_centre_xy_m - 0.5 * s.table_size_xy_m, s.table_centre_xy_m + 0.5 * s.table_size_xy_m);
  std::vector<Eigen::AlignedBox2d> taken{footprint(object)};
  const Eigen::Vector2d centre = taken.front().center();
  std::vector<TriangleMesh> out;
  for (std::size_t i = 0; i < s.neighbours.size(); ++i) {
    const NeighbourConfig& n = s.neighbours[i];
    const std::string which = "simulation/neighbours[" + std::to_string(i) + "] '" + formatNeighbour(n) + "'";
    TriangleMesh mesh;
    try {
      mesh = loadSpec(n.object, n.scale, s.procedural_size_m * n.scale);
    } catch (const std::exception& e) {
      throw std::runtime_error(which + ": " + e.what());
    }
    placeOnTable(mesh);
    Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
    turn.linear() = Eigen::AngleAxisd(n.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    mesh.transform(turn);
    placeOnTable(mesh, centre + n.offset_xy_m);
    const Eigen::AlignedBox2d box = footprint(mesh);
    if (s.table && !table.contains(box))
      throw std::runtime_error(which + " does not stand on the table (its footprint " + describeBox(box) + ")");
    for (std::size_t j = 0; j < taken.size(); ++j)
      if (taken[j].intersects(box))
        throw std::runtime_error(which + "'s footprint " + describeBox(box) + " overlaps " +
                                 (j == 0 ? std::string("the explored object's") : "neighbour " + std::to_string(j - 1) + "'s") +
                                 " " + describeBox(taken[j]));
    taken.push_back(box);
    out.push_back(std::move(mesh));
  }
  return out;
}

std::vector<TriangleMesh> sceneObjects(const SimulationSettings& s, const TriangleMesh& object) {
  std::vector<TriangleMesh> objects{object};
  for (TriangleMesh& neighbour : loadNeighbours(s, object)) objects.push_back(std::move(neighbour));
  return objects;
}

std::shared_ptr<Scene> makeSimulatedScene(const SimulationSettings& s, const TriangleMesh& object) {
  return makeSimulatedScene(s, sceneObjects(s, object), 0);
}

std::shared_ptr<Scene> makeSimulatedScene(const SimulationSettings& s, const std::vector<TriangleMesh>& objects,
                                          std::size_t explored) {
  if (explored >= objects.size())
    throw std::invalid_argument("object " + std::to_string(explored) + " of " + std::to_string(objects.size()));
  auto scene = std::make_shared<Scene>(objects[explored], sceneConfig(s));
  for (std::size_t i = 0; i < objects.size(); ++i)
    if (i != explored) scene->addObstacleMesh(objects[i]);
  return scene;
}

std::size_t nearestObject(const std::vector<TriangleMesh>& objects, const Eigen::Vector3d& point, double* distance_m) {
  std::size_t nearest = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const double d = objects[i].boundingBox().exteriorDistance(point);
    if (d < best) {
      best = d;
      nearest = i;
    }
  }
  if (distance_m) *distance_m = best;
  return nearest;
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
  // The neighbours are in the cloud as a real camera sees them; segmentation picks the object.
  config.include_obstacles = true;
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
