#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/approach_arm.h"
#include "gpatlas_ros/markers.h"
#include "gpatlas_ros/collision_map_server.h"
#include "gpatlas_ros/shared_models.h"

#include <gpatlas_motion/touch_approach.h>
#include <gpatlas_msgs/CollisionMapStatus.h>
#include <gpatlas_msgs/OctomapBinary.h>
#include <visualization_msgs/MarkerArray.h>

#include <octomap/OcTree.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

namespace {

// The map as octomap's binary stream (OcTree::writeBinaryData), for the training set it was built on.
gpatlas_msgs::OctomapBinary octomapMessage(const octomap::OcTree& tree, const std::string& frame_id,
                                           const ros::Time& stamp, std::uint32_t training_sequence) {
  gpatlas_msgs::OctomapBinary out;
  out.header.frame_id = frame_id;
  out.header.stamp = stamp;
  out.training_sequence = training_sequence;
  out.id = tree.getTreeType();
  out.resolution = tree.getResolution();
  out.binary = true;
  std::stringstream stream;
  tree.writeBinaryData(stream);
  const std::string bytes = stream.str();
  out.data.assign(bytes.begin(), bytes.end());
  return out;
}

// The model's tree with the scene's obstacles; the model's own when there are none.
std::shared_ptr<const octomap::OcTree> withObstacles(const std::shared_ptr<const octomap::OcTree>& model_tree,
                                                     const std::vector<Eigen::Vector3d>* obstacles) {
  if (!obstacles || obstacles->empty()) return model_tree;
  auto merged = std::make_shared<octomap::OcTree>(*model_tree);
  gpatlas_motion::addObstacles(merged.get(), *obstacles);
  return merged;
}

}  // namespace

struct CollisionMapServer::Map {
  // Occupied or not at approach/occupied_probability: what approaches are planned on, the
  // model's and the scene's obstacles.
  std::shared_ptr<const octomap::OcTree> tree;
  // The model's alone, which a camera cloud re-merges with the scene.
  std::shared_ptr<const octomap::OcTree> model_tree;
  // The scene's obstacles in both trees (null: none).
  std::shared_ptr<const std::vector<Eigen::Vector3d>> scene_obstacles;
  // The model's occupied voxels' centres, and the space near them and the object's points that
  // no sensor observed, which the way to a touch and back avoids (null: none;
  // collision_map/scene_unseen_reach_m).
  std::shared_ptr<const std::vector<Eigen::Vector3d>> model_occupied;
  std::shared_ptr<const octomap::OcTree> unseen;
  gpatlas_msgs::TrainingSet::ConstPtr training;
  // P(occupied) per voxel, for the map's topics and save_map; null until asked for (mutex_).
  std::shared_ptr<const octomap::OcTree> probabilities;
  // The model's alone (mutex_): a camera cloud's re-merge keeps them, so that a stream of clouds
  // does not recompute the model's grid, which has not changed.
  std::shared_ptr<const octomap::OcTree> model_probabilities;
  std::shared_ptr<const gpatlas_core::SurfaceModel> model;
  std::uint32_t training_sequence{0};
  ros::Time training_stamp;
  // The scene's revision its obstacles were taken from: a cloud that changed nothing in the
  // scene (a still camera's next frame) re-merges nothing.
  std::uint64_t scene_revision{0};
};

