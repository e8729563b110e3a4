#pragma once

#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/exploration/observation_history.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_core/observations/view_shadow.h>
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
// The surface model. Views are fitted in a thread of their own, newest first: a cloud that arrives
// while a fit runs replaces the one waiting (latest wins), so a streaming camera never queues
// refits. Its training set is published as soon as the model changes; the predicted surface is
// meshed for every model in a thread of its own from a copy of the newest model (latest wins), so
// that add_observations never waits behind a mesh and a late subscriber gets the current surface,
// stamped like the training set it shows.
class GpModelServer {
 public:
  GpModelServer(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~GpModelServer();
  GpModelServer(const GpModelServer&) = delete;
  GpModelServer& operator=(const GpModelServer&) = delete;

 private:
  void onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg);
  // Hands a cloud to the fit thread, replacing one that waits there.
  void queueFit(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void fitLoop();
  // Waits up to plane_wait_s_ for the support plane of the cloud stamped `stamp`.
  void waitForPlane(const ros::Time& stamp);
  // True when the model was refitted and published; otherwise the reason is logged.
  bool fitCloud(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg);
  void onContacts(const gpatlas_msgs::Observations::ConstPtr& msg);
  bool onAddObservations(gpatlas_msgs::AddObservations::Request& req, gpatlas_msgs::AddObservations::Response& res);
  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  // Arms the fit of the next cloud that arrives (the one-shot view with fit_every_cloud false).
  bool onFitNextCloud(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool onRemoveObservations(gpatlas_msgs::RemoveObservations::Request& req,
                            gpatlas_msgs::RemoveObservations::Response& res);
  // Adds observations and fills the answer (AddObservations.srv says what each field is);
  // false with a message when nothing could be used.
  bool addObservations(const gpatlas_msgs::Observations& msg, gpatlas_msgs::AddObservations::Response* answer);
  void publishModel();  // with mutex_ held
  void meshLoop();
  // Publishes the predicted surface of the model of `generation` unless a reset came meanwhile
  // (a late subscriber would otherwise get the shape the reset removed).
  void publishSurface(const gpatlas_geometry::SurfaceMeshResult& surface, const ros::Time& stamp,
                      std::uint64_t generation);
  // The empty surface, cloud and shape and a DELETEALL mesh marker, for every latched surface
  // topic: what a late subscriber gets after a reset. With mesh_mutex_ held.
  void publishEmptySurface(const ros::Time& stamp);
  std::uint32_t training_sequence_{0};  // with mutex_
  // A remove_observations rebuild logs how far it is this often.
  static constexpr double kRebuildReportPeriodS{2.0};

  // False: only the cloud after each ~fit_next_cloud call is fitted (a streaming camera, a
  // pipeline that wants one view); true: every cloud, the newest first.
  bool fit_every_cloud_{true};
  std::mutex fit_mutex_;  // guards the five below
  bool fit_next_armed_{false};
  std::condition_variable fit_wake_;
  sensor_msgs::PointCloud2::ConstPtr fit_pending_;  // the newest cloud not fitted yet
  std::size_t clouds_dropped_{0};  // replaced while waiting, since the last fit
  bool fit_stopping_{false};
  std::thread fitter_;
  // Segmentation publishes a cloud's plane just before it: a fit waits this long for it, so that
  // one cloud is fitted once, with its plane.
  static constexpr double plane_wait_s_{0.5};
  std::condition_variable plane_arrived_;  // with plane_mutex_

  std::mutex mesh_mutex_;  // guards the four below and the surface topics' publishing
  std::condition_variable mesh_wake_;
  std::shared_ptr<const gpatlas_core::SurfaceModel> mesh_pending_;  // the newest model's snapshot
  ros::Time mesh_stamp_;
  std::uint64_t mesh_generation_{0};  // counts resets: a mesh of an earlier generation is not published
  bool mesh_stopping_{false};
  std::thread mesher_;

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_;
  double tf_timeout_s_{0.5};
  // How a view and a touch become training data (the bench uses the same Configs).
  gpatlas_core::ViewTrainingConfig view_config_;
  gpatlas_core::TouchObservationConfig touch_config_;
  std::uint64_t seed_{0};
  gpatlas_core::PositionCalibrationConfig position_calibration_;
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
  std::mutex plane_mutex_;  // guards the two below
  std::optional<StampedPlane> support_plane_;
  // The cloud of the last fit when it was fitted without its plane (a plane that came after the
  // fit's wait): refitted when its plane arrives.
  sensor_msgs::PointCloud2::ConstPtr last_fitted_without_plane_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;

  std::mutex mutex_;  // guards model_, history_ and view_ (callbacks may run concurrently in a multi-threaded manager)
  std::unique_ptr<gpatlas_core::SurfaceModel> model_;
  gpatlas_core::ObservationHistory history_;  // the view and each touch, for remove_observations
  // The fitted view's sensor origin and object points (world frame), published with every
  // training set for the planner's shadow of unobserved space; none without a sensor_frame.
  std::optional<gpatlas_core::CameraView> view_;

  std::unique_ptr<TfGatedCloudSubscriber> points_sub_;
  ros::Subscriber contacts_sub_, plane_sub_;
  ros::ServiceServer add_srv_, reset_srv_, remove_srv_, fit_next_srv_;
  ros::Publisher training_pub_, surface_pub_, mesh_marker_pub_, mesh_shape_pub_;
};

}  // namespace gpatlas_ros
