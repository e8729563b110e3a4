#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/markers.h"
#include "gpatlas_ros/servers.h"

#include <gpatlas_core/explorer.h>
#include <tf2_eigen/tf2_eigen.h>
#include <shape_msgs/Mesh.h>
#include <visualization_msgs/Marker.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace gpatlas_ros {

namespace {
void appendTrainingPoints(const std::vector<Eigen::Vector3d>& positions, gpatlas_core::PointLabel label, double sigma,
                          gpatlas_core::PointSource source, std::vector<gpatlas_core::TrainingPoint>* out) {
  for (const auto& p : positions) {
    gpatlas_core::TrainingPoint t;
    t.position = p;
    t.label = label;
    t.noise_sigma = sigma;
    t.source = source;
    out->push_back(t);
  }
}
}  // namespace

GpModelServer::GpModelServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  ParamReader reader(pnh_);
  world_frame_ = reader.text("world_frame", "world");
  tf_timeout_s_ = reader.number("tf_timeout_s", tf_timeout_s_, 0.0, 60.0);
  // The fit is O(n^3) in time and O(n^2) in memory: a few thousand points is the useful range.
  max_vision_points_ = reader.integer("max_vision_points", max_vision_points_, 4, 5000);
  touch_config_.min_point_spacing_m = reader.number("min_point_spacing_m", touch_config_.min_point_spacing_m, 0.0, 1.0);
  touch_config_.min_free_space_spacing_m =
      reader.number("min_free_space_spacing_m", touch_config_.min_free_space_spacing_m, 0.0, 1.0);
  touch_config_.contact_inside_depth_m =
      reader.number("contact_inside/depth_m", touch_config_.contact_inside_depth_m, 0.0, 0.1);
  touch_config_.contact_inside_noise_sigma =
      reader.number("contact_inside/noise_sigma", touch_config_.contact_inside_noise_sigma, 0.0, 10.0);
  touch_config_.contact_tangent_noise_sigma =
      reader.number("contact_tangent/noise_sigma", touch_config_.contact_tangent_noise_sigma, -1.0, 10.0);
  tune_ = reader.flag("tuning/enabled", tune_);
  display_v_max_ = reader.number("v_max", display_v_max_, 1e-12, 1e12);
  readGpis(reader, &gpis_config_);
  readNoise(reader, &noise_);
  readTuner(reader, &tuner_config_);
  readMesher(reader, &mesher_config_);
  readViewFreeSpace(reader, &view_free_config_, &sensor_frame_);
  view_free_config_.noise_sigma = noise_.free_space_sigma;
  readOccludedInterior(reader, &occluded_config_);
  touch_config_.retract_contradicted_guesses =
      reader.flag("occluded_interior/retract_on_touch", touch_config_.retract_contradicted_guesses);
  // A guess left shallower than the sampling's own clearance is dropped (same fraction, of the
  // model's scale rather than of the view's radius: equal at the first fit).
  touch_config_.guess_min_depth_fraction = occluded_config_.margin_fraction;
  readSupportPlane(reader, &use_support_plane_, &support_clearance_m_, &below_support_config_);
  below_support_config_.noise_sigma = noise_.free_space_sigma;
  touch_config_.contact_noise_sigma = noise_.touch_sigma;
  touch_config_.free_space_noise_sigma = noise_.free_space_sigma;
  reader.report("gp_model");
  model_ = gpatlas_core::GpisModel(gpis_config_);  // readGpis() validated the config

  training_pub_ = pnh_.advertise<gpatlas_msgs::TrainingSet>("training_set", 1, true);
  surface_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("surface", 1, true);
  mesh_marker_pub_ = pnh_.advertise<visualization_msgs::Marker>("surface_mesh", 1, true);
  mesh_shape_pub_ = pnh_.advertise<shape_msgs::Mesh>("surface_shape", 1, true);
  add_srv_ = pnh_.advertiseService("add_observations", &GpModelServer::onAddObservations, this);
  reset_srv_ = pnh_.advertiseService("reset", &GpModelServer::onReset, this);
  points_sub_ = std::make_unique<TfGatedCloudSubscriber>(
      nh_, "points", &tf_buffer_, world_frame_, "gp_model", kTfWaitWarningS,
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg) { onPoints(msg); });
  contacts_sub_ = nh_.subscribe("contacts", 10, &GpModelServer::onContacts, this);
  if (use_support_plane_) plane_sub_ = nh_.subscribe("support_plane", 1, &GpModelServer::onSupportPlane, this);
  ROS_INFO_STREAM("gp_model: kernel " << gpis_config_.kernel << ", waiting for object points on "
                                      << points_sub_->topic());
}