CollisionMapServer::CollisionMapServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  RosParamReader reader(pnh_);
  const ServerPreamble preamble = readServerPreamble(reader, "collision_map");
  world_frame_ = preamble.frames.world_frame;
  tf_timeout_s_ = preamble.frames.tf_timeout_s;
  const bool use_support_plane = preamble.use_support_plane;
  model_config_ = preamble.model;
  readApproach(reader, &approach_config_);
  approach_arm_ = loadApproachArm(nh_, approach_config_, &approach_arm_error_);
  if (!approach_arm_error_.empty()) ROS_ERROR_STREAM("collision_map: approach/use_arm: " << approach_arm_error_);
  readCollisionMap(reader, &map_config_);
  readSceneMap(reader, &scene_config_);
  sensor_frame_ = preamble.frames.sensor_frame;
  reader.report("collision_map");
  if (const std::string invalid = gpatlas_motion::validate(scene_config_); !invalid.empty()) {
    ROS_ERROR_STREAM("collision_map: inconsistent scene parameters (" << invalid << "); the scene's defaults used");
    scene_config_ = gpatlas_motion::SceneMapConfig();
  }
  if (scene_config_.enabled) scene_ = std::make_unique<gpatlas_motion::SceneMap>(scene_config_, map_config_.grid.resolution_m);
  // A new subscriber gets the newest map's probabilities, built then if no one asked before.
  const ros::SubscriberStatusCallback connected = [this](const ros::SingleSubscriberPublisher&) {
    std::lock_guard<std::mutex> lock(mutex_);
    requestProbabilities();
  };
  octomap_pub_ = pnh_.advertise<gpatlas_msgs::OctomapBinary>("octomap_binary", 1, connected, ros::SubscriberStatusCallback(),
                                                             ros::VoidConstPtr(), true);
  voxels_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("occupied_voxels", 1, connected,
                                                                ros::SubscriberStatusCallback(), ros::VoidConstPtr(), true);
  status_pub_ = pnh_.advertise<gpatlas_msgs::CollisionMapStatus>("status", 1, true);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_ = gpatlas_msgs::CollisionMapStatus::NONE;
    status_message_ = "no training set yet";
    publishStatus();
  }
  builder_ = std::thread(&CollisionMapServer::buildLoop, this);
  publisher_ = std::thread(&CollisionMapServer::publishLoop, this);
  approach_pub_ = pnh_.advertise<visualization_msgs::Marker>("approach_path", 1, true);
  approach_arm_pub_ = pnh_.advertise<visualization_msgs::Marker>("approach_arm", 1, true);
  if (approach_arm_) approach_trajectory_pub_ = pnh_.advertise<trajectory_msgs::JointTrajectory>("approach_trajectory", 1, true);
  save_srv_ = pnh_.advertiseService("save_map", &CollisionMapServer::onSaveMap, this);
  approach_srv_ = pnh_.advertiseService("plan_approach", &CollisionMapServer::onPlanApproach, this);
  training_sub_ = nh_.subscribe("training_set", 1, &CollisionMapServer::onTrainingSet, this);
  // The planner nodelet of this manager tests its candidates on these maps.
  SharedCollisionMaps::attend(training_sub_.getTopic());
  if (use_support_plane)
    plane_sub_ = nh_.subscribe("support_plane", 1, &CollisionMapServer::onSupportPlane, this);
  if (scene_)
    points_sub_ = std::make_unique<TfGatedCloudSubscriber>(
        nh_, "points", &tf_buffer_, world_frame_, "collision_map", kTfWaitWarningS,
        [this](const sensor_msgs::PointCloud2::ConstPtr& msg) { onPoints(msg); });
}

void CollisionMapServer::onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  // roscpp does not catch exceptions from callbacks: one would end the nodelet manager.
  try {
    auto cloud = std::make_shared<SceneCloud>();
    std::size_t invalid = 0;
    std::string error;
    if (!cloudToWorld(*msg, tf_buffer_, world_frame_, tf_timeout_s_, &cloud->points, &invalid, &error)) {
      ROS_WARN_STREAM_THROTTLE(10.0, "collision_map: cloud not added to the scene: " << error);
      return;
    }
    // The rays start at the camera: the cloud's own frame, as octomap_server takes it, unless the
    // cloud is already given in world_frame, whose origin is no camera.
    const std::string& frame = msg->header.frame_id;
    cloud->frame = frame.empty() || frame == world_frame_ ? sensor_frame_ : frame;
    if (cloud->frame.empty()) {
      ROS_ERROR_STREAM_THROTTLE(10.0, "collision_map: a cloud in '" << world_frame_
                                          << "' with sensor_frame empty: no sensor origin to cast the scene's free "
                                             "space from; set sensor_frame to the camera's frame");
      return;
    }
    std::vector<Eigen::Vector3d> origin{Eigen::Vector3d::Zero()};
    if (!transformToWorld(tf_buffer_, world_frame_, cloud->frame, msg->header.stamp, tf_timeout_s_, &origin, &error)) {
      ROS_WARN_STREAM_THROTTLE(10.0, "collision_map: cloud not added to the scene: no origin for '"
                                         << cloud->frame << "': " << error);
      return;
    }
    cloud->origin = origin.front();
    cloud->stamp = msg->header.stamp;
    std::lock_guard<std::mutex> lock(mutex_);
    pending_cloud_ = std::move(cloud);
    wake_.notify_one();
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("collision_map: cloud ignored: " << e.what());
  }
}

