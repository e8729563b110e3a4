#pragma once

#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_core/planning/strategy_registry.h>
#include <gpatlas_motion/arm_approach_planner.h>
#include <gpatlas_motion/touch_approach.h>
#include <gpatlas_msgs/GetNextTouch.h>
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

namespace gpatlas_ros {

// GPAtlasRRT: `~next_touch` plans on the GP model of `training_set` (SharedModels) and
// publishes the grown atlas (`~atlas` markers, `~atlas_charts`) and the touch (`~touch`).
class AtlasPlannerServer {
 public:
  AtlasPlannerServer(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg);
  bool onNextTouch(gpatlas_msgs::GetNextTouch::Request& req, gpatlas_msgs::GetNextTouch::Response& res);
  // The answers without a plan: no model, a model older than asked for, an invalid V_max.
  bool answeredWithoutAPlan(const gpatlas_msgs::GetNextTouch::Request& req,
                            gpatlas_msgs::GetNextTouch::Response& res) const;
  // reachable_only: the approach planner's cheap test on the collision map of this model, in
  // request->reachable (it calls *approach_check), or a note that every candidate is taken.
  // False when the answer is given instead (the map is not built yet, there is no arm).
  bool addReachability(gpatlas_core::PlanRequest* request,
                       std::unique_ptr<gpatlas_motion::TouchMotionPlanner>* approach_check, std::string* note,
                       gpatlas_msgs::GetNextTouch::Response& res);
  // The strategy's plan, or an error plan for a strategy that throws or returns a malformed touch.
  gpatlas_core::PlanResult planWith(const gpatlas_core::ExplorationStrategy& chosen, const std::string& name,
                                    const gpatlas_core::PlanRequest& request) const;
  void publishAtlas(const gpatlas_core::AtlasPlanResult& planned, double v_max, const std_msgs::Header& header);
  // After a reset (an empty training set), with mutex_ held: no atlas (DELETEALL markers, no
  // charts) and no touch, so that a late subscriber sees no plan on the model that is gone.
  void publishNoPlan(const std_msgs::Header& header);
  // The strategy of that name, made on first use; it reads its settings with `settings` (the
  // start-up's reader) or, without, a reader of its own.
  const gpatlas_core::ExplorationStrategy* strategy(const std::string& name, std::string* error,
                                                    gpatlas_core::ParamReader* settings = nullptr);

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  std::string default_strategy_;
  double default_v_max_{0.1};
  std::optional<double> default_max_position_sd_m_;
  gpatlas_core::SurfaceModelConfig model_config_;
  std::uint64_t seed_{0};  // the run's: every strategy's (readSeed)
  gpatlas_core::TouchObservationConfig touch_config_;  // touch/, as the GP nodelet reads it: the score's fantasy touches
  void onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg);
  double tf_timeout_s_{0.5};
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::optional<gpatlas_core::SupportPlane> support_plane_;  // the latest, world frame (guarded by mutex_)
  ros::Subscriber plane_sub_;

  std::mutex mutex_;
  // The GP nodelet's snapshot when it is in this manager, otherwise a replica (SharedModels).
  std::shared_ptr<const gpatlas_core::SurfaceModel> model_;
  // The camera view model_ was fitted from (its training set's), for atlas_frontier's shadow.
  std::optional<gpatlas_core::CameraView> view_;
  ros::Time model_stamp_;  // the stamp of the training set model_ is from
  std::uint32_t model_sequence_{0};  // and its sequence number
  gpatlas_motion::ApproachConfig approach_config_;  // for GetNextTouch's reachable_only
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

}  // namespace gpatlas_ros
