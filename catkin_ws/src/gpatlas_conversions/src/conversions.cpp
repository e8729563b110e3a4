#include "gpatlas_conversions/conversions.h"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

namespace gpatlas_conversions {

geometry_msgs::Point toPointMsg(const Eigen::Vector3d& p) {
  geometry_msgs::Point m;
  m.x = p.x();
  m.y = p.y();
  m.z = p.z();
  return m;
}

geometry_msgs::Vector3 toVectorMsg(const Eigen::Vector3d& v) {
  geometry_msgs::Vector3 m;
  m.x = v.x();
  m.y = v.y();
  m.z = v.z();
  return m;
}

Eigen::Vector3d fromMsg(const geometry_msgs::Point& p) { return {p.x, p.y, p.z}; }
Eigen::Vector3d fromMsg(const geometry_msgs::Vector3& v) { return {v.x, v.y, v.z}; }

gpatlas_msgs::SupportPlane toMsg(const gpatlas_core::SupportPlane& plane, const std::string& frame_id) {
  gpatlas_msgs::SupportPlane msg;
  msg.header.frame_id = frame_id;
  msg.normal = toVectorMsg(plane.normal);
  msg.offset = plane.offset;
  return msg;
}

bool fromMsg(const gpatlas_msgs::SupportPlane& msg, gpatlas_core::SupportPlane* plane, std::string* error) {
  const Eigen::Vector3d normal = fromMsg(msg.normal);
  const double norm = normal.norm();
  if (!normal.allFinite() || !(norm > 1e-9) || !std::isfinite(msg.offset)) {
    if (error) *error = "support plane: the normal must be finite and non-zero, the offset finite";
    return false;
  }
  plane->normal = normal / norm;
  plane->offset = msg.offset / norm;
  return true;
}

gpatlas_core::SupportPlane transformPlane(const gpatlas_core::SupportPlane& plane, const Eigen::Isometry3d& pose) {
  gpatlas_core::SupportPlane out;
  out.normal = (pose.linear() * plane.normal).normalized();
  out.offset = -out.normal.dot(pose * Eigen::Vector3d(-plane.offset * plane.normal));
  return out;
}

trajectory_msgs::JointTrajectory toJointTrajectoryMsg(const std::vector<Eigen::VectorXd>& path,
                                                      const std::vector<std::string>& joint_names,
                                                      double joint_speed_rad_s) {
  if (!(joint_speed_rad_s > 0.0)) throw std::invalid_argument("a joint trajectory needs a positive joint speed");
  trajectory_msgs::JointTrajectory msg;
  msg.joint_names = joint_names;
  double time_s = 0.0;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (path[i].size() != static_cast<Eigen::Index>(joint_names.size()))
      throw std::invalid_argument("a configuration of " + std::to_string(path[i].size()) + " joints for " +
                                  std::to_string(joint_names.size()) + " joint names");
    if (i > 0) time_s += (path[i] - path[i - 1]).cwiseAbs().maxCoeff() / joint_speed_rad_s;
    trajectory_msgs::JointTrajectoryPoint point;
    point.positions.assign(path[i].data(), path[i].data() + path[i].size());
    point.time_from_start = ros::Duration(time_s);
    msg.points.push_back(std::move(point));
  }
  return msg;
}

bool fromJointTrajectoryMsg(const trajectory_msgs::JointTrajectory& msg, const std::vector<std::string>& joint_names,
                            std::vector<Eigen::VectorXd>* path, std::string* error) {
  std::vector<std::size_t> index;
  for (const std::string& name : joint_names) {
    const auto it = std::find(msg.joint_names.begin(), msg.joint_names.end(), name);
    if (it == msg.joint_names.end()) {
      *error = "the joint trajectory has no joint '" + name + "'";
      return false;
    }
    index.push_back(static_cast<std::size_t>(it - msg.joint_names.begin()));
  }
  std::vector<Eigen::VectorXd> out;
  for (std::size_t i = 0; i < msg.points.size(); ++i) {
    const auto& positions = msg.points[i].positions;
    if (positions.size() != msg.joint_names.size()) {
      *error = "point " + std::to_string(i) + " of the joint trajectory has " + std::to_string(positions.size()) +
               " positions for " + std::to_string(msg.joint_names.size()) + " joints";
      return false;
    }
    Eigen::VectorXd q(static_cast<Eigen::Index>(joint_names.size()));
    for (std::size_t j = 0; j < index.size(); ++j) q[static_cast<Eigen::Index>(j)] = positions[index[j]];
    if (!q.allFinite()) {
      *error = "point " + std::to_string(i) + " of the joint trajectory is not finite";
      return false;
    }
    out.push_back(std::move(q));
  }
  *path = std::move(out);
  return true;
}

