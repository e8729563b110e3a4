#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/markers.h"
#include "gpatlas_ros/gp_model_server.h"
#include "gpatlas_ros/shared_models.h"

#include <gpatlas_core/common/background_work.h>
#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/observations/view_training.h>
#include <gpatlas_core/observations/view_update.h>
#include <tf2_eigen/tf2_eigen.h>
#include <shape_msgs/Mesh.h>
#include <visualization_msgs/Marker.h>

#include <algorithm>
#include <cmath>

namespace gpatlas_ros {

using namespace gpatlas_conversions;


GpModelServer::GpModelServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  RosParamReader reader(pnh_);
  const ServerPreamble preamble = readServerPreamble(reader, "gp_model");
  world_frame_ = preamble.frames.world_frame;
  tf_timeout_s_ = preamble.frames.tf_timeout_s;
  sensor_frame_ = preamble.frames.sensor_frame;
  seed_ = preamble.seed;
  use_support_plane_ = preamble.use_support_plane;
  model_config_ = preamble.model;
  readViewTraining(reader, &view_config_);
  readTouchObservations(reader, &touch_config_);
  readPositionCalibration(reader, &position_calibration_);
  display_v_max_ = readVMax(reader);
  readMesher(reader, &mesher_config_);
  fit_every_cloud_ = reader.flag("fit_every_cloud", fit_every_cloud_);
  reader.report("gp_model");
  try {
    model_ = gpatlas_core::makeSurfaceModel(model_config_);
  } catch (const std::exception& e) {
    // An exception here would take the nodelet manager down with every other nodelet in it.
    ROS_ERROR_STREAM("gp_model: " << e.what() << "; using the default model '" << gpatlas_core::SurfaceModelConfig().type
                                  << "' instead");
    model_config_.type = gpatlas_core::SurfaceModelConfig().type;
    model_ = gpatlas_core::makeSurfaceModel(model_config_);
  }

  mesher_ = std::thread(&GpModelServer::meshLoop, this);
  fitter_ = std::thread(&GpModelServer::fitLoop, this);
  training_pub_ = pnh_.advertise<gpatlas_msgs::TrainingSet>("training_set", 1, true);
  surface_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("surface", 1, true);
  mesh_marker_pub_ = pnh_.advertise<visualization_msgs::Marker>("surface_mesh", 1, true);
  mesh_shape_pub_ = pnh_.advertise<shape_msgs::Mesh>("surface_shape", 1, true);
  add_srv_ = pnh_.advertiseService("add_observations", &GpModelServer::onAddObservations, this);
  reset_srv_ = pnh_.advertiseService("reset", &GpModelServer::onReset, this);
  remove_srv_ = pnh_.advertiseService("remove_observations", &GpModelServer::onRemoveObservations, this);
  fit_next_srv_ = pnh_.advertiseService("fit_next_cloud", &GpModelServer::onFitNextCloud, this);
  points_sub_ = std::make_unique<TfGatedCloudSubscriber>(
      nh_, "points", &tf_buffer_, world_frame_, "gp_model", kTfWaitWarningS,
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg) { onPoints(msg); });
  contacts_sub_ = nh_.subscribe("contacts", 10, &GpModelServer::onContacts, this);
  if (use_support_plane_) plane_sub_ = nh_.subscribe("support_plane", 1, &GpModelServer::onSupportPlane, this);
  ROS_INFO_STREAM("gp_model: " << model_->name() << " model, waiting for object points on "
                                      << points_sub_->topic());
}

void GpModelServer::onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(fit_mutex_);
    if (!fit_every_cloud_ && !fit_next_armed_) return;
    fit_next_armed_ = false;
  }
  queueFit(msg);
}

bool GpModelServer::onFitNextCloud(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  {
    std::lock_guard<std::mutex> lock(fit_mutex_);
    fit_next_armed_ = true;
  }
  res.success = true;
  res.message = fit_every_cloud_ ? "every cloud is fitted (fit_every_cloud); the next one too"
                                 : "the next cloud on " + (points_sub_ ? points_sub_->topic() : std::string("points")) +
                                       " will be fitted";
  ROS_INFO_STREAM("gp_model: " << res.message);
  return true;
}

