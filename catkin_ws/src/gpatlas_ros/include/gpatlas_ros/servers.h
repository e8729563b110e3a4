#pragma once

// Plain ROS server classes, one per pipeline stage. The nodelets (src/nodelets.cpp) only
// construct them from (nh, pnh); tests and custom executables can do the same.

#include <gpatlas_core/exploration_strategy.h>
#include <gpatlas_core/explorer.h>
#include <gpatlas_core/surface_model_factory.h>
#include <gpatlas_core/hyperparameter_tuner.h>
#include <gpatlas_core/observation_history.h>
#include <gpatlas_core/occupancy_grid.h>
#include <gpatlas_core/segmentation.h>
#include <gpatlas_core/surface_mesher.h>
#include <gpatlas_motion/arm_approach_planner.h>
#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/Observations.h>
#include <gpatlas_msgs/RemoveObservations.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/SaveMap.h>
#include <gpatlas_msgs/SupportPlane.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <gpatlas_ros/ros_params.h>
#include <gpatlas_ros/tf_gated_subscriber.h>

#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace octomap {
class OcTree;
}

namespace gpatlas_ros {

// A cloud that waits this long for its transform is reported (it is still processed when the
// transform comes).
constexpr double kTfWaitWarningS = 3.0;

// Transforms points stamped in `frame` into `world_frame` with tf2 (waiting up to timeout_s).
bool transformToWorld(const tf2_ros::Buffer& buffer, const std::string& world_frame, const std::string& frame,
                      const ros::Time& stamp, double timeout_s, std::vector<Eigen::Vector3d>* points,
                      std::string* error);

// A support plane message moved to world_frame (tf2 for another frame; an empty frame is taken
// to be world_frame); false with the reason when it is malformed or there is no transform.
bool planeToWorld(const gpatlas_msgs::SupportPlane& msg, const tf2_ros::Buffer& buffer, const std::string& world_frame,
                  double timeout_s, gpatlas_core::SupportPlane* plane, std::string* error);

// A `support_plane` callback's work: the plane moved to world_frame and stored in `*latest`
// under `mutex`, or a warning from `who` with the reason. Never throws (roscpp does not catch
// exceptions from callbacks, and one would end the nodelet manager).
void receiveSupportPlane(const gpatlas_msgs::SupportPlane& msg, const tf2_ros::Buffer& buffer,
                         const std::string& world_frame, double timeout_s, const char* who, std::mutex* mutex,
                         std::optional<gpatlas_core::SupportPlane>* latest);

// The finite points of a cloud, in world_frame; false with the reason when the cloud has no
// x/y/z or there is no transform.
bool cloudToWorld(const sensor_msgs::PointCloud2& cloud, const tf2_ros::Buffer& buffer, const std::string& world_frame,
                  double timeout_s, std::vector<Eigen::Vector3d>* points, std::size_t* num_invalid, std::string* error);

// PCL segmentation of the camera cloud: `points` (sensor_msgs/PointCloud2, any frame) in,
// `~object_points` (world_frame) out.
class SegmentationServer {
 public:
  SegmentationServer(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg);

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  double tf_timeout_s_{0.5};
  gpatlas_core::ObjectSegmenter segmenter_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::unique_ptr<TfGatedCloudSubscriber> points_sub_;
  ros::Publisher object_pub_, plane_pub_;
};

// The GPIS: fitted to the object points (`points`), updated with touch observations
// (`contacts` topic and `~add_observations` service). Publishes the training set for the
// planner and the collision map (`~training_set`, latched), and the predicted surface
// (`~surface` cloud coloured by variance, `~surface_mesh` marker, `~surface_shape` mesh).
// The surface model. Its training set is published as soon as the model changes; the predicted
// surface for display is meshed in a thread of its own from a copy of the newest model (latest
// wins), so that add_observations never waits behind a mesh.
class GpModelServer {
 public:
  GpModelServer(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~GpModelServer();
  GpModelServer(const GpModelServer&) = delete;
  GpModelServer& operator=(const GpModelServer&) = delete;

 private:
  void onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void fitCloud(const sensor_msgs::PointCloud2& cloud);
  void onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg);
  void onContacts(const gpatlas_msgs::Observations::ConstPtr& msg);
  bool onAddObservations(gpatlas_msgs::AddObservations::Request& req, gpatlas_msgs::AddObservations::Response& res);
  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool onRemoveObservations(gpatlas_msgs::RemoveObservations::Request& req,
                            gpatlas_msgs::RemoveObservations::Response& res);
  // Adds observations and fills the answer (AddObservations.srv says what each field is);
  // false with a message when nothing could be used.
  bool addObservations(const gpatlas_msgs::Observations& msg, gpatlas_msgs::AddObservations::Response* answer);
  void publishModel();  // with mutex_ held
  void meshLoop();
  std::uint32_t training_sequence_{0};  // with mutex_

