#include "simulation_server.h"

#include "probe_sim/object_mesh.h"

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_conversions/ros_parameters.h>
#include <gpatlas_core/config/config_readers.h>
#include <gpatlas_geometry/config_readers.h>
#include <gpatlas_motion/config_readers.h>

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/JointState.h>
#include <urdf/model.h>
#include <visualization_msgs/Marker.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <sstream>
#include <utility>

namespace probe_sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

template <typename Vector>
std::string describe(const Vector& v) {
  std::ostringstream out;
  out << "(";
  for (Eigen::Index i = 0; i < v.size(); ++i) out << (i ? ", " : "") << v[i];
  out << ")";
  return out.str();
}

// Empty when every waypoint and normal is finite, else which one is not and how. The prober
// checks this too, but a NaN deserves to be called by its name: it usually means a planner bug.
std::string findNonFinite(const gpatlas_core::Touch& touch) {
  auto check = [](const Eigen::Vector3d& v, const std::string& what) -> std::string {
    if (v.allFinite()) return "";
    const bool nan = v.array().isNaN().any();
    return what + " has " + (nan ? "a NaN" : "an infinite") + " coordinate " + describe(v);
  };
  for (std::size_t i = 0; i < touch.points.size(); ++i) {
    std::string problem = check(touch.points[i], "waypoint " + std::to_string(i));
    if (!problem.empty()) return problem;
  }
  for (std::size_t i = 0; i < touch.normals.size(); ++i) {
    std::string problem = check(touch.normals[i], "normal " + std::to_string(i));
    if (!problem.empty()) return problem;
  }
  return "";
}

geometry_msgs::TransformStamped toTransformMsg(const Eigen::Isometry3d& pose,
                                               const std::string& parent,
                                               const std::string& child) {
  geometry_msgs::TransformStamped msg;
  msg.header.stamp = ros::Time::now();
  msg.header.frame_id = parent;
  msg.child_frame_id = child;
  msg.transform.translation.x = pose.translation().x();
  msg.transform.translation.y = pose.translation().y();
  msg.transform.translation.z = pose.translation().z();
  const Eigen::Quaterniond q(pose.linear());
  msg.transform.rotation.x = q.x();
  msg.transform.rotation.y = q.y();
  msg.transform.rotation.z = q.z();
  msg.transform.rotation.w = q.w();
  return msg;
}

// The pad's squares and the patch's points, replacing the last touch's (a touch without a pad
// press only clears them).
visualization_msgs::MarkerArray padMarkers(const gpatlas_core::ProbeResult& result,
                                           const gpatlas_msgs::Observations& observations) {
  visualization_msgs::MarkerArray markers;
  visualization_msgs::Marker clear;
  clear.header = observations.header;
  clear.action = visualization_msgs::Marker::DELETEALL;
  markers.markers.push_back(clear);
  if (result.pads.empty()) return markers;
  visualization_msgs::Marker points;
  points.header = observations.header;
  points.ns = "patch";
  points.type = visualization_msgs::Marker::POINTS;
  points.scale.x = points.scale.y = 0.001;
  points.color.g = 0.8f;
  points.color.b = 0.2f;
  points.color.a = 1.0f;
  points.pose.orientation.w = 1.0;
  points.points = observations.contacts;
  markers.markers.push_back(points);
  for (std::size_t i = 0; i < result.pads.size(); ++i) {
    visualization_msgs::Marker pad;
    pad.header = observations.header;
    pad.ns = "pad";
    pad.id = static_cast<int>(i);
    pad.type = visualization_msgs::Marker::CUBE;
    pad.pose = observations.pad_poses[i];
    pad.scale.x = pad.scale.y = result.pads[i].size_m;
    pad.scale.z = 0.001;
    pad.color.r = 0.2f;
    pad.color.g = 0.4f;
    pad.color.b = 1.0f;
    pad.color.a = 0.4f;
    markers.markers.push_back(pad);
  }
  return markers;
}

}  // namespace