gpatlas_msgs::Touch toMsg(const gpatlas_core::Touch& touch, const std::vector<std::string>& joint_names,
                          double joint_speed_rad_s) {
  gpatlas_msgs::Touch msg;
  msg.kind = touch.kind == gpatlas_core::Touch::Kind::kSlide ? gpatlas_msgs::Touch::SLIDE : gpatlas_msgs::Touch::POKE;
  for (const auto& p : touch.points) msg.points.push_back(toPointMsg(p));
  for (const auto& n : touch.normals) msg.normals.push_back(toVectorMsg(n));
  msg.variances = touch.variances;
  msg.strategy = touch.strategy;
  msg.explores_unknown = touch.explores_unknown;
  for (const auto& p : touch.approach_path) msg.approach_path.push_back(toPointMsg(p));
  for (const auto& p : touch.retreat_path) msg.retreat_path.push_back(toPointMsg(p));
  if (!touch.approach_joints.empty())
    msg.approach_trajectory = toJointTrajectoryMsg(touch.approach_joints, joint_names, joint_speed_rad_s);
  if (!touch.retreat_joints.empty())
    msg.retreat_trajectory = toJointTrajectoryMsg(touch.retreat_joints, joint_names, joint_speed_rad_s);
  return msg;
}

bool fromMsg(const gpatlas_msgs::Touch& msg, gpatlas_core::Touch* touch, std::string* error,
             const std::vector<std::string>* joint_names) {
  if (msg.kind != gpatlas_msgs::Touch::POKE && msg.kind != gpatlas_msgs::Touch::SLIDE) {
    *error = "touch kind " + std::to_string(msg.kind) + " is neither POKE (0) nor SLIDE (1)";
    return false;
  }
  if (msg.normals.size() != msg.points.size()) {
    *error = "touch has " + std::to_string(msg.points.size()) + " points but " + std::to_string(msg.normals.size()) +
             " normals";
    return false;
  }
  if (!msg.variances.empty() && msg.variances.size() != msg.points.size()) {
    *error = "touch variances must be empty or one per point";
    return false;
  }
  gpatlas_core::Touch out;
  out.kind = msg.kind == gpatlas_msgs::Touch::SLIDE ? gpatlas_core::Touch::Kind::kSlide : gpatlas_core::Touch::Kind::kPoke;
  for (const auto& p : msg.points) out.points.push_back(fromMsg(p));
  for (const auto& n : msg.normals) out.normals.push_back(fromMsg(n));
  out.variances = msg.variances;
  out.strategy = msg.strategy;
  out.explores_unknown = msg.explores_unknown;
  for (const auto& p : msg.approach_path) out.approach_path.push_back(fromMsg(p));
  for (const auto& p : msg.retreat_path) out.retreat_path.push_back(fromMsg(p));
  if (joint_names) {
    std::string why;
    if ((!msg.approach_trajectory.points.empty() &&
         !fromJointTrajectoryMsg(msg.approach_trajectory, *joint_names, &out.approach_joints, &why)) ||
        (!msg.retreat_trajectory.points.empty() &&
         !fromJointTrajectoryMsg(msg.retreat_trajectory, *joint_names, &out.retreat_joints, &why))) {
      *error = "touch trajectory: " + why;
      return false;
    }
  }
  *touch = std::move(out);
  return true;
}

gpatlas_msgs::Observations toMsg(const gpatlas_core::ProbeResult& result) {
  gpatlas_msgs::Observations msg;
  for (const auto& c : result.contacts) {
    msg.contacts.push_back(toPointMsg(c.position));
    msg.contact_normals.push_back(toVectorMsg(c.normal));
  }
  for (const auto& p : result.free_space) msg.free_space.push_back(toPointMsg(p));
  for (const gpatlas_core::PadPress& pad : result.pads) {
    geometry_msgs::Pose pose;
    pose.position = toPointMsg(pad.centre);
    pose.orientation.x = pad.orientation.x();
    pose.orientation.y = pad.orientation.y();
    pose.orientation.z = pad.orientation.z();
    pose.orientation.w = pad.orientation.w();
    msg.pad_poses.push_back(pose);
    msg.pad_sizes_m.push_back(pad.size_m);
  }
  return msg;
}