  std::mutex mesh_mutex_;  // guards the three below
  std::condition_variable mesh_wake_;
  std::shared_ptr<const gpatlas_core::SurfaceModel> mesh_pending_;  // the newest model's snapshot
  ros::Time mesh_stamp_;
  bool mesh_stopping_{false};
  std::thread mesher_;

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  double tf_timeout_s_{0.5};
  // How a view and a touch become training data (the bench uses the same Configs).
  gpatlas_core::ViewTrainingConfig view_config_;
  gpatlas_core::TouchObservationConfig touch_config_;
  std::uint64_t seed_{0};
  gpatlas_core::TuningConfig tuning_;
  double display_v_max_{0.1};
  gpatlas_core::SurfaceModelConfig model_config_;
  gpatlas_core::SurfaceMesher::Config mesher_config_;
  std::string sensor_frame_;  // empty: no view free space
  // The table under the object (segmentation's `support_plane`): outside points below it, no
  // guessed inside points in it.
  bool use_support_plane_{true};
  // A plane (in world_frame) belongs to the cloud with the same stamp (segmentation stamps
  // both with the camera's); a plane stamped 0 (a fixed table, published by hand) belongs to
  // every cloud.
  struct StampedPlane {
    gpatlas_core::SupportPlane plane;
    ros::Time stamp;
    bool belongsTo(const ros::Time& cloud_stamp) const { return stamp.isZero() || stamp == cloud_stamp; }
  };
  std::mutex plane_mutex_;  // guards the three below
  std::optional<StampedPlane> support_plane_;
  sensor_msgs::PointCloud2::ConstPtr last_cloud_;
  bool last_fit_had_plane_{false};
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;

  std::mutex mutex_;  // guards model_ and history_ (callbacks may run concurrently in a multi-threaded manager)
  std::unique_ptr<gpatlas_core::SurfaceModel> model_;
  gpatlas_core::ObservationHistory history_;  // the view and each touch, for remove_observations

  std::unique_ptr<TfGatedCloudSubscriber> points_sub_;
  ros::Subscriber contacts_sub_, plane_sub_;
  ros::ServiceServer add_srv_, reset_srv_, remove_srv_;
  ros::Publisher training_pub_, surface_pub_, mesh_marker_pub_, mesh_shape_pub_;
};

// GPAtlasRRT: `~next_touch` plans on the GP model of `training_set` (SharedModels) and
// publishes the grown atlas (`~atlas` markers, `~atlas_charts`) and the touch (`~touch`).
class AtlasPlannerServer {
 public:
  AtlasPlannerServer(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg);
  bool onNextTouch(gpatlas_msgs::GetNextTouch::Request& req, gpatlas_msgs::GetNextTouch::Response& res);
  const gpatlas_core::ExplorationStrategy* strategy(const std::string& name, std::string* error);

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  std::string default_strategy_;
  double default_v_max_{0.1};
  // The evidence test of every plan (its support plane from `support_plane`).
  gpatlas_core::EvidenceRule evidence_;
  gpatlas_core::SurfaceModelConfig model_config_;
  gpatlas_core::StrategyConfig strategy_config_;
  void onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg);
  double tf_timeout_s_{0.5};
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::optional<gpatlas_core::SupportPlane> support_plane_;  // the latest, world frame (guarded by mutex_)
  ros::Subscriber plane_sub_;

  std::mutex mutex_;
  // The GP nodelet's snapshot when it is in this manager, otherwise a replica (SharedModels).
  std::shared_ptr<const gpatlas_core::SurfaceModel> model_;
  ros::Time model_stamp_;  // the stamp of the training set model_ is from
  std::uint32_t model_sequence_{0};  // and its sequence number
  gpatlas_core::ApproachConfig approach_config_;  // for GetNextTouch's reachable_only
  std::shared_ptr<const gpatlas_motion::Arm> approach_arm_;  // with approach/use_arm
  std::string approach_arm_error_;
  // What the cheap test learnt of the arm's reach, kept from one model's map to the next.
  std::shared_ptr<gpatlas_motion::ArmReachMemory> arm_reach_{std::make_shared<gpatlas_motion::ArmReachMemory>()};
  std::string model_error_;
  std::map<std::string, std::unique_ptr<gpatlas_core::ExplorationStrategy>> strategies_;
  std::uint64_t plan_count_{0};