void CollisionMapServer::onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg) {
  receiveSupportPlane(*msg, tf_buffer_, world_frame_, tf_timeout_s_, "collision_map", &mutex_, &support_plane_);
}

bool CollisionMapServer::onPlanApproach(gpatlas_msgs::PlanApproach::Request& req,
                                        gpatlas_msgs::PlanApproach::Response& res) {
  res.success = false;
  try {
    std::shared_ptr<Map> map;
    std::uint32_t latest = 0;
    std::uint64_t resets = 0;
    std::optional<gpatlas_core::SupportPlane> plane;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      map = map_;
      latest = latest_sequence_;
      resets = resets_;
      plane = support_plane_;
    }
    if (approach_config_.use_arm && !approach_arm_) {
      res.message = "approach/use_arm is set but there is no arm: " + approach_arm_error_;
      return true;
    }
    if (!map) {
      res.message = "no collision map yet: the GP has not published a model, or its map is not built";
      return true;
    }
    const std::string& frame = req.touch.header.frame_id;
    if (!frame.empty() && frame != world_frame_) {
      res.message = "the touch is in frame '" + frame + "', plan_approach works in '" + world_frame_ + "'";
      return true;
    }
    gpatlas_core::Touch touch;
    if (!fromMsg(req.touch, &touch, &res.message)) {
      res.message = "invalid touch: " + res.message;
      return true;
    }
    if (touch.points.empty()) {
      res.message = "invalid touch: no waypoint";
      return true;
    }
    res.map_training_sequence = map->training_sequence;
    res.map_stale = map->training_sequence != latest;
    const gpatlas_motion::TouchMotionPlanner planner(approach_config_, map->tree, plane, approach_arm_, nullptr, map->unseen);
    const Eigen::Vector3d start = fromMsg(req.start);
    Eigen::VectorXd start_joints;
    if (approach_arm_ && !req.start_joints.name.empty()) {
      trajectory_msgs::JointTrajectory as_trajectory;
      as_trajectory.joint_names = req.start_joints.name;
      as_trajectory.points.resize(1);
      as_trajectory.points[0].positions = req.start_joints.position;
      std::vector<Eigen::VectorXd> joints;
      if (!fromJointTrajectoryMsg(as_trajectory, approach_arm_->jointNames(), &joints, &res.message)) {
        res.message = "start_joints: " + res.message;
        return true;
      }
      start_joints = joints.front();
    }
    const gpatlas_motion::TouchMotion plan =
        planner.plan(touch, &start, start_joints.size() > 0 ? &start_joints : nullptr);
    res.planning_time_s = plan.planning_ms / 1000.0;
    res.success = plan.ok;
    res.message = plan.message;
    for (const auto& p : plan.approach) res.approach.push_back(toPointMsg(p));
    for (const auto& p : plan.probing) res.probing.push_back(toPointMsg(p));
    for (const auto& p : plan.retreat) res.retreat.push_back(toPointMsg(p));
    res.direction = toVectorMsg(plan.direction);
    res.guarded_entry = plan.ok && plan.guarded_entry;
    if (approach_arm_ && plan.ok) {
      const std::vector<std::string>& names = approach_arm_->jointNames();
      const double speed = approach_config_.arm_joint_speed_rad_s;
      res.approach_trajectory = toJointTrajectoryMsg(plan.approach_joints, names, speed);
      res.probing_trajectory = toJointTrajectoryMsg(plan.probing_joints, names, speed);
      res.retreat_trajectory = toJointTrajectoryMsg(plan.retreat_joints, names, speed);
      for (auto* trajectory : {&res.approach_trajectory, &res.probing_trajectory, &res.retreat_trajectory}) {
        trajectory->header.frame_id = world_frame_;
        trajectory->header.stamp = ros::Time::now();
      }
    }
    if (res.guarded_entry)
      ROS_INFO_STREAM("collision_map: every acceptable approach pose of the touch lies in space no sensor observed: "
                      "the way ends where the touch's line leaves it, and the probe comes in along that line (a guarded move)");
    if (plan.ok) publishApproach(plan, res, resets);
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("approach planning failed: ") + e.what();
  }
  return true;
}

