#pragma once

#include <gpatlas_core/model/occupancy_grid.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_motion/arm_approach_planner.h>
#include <gpatlas_motion/scene_map.h>
#include <gpatlas_motion/touch_approach.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/SaveMap.h>
#include <gpatlas_msgs/SupportPlane.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <gpatlas_ros/ros_params.h>
#include <gpatlas_ros/tf_gated_subscriber.h>
#include <gpatlas_ros/world_frame.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
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

// A camera cloud in world_frame and the origin of its rays.
struct SceneCloud {
  std::vector<Eigen::Vector3d> points;
  Eigen::Vector3d origin{Eigen::Vector3d::Zero()};
  std::string frame;
  ros::Time stamp;
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
// The scene (collision_map/scene_*): every camera cloud on `points` goes into a
// gpatlas_motion::SceneMap, cast from the cloud's frame (sensor_frame for a cloud already in
// world_frame), and its occupied voxels join the map as obstacles, except near the explored
// object's points and contacts (its model governs there) and where the probe went. A cloud that
// changed the scene (SceneMap::revision) re-merges the current map with it. The scene outlasts a reset
// of the model: the table the camera saw is unchanged (selecting another object resets the
// model, and the object explored before stays in the scene as an obstacle).
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
  // A camera cloud for the scene: moved to world_frame with its sensor's origin, handed to
  // builder_ (latest wins).
  void onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void buildLoop();
  // In builder_: the cloud into the scene.
  void insertSceneCloud(const SceneCloud& cloud);
  // In builder_: the newest map again with the scene as it is now (after a cloud), keeping the
  // model's probabilities when they were built (null: built when asked for).
  std::shared_ptr<Map> remerge(const Map& map, std::shared_ptr<const octomap::OcTree> model_probabilities,
                               std::string* summary) const;
  // In builder_, after a build or a re-merge: the new map (or the failure) becomes the current
  // one unless a reset or a newer training set came meanwhile, and ~status says so.
  void install(const gpatlas_msgs::TrainingSet& msg, const std::shared_ptr<Map>& map, const std::string& error,
               const std::string& summary, const ros::WallTime& started);
  // The scene's obstacles for a training set (its object points and the probe's free space).
  std::shared_ptr<const std::vector<Eigen::Vector3d>> sceneObstacles(const gpatlas_msgs::TrainingSet& msg) const;
  // The space near the explored object that no sensor observed (SceneMap::unseen), for a
  // training set (its object points and probe's free space) and its model's occupied voxels;
  // null without a scene, with collision_map/scene_unseen_reach_m 0, or when there is none.
  std::shared_ptr<const octomap::OcTree> unseenSpace(const gpatlas_msgs::TrainingSet& msg,
                                                     const std::vector<Eigen::Vector3d>& model_occupied) const;
  // The map of one training set and what it holds, or null with the reason.
  // `model` is the GP nodelet's snapshot of it, null for a replica refitted from the message.
  std::shared_ptr<Map> build(const gpatlas_msgs::TrainingSet& msg, std::shared_ptr<const gpatlas_core::SurfaceModel> model,
                             std::string* error, std::string* summary);
  // Builds the probabilities of the newest map for its subscribers, latest wins.
  void publishLoop();
  bool hasMapSubscribers() const;
  void requestProbabilities();  // with mutex_ held: for map_, when someone subscribes
  // The map's probabilities, built now if they are not yet (null with the reason on failure).
  std::shared_ptr<const octomap::OcTree> probabilitiesOf(const std::shared_ptr<Map>& map, std::string* error);
  void publishMap(const Map& map);  // with mutex_ held, the map's probabilities built
  // After a reset (an empty training set), with mutex_ held: an empty OctoMap, DELETEALL on the
  // voxel and approach markers and an empty approach trajectory, so that a late subscriber sees
  // no map and no plan on the map that is gone.
  void publishEmptyMap(const gpatlas_msgs::TrainingSet& reset);
  // The displays of a planned approach (with the arm, its trajectory), unless a reset came
  // after the plan started (resets_ no longer `resets_at_start`).
  void publishApproach(const gpatlas_motion::TouchMotion& plan, const gpatlas_msgs::PlanApproach::Response& res,
                       std::uint64_t resets_at_start);
  void publishStatus();  // with mutex_ held

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  gpatlas_core::SurfaceModelConfig model_config_;
  gpatlas_core::CollisionMapConfig map_config_;
  gpatlas_motion::SceneMapConfig scene_config_;
  std::string sensor_frame_;
  std::unique_ptr<gpatlas_motion::SceneMap> scene_;  // builder_'s only; null with scene_enabled false
  std::size_t scene_clouds_{0};                      // clouds in the scene (builder_)
  gpatlas_motion::ApproachConfig approach_config_;
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
  // Its snapshot, taken as it arrived (the GP nodelet holds only its newest one); null when the
  // GP nodelet is in another process.
  std::shared_ptr<const gpatlas_core::SurfaceModel> pending_model_;
  std::shared_ptr<const SceneCloud> pending_cloud_;  // the newest cloud not in the scene yet
  std::shared_ptr<Map> map_;                     // the newest map approaches are planned on
  std::shared_ptr<Map> publish_pending_;         // the map whose probabilities subscribers wait for
  // The map on octomap_binary: save_map computes a map's probabilities without publishing them,
  // so that having them does not mean a subscriber got them. Weak: it keeps no old map alive.
  std::weak_ptr<const Map> published_;
  std::uint32_t latest_sequence_{0};
  std::uint64_t resets_{0};  // empty training sets received
  std::uint8_t state_{0};
  std::string status_message_;
  std::condition_variable publish_wake_;
  std::thread builder_, publisher_;

  ros::Subscriber training_sub_, plane_sub_;
  std::unique_ptr<TfGatedCloudSubscriber> points_sub_;
  ros::ServiceServer save_srv_, approach_srv_;
  ros::Publisher octomap_pub_, voxels_pub_, status_pub_, approach_pub_, approach_arm_pub_, approach_trajectory_pub_;
};

}  // namespace gpatlas_ros