  ros::Subscriber training_sub_;
  ros::ServiceServer next_touch_srv_;
  ros::Publisher atlas_marker_pub_, atlas_pub_, touch_pub_;
};

// Probabilistic collision map (paper section 4.1): P(the object reaches into a voxel) from the GP
// (gpatlas_core::OccupancyGridBuilder) on a coarse grid, stored in an OctoMap octree. Publishes `~octomap_binary`
// (gpatlas_msgs/OctomapBinary) and `~occupied_voxels` (markers); `~save_map` writes a .bt file.
// Builds the collision map in a thread of its own: a training set only replaces the pending
// one (latest wins, intermediate models are skipped), so no callback of the manager waits for
// a rebuild. What approaches are planned on is built first: the voxels above
// approach/occupied_probability (OccupancyGridBuilder::buildOccupancy, no variance at 0.5);
// ~status says which training set it is from. The probabilities are built after it, in a
// second thread, only while someone subscribes to the map's topics (as octomap_server does),
// and for `~save_map`. `~plan_approach` plans the probe's way to a touch on that map and the
// table (`support_plane`), with gpatlas_motion's TouchMotionPlanner (for the arm of
// robot_description with approach/use_arm), and shows it on `~approach_path` (the tip) and
// `~approach_arm` (the arm's links); with the arm, `~approach_trajectory`
// (trajectory_msgs/JointTrajectory) is the last planned approach.
class CollisionMapServer {
 public:
  CollisionMapServer(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~CollisionMapServer();
  CollisionMapServer(const CollisionMapServer&) = delete;
  CollisionMapServer& operator=(const CollisionMapServer&) = delete;

 private:
  struct Map;
  void onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg);
  bool onSaveMap(gpatlas_msgs::SaveMap::Request& req, gpatlas_msgs::SaveMap::Response& res);
  bool onPlanApproach(gpatlas_msgs::PlanApproach::Request& req, gpatlas_msgs::PlanApproach::Response& res);
  void onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg);
  void buildLoop();
  // The map of one training set and what it holds, or null with the reason.
  std::shared_ptr<Map> build(const gpatlas_msgs::TrainingSet& msg, std::string* error, std::string* summary);
  // Builds the probabilities of the newest map for its subscribers, latest wins.
  void publishLoop();
  bool hasMapSubscribers() const;
  void requestProbabilities();  // with mutex_ held: for map_, when someone subscribes
  // The map's probabilities, built now if they are not yet (null with the reason on failure).
  std::shared_ptr<const octomap::OcTree> probabilitiesOf(const std::shared_ptr<Map>& map, std::string* error);
  void publishMap(const Map& map);  // with mutex_ held, the map's probabilities built
  void publishStatus();  // with mutex_ held

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  gpatlas_core::SurfaceModelConfig model_config_;
  gpatlas_core::CollisionMapConfig map_config_;
  gpatlas_core::ApproachConfig approach_config_;
  std::shared_ptr<const gpatlas_motion::Arm> approach_arm_;  // with approach/use_arm
  std::string approach_arm_error_;                           // why there is none, when asked for
  double tf_timeout_s_{0.5};
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<gpatlas_core::SupportPlane> support_plane_;  // the table, world frame
  bool stopping_{false};
  gpatlas_msgs::TrainingSet::ConstPtr pending_;  // the newest training set not built yet
  std::shared_ptr<Map> map_;                     // the newest map approaches are planned on
  std::shared_ptr<Map> publish_pending_;         // the map whose probabilities subscribers wait for
  std::uint32_t latest_sequence_{0};
  std::uint8_t state_{0};
  std::string status_message_;
  std::condition_variable publish_wake_;
  std::thread builder_, publisher_;

  ros::Subscriber training_sub_, plane_sub_;
  ros::ServiceServer save_srv_, approach_srv_;
  ros::Publisher octomap_pub_, voxels_pub_, status_pub_, approach_pub_, approach_arm_pub_, approach_trajectory_pub_;
};

}  // namespace gpatlas_ros