void CollisionMapServer::publishApproach(const gpatlas_motion::TouchMotion& plan,
                                         const gpatlas_msgs::PlanApproach::Response& res, std::uint64_t resets_at_start) {
  std::vector<Eigen::Vector3d> tip_path = plan.approach;
  tip_path.push_back(plan.probing.back());
  visualization_msgs::Marker tip_marker = approachMarker(tip_path, world_frame_);
  tip_marker.header.stamp = ros::Time::now();
  std::optional<visualization_msgs::Marker> arm_marker;
  if (approach_arm_) {
    // The arm at a few configurations along each stretch of the approach and the probing.
    std::vector<std::vector<gpatlas_motion::LinkCapsule>> trail;
    std::vector<Eigen::VectorXd> path = plan.approach_joints;
    path.push_back(plan.probing_joints.back());
    constexpr int kSamplesPerStretch = 6;
    for (std::size_t i = 0; i + 1 < path.size(); ++i)
      for (int k = 0; k < kSamplesPerStretch; ++k)
        trail.push_back(approach_arm_->linkCapsules(path[i] + (path[i + 1] - path[i]) * (double(k) / kSamplesPerStretch)));
    trail.push_back(approach_arm_->linkCapsules(path.back()));
    arm_marker = armTrailMarker(trail, world_frame_);
    arm_marker->header.stamp = ros::Time::now();
  }
  // Under the lock a reset takes: a plan on the map a reset removed is not shown after the
  // reset's empty displays.
  std::lock_guard<std::mutex> lock(mutex_);
  if (resets_ != resets_at_start) return;
  if (arm_marker) {
    approach_trajectory_pub_.publish(res.approach_trajectory);
    approach_arm_pub_.publish(*arm_marker);
  }
  approach_pub_.publish(tip_marker);
}

void CollisionMapServer::publishEmptyMap(const gpatlas_msgs::TrainingSet& reset) {
  octomap_pub_.publish(octomapMessage(octomap::OcTree(map_config_.grid.resolution_m), world_frame_,
                                      reset.header.stamp, reset.sequence));
  visualization_msgs::MarkerArray clear_voxels = deleteAllMarkers(world_frame_);
  clear_voxels.markers.front().header.stamp = reset.header.stamp;
  voxels_pub_.publish(clear_voxels);
  visualization_msgs::Marker clear = deleteAllMarker(world_frame_);
  clear.header.stamp = reset.header.stamp;
  approach_pub_.publish(clear);
  approach_arm_pub_.publish(clear);
  if (approach_trajectory_pub_) {
    trajectory_msgs::JointTrajectory none;
    none.header = clear.header;
    approach_trajectory_pub_.publish(none);
  }
}

CollisionMapServer::~CollisionMapServer() {
  training_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  publish_wake_.notify_all();
  if (builder_.joinable()) builder_.join();
  if (publisher_.joinable()) publisher_.join();
  // After the builder, whose last map would offer the topic again.
  SharedCollisionMaps::withdraw(training_sub_.getTopic());
}

void CollisionMapServer::publishStatus() {
  gpatlas_msgs::CollisionMapStatus status;
  status.header.frame_id = world_frame_;
  status.header.stamp = ros::Time::now();
  status.state = state_;
  if (map_) {
    status.map_training_sequence = map_->training_sequence;
    status.map_training_stamp = map_->training_stamp;
  }
  status.latest_training_sequence = latest_sequence_;
  status.message = status_message_;
  status_pub_.publish(status);
}