void GpModelServer::queueFit(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(fit_mutex_);
    if (fit_pending_) ++clouds_dropped_;
    fit_pending_ = msg;
  }
  fit_wake_.notify_one();
}

void GpModelServer::waitForPlane(const ros::Time& stamp) {
  if (!use_support_plane_) return;
  std::unique_lock<std::mutex> lock(plane_mutex_);
  plane_arrived_.wait_for(lock, std::chrono::duration<double>(plane_wait_s_),
                          [&] { return support_plane_ && support_plane_->belongsTo(stamp); });
}

void GpModelServer::fitLoop() {
  for (;;) {
    sensor_msgs::PointCloud2::ConstPtr cloud;
    std::size_t dropped = 0;
    {
      std::unique_lock<std::mutex> lock(fit_mutex_);
      fit_wake_.wait(lock, [this] { return fit_stopping_ || fit_pending_; });
      if (fit_stopping_) return;
      cloud = std::move(fit_pending_);
      fit_pending_.reset();
      dropped = clouds_dropped_;
      clouds_dropped_ = 0;
    }
    // Nothing may escape this thread: an exception would end the nodelet manager. A failed fit
    // keeps the previous model.
    try {
      waitForPlane(cloud->header.stamp);
      const bool fitted = fitCloud(cloud);
      // A fit's working memory (trial copies of the model, factors) is as large as the model.
      releaseFreedMemory();
      if (fitted)
        ROS_INFO_STREAM("gp_model: cloud to model " << (ros::Time::now() - cloud->header.stamp).toSec() << " s; "
                                                    << dropped << " newer cloud(s) replaced older ones while it waited");
      else if (dropped > 0)
        ROS_INFO_STREAM("gp_model: " << dropped << " cloud(s) replaced while waiting for the fit");
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM("gp_model: object cloud ignored: " << e.what());
    }
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
      if (last_fitted_without_plane_ && support_plane_->belongsTo(last_fitted_without_plane_->header.stamp))
        refit = last_fitted_without_plane_;
    }
    plane_arrived_.notify_all();
    if (refit) queueFit(refit);
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("gp_model: support plane ignored: " << e.what());
  }
}