void GpModelServer::onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  // roscpp does not catch exceptions thrown by subscription callbacks: one would end the
  // nodelet manager. Report it and keep the previous model.
  try {
    {
      std::lock_guard<std::mutex> lock(plane_mutex_);
      last_cloud_ = msg;
    }
    fitCloud(*msg);
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("gp_model: object cloud ignored: " << e.what());
  }
}

void GpModelServer::onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg) {
  try {
    gpatlas_core::SupportPlane plane;
    std::string error;
    if (!planeToWorld(*msg, tf_buffer_, world_frame_, tf_timeout_s_, &plane, &error)) {
      ROS_WARN_STREAM("gp_model: support plane ignored: " << error);
      return;
    }
    sensor_msgs::PointCloud2::ConstPtr refit;
    {
      std::lock_guard<std::mutex> lock(plane_mutex_);
      support_plane_ = StampedPlane{plane, msg->header.stamp};
      // The plane and its cloud come on two topics: if the cloud it belongs to was fitted
      // before the plane arrived, fit that cloud again.
      if (last_cloud_ && !last_fit_had_plane_ && support_plane_->belongsTo(last_cloud_->header.stamp))
        refit = last_cloud_;
    }
    if (refit) fitCloud(*refit);
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("gp_model: support plane ignored: " << e.what());
  }
}