void CollisionMapServer::onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg) {
  // Only hand the message and its snapshot over: the build runs in builder_.
  std::shared_ptr<const gpatlas_core::SurfaceModel> snapshot;
  if (!msg->points.empty()) {
    snapshot = SharedModels::find(training_sub_.getTopic(), *msg);
    if (!snapshot && SharedModels::superseded(training_sub_.getTopic(), *msg)) {
      ROS_DEBUG_STREAM("collision_map: training set " << msg->sequence << " skipped: a newer one follows");
      return;
    }
  }
  // What this lets go is freed after the lock (declared before it): a model and its map take
  // milliseconds to free, which the builder and the service callbacks would wait for.
  std::shared_ptr<const gpatlas_core::SurfaceModel> released_model;
  std::shared_ptr<Map> released_map, released_publish;
  std::lock_guard<std::mutex> lock(mutex_);
  latest_sequence_ = msg->sequence;
  if (msg->points.empty()) {  // the GP node was reset
    pending_.reset();
    released_model = std::move(pending_model_);
    released_map = std::move(map_);
    released_publish = std::move(publish_pending_);
    ++resets_;
    state_ = gpatlas_msgs::CollisionMapStatus::NONE;
    status_message_ = "the model was reset";
    publishEmptyMap(*msg);
  } else {
    pending_ = msg;  // a newer training set replaces one not built yet
    released_model = std::exchange(pending_model_, std::move(snapshot));
    state_ = gpatlas_msgs::CollisionMapStatus::BUILDING;
    status_message_ = "building the map of training set " + std::to_string(msg->sequence);
    wake_.notify_one();
  }
  publishStatus();
}

void CollisionMapServer::buildLoop() {
  // The exploration's next plan and approach wait for the map of the updated model: it is built
  // at normal priority, on every core.
  for (;;) {
    gpatlas_msgs::TrainingSet::ConstPtr msg;
    std::shared_ptr<const gpatlas_core::SurfaceModel> snapshot;
    std::shared_ptr<const SceneCloud> cloud;
    std::shared_ptr<Map> current;
    std::shared_ptr<const octomap::OcTree> current_probabilities;  // the model's, if built
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || pending_ || pending_cloud_; });
      if (stopping_) return;
      msg = std::move(pending_);
      pending_.reset();
      snapshot = std::move(pending_model_);
      pending_model_.reset();
      cloud = std::move(pending_cloud_);
      pending_cloud_.reset();
      current = map_;
      if (current) current_probabilities = current->model_probabilities;
    }
    const ros::WallTime started = ros::WallTime::now();
    // Nothing may escape this thread: an exception would end the nodelet manager.
    try {
      if (cloud && scene_) insertSceneCloud(*cloud);
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM("collision_map: cloud not added to the scene: " << e.what());
    }
    std::string error, summary;
    std::shared_ptr<Map> map;
    try {
      if (msg) {
        map = build(*msg, std::move(snapshot), &error, &summary);
        if (map) map->training = msg;
      } else if (cloud && current && scene_ && current->scene_revision != scene_->revision()) {
        map = remerge(*current, current_probabilities, &summary);
      }
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (msg) install(*msg, map, error, summary, started);
    else if (current && (map || !error.empty())) install(*current->training, map, error, summary, started);
  }
}

void CollisionMapServer::insertSceneCloud(const SceneCloud& cloud) {
  const ros::WallTime started = ros::WallTime::now();
  const std::size_t inserted = scene_->insertCloud(cloud.points, cloud.origin);
  ++scene_clouds_;
  const double seconds = (ros::WallTime::now() - started).toSec();
  if (inserted == 0 && !cloud.points.empty()) {
    ROS_WARN_STREAM_THROTTLE(10.0, "collision_map: none of the cloud's " << cloud.points.size()
                                       << " points lies in the scene's box (collision_map/scene_min_corner_m, "
                                          "scene_max_corner_m, world frame) within scene_max_range_m of '"
                                       << cloud.frame << "'");
    return;
  }
  ROS_DEBUG_STREAM("collision_map: scene: " << inserted << " of the cloud's " << cloud.points.size()
                                           << " points cast from '" << cloud.frame << "' in " << seconds << " s, "
                                           << scene_->occupiedVoxels() << " occupied voxels");
}