SimulationServer::SimulationServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(std::move(nh)), pnh_(std::move(pnh)) {
  // Each step needs the previous ones; the first failure is the reason every service gives.
  for (auto step : {&SimulationServer::readSettings, &SimulationServer::loadRobot,
                    &SimulationServer::loadObject, &SimulationServer::setUpCamera,
                    &SimulationServer::setUpProber}) {
    try {
      unavailable_reason_ = (this->*step)();
    } catch (const std::exception& e) {
      unavailable_reason_ = std::string("unexpected error while starting: ") + e.what();
    }
    if (!unavailable_reason_.empty()) break;
  }

  probe_service_ = pnh_.advertiseService("probe", &SimulationServer::onProbe, this);
  capture_service_ = pnh_.advertiseService("capture", &SimulationServer::onCapture, this);
  ground_truth_service_ = pnh_.advertiseService("ground_truth", &SimulationServer::onGroundTruth, this);
  select_object_service_ = pnh_.advertiseService("select_object", &SimulationServer::onSelectObject, this);
  clicked_point_subscriber_ = nh_.subscribe("clicked_point", 1, &SimulationServer::onClickedPoint, this);
  cloud_publisher_ = pnh_.advertise<sensor_msgs::PointCloud2>("points", 1);
  marker_publisher_ = pnh_.advertise<visualization_msgs::Marker>("object_marker", 1, true);
  patch_publisher_ = pnh_.advertise<visualization_msgs::MarkerArray>("patch", 1, true);

  // The robot is shown (joint_states) even when the object failed to load, so that rviz still
  // displays something while the user fixes the object parameter.
  if (!joint_names_.empty()) {
    joint_state_publisher_ = nh_.advertise<sensor_msgs::JointState>("joint_states", 10);
    joint_state_timer_ = nh_.createTimer(ros::Duration(1.0 / settings_.joint_states_rate_hz),
                                         &SimulationServer::onJointStateTimer, this);
  }

  if (!unavailable_reason_.empty()) {
    ROS_ERROR_STREAM("probe_sim: simulation unavailable, every service will answer with the "
                     "reason: " << unavailable_reason_);
    return;
  }
  publishObjectMarker();
  if (settings_.publish_cloud_rate_hz > 0.0) {
    cloud_timer_ = nh_.createTimer(ros::Duration(1.0 / settings_.publish_cloud_rate_hz),
                                   &SimulationServer::onCloudTimer, this);
  }
  ROS_INFO_STREAM("probe_sim: ready: object '" << settings_.object << "' ("
                  << scene_->objectMesh().triangles.size() << " triangles) at "
                  << describe(settings_.object_position_xy_m) << " in '" << settings_.world_frame
                  << "', " << settings_.probe << " probe, "
                  << (arm_ ? "on the left arm (judged on the way to each touch and back)" : "free-floating probe")
                  << ", camera '" << settings_.camera_frame << "' at "
                  << describe(camera_->pose().translation()));
}

std::string SimulationServer::readSettings() {
  // probe_sim's config/simulation.yaml and, from config/pipeline.yaml, the world frame, the
  // probe's body and rest (approach/), segmentation/ and the seed: read as gpatlas_bench reads them.
  const gpatlas_conversions::RosParameterSource source(pnh_);
  gpatlas_core::ParamReader reader(source);
  readSimulation(reader, &settings_);
  gpatlas_core::PipelineFrames frames;
  gpatlas_core::readFrames(reader, &frames);
  settings_.world_frame = frames.world_frame;
  gpatlas_motion::readApproach(reader, &approach_);
  // A pick reaches as far as segmentation's, so that one click picks for both.
  gpatlas_geometry::ObjectSegmenter::Config segmentation;
  gpatlas_geometry::readSegmenter(reader, &segmentation);
  select_max_distance_m_ = segmentation.select_max_distance_m;
  seed_ = gpatlas_core::readSeed(reader);
  std::string errors = reader.errors();
  const std::string invalid = validate(settings_);
  if (!invalid.empty()) errors += (errors.empty() ? "" : "; ") + invalid;
  return errors.empty() ? "" : "invalid parameters: " + errors;
}