void GpModelServer::fitCloud(const sensor_msgs::PointCloud2& cloud) {
  const sensor_msgs::PointCloud2* msg = &cloud;
  std::vector<Eigen::Vector3d> points;
  std::size_t invalid = 0;
  std::string error;
  if (!cloudToWorld(*msg, tf_buffer_, world_frame_, tf_timeout_s_, &points, &invalid, &error)) {
    ROS_WARN_STREAM("gp_model: object cloud ignored: " << error);
    return;
  }
  if (points.size() < 4) {
    ROS_WARN_STREAM("gp_model: object cloud ignored: " << points.size() << " valid points (" << invalid
                                                       << " NaN), need at least 4");
    return;
  }
  std::optional<gpatlas_core::SupportPlane> plane;
  if (use_support_plane_) {
    std::lock_guard<std::mutex> lock(plane_mutex_);
    if (support_plane_ && support_plane_->belongsTo(cloud.header.stamp)) plane = support_plane_->plane;
  }
  // The camera's rays crossed free space up to the object: outside points that keep the model
  // from closing cavities the camera looked into. Labels use the whole view, before the subset.
  std::vector<gpatlas_core::TrainingPoint> view_free;
  if (!sensor_frame_.empty()) {
    std::vector<Eigen::Vector3d> origin{Eigen::Vector3d::Zero()};
    std::string tf_error;
    if (!transformToWorld(tf_buffer_, world_frame_, sensor_frame_, msg->header.stamp, tf_timeout_s_, &origin,
                          &tf_error)) {
      ROS_WARN_STREAM_THROTTLE(10.0, "gp_model: no view free space (sensor_frame): " << tf_error);
    } else {
      auto free = gpatlas_core::sampleViewFreeSpace(points, origin.front(), view_free_config_);
      if (free.ok) view_free = std::move(free.points);
      else ROS_WARN_STREAM("gp_model: no view free space: " << free.message);
      // The fit is O(n^3): the view's free space gets at most as many points as its surface.
      if (view_free.size() > static_cast<std::size_t>(max_vision_points_)) {
        std::mt19937 pick(11);
        std::shuffle(view_free.begin(), view_free.end(), pick);
        view_free.resize(static_cast<std::size_t>(max_vision_points_));
      }
      // Material behind what the camera saw, within the view's hull: without it a surface the
      // camera never saw (a bowl's bottom behind its rim) has no zero crossing to explore.
      if (occluded_config_.max_points > 0) {
        auto inside = gpatlas_core::sampleOccludedInterior(points, origin.front(), occluded_config_);
        if (inside.ok) {
          if (plane) gpatlas_core::dropNearOrBelowPlane(&inside.points, *plane, support_clearance_m_);
          view_free.insert(view_free.end(), inside.points.begin(), inside.points.end());
        } else {
          ROS_WARN_STREAM("gp_model: no occluded interior: " << inside.message);
        }
      }
    }
  }
  if (plane) {
    auto below = gpatlas_core::sampleBelowSupport(points, *plane, below_support_config_);
    if (below.ok) view_free.insert(view_free.end(), below.points.begin(), below.points.end());
    else ROS_WARN_STREAM("gp_model: support plane not used: " << below.message);
  }
  // The GP costs O(n^3): keep a random, seeded subset of the view.
  std::mt19937 rng(7);
  std::shuffle(points.begin(), points.end(), rng);
  if (points.size() > static_cast<std::size_t>(max_vision_points_)) points.resize(static_cast<std::size_t>(max_vision_points_));

  std::lock_guard<std::mutex> lock(mutex_);
  // A new view replaces the previous vision points; touches and free space are kept.
  std::vector<gpatlas_core::TrainingPoint> data;
  appendTrainingPoints(points, gpatlas_core::PointLabel::kSurface, noise_.vision_sigma,
                       gpatlas_core::PointSource::kVision, &data);
  data.insert(data.end(), view_free.begin(), view_free.end());
  std::vector<Eigen::Vector3d> touch_evidence;
  for (const auto& t : model_.observations()) {
    if (t.source == gpatlas_core::PointSource::kVision) continue;
    data.push_back(t);
    if (t.source == gpatlas_core::PointSource::kFreeSpace || gpatlas_core::isSurfaceValue(t))
      touch_evidence.push_back(t.position);
  }
  // The new view's guesses must not bring back what earlier touches retracted (their kept,
  // thinned points stand for the touches here).
  if (touch_config_.retract_contradicted_guesses && model_.isFitted())
    gpatlas_core::retractContradictedInterior(&data, touch_evidence,
                                              touch_config_.guess_min_depth_fraction * model_.scale());
  const ros::WallTime start = ros::WallTime::now();
  const gpatlas_core::FitReport report = model_.fit(data);
  if (!report.ok) {
    ROS_ERROR_STREAM("gp_model: fit failed, previous model kept: " << report.message);
    return;
  }
  {
    std::lock_guard<std::mutex> plane_lock(plane_mutex_);
    last_fit_had_plane_ = plane.has_value();
  }
  for (const auto& w : report.warnings) ROS_WARN_STREAM("gp_model: " << w);
  std::string tuned;
  if (tune_) {
    const gpatlas_core::TuneReport tune = gpatlas_core::HyperparameterTuner(tuner_config_).tune(model_);
    tuned = tune.ok ? ", tuned: " + tune.message : ", tuning kept the previous hyperparameters: " + tune.message;
  }
  ROS_INFO_STREAM("gp_model: " << report.message << " in " << (ros::WallTime::now() - start).toSec() << " s" << tuned);
  publishModel();
}

void GpModelServer::onContacts(const gpatlas_msgs::Observations::ConstPtr& msg) {
  try {
    std::string message;
    std::uint32_t added = 0;
    if (addObservations(*msg, &message, &added)) ROS_INFO_STREAM("gp_model: " << message);
    else ROS_WARN_STREAM("gp_model: observations ignored: " << message);
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("gp_model: observations ignored: " << e.what());
  }
}

bool GpModelServer::onAddObservations(gpatlas_msgs::AddObservations::Request& req,
                                      gpatlas_msgs::AddObservations::Response& res) {
  res.success = addObservations(req.observations, &res.message, &res.num_added);
  return true;
}

bool GpModelServer::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  {
    std::lock_guard<std::mutex> plane_lock(plane_mutex_);
    support_plane_.reset();
    last_cloud_.reset();
    last_fit_had_plane_ = false;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  model_ = gpatlas_core::GpisModel(gpis_config_);
  // An empty training set tells the planner and the collision map to drop their copies.
  gpatlas_msgs::TrainingSet empty;
  empty.header.frame_id = world_frame_;
  empty.header.stamp = ros::Time::now();
  training_pub_.publish(empty);
  res.success = true;
  res.message = "model cleared; waiting for a new object cloud";
  return true;
}

