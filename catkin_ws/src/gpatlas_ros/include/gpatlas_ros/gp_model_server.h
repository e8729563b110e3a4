#pragma once

#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/exploration/observation_history.h>
#include <gpatlas_core/model/hyperparameter_tuner.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_geometry/surface_mesher.h>
#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/Observations.h>
#include <gpatlas_msgs/RemoveObservations.h>
#include <gpatlas_msgs/SupportPlane.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <gpatlas_ros/ros_params.h>
#include <gpatlas_ros/tf_gated_subscriber.h>
#include <gpatlas_ros/world_frame.h>
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

namespace gpatlas_ros {

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
  gpatlas_geometry::SurfaceMesher::Config mesher_config_;
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

}  // namespace gpatlas_ros