bool fromMsg(const gpatlas_msgs::Observations& msg, gpatlas_core::ProbeResult* result, std::string* error) {
  if (!msg.contact_normals.empty() && msg.contact_normals.size() != msg.contacts.size()) {
    *error = "observations have " + std::to_string(msg.contacts.size()) + " contacts but " +
             std::to_string(msg.contact_normals.size()) + " normals (must be 0 or equal)";
    return false;
  }
  if (msg.pad_sizes_m.size() != msg.pad_poses.size()) {
    *error = "observations have " + std::to_string(msg.pad_poses.size()) + " pad poses but " +
             std::to_string(msg.pad_sizes_m.size()) + " pad sizes (must be equal)";
    return false;
  }
  std::vector<gpatlas_core::PadPress> pads;
  for (std::size_t i = 0; i < msg.pad_poses.size(); ++i) {
    const geometry_msgs::Pose& pose = msg.pad_poses[i];
    gpatlas_core::PadPress pad;
    pad.centre = fromMsg(pose.position);
    const Eigen::Quaterniond q(pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z);
    if (!pad.centre.allFinite() || !q.coeffs().allFinite() || std::abs(q.norm() - 1.0) > 1e-3 ||
        !(msg.pad_sizes_m[i] > 0.0) || !std::isfinite(msg.pad_sizes_m[i])) {
      *error = "pad " + std::to_string(i) + ": the pose must be finite with a unit quaternion, the size > 0";
      return false;
    }
    pad.orientation = q.normalized();
    pad.size_m = msg.pad_sizes_m[i];
    pads.push_back(pad);
  }
  result->pads = std::move(pads);
  result->contacts.clear();
  result->free_space.clear();
  for (std::size_t i = 0; i < msg.contacts.size(); ++i) {
    gpatlas_core::Contact c;
    c.position = fromMsg(msg.contacts[i]);
    if (!msg.contact_normals.empty()) c.normal = fromMsg(msg.contact_normals[i]);
    result->contacts.push_back(c);
  }
  for (const auto& p : msg.free_space) result->free_space.push_back(fromMsg(p));
  return true;
}

gpatlas_msgs::TrainingSet toMsg(const gpatlas_core::SurfaceModel& model) {
  gpatlas_msgs::TrainingSet msg;
  msg.model = model.name();
  msg.hyperparameter_names = model.hyperparameterNames();
  const Eigen::VectorXd params = model.hyperparameters();
  msg.hyperparameters.assign(params.data(), params.data() + params.size());
  msg.centroid = toPointMsg(model.centroid());
  msg.scale = model.scale();
  msg.position_sd_scale = model.positionSdScale();
  const auto& observations = model.observations();
  for (const auto& p : observations) {
    msg.points.push_back(toPointMsg(p.position));
    msg.labels.push_back(static_cast<int8_t>(p.label));
    msg.noise_sigmas.push_back(p.noise_sigma);
    msg.sources.push_back(static_cast<uint8_t>(p.source));
    msg.surface_distances_m.push_back(p.surface_distance_m);
  }
  // Slopes and target overrides are rare (a probe's tangents): sent only when present.
  if (std::any_of(observations.begin(), observations.end(), [](const gpatlas_core::TrainingPoint& p) {
        return gpatlas_core::observesSlope(p) || std::isfinite(p.target_override);
      })) {
    for (const auto& p : observations) {
      geometry_msgs::Vector3 direction;
      direction.x = p.slope_direction.x();
      direction.y = p.slope_direction.y();
      direction.z = p.slope_direction.z();
      msg.slope_directions.push_back(direction);
      msg.target_overrides.push_back(p.target_override);
    }
  }
  if (std::any_of(observations.begin(), observations.end(),
                  [](const gpatlas_core::TrainingPoint& p) { return std::isfinite(p.prediction_error_m); }))
    for (const auto& p : observations) msg.prediction_errors_m.push_back(p.prediction_error_m);
  return msg;
}