bool GpModelServer::fitCloud(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  std::vector<Eigen::Vector3d> points;
  std::size_t invalid = 0;
  std::string error;
  if (!cloudToWorld(*msg, tf_buffer_, world_frame_, tf_timeout_s_, &points, &invalid, &error)) {
    ROS_WARN_STREAM("gp_model: object cloud ignored: " << error);
    return false;
  }
  if (points.size() < 4) {
    ROS_WARN_STREAM("gp_model: object cloud ignored: " << points.size() << " valid points (" << invalid
                                                       << " NaN), need at least 4");
    return false;
  }
  std::optional<gpatlas_core::SupportPlane> plane;
  if (use_support_plane_) {
    std::lock_guard<std::mutex> lock(plane_mutex_);
    if (support_plane_ && support_plane_->belongsTo(msg->header.stamp)) plane = support_plane_->plane;
  }
  std::optional<Eigen::Vector3d> sensor_origin;
  if (!sensor_frame_.empty()) {
    std::vector<Eigen::Vector3d> origin{Eigen::Vector3d::Zero()};
    std::string tf_error;
    if (transformToWorld(tf_buffer_, world_frame_, sensor_frame_, msg->header.stamp, tf_timeout_s_, &origin, &tf_error))
      sensor_origin = origin.front();
    else
      ROS_ERROR_STREAM_THROTTLE(10.0, "gp_model: the view is fitted without its free space and occluded interior: "
                                          "no transform for sensor_frame '"
                                          << sensor_frame_ << "' (" << tf_error
                                          << "); set sensor_frame to the camera cloud's frame, or \"\" to fit without them");
  }
  const gpatlas_core::ViewTraining view = gpatlas_core::buildViewTraining(points, sensor_origin, plane, view_config_, seed_);
  if (!view.ok) {
    ROS_WARN_STREAM("gp_model: object cloud ignored: " << view.message);
    return false;
  }
  for (const auto& w : view.warnings) ROS_WARN_STREAM("gp_model: " << w);

  std::lock_guard<std::mutex> lock(mutex_);
  // The same fit as the bench's: a new view replaces the previous one, the touches stay.
  const ros::WallTime start = ros::WallTime::now();
  const gpatlas_core::ViewUpdate update =
      gpatlas_core::applyView(*model_, view.points, touch_config_, &position_calibration_);
  if (!update.ok) {
    ROS_ERROR_STREAM("gp_model: fit failed, previous model kept: " << update.fit.message);
    return false;
  }
  history_.setView(view.points);
  view_.reset();
  if (sensor_origin) view_ = gpatlas_core::CameraView{*sensor_origin, points};
  if (use_support_plane_) {
    std::lock_guard<std::mutex> plane_lock(plane_mutex_);
    last_fitted_without_plane_ = plane ? nullptr : msg;
  }
  for (const auto& w : update.fit.warnings) ROS_WARN_STREAM("gp_model: " << w);
  for (const auto& note : update.fit.notes) ROS_DEBUG_STREAM("gp_model: " << note);
  std::string retracted;
  if (update.retraction.any())
    retracted = "; the touches contradicted " + std::to_string(update.retraction.shrunk + update.retraction.dropped) +
                " of its occluded-interior guesses (" + std::to_string(update.retraction.dropped) + " dropped)";
  if (update.calibration && !update.calibration->ok)
    ROS_WARN_STREAM("gp_model: position sd not calibrated: " << update.calibration->message);
  const std::string calibrated = update.calibration && update.calibration->ok ? "; " + update.calibration->message : "";
  ROS_INFO_STREAM("gp_model: view: " << view.message << retracted << "; " << update.fit.message << " in "
                                     << (ros::WallTime::now() - start).toSec() << " s" << calibrated);
  publishModel();
  return true;
}

void GpModelServer::onContacts(const gpatlas_msgs::Observations::ConstPtr& msg) {
  try {
    gpatlas_msgs::AddObservations::Response answer;
    if (addObservations(*msg, &answer)) ROS_INFO_STREAM("gp_model: " << answer.message);
    else ROS_WARN_STREAM("gp_model: observations ignored: " << answer.message);
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("gp_model: observations ignored: " << e.what());
  }
}

bool GpModelServer::onAddObservations(gpatlas_msgs::AddObservations::Request& req,
                                      gpatlas_msgs::AddObservations::Response& res) {
  res.success = addObservations(req.observations, &res);
  return true;
}

bool GpModelServer::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  {
    std::lock_guard<std::mutex> fit_lock(fit_mutex_);  // a cloud waiting for its fit is forgotten too
    fit_pending_.reset();
    clouds_dropped_ = 0;
  }
  {
    std::lock_guard<std::mutex> plane_lock(plane_mutex_);
    support_plane_.reset();
    last_fitted_without_plane_.reset();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  model_ = gpatlas_core::makeSurfaceModel(model_config_);
  history_.clear();
  view_.reset();
  // An empty training set tells the planner and the collision map to drop their copies and
  // publish their own empty outputs. Offered without a model, it supersedes the training sets
  // before it that they have not taken yet: they skip them instead of refitting replicas of a
  // model that is gone.
  gpatlas_msgs::TrainingSet empty;
  empty.sequence = ++training_sequence_;
  empty.header.frame_id = world_frame_;
  empty.header.stamp = ros::Time::now();
  SharedModels::offer(training_pub_.getTopic(), empty, nullptr);
  training_pub_.publish(empty);
  {
    std::lock_guard<std::mutex> mesh_lock(mesh_mutex_);
    mesh_pending_.reset();
    ++mesh_generation_;
    publishEmptySurface(empty.header.stamp);
  }
  releaseFreedMemory();  // the model just dropped (its snapshot goes when its last user lets it go)
  res.success = true;
  res.message = "model cleared; waiting for a new object cloud";
  return true;
}