std::string SimulationServer::loadRobot() {
  if (!nh_.getParam("robot_description", urdf_xml_) || urdf_xml_.empty()) {
    urdf_xml_.clear();
    // Without a robot the probe floats freely, but the camera then needs an explicit pose.
    if (settings_.use_arm) {
      return "use_arm is true but the parameter " + nh_.resolveName("robot_description") +
             " is not set (load the URDF, or set ~use_arm false)";
    }
    return "";
  }
  urdf::Model model;
  if (!model.initString(urdf_xml_)) {
    return "the parameter " + nh_.resolveName("robot_description") + " is not a valid URDF";
  }

  std::vector<double> lower, upper;
  for (const auto& [name, joint] : model.joints_) {  // std::map: sorted by name
    if (joint->type != urdf::Joint::REVOLUTE && joint->type != urdf::Joint::CONTINUOUS &&
        joint->type != urdf::Joint::PRISMATIC) {
      continue;
    }
    joint_names_.push_back(name);
    const bool limited = joint->type != urdf::Joint::CONTINUOUS && joint->limits;
    lower.push_back(limited ? joint->limits->lower : -kPi);
    upper.push_back(limited ? joint->limits->upper : kPi);
  }
  // ~zeros has the name and format of joint_state_publisher's, so vito_description's
  // config/ready_pose.yaml loads into this node unchanged.
  ready_positions_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(joint_names_.size()));
  std::map<std::string, double> zeros;
  if (pnh_.hasParam("zeros") && !pnh_.getParam("zeros", zeros)) {
    return "invalid parameters: " + pnh_.resolveName("zeros") +
           " must map joint names to positions (rad)";
  }
  for (std::size_t j = 0; j < joint_names_.size(); ++j) {
    const auto given = zeros.find(joint_names_[j]);
    const double position = given != zeros.end() ? given->second : 0.0;
    ready_positions_[static_cast<Eigen::Index>(j)] = std::clamp(position, lower[j], upper[j]);
  }
  for (const auto& [name, position] : zeros) {
    if (std::find(joint_names_.begin(), joint_names_.end(), name) == joint_names_.end()) {
      ROS_WARN_STREAM("probe_sim: " << pnh_.resolveName("zeros") << " names joint '" << name
                      << "', which robot_description does not have as a movable joint");
    }
  }
  displayed_positions_ = ready_positions_;

  if (!settings_.use_arm) return "";
  ArmConfig arm_config;
  arm_config.base_link = settings_.world_frame;
  arm_config.tip_link = settings_.tip_frame;
  try {
    arm_ = std::make_shared<const Arm>(Arm::fromUrdfString(urdf_xml_, arm_config));
  } catch (const std::exception& e) {
    return "use_arm is true but no arm from '" + settings_.world_frame + "' to '" +
           settings_.tip_frame + "' in robot_description: " + e.what();
  }
  for (const std::string& name : arm_->jointNames()) {
    const auto it = std::find(joint_names_.begin(), joint_names_.end(), name);
    if (it == joint_names_.end()) return "arm joint '" + name + "' is not a movable URDF joint";
    arm_joint_indices_.push_back(static_cast<int>(it - joint_names_.begin()));
  }
  return "";
}

std::string SimulationServer::loadObject() {
  const SimulationSettings& s = settings_;
  TriangleMesh mesh;
  try {
    mesh = loadSimulatedObject(s);
  } catch (const std::exception& e) {
    return std::string("no object loaded: ") + e.what();
  }
  const Eigen::AlignedBox3d bounds = mesh.boundingBox();
  const Eigen::Vector2d table_min = s.table_centre_xy_m - 0.5 * s.table_size_xy_m;
  const Eigen::Vector2d table_max = s.table_centre_xy_m + 0.5 * s.table_size_xy_m;
  if ((bounds.min().head<2>().array() < table_min.array()).any() ||
      (bounds.max().head<2>().array() > table_max.array()).any()) {
    ROS_WARN_STREAM("probe_sim: the object's footprint " << describe(bounds.min().head<2>())
                    << " to " << describe(bounds.max().head<2>())
                    << " overhangs the table; check ~simulation/object_position_xy_m and ~simulation/object_scale");
  }
  const double largest_side_m = bounds.sizes().maxCoeff();
  if (largest_side_m > 2.0 || largest_side_m < 0.005) {
    ROS_WARN_STREAM("probe_sim: the object is " << largest_side_m
                    << " m across; is ~simulation/object_scale right (0.001 for a mesh in mm)?");
  }
  try {
    objects_ = sceneObjects(s, mesh);
    scene_ = makeSimulatedScene(s, objects_, 0);
  } catch (const std::exception& e) {
    return std::string("no scene: ") + e.what();
  }
  return "";
}

std::string SimulationServer::setUpCamera() {
  const SimulationSettings& s = settings_;
  if (s.camera_eye_m) {
    // A camera placed by parameters has no frame in the robot; a URDF frame of the same name
    // would get two conflicting poses in tf.
    urdf::Model model;
    if (!urdf_xml_.empty() && model.initString(urdf_xml_) && model.getLink(s.camera_frame)) {
      return "invalid parameters: " + pnh_.resolveName("simulation/camera_frame") + " '" + s.camera_frame +
             "' is a frame of robot_description, so it cannot be placed by camera_eye_m and "
             "camera_target_m: choose another frame name, or drop them to use the URDF's pose";
    }
  }
  std::string error;
  // The URDF's fixed camera frame: the same transform that robot_state_publisher puts on
  // /tf_static, without waiting for tf at start-up.
  const std::optional<Eigen::Isometry3d> pose = cameraPose(s, urdf_xml_, &error);
  if (!pose) return error;
  if (s.camera_eye_m) static_broadcaster_.sendTransform(toTransformMsg(*pose, s.world_frame, s.camera_frame));
  // The bench's rule: the camera's noise follows the run's seed.
  camera_ = std::make_unique<DepthCamera>(cameraConfig(s, static_cast<std::uint32_t>(seed_ + 1)), *pose);
  return "";
}