bool fromMsg(const gpatlas_msgs::TrainingSet& msg, gpatlas_core::SurfaceModelState* state, std::string* error) {
  const std::size_t n = msg.points.size();
  if (msg.labels.size() != n || msg.noise_sigmas.size() != n || msg.sources.size() != n ||
      (!msg.surface_distances_m.empty() && msg.surface_distances_m.size() != n) ||
      (!msg.slope_directions.empty() && msg.slope_directions.size() != n) ||
      (!msg.target_overrides.empty() && msg.target_overrides.size() != n) ||
      (!msg.prediction_errors_m.empty() && msg.prediction_errors_m.size() != n) ||
      (!msg.hyperparameter_names.empty() && msg.hyperparameter_names.size() != msg.hyperparameters.size())) {
    *error = "training set arrays differ in length";
    return false;
  }
  gpatlas_core::SurfaceModelState out;
  out.model = msg.model;
  out.hyperparameters = msg.hyperparameters;
  out.centroid = fromMsg(msg.centroid);
  out.scale = msg.scale;
  out.position_sd_scale = msg.position_sd_scale > 0.0 && std::isfinite(msg.position_sd_scale) ? msg.position_sd_scale : 1.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (msg.labels[i] < -1 || msg.labels[i] > 1 || msg.sources[i] > static_cast<uint8_t>(gpatlas_core::PointSource::kViewSupport)) {
      *error = "training point " + std::to_string(i) + " has an invalid label or source";
      return false;
    }
    gpatlas_core::TrainingPoint p;
    p.position = fromMsg(msg.points[i]);
    p.label = static_cast<gpatlas_core::PointLabel>(msg.labels[i]);
    p.noise_sigma = msg.noise_sigmas[i];
    p.source = static_cast<gpatlas_core::PointSource>(msg.sources[i]);
    if (!msg.surface_distances_m.empty()) p.surface_distance_m = msg.surface_distances_m[i];
    if (!msg.slope_directions.empty())
      p.slope_direction = {msg.slope_directions[i].x, msg.slope_directions[i].y, msg.slope_directions[i].z};
    if (!msg.target_overrides.empty()) p.target_override = msg.target_overrides[i];
    if (!msg.prediction_errors_m.empty()) p.prediction_error_m = msg.prediction_errors_m[i];
    out.observations.push_back(p);
  }
  *state = std::move(out);
  return true;
}

void setView(const std::optional<gpatlas_core::CameraView>& view, gpatlas_msgs::TrainingSet* msg) {
  msg->view_origin = toPointMsg(view ? view->origin : Eigen::Vector3d::Zero());
  msg->view_points.clear();
  if (!view) return;
  msg->view_points.reserve(view->points.size());
  for (const auto& p : view->points) {
    geometry_msgs::Point32 q;
    q.x = static_cast<float>(p.x());
    q.y = static_cast<float>(p.y());
    q.z = static_cast<float>(p.z());
    msg->view_points.push_back(q);
  }
}

bool viewFromMsg(const gpatlas_msgs::TrainingSet& msg, std::optional<gpatlas_core::CameraView>* view,
                 std::string* error) {
  view->reset();
  if (msg.view_points.empty()) return true;
  gpatlas_core::CameraView out;
  out.origin = fromMsg(msg.view_origin);
  out.points.reserve(msg.view_points.size());
  for (const auto& p : msg.view_points) out.points.emplace_back(p.x, p.y, p.z);
  if (const std::string problem = gpatlas_core::validate(out); !problem.empty()) {
    *error = "training set's camera view: " + problem;
    return false;
  }
  *view = std::move(out);
  return true;
}

bool modelFromMsg(const gpatlas_msgs::TrainingSet& msg, gpatlas_core::SurfaceModelConfig config,
                  std::unique_ptr<gpatlas_core::SurfaceModel>* model, std::string* error) {
  gpatlas_core::SurfaceModelState state;
  if (!fromMsg(msg, &state, error)) return false;
  config.type = state.model;
  try {
    std::unique_ptr<gpatlas_core::SurfaceModel> rebuilt = gpatlas_core::makeSurfaceModel(config);
    const gpatlas_core::FitReport report = rebuilt->restore(state);
    if (!report.ok) {
      *error = "cannot fit the received training set: " + report.message;
      return false;
    }
    *model = std::move(rebuilt);
  } catch (const std::exception& e) {
    *error = std::string("cannot build the model: ") + e.what();
    return false;
  }
  return true;
}