void CollisionMapServer::install(const gpatlas_msgs::TrainingSet& msg, const std::shared_ptr<Map>& map,
                                 const std::string& error, const std::string& summary, const ros::WallTime& started) {
  // Offered even when the build failed (as none), so that the planner does not wait for it.
  SharedCollisionMaps::offer(training_sub_.getTopic(), msg, map ? map->tree : std::shared_ptr<const octomap::OcTree>());
  std::lock_guard<std::mutex> lock(mutex_);
  // A reset while it was built (a newer sequence, nothing pending) makes it worthless: the
  // status already says NONE.
  if (!pending_ && latest_sequence_ != msg.sequence) return;
  if (map) {
    map_ = map;
    if (hasMapSubscribers()) requestProbabilities();
    status_message_ = summary;
    // At most one line a second: a streaming camera's clouds may re-merge the map at its rate.
    ROS_INFO_STREAM_THROTTLE(1.0, "collision_map: " << summary << " in " << (ros::WallTime::now() - started).toSec()
                                                    << " s");
  } else {
    ROS_ERROR_STREAM("collision_map: no map for training set " << msg.sequence << ": " << error);
  }
  if (pending_) {
    state_ = gpatlas_msgs::CollisionMapStatus::BUILDING;  // a newer set is waiting
  } else if (map) {
    state_ = gpatlas_msgs::CollisionMapStatus::CURRENT;
  } else {
    state_ = map_ ? gpatlas_msgs::CollisionMapStatus::STALE : gpatlas_msgs::CollisionMapStatus::NONE;
    status_message_ = "the map of training set " + std::to_string(msg.sequence) + " failed: " + error;
  }
  publishStatus();
}

namespace {

// The training set's points the scene map takes apart: the explored object (what the camera saw
// of it and the probe's contacts, on its surface), appended to `object`, and the space the probe
// went through, to `free`.
void splitByScene(const gpatlas_msgs::TrainingSet& msg, std::vector<Eigen::Vector3d>* object,
                  std::vector<Eigen::Vector3d>* free) {
  for (std::size_t i = 0; i < msg.points.size() && i < msg.labels.size() && i < msg.sources.size(); ++i) {
    const gpatlas_motion::SceneRole role = gpatlas_motion::sceneRole(static_cast<gpatlas_core::PointLabel>(msg.labels[i]),
                                                                     static_cast<gpatlas_core::PointSource>(msg.sources[i]));
    if (role == gpatlas_motion::SceneRole::kObject) object->push_back(fromMsg(msg.points[i]));
    else if (role == gpatlas_motion::SceneRole::kProbed) free->push_back(fromMsg(msg.points[i]));
  }
  for (const auto& p : msg.view_points) object->emplace_back(p.x, p.y, p.z);
}

}  // namespace

std::shared_ptr<const std::vector<Eigen::Vector3d>> CollisionMapServer::sceneObstacles(
    const gpatlas_msgs::TrainingSet& msg) const {
  if (!scene_) return nullptr;
  std::vector<Eigen::Vector3d> object, free;
  splitByScene(msg, &object, &free);
  return std::make_shared<const std::vector<Eigen::Vector3d>>(scene_->obstacles(object, free));
}

std::shared_ptr<const octomap::OcTree> CollisionMapServer::unseenSpace(
    const gpatlas_msgs::TrainingSet& msg, const std::vector<Eigen::Vector3d>& model_occupied) const {
  if (!scene_) return nullptr;
  std::vector<Eigen::Vector3d> object = model_occupied, free;
  splitByScene(msg, &object, &free);
  const std::vector<Eigen::Vector3d> unseen = scene_->unseen(object, free);
  if (unseen.empty()) return nullptr;
  return gpatlas_motion::voxelOctree(unseen, map_config_.grid.resolution_m);
}