std::string SimulationServer::setUpProber() {
  prober_ = makeSimulatedProber(scene_, settings_, approach_);
  if (arm_) {
    try {
      prober_->setArm(arm_);
    } catch (const std::exception& e) {
      return std::string("use_arm: ") + e.what() + " (approach/rest_tip_position_m)";
    }
    // The arm is shown resting where the prober rests it.
    std::lock_guard<std::mutex> lock(joint_state_mutex_);
    for (std::size_t i = 0; i < arm_joint_indices_.size(); ++i)
      ready_positions_[arm_joint_indices_[i]] = prober_->armRest()[static_cast<Eigen::Index>(i)];
    displayed_positions_ = ready_positions_;
  }

  // Not an error (the camera may be meant to see only part of the scene), but a blank view is
  // almost always a misplaced object or camera.
  sensor_msgs::PointCloud2 cloud;
  std::string message;
  if (!renderCloud(&cloud, &message)) ROS_WARN_STREAM("probe_sim: " << message);
  // A fresh camera, so that the first view a client captures has the noise of the run's seed
  // (as in gpatlas_bench), not the noise that follows this check's.
  camera_ = std::make_unique<DepthCamera>(camera_->config(), camera_->pose());
  return "";
}

bool SimulationServer::onProbe(gpatlas_msgs::Probe::Request& request,
                               gpatlas_msgs::Probe::Response& response) {
  response.success = false;
  response.observations.header.frame_id = settings_.world_frame;
  response.observations.header.stamp = ros::Time::now();
  try {
    if (!unavailable_reason_.empty()) {
      response.reason = unavailable_reason_;
      return true;
    }
    const std::string& frame = request.touch.header.frame_id;
    if (!frame.empty() && frame != settings_.world_frame) {
      response.reason = "touch is in frame '" + frame + "' but the simulation works in '" +
                        settings_.world_frame + "'";
      return true;
    }
    gpatlas_core::Touch touch;
    std::string error;
    // The arm's trajectories, when planned for it, in the order of its joints.
    if (!gpatlas_conversions::fromMsg(request.touch, &touch, &error, arm_ ? &arm_->jointNames() : nullptr)) {
      response.reason = "invalid touch: " + error;
      return true;
    }
    error = findNonFinite(touch);
    if (!error.empty()) {
      response.reason = "invalid touch: " + error;
      return true;
    }

    gpatlas_core::ProbeResult result;
    std::vector<Eigen::VectorXd> arm_solutions;
    {
      std::lock_guard<std::mutex> lock(simulation_mutex_);
      result = prober_->probe(touch);
      arm_solutions = prober_->lastArmSolutions();
    }
    response = gpatlas_conversions::toProbeResponseMsg(result);
    response.observations.header.frame_id = settings_.world_frame;
    response.observations.header.stamp = ros::Time::now();
    if (result.approach_collisions + result.retreat_collisions > 0)
      ROS_WARN_STREAM("probe_sim: the probe hit the scene " << result.approach_collisions << " time(s) on the way to the touch and "
                      << result.retreat_collisions << " on the way back"
                      << (touch.approach_path.empty() ? " (no planned approach: a straight motion from the rest)" : ""));
    if (!arm_solutions.empty()) animateArm(arm_solutions);
    patch_publisher_.publish(padMarkers(result, response.observations));
    ROS_DEBUG_STREAM("probe_sim: touch with " << touch.points.size() << " waypoint(s): "
                     << (result.success ? "success" : "failed: " + result.reason) << ", "
                     << result.contacts.size() << " contacts");
  } catch (const std::exception& e) {
    response.success = false;
    response.reason = std::string("probe failed: ") + e.what();
    ROS_ERROR_STREAM("probe_sim: ~probe: " << response.reason);
  }
  return true;
}