bool cloudToPoints(const sensor_msgs::PointCloud2& cloud, std::vector<Eigen::Vector3d>* points,
                   std::size_t* num_invalid, std::string* error) {
  bool has_x = false, has_y = false, has_z = false;
  for (const auto& f : cloud.fields) {
    const bool is_float = f.datatype == sensor_msgs::PointField::FLOAT32;
    const bool is_xyz = f.name == "x" || f.name == "y" || f.name == "z";
    // A field that does not fit in a point would make the iterators read past the buffer.
    if (is_xyz && is_float && static_cast<std::size_t>(f.offset) + sizeof(float) > cloud.point_step) {
      *error = "point cloud field '" + f.name + "' lies outside point_step";
      return false;
    }
    has_x |= f.name == "x" && is_float;
    has_y |= f.name == "y" && is_float;
    has_z |= f.name == "z" && is_float;
  }
  if (!(has_x && has_y && has_z)) {
    *error = "point cloud has no float32 x, y, z fields";
    return false;
  }
  const std::size_t total = static_cast<std::size_t>(cloud.width) * cloud.height;
  const std::size_t packed_row = static_cast<std::size_t>(cloud.width) * cloud.point_step;
  if (cloud.height > 1 && cloud.row_step != packed_row) {
    // The iterators walk the data as one packed array: padded rows would be misread.
    *error = "point cloud rows are padded (row_step != width * point_step): not supported";
    return false;
  }
  if (cloud.data.size() < total * cloud.point_step) {
    *error = "point cloud data is shorter than width * height * point_step";
    return false;
  }
  points->clear();
  points->reserve(total);
  *num_invalid = 0;
  sensor_msgs::PointCloud2ConstIterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (std::size_t i = 0; i < total; ++i, ++x, ++y, ++z) {
    if (std::isfinite(*x) && std::isfinite(*y) && std::isfinite(*z)) points->emplace_back(*x, *y, *z);
    else ++*num_invalid;
  }
  return true;
}

void varianceColour(double variance, double variance_max, float* r, float* g, float* b) {
  const double t = variance_max > 0.0 && std::isfinite(variance) ? std::clamp(variance / variance_max, 0.0, 1.0) : 1.0;
  // Blue -> green -> red.
  *r = static_cast<float>(std::clamp(2.0 * t - 1.0, 0.0, 1.0));
  *g = static_cast<float>(1.0 - std::abs(2.0 * t - 1.0));
  *b = static_cast<float>(std::clamp(1.0 - 2.0 * t, 0.0, 1.0));
}

sensor_msgs::PointCloud2 pointsToCloud(const std::vector<Eigen::Vector3d>& points,
                                       const std::vector<double>& variances, double variance_max,
                                       const std::string& frame_id) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = frame_id;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(5, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32,
                                "z", 1, sensor_msgs::PointField::FLOAT32, "rgb", 1, sensor_msgs::PointField::FLOAT32,
                                "variance", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(points.size());
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z"), var(cloud, "variance");
  sensor_msgs::PointCloud2Iterator<uint8_t> rgb(cloud, "rgb");
  for (std::size_t i = 0; i < points.size(); ++i, ++x, ++y, ++z, ++var, ++rgb) {
    *x = static_cast<float>(points[i].x());
    *y = static_cast<float>(points[i].y());
    *z = static_cast<float>(points[i].z());
    const double v = i < variances.size() ? variances[i] : 0.0;
    *var = static_cast<float>(v);
    float r, g, b;
    varianceColour(v, variance_max, &r, &g, &b);
    // PCL's packed rgb layout: b, g, r, (unused) bytes in memory.
    rgb[0] = static_cast<uint8_t>(b * 255.0f);
    rgb[1] = static_cast<uint8_t>(g * 255.0f);
    rgb[2] = static_cast<uint8_t>(r * 255.0f);
    rgb[3] = 0;
  }
  return cloud;
}

shape_msgs::Mesh toMsg(const gpatlas_core::TriangleMesh& mesh) {
  shape_msgs::Mesh msg;
  msg.vertices.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) msg.vertices.push_back(toPointMsg(v));
  msg.triangles.reserve(mesh.triangles.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    shape_msgs::MeshTriangle triangle;
    for (int k = 0; k < 3; ++k) triangle.vertex_indices[static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(t[k]);
    msg.triangles.push_back(triangle);
  }
  return msg;
}

bool fromMsg(const shape_msgs::Mesh& msg, gpatlas_core::TriangleMesh* mesh, std::string* error) {
  gpatlas_core::TriangleMesh out;
  out.vertices.reserve(msg.vertices.size());
  for (const auto& v : msg.vertices) out.vertices.push_back(fromMsg(v));
  out.triangles.reserve(msg.triangles.size());
  for (std::size_t i = 0; i < msg.triangles.size(); ++i) {
    const auto& t = msg.triangles[i].vertex_indices;
    if (t[0] >= msg.vertices.size() || t[1] >= msg.vertices.size() || t[2] >= msg.vertices.size()) {
      *error = "triangle " + std::to_string(i) + " indexes a vertex past the " + std::to_string(msg.vertices.size()) +
               " of the mesh";
      return false;
    }
    out.triangles.emplace_back(static_cast<int>(t[0]), static_cast<int>(t[1]), static_cast<int>(t[2]));
  }
  *mesh = std::move(out);
  return true;
}

}  // namespace gpatlas_conversions