std::shared_ptr<CollisionMapServer::Map> CollisionMapServer::remerge(
    const Map& map, std::shared_ptr<const octomap::OcTree> model_probabilities, std::string* summary) const {
  auto out = std::make_shared<Map>();
  out->model = map.model;
  out->model_probabilities = std::move(model_probabilities);
  out->model_tree = map.model_tree;
  out->training = map.training;
  out->training_sequence = map.training_sequence;
  out->training_stamp = map.training_stamp;
  out->scene_revision = scene_->revision();
  out->scene_obstacles = sceneObstacles(*map.training);
  out->tree = withObstacles(out->model_tree, out->scene_obstacles.get());
  out->model_occupied = map.model_occupied;
  out->unseen = unseenSpace(*map.training, *map.model_occupied);
  *summary = "training set " + std::to_string(map.training_sequence) + " with the scene of " +
             std::to_string(scene_clouds_) + " clouds: " + std::to_string(out->scene_obstacles->size()) +
             " scene voxels are obstacles";
  return out;
}

std::shared_ptr<CollisionMapServer::Map> CollisionMapServer::build(
    const gpatlas_msgs::TrainingSet& msg, std::shared_ptr<const gpatlas_core::SurfaceModel> model, std::string* error,
    std::string* summary) {
  if (!model) {
    const ModelSource source = modelForTrainingSet(training_sub_.getTopic(), msg, model_config_, &model, error);
    if (source == ModelSource::kSuperseded) *error = "its model was superseded before it was built";
    if (!model) return nullptr;
  }
  const double threshold = approach_config_.occupied_probability;
  const gpatlas_core::OccupancyGrid grid = gpatlas_core::OccupancyGridBuilder(map_config_.grid).buildOccupancy(*model, threshold);
  if (!grid.ok) {
    *error = grid.message;
    return nullptr;
  }
  auto map = std::make_shared<Map>();
  map->model = model;
  map->training_sequence = msg.sequence;
  map->training_stamp = msg.header.stamp;
  std::size_t occupied = 0;
  map->model_tree = gpatlas_motion::collisionOctree(grid, threshold, &occupied);
  map->scene_revision = scene_ ? scene_->revision() : 0;
  const ros::WallTime scene_started = ros::WallTime::now();
  map->scene_obstacles = sceneObstacles(msg);
  map->tree = withObstacles(map->model_tree, map->scene_obstacles.get());
  map->model_occupied =
      std::make_shared<const std::vector<Eigen::Vector3d>>(gpatlas_motion::occupiedCentres(grid, threshold));
  map->unseen = unseenSpace(msg, *map->model_occupied);
  const double scene_s = (ros::WallTime::now() - scene_started).toSec();
  std::ostringstream message;
  message << "training set " << msg.sequence << ": " << occupied << " of " << grid.probabilities.size()
          << " cells occupied (P > " << threshold << ") at " << grid.resolution << " m";
  // The scene's share of the build: what a shadow costs shows here.
  if (map->scene_obstacles)
    message << ", " << map->scene_obstacles->size() << " scene voxels from " << scene_clouds_ << " clouds ("
            << scene_->skippedClouds() << " not cast: unchanged) merged in " << scene_s << " s";
  *summary = message.str();
  return map;
}

bool CollisionMapServer::hasMapSubscribers() const {
  return octomap_pub_.getNumSubscribers() + voxels_pub_.getNumSubscribers() > 0;
}

void CollisionMapServer::requestProbabilities() {
  if (!map_ || map_ == published_.lock()) return;
  publish_pending_ = map_;
  publish_wake_.notify_one();
}

void CollisionMapServer::publishLoop() {
  for (;;) {
    std::shared_ptr<Map> map;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      publish_wake_.wait(lock, [this] { return stopping_ || publish_pending_; });
      if (stopping_) return;
      map = std::move(publish_pending_);
      publish_pending_.reset();
    }
    std::string error;
    const ros::WallTime started = ros::WallTime::now();
    if (!probabilitiesOf(map, &error)) {
      ROS_ERROR_STREAM("collision_map: no probabilities for training set " << map->training_sequence << ": " << error);
      continue;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (map != map_) continue;  // a newer map came meanwhile: its own request follows
    publishMap(*map);
    published_ = map;
    ROS_DEBUG_STREAM("collision_map: probabilities of training set " << map->training_sequence << " in "
                                                                     << (ros::WallTime::now() - started).toSec() << " s");
  }
}