bool SimulationServer::onGroundTruth(gpatlas_msgs::GetMesh::Request& /*request*/,
                                     gpatlas_msgs::GetMesh::Response& response) {
  response.success = false;
  if (!unavailable_reason_.empty()) {
    response.message = unavailable_reason_;
    return true;
  }
  // A pick may replace the scene meanwhile: this one stays alive while its mesh is sent.
  const std::shared_ptr<const Scene> scene = currentScene();
  const TriangleMesh& mesh = scene->objectMesh();
  response.header.frame_id = settings_.world_frame;
  response.header.stamp = ros::Time::now();
  response.mesh = gpatlas_conversions::toMsg(mesh);
  response.success = true;
  response.message = std::to_string(mesh.triangles.size()) + " triangles in " + settings_.world_frame;
  return true;
}

bool SimulationServer::onSelectObject(gpatlas_msgs::SelectObject::Request& request,
                                      gpatlas_msgs::SelectObject::Response& response) {
  response.success = false;
  response.changed = false;
  try {
    if (!unavailable_reason_.empty()) {
      response.message = unavailable_reason_;
      return true;
    }
    const geometry_msgs::Point& p = request.point.point;
    const Eigen::Vector3d point(p.x, p.y, p.z);
    if (!point.allFinite()) {
      response.message = "the point is not finite";
      return true;
    }
    if (!request.point.header.frame_id.empty() && request.point.header.frame_id != settings_.world_frame) {
      response.message = "the point must be in '" + settings_.world_frame + "' (the simulation has no tf), not '" +
                         request.point.header.frame_id + "'";
      return true;
    }
    std::lock_guard<std::mutex> lock(simulation_mutex_);
    const std::size_t nearest = nearestObject(objects_, point, &response.distance_m);
    // Segmentation's bound, to the object's box (which holds every point of it the camera saw).
    if (response.distance_m > select_max_distance_m_) {
      response.message = "no object within " + std::to_string(select_max_distance_m_) + " m of " + describe(point);
      return true;
    }
    if (nearest != explored_) {
      std::shared_ptr<Scene> scene = makeSimulatedScene(settings_, objects_, nearest);
      std::unique_ptr<SimulatedProber> prober = makeSimulatedProber(scene, settings_, approach_);
      if (arm_) prober->setArm(arm_);  // the arm rests where it did: its rest is not the object's
      scene_ = std::move(scene);
      prober_ = std::move(prober);
      explored_ = nearest;
      response.changed = true;
    }
    response.success = true;
    response.object_points = static_cast<std::uint32_t>(objects_[nearest].vertices.size());
    response.message = nearest == 0 ? "the object" : "neighbour " + std::to_string(nearest - 1);
    response.message += " (" + std::to_string(objects_[nearest].triangles.size()) + " triangles) is explored";
  } catch (const std::exception& e) {
    response.success = false;
    response.message = std::string("selection failed: ") + e.what();
    ROS_ERROR_STREAM("probe_sim: ~select_object: " << response.message);
    return true;
  }
  ROS_INFO_STREAM("probe_sim: ~select_object: " << response.message);
  if (response.changed) publishObjectMarker();
  return true;
}

void SimulationServer::onClickedPoint(const geometry_msgs::PointStamped::ConstPtr& point) {
  gpatlas_msgs::SelectObject::Request request;
  gpatlas_msgs::SelectObject::Response response;
  request.point = *point;
  onSelectObject(request, response);
  if (!response.success) ROS_WARN_STREAM("probe_sim: clicked_point: " << response.message);
}

bool SimulationServer::onCapture(gpatlas_msgs::Capture::Request& /*request*/,
                                 gpatlas_msgs::Capture::Response& response) {
  response.success = false;
  try {
    if (!unavailable_reason_.empty()) {
      response.message = unavailable_reason_;
      return true;
    }
    response.success = renderCloud(&response.cloud, &response.message);
    if (response.success) cloud_publisher_.publish(response.cloud);
  } catch (const std::exception& e) {
    response.success = false;
    response.message = std::string("capture failed: ") + e.what();
    ROS_ERROR_STREAM("probe_sim: ~capture: " << response.message);
  }
  return true;
}

void SimulationServer::onCloudTimer(const ros::TimerEvent& /*event*/) {
  try {
    sensor_msgs::PointCloud2 cloud;
    std::string message;
    if (renderCloud(&cloud, &message)) {
      cloud_publisher_.publish(cloud);
    } else {
      ROS_WARN_STREAM_THROTTLE(10.0, "probe_sim: " << message);
    }
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM_THROTTLE(10.0, "probe_sim: rendering the depth cloud failed: " << e.what());
  }
}