bool GpModelServer::addObservations(const gpatlas_msgs::Observations& msg, std::string* message,
                                    std::uint32_t* num_added) {
  *num_added = 0;
  gpatlas_core::ProbeResult observed;
  if (!fromMsg(msg, &observed, message)) return false;
  // One transform for everything: contacts, then the tips of their normals (a normal moves as
  // the difference of two transformed points), then the free space.
  const std::size_t num_contacts = observed.contacts.size();
  std::vector<Eigen::Vector3d> in_world;
  in_world.reserve(2 * num_contacts + observed.free_space.size());
  for (const auto& c : observed.contacts) in_world.push_back(c.position);
  for (const auto& c : observed.contacts) in_world.push_back(c.position + c.normal);
  in_world.insert(in_world.end(), observed.free_space.begin(), observed.free_space.end());
  if (!transformToWorld(tf_buffer_, world_frame_, msg.header.frame_id, msg.header.stamp, tf_timeout_s_, &in_world,
                        message))
    return false;
  for (std::size_t i = 0; i < num_contacts; ++i) {
    observed.contacts[i].position = in_world[i];
    observed.contacts[i].normal = in_world[num_contacts + i] - in_world[i];
  }
  const std::vector<Eigen::Vector3d> free_space(in_world.begin() + static_cast<std::ptrdiff_t>(2 * num_contacts),
                                                in_world.end());
  if (observed.contacts.empty() && free_space.empty()) {
    *message = "no observation in the message";
    return false;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!model_.isFitted()) {
    *message = "no model yet: the object points have not arrived";
    return false;
  }
  // As the Explorer does: thinned (near-duplicates of a slide cost every later query and add
  // nothing), free space in the domain and labelled with its distance to the surface.
  const std::vector<gpatlas_core::TrainingPoint> points =
      gpatlas_core::touchTrainingPoints(model_, observed.contacts, free_space, touch_config_);
  if (points.empty()) {
    *message = "no observation inside the model's domain";
    return false;
  }
  gpatlas_core::InteriorRetraction retraction;
  const gpatlas_core::FitReport report = gpatlas_core::addTouchPoints(
      model_, points, gpatlas_core::measuredPositions(observed.contacts, free_space), touch_config_, &retraction);
  *num_added = static_cast<std::uint32_t>(report.num_added);
  *message = report.message;
  if (retraction.any())
    *message += "; the touch contradicted " + std::to_string(retraction.shrunk + retraction.dropped) +
                " occluded-interior guesses (" + std::to_string(retraction.dropped) + " dropped, " +
                std::to_string(retraction.shrunk) + " made shallower)";
  for (const auto& w : report.warnings) *message += "; " + w;
  if (!report.ok) return false;
  publishModel();
  return true;
}

void GpModelServer::publishModel() {
  // Called with mutex_ held.
  gpatlas_msgs::TrainingSet training = toMsg(model_);
  training.header.frame_id = world_frame_;
  training.header.stamp = ros::Time::now();
  training_pub_.publish(training);

  if (surface_pub_.getNumSubscribers() == 0 && mesh_marker_pub_.getNumSubscribers() == 0 &&
      mesh_shape_pub_.getNumSubscribers() == 0)
    return;
  const gpatlas_core::SurfaceMeshResult surface = gpatlas_core::SurfaceMesher(mesher_config_).mesh(model_);
  if (!surface.ok) {
    ROS_WARN_STREAM("gp_model: no predicted surface: " << surface.message);
    return;
  }
  visualization_msgs::Marker marker = meshMarker(surface.mesh, display_v_max_, world_frame_);
  marker.header.stamp = training.header.stamp;
  mesh_marker_pub_.publish(marker);
  mesh_shape_pub_.publish(toShapeMsg(surface.mesh));
  sensor_msgs::PointCloud2 cloud =
      pointsToCloud(surface.mesh.vertices, surface.mesh.vertex_variances, display_v_max_, world_frame_);
  cloud.header.stamp = training.header.stamp;
  surface_pub_.publish(cloud);
}

}  // namespace gpatlas_ros