bool GpModelServer::onRemoveObservations(gpatlas_msgs::RemoveObservations::Request& req,
                                         gpatlas_msgs::RemoveObservations::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::uint32_t> ids = req.batch_ids;
  if (req.last > 0) {
    const std::vector<std::uint32_t> last = history_.lastTouches(req.last);
    ids.insert(ids.end(), last.begin(), last.end());
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  if (ids.empty()) {
    res.success = false;
    res.message = req.last > 0 ? "no touch to remove" : "say which: batch_ids, or last > 0";
    return true;
  }
  std::string error;
  const ros::WallTime started = ros::WallTime::now();
  // The rebuild re-applies every touch kept (17 s for 149 touches): say how far it is.
  ROS_INFO_STREAM("gp_model: remove_observations: removing " << ids.size() << " of " << history_.touchCount()
                                                             << " touch(es); the model is rebuilt from the view and the others");
  ros::WallTime next_report = started + ros::WallDuration(kRebuildReportPeriodS);
  const auto progress = [&](std::size_t applied, std::size_t total) {
    const ros::WallTime now = ros::WallTime::now();
    if (now < next_report || applied == total) return;
    next_report = now + ros::WallDuration(kRebuildReportPeriodS);
    ROS_INFO_STREAM("gp_model: remove_observations: " << applied << " of " << total << " touches re-applied in "
                                                      << (now - started).toSec() << " s");
  };
  if (!history_.remove(ids, touch_config_, &model_, &error, progress)) {
    res.success = false;
    res.message = error;
    ROS_WARN_STREAM("gp_model: remove_observations: " << error);
    return true;
  }
  res.success = true;
  res.removed_batch_ids = ids;
  res.message = "removed " + std::to_string(ids.size()) + " touch(es); the model was rebuilt from the view and " +
                std::to_string(history_.touchCount()) + " touch(es) in " +
                std::to_string((ros::WallTime::now() - started).toSec()) + " s";
  ROS_INFO_STREAM("gp_model: remove_observations: " << res.message);
  releaseFreedMemory();  // the model it replaced and the rebuild's working memory
  publishModel();
  return true;
}

bool GpModelServer::addObservations(const gpatlas_msgs::Observations& msg,
                                    gpatlas_msgs::AddObservations::Response* answer) {
  *answer = gpatlas_msgs::AddObservations::Response();
  std::string* message = &answer->message;
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
  if (!model_->isFitted()) {
    *message = "no model yet: the object points have not arrived";
    return false;
  }
  // The same rules as the bench's exploration loop (gpatlas_core::applyTouch).
  const gpatlas_core::TouchUpdate update = gpatlas_core::applyTouch(*model_, observed.contacts, free_space, touch_config_);
  *answer = toMsg(update);
  if (update.retraction.any())
    *message += "; the touch contradicted " + std::to_string(update.retraction.shrunk + update.retraction.dropped) +
                " occluded-interior guesses (" + std::to_string(update.retraction.dropped) + " dropped, " +
                std::to_string(update.retraction.shrunk) + " made shallower)";
  for (const auto& w : update.warnings) *message += "; " + w;
  if (!update.ok) return false;
  answer->batch_id = history_.addTouch(observed.contacts, free_space);
  *message += " (batch " + std::to_string(answer->batch_id) + ")";
  publishModel();
  return true;
}

void GpModelServer::publishModel() {
  // Called with mutex_ held.
  gpatlas_msgs::TrainingSet training = toMsg(*model_);
  setView(view_, &training);
  training.sequence = ++training_sequence_;
  training.header.frame_id = world_frame_;
  training.header.stamp = ros::Time::now();
  // One immutable copy for the planner and the collision map in this manager and for the mesh.
  const std::shared_ptr<const gpatlas_core::SurfaceModel> snapshot = modelSnapshot(model_->clone());
  SharedModels::offer(training_pub_.getTopic(), training, snapshot);
  training_pub_.publish(training);

  {
    std::lock_guard<std::mutex> lock(mesh_mutex_);
    mesh_pending_ = snapshot;  // replaces one not meshed yet
    mesh_stamp_ = training.header.stamp;
  }
  mesh_wake_.notify_one();
}

void GpModelServer::meshLoop() {
  // The display mesh is for people watching: touches and plans come first.
  if (!gpatlas_core::lowerCurrentThreadPriority())
    ROS_WARN("gp_model: cannot lower the mesher's priority; display meshes compete with the model's updates");
  for (;;) {
    std::shared_ptr<const gpatlas_core::SurfaceModel> model;
    ros::Time stamp;
    std::uint64_t generation = 0;
    {
      std::unique_lock<std::mutex> lock(mesh_mutex_);
      mesh_wake_.wait(lock, [this] { return mesh_stopping_ || mesh_pending_; });
      if (mesh_stopping_) return;
      model = std::move(mesh_pending_);
      stamp = mesh_stamp_;
      generation = mesh_generation_;
    }
    // Nothing may escape this thread: an exception would end the nodelet manager.
    try {
      gpatlas_geometry::SurfaceMeshResult surface;
      gpatlas_core::runOnThisThreadOnly([&] { surface = gpatlas_geometry::SurfaceMesher(mesher_config_).mesh(*model); });
      if (!surface.ok) {
        ROS_WARN_STREAM("gp_model: no predicted surface: " << surface.message);
        continue;
      }
      publishSurface(surface, stamp, generation);
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM("gp_model: no predicted surface: " << e.what());
    }
  }
}

void GpModelServer::publishSurface(const gpatlas_geometry::SurfaceMeshResult& surface, const ros::Time& stamp,
                                   std::uint64_t generation) {
  visualization_msgs::Marker marker = meshMarker(surface.mesh, display_v_max_, world_frame_);
  marker.header.stamp = stamp;
  const shape_msgs::Mesh shape = toMsg(surface.mesh);
  sensor_msgs::PointCloud2 cloud =
      pointsToCloud(surface.mesh.vertices, surface.mesh.vertex_variances, display_v_max_, world_frame_);
  cloud.header.stamp = stamp;
  // Checked and published under the lock a reset takes: no surface of the model before it can
  // be published after its empty one.
  std::lock_guard<std::mutex> lock(mesh_mutex_);
  if (generation != mesh_generation_) return;
  mesh_marker_pub_.publish(marker);
  mesh_shape_pub_.publish(shape);
  surface_pub_.publish(cloud);
}

void GpModelServer::publishEmptySurface(const ros::Time& stamp) {
  visualization_msgs::Marker clear = deleteAllMarker(world_frame_);
  clear.header.stamp = stamp;
  mesh_marker_pub_.publish(clear);
  mesh_shape_pub_.publish(shape_msgs::Mesh());
  sensor_msgs::PointCloud2 cloud = pointsToCloud({}, {}, display_v_max_, world_frame_);
  cloud.header.stamp = stamp;
  surface_pub_.publish(cloud);
}

GpModelServer::~GpModelServer() {
  {
    std::lock_guard<std::mutex> lock(fit_mutex_);
    fit_stopping_ = true;
  }
  fit_wake_.notify_all();
  if (fitter_.joinable()) fitter_.join();
  SharedModels::withdraw(training_pub_.getTopic());
  {
    std::lock_guard<std::mutex> lock(mesh_mutex_);
    mesh_stopping_ = true;
  }
  mesh_wake_.notify_all();
  if (mesher_.joinable()) mesher_.join();
}

}  // namespace gpatlas_ros