std::shared_ptr<const octomap::OcTree> CollisionMapServer::probabilitiesOf(const std::shared_ptr<Map>& map,
                                                                          std::string* error) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (map->probabilities) return map->probabilities;
  }
  std::shared_ptr<const octomap::OcTree> tree, model_tree;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    model_tree = map->model_probabilities;
  }
  // Nothing may escape: this runs in the publisher thread and in save_map's callback.
  try {
    if (!model_tree) {
      const gpatlas_core::OccupancyGrid grid = gpatlas_core::OccupancyGridBuilder(map_config_.grid).build(*map->model);
      if (!grid.ok) {
        *error = grid.message;
        return nullptr;
      }
      model_tree = gpatlas_motion::collisionOctree(grid, approach_config_.occupied_probability);
    }
    tree = withObstacles(model_tree, map->scene_obstacles.get());
  } catch (const std::exception& e) {
    *error = e.what();
    return nullptr;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!map->model_probabilities) map->model_probabilities = model_tree;
  if (!map->probabilities) map->probabilities = tree;
  return map->probabilities;
}

void CollisionMapServer::publishMap(const Map& map) {
  const octomap::OcTree& tree = *map.probabilities;
  const gpatlas_msgs::OctomapBinary out = octomapMessage(tree, world_frame_, map.training_stamp, map.training_sequence);
  octomap_pub_.publish(out);

  visualization_msgs::MarkerArray markers;
  visualization_msgs::Marker cubes;
  cubes.header = out.header;
  cubes.ns = "occupied_voxels";
  cubes.type = visualization_msgs::Marker::CUBE_LIST;
  cubes.action = visualization_msgs::Marker::ADD;
  cubes.pose.orientation.w = 1.0;
  cubes.scale.x = cubes.scale.y = cubes.scale.z = tree.getResolution();
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    geometry_msgs::Point p;
    p.x = it.getX();
    p.y = it.getY();
    p.z = it.getZ();
    cubes.points.push_back(p);
    std_msgs::ColorRGBA c;
    const double probability = it->getOccupancy();
    c.r = static_cast<float>(probability);
    c.g = 0.3f;
    c.b = static_cast<float>(1.0 - probability);
    c.a = 0.5f;
    cubes.colors.push_back(c);
  }
  markers.markers.push_back(cubes);
  voxels_pub_.publish(markers);
}

bool CollisionMapServer::onSaveMap(gpatlas_msgs::SaveMap::Request& req, gpatlas_msgs::SaveMap::Response& res) {
  std::shared_ptr<Map> map;
  std::uint32_t latest = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    map = map_;
    latest = latest_sequence_;
  }
  if (!map) {
    res.success = false;
    res.message = "no collision map yet: the GP has not published a training set";
    return true;
  }
  if (req.path.empty()) {
    res.success = false;
    res.message = "path is empty";
    return true;
  }
  std::string error;
  const std::shared_ptr<const octomap::OcTree> probabilities = probabilitiesOf(map, &error);
  if (!probabilities) {
    res.success = false;
    res.message = "no probabilities for the map of training set " + std::to_string(map->training_sequence) + ": " + error;
    return true;
  }
  // The answer names the absolute path: a relative one is resolved against the node's working
  // directory, which roslaunch sets to ~/.ros.
  std::error_code ignored;
  const std::filesystem::path absolute = std::filesystem::absolute(req.path, ignored);
  const std::string shown = absolute.empty() ? req.path : absolute.string();
  errno = 0;
  std::ofstream file(shown, std::ios::binary | std::ios::trunc);
  if (!file) {
    res.success = false;
    res.message = "cannot write " + shown + ": " + (errno != 0 ? std::strerror(errno) : "cannot open the file");
    return true;
  }
  res.training_sequence = map->training_sequence;
  res.stale = latest != map->training_sequence;
  res.success = probabilities->writeBinaryConst(file) && static_cast<bool>(file.flush());
  res.message = res.success ? "wrote " + shown : "cannot write " + shown + ": the write failed (disk full?)";
  res.message += " (the map of training set " + std::to_string(map->training_sequence) +
                 (res.stale ? "; STALE: the newest is " + std::to_string(latest) + ", see ~status)" : ", the newest)");
  return true;
}

}  // namespace gpatlas_ros
