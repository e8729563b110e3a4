#pragma once

// Conversions between gpatlas_core types and ROS messages. Every function here is a pure
// function of its arguments, round-trip tested in test/test_conversions.cpp.
// Its own package (so that probe_sim_ros and other nodes can use it without the pipeline's
// nodelets).

#include <gpatlas_core/common/triangle_mesh.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/exploration/prober.h>
#include <gpatlas_core/planning/atlas.h>
#include <gpatlas_core/planning/exploration_strategy.h>
#include <gpatlas_core/common/types.h>
#include <gpatlas_core/observations/support_plane.h>
#include <gpatlas_core/observations/view_shadow.h>

#include <geometry_msgs/Point.h>
#include <geometry_msgs/Vector3.h>
#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/Atlas.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/Observations.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/Probe.h>
#include <gpatlas_msgs/SupportPlane.h>
#include <gpatlas_msgs/Touch.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <sensor_msgs/PointCloud2.h>
#include <shape_msgs/Mesh.h>
#include <trajectory_msgs/JointTrajectory.h>

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_conversions {

geometry_msgs::Point toPointMsg(const Eigen::Vector3d& p);
geometry_msgs::Vector3 toVectorMsg(const Eigen::Vector3d& v);
Eigen::Vector3d fromMsg(const geometry_msgs::Point& p);
Eigen::Vector3d fromMsg(const geometry_msgs::Vector3& v);

gpatlas_msgs::SupportPlane toMsg(const gpatlas_core::SupportPlane& plane, const std::string& frame_id);
// Fails on a non-finite or zero normal or offset; the normal is normalised (offset scaled).
bool fromMsg(const gpatlas_msgs::SupportPlane& msg, gpatlas_core::SupportPlane* plane, std::string* error);

// The same plane in another frame: `pose` maps its frame's coordinates into the new one.
gpatlas_core::SupportPlane transformPlane(const gpatlas_core::SupportPlane& plane, const Eigen::Isometry3d& pose);

// The arm's joint paths (approach_joints, retreat_joints) become the trajectories, named by
// joint_names (the arm's chain order) and timed at joint_speed_rad_s; they need both.
gpatlas_msgs::Touch toMsg(const gpatlas_core::Touch& touch, const std::vector<std::string>& joint_names = {},
                          double joint_speed_rad_s = 0.5);
// Fails (returns false with a reason) on mismatched array lengths or an unknown kind.
// The trajectories are read into approach_joints and retreat_joints in the order of
// joint_names (every one must be in them) when given, and ignored otherwise.
bool fromMsg(const gpatlas_msgs::Touch& msg, gpatlas_core::Touch* touch, std::string* error,
             const std::vector<std::string>* joint_names = nullptr);

// A joint path as a trajectory: one point per configuration, with the time at which the
// slowest joint, moving at joint_speed_rad_s, gets there. Throws std::invalid_argument when a
// configuration's size is not the names' count or the speed is not positive.
trajectory_msgs::JointTrajectory toJointTrajectoryMsg(const std::vector<Eigen::VectorXd>& path,
                                                      const std::vector<std::string>& joint_names,
                                                      double joint_speed_rad_s);
// The trajectory's positions in the order of joint_names; false with why when a name is
// missing, a point's positions do not match the trajectory's names, or one is not finite.
bool fromJointTrajectoryMsg(const trajectory_msgs::JointTrajectory& msg, const std::vector<std::string>& joint_names,
                            std::vector<Eigen::VectorXd>* path, std::string* error);

gpatlas_msgs::Observations toMsg(const gpatlas_core::ProbeResult& result);
// Contacts (with normals when given) and free-space points; success/reason are not part of it.
bool fromMsg(const gpatlas_msgs::Observations& msg, gpatlas_core::ProbeResult* result, std::string* error);

// The probe service's answer (Probe): the touch's outcome and its observations, whose header is
// the caller's. Malformed observations give a failed probe that says why.
gpatlas_msgs::Probe::Response toProbeResponseMsg(const gpatlas_core::ProbeResult& result);
gpatlas_core::ProbeResult fromMsg(const gpatlas_msgs::Probe::Response& msg);

// The model's answer to a touch (AddObservations): what it accepted and refused. The batch id
// is the caller's; the message says why a touch was refused.
gpatlas_msgs::AddObservations::Response toMsg(const gpatlas_core::TouchUpdate& update);
gpatlas_core::TouchUpdate fromMsg(const gpatlas_msgs::AddObservations::Response& msg);

// plan_approach's answer (PlanApproach) as the loop's ApproachResult: the probe's way there and
// back and, planned for the arm, its joint paths in the order of the trajectory's joint names
// (*joint_names, which the probe's touch then names them by). A map that was not the newest
// model's is said in the message. False, with why, on a malformed joint trajectory.
bool fromMsg(const gpatlas_msgs::PlanApproach::Response& msg, gpatlas_core::ApproachResult* result,
             std::vector<std::string>* joint_names, std::string* error);

// A triangle mesh (the ground truth, the predicted surface). fromMsg fails on a triangle that
// indexes no vertex.
shape_msgs::Mesh toMsg(const gpatlas_core::TriangleMesh& mesh);
bool fromMsg(const shape_msgs::Mesh& msg, gpatlas_core::TriangleMesh* mesh, std::string* error);

// The next_touch service (GetNextTouch): a plan request and the planner's answer. The request's
// strategy, model_stamp and reachable_only are the caller's to fill; the plan request's
// reachable test, support plane and camera views do not travel (the planner nodelet has its
// own: the views come with the training set). A plan request's message sets its V_max, stop
// rule and seed explicitly; what a message leaves to the node (use_v_max false,
// STOP_RULE_PARAMETER, use_seed false) comes from `node`. The server refuses a message whose
// values are unusable (an unknown stop_rule, a v_max or bound <= 0) before it converts it.
struct NodePlanDefaults {
  double v_max{0.1};
  std::optional<double> max_position_sd_m;
  std::uint64_t seed{0};
};
gpatlas_msgs::GetNextTouch::Request toMsg(const gpatlas_core::PlanRequest& request);
gpatlas_core::PlanRequest fromMsg(const gpatlas_msgs::GetNextTouch::Request& msg, const NodePlanDefaults& node);
// The touch's header is the caller's; the atlas travels on its own topic.
gpatlas_msgs::GetNextTouch::Response toMsg(const gpatlas_core::PlanResult& result);
// NO_MODEL, STALE_MODEL, ERROR and an unknown status are kError, and so is a TOUCH whose touch
// is malformed (the message says why).
gpatlas_core::PlanResult fromMsg(const gpatlas_msgs::GetNextTouch::Response& msg);

// The grown atlas as data (the planner's `~atlas_charts`): its charts and the path to the touch
// (chart indices, root first); the header is the caller's.
gpatlas_msgs::Atlas toMsg(const gpatlas_core::Atlas& atlas, const std::vector<int>& path);

// The model's state: name, hyperparameters, frame and observations (not the pseudo-points,
// which the model adds).
gpatlas_msgs::TrainingSet toMsg(const gpatlas_core::SurfaceModel& model);
// Fails (false with a reason) on mismatched array lengths or invalid labels or sources.
bool fromMsg(const gpatlas_msgs::TrainingSet& msg, gpatlas_core::SurfaceModelState* state, std::string* error);
// The camera view a model was fitted from travels with its training set (view_origin,
// view_points as float32: the shadow's bins are millimetres wide). An empty optional clears it.
void setView(const std::optional<gpatlas_core::CameraView>& view, gpatlas_msgs::TrainingSet* msg);
// Empty view_points: no view (nullopt). Fails (false with why) on a non-finite origin or point.
bool viewFromMsg(const gpatlas_msgs::TrainingSet& msg, std::optional<gpatlas_core::CameraView>* view,
                 std::string* error);
// Rebuilds the sender's model: the model named in the message, built with `config`'s settings
// (they must match the sender's for an exact copy), then restored from the message's state.
bool modelFromMsg(const gpatlas_msgs::TrainingSet& msg, gpatlas_core::SurfaceModelConfig config,
                  std::unique_ptr<gpatlas_core::SurfaceModel>* model, std::string* error);

// XYZ of a PointCloud2 (any layout with float32 x, y, z fields). Points with NaN/Inf are
// skipped and counted in *num_invalid. Returns false if the cloud has no x/y/z fields.
bool cloudToPoints(const sensor_msgs::PointCloud2& cloud, std::vector<Eigen::Vector3d>* points,
                   std::size_t* num_invalid, std::string* error);
// XYZ + RGB (blue = low, red = high variance, saturating at variance_max) + a float32
// "variance" field, so that rviz can colour either by RGB or by the variance channel.
sensor_msgs::PointCloud2 pointsToCloud(const std::vector<Eigen::Vector3d>& points,
                                       const std::vector<double>& variances, double variance_max,
                                       const std::string& frame_id);
// The colour map used everywhere for variance: blue (0) -> green -> red (>= variance_max).
void varianceColour(double variance, double variance_max, float* r, float* g, float* b);

}  // namespace gpatlas_conversions