bool SimulationServer::renderCloud(sensor_msgs::PointCloud2* cloud, std::string* message) {
  DepthCloud depth;
  {
    std::lock_guard<std::mutex> lock(simulation_mutex_);
    depth = camera_->capture(*scene_);
  }
  if (depth.points_camera.cols() == 0) {
    *message = "the object is not in the camera's view (0 points); camera '" +
               settings_.camera_frame + "' at " + describe(camera_->pose().translation()) +
               " looking along " + describe(camera_->pose().linear().col(2));
    return false;
  }
  std::vector<Eigen::Vector3d> points(static_cast<std::size_t>(depth.points_camera.cols()));
  for (Eigen::Index i = 0; i < depth.points_camera.cols(); ++i) {
    points[static_cast<std::size_t>(i)] = depth.points_camera.col(i);
  }
  // Camera points carry no model variance: the cloud's variance channel is 0 throughout.
  *cloud = gpatlas_conversions::pointsToCloud(points, {}, 1.0, settings_.camera_frame);
  cloud->header.stamp = ros::Time::now();
  *message = std::to_string(points.size()) + " points";
  return true;
}

std::shared_ptr<const Scene> SimulationServer::currentScene() {
  std::lock_guard<std::mutex> lock(simulation_mutex_);
  return scene_;
}

void SimulationServer::publishObjectMarker() {
  const std::shared_ptr<const Scene> scene = currentScene();
  const TriangleMesh& mesh = scene->objectMesh();
  visualization_msgs::Marker marker;
  marker.header.frame_id = settings_.world_frame;
  marker.header.stamp = ros::Time::now();
  marker.ns = "ground_truth_object";
  marker.id = 0;
  marker.type = visualization_msgs::Marker::TRIANGLE_LIST;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.scale.x = marker.scale.y = marker.scale.z = 1.0;
  marker.color.r = 0.55f;
  marker.color.g = 0.75f;
  marker.color.b = 0.55f;
  marker.color.a = 0.5f;  // see-through, so the learned surface can be compared inside it
  marker.points.reserve(3 * mesh.triangles.size());
  for (const Eigen::Vector3i& triangle : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      marker.points.push_back(gpatlas_conversions::toPointMsg(mesh.vertices[triangle[k]]));
    }
  }
  marker_publisher_.publish(marker);
}

void SimulationServer::animateArm(const std::vector<Eigen::VectorXd>& arm_solutions) {
  const double max_step_rad = settings_.arm_max_joint_speed_rad_s / settings_.joint_states_rate_hz;
  std::lock_guard<std::mutex> lock(joint_state_mutex_);
  std::vector<Eigen::VectorXd> keyframes;
  for (const Eigen::VectorXd& arm_joints : arm_solutions) {
    Eigen::VectorXd full = ready_positions_;
    for (std::size_t i = 0; i < arm_joint_indices_.size(); ++i) {
      full[arm_joint_indices_[i]] = arm_joints[static_cast<Eigen::Index>(i)];
    }
    keyframes.push_back(full);
  }
  // The motion ends at the arm's rest (ready_positions_ holds it for the arm's joints).
  keyframes.push_back(ready_positions_);

  // A new touch replaces whatever motion is still queued, starting from what is shown now.
  pending_positions_.clear();
  Eigen::VectorXd from = displayed_positions_;
  for (const Eigen::VectorXd& to : keyframes) {
    const double largest_change = (to - from).cwiseAbs().maxCoeff();
    const int steps = std::max(1, static_cast<int>(std::ceil(largest_change / max_step_rad)));
    for (int k = 1; k < steps; ++k) {
      pending_positions_.push_back(from + (to - from) * (static_cast<double>(k) / steps));
    }
    pending_positions_.push_back(to);  // exactly, so that the arm comes back to rest exactly
    from = to;
  }
}

void SimulationServer::onJointStateTimer(const ros::TimerEvent& /*event*/) {
  sensor_msgs::JointState msg;
  {
    std::lock_guard<std::mutex> lock(joint_state_mutex_);
    if (!pending_positions_.empty()) {
      displayed_positions_ = pending_positions_.front();
      pending_positions_.pop_front();
    }
    msg.position.assign(displayed_positions_.data(),
                        displayed_positions_.data() + displayed_positions_.size());
  }
  msg.header.stamp = ros::Time::now();
  msg.name = joint_names_;
  joint_state_publisher_.publish(msg);
}

}  // namespace probe_sim
