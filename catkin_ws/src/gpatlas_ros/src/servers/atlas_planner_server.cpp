#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/approach_arm.h"
#include "gpatlas_ros/markers.h"
#include "gpatlas_ros/atlas_planner_server.h"
#include "gpatlas_ros/shared_models.h"

#include <gpatlas_msgs/Atlas.h>
#include <gpatlas_msgs/Touch.h>

#include <gpatlas_core/planning/strategy_library.h>
#include <gpatlas_motion/touch_approach.h>

#include <cmath>
#include <limits>
#include <sstream>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

AtlasPlannerServer::AtlasPlannerServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  RosParamReader reader(pnh_);
  // Strategies and models of your own are loaded with it, before the default is looked up.
  const ServerPreamble preamble = readServerPreamble(reader, "atlas_planner");
  world_frame_ = preamble.frames.world_frame;
  tf_timeout_s_ = preamble.frames.tf_timeout_s;
  const bool use_support_plane = preamble.use_support_plane;
  default_strategy_ = preamble.strategy_choice.name;
  model_config_ = preamble.model;
  default_v_max_ = readVMax(reader);
  default_max_position_sd_m_ = readMaxPositionSd(reader);
  seed_ = preamble.seed;
  readTouchObservations(reader, &touch_config_);
  readApproach(reader, &approach_config_);
  approach_arm_ = loadApproachArm(nh_, approach_config_, &approach_arm_error_);
  if (!approach_arm_error_.empty()) ROS_ERROR_STREAM("atlas_planner: approach/use_arm: " << approach_arm_error_);
  std::string error;
  if (!strategy(default_strategy_, &error, &reader)) reader.invalid("strategy", error);
  // Every other strategy reads its settings now too, so that a bad one is reported at start-up,
  // as the bench does, and not when a request first names it.
  for (const std::string& name : gpatlas_core::strategyNames())
    if (name != default_strategy_ && !strategy(name, &error, &reader)) reader.invalid("strategy " + name, error);
  reader.report("atlas_planner");

  atlas_marker_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("atlas", 1, true);
  atlas_pub_ = pnh_.advertise<gpatlas_msgs::Atlas>("atlas_charts", 1, true);
  touch_pub_ = pnh_.advertise<gpatlas_msgs::Touch>("touch", 1, true);
  next_touch_srv_ = pnh_.advertiseService("next_touch", &AtlasPlannerServer::onNextTouch, this);
  training_sub_ = nh_.subscribe("training_set", 1, &AtlasPlannerServer::onTrainingSet, this);
  if (use_support_plane)
    plane_sub_ = nh_.subscribe("support_plane", 1, &AtlasPlannerServer::onSupportPlane, this);
  const gpatlas_core::StopRule stop_rule{default_v_max_, default_max_position_sd_m_};
  ROS_INFO_STREAM("atlas_planner: strategy " << default_strategy_ << ", stop rule: " << stop_rule.describe() << "; call "
                                             << next_touch_srv_.getService());
}

const gpatlas_core::ExplorationStrategy* AtlasPlannerServer::strategy(const std::string& name, std::string* error,
                                                                      gpatlas_core::ParamReader* settings) {
  auto it = strategies_.find(name);
  if (it != strategies_.end()) return it->second.get();
  try {
    // The strategy reads its settings from the node's parameters (strategy_library.h): the
    // default one with the node's other settings at start-up, another when it is first asked
    // for, its problems logged here.
    std::optional<RosParamReader> own;
    if (!settings) settings = &own.emplace(pnh_);
    auto created = gpatlas_core::makeStrategy(name, *settings, seed_);
    if (own && !own->ok())
      ROS_ERROR_STREAM("atlas_planner: strategy " << name << ": invalid parameters, defaults used instead: " << own->errors());
    const auto* raw = created.get();
    strategies_.emplace(name, std::move(created));
    return raw;
  } catch (const std::exception& e) {
    *error = e.what();
    return nullptr;
  } catch (...) {
    *error = "creating strategy '" + name + "' threw an exception that is not a std::exception";
    return nullptr;
  }
}

void AtlasPlannerServer::onSupportPlane(const gpatlas_msgs::SupportPlane::ConstPtr& msg) {
  receiveSupportPlane(*msg, tf_buffer_, world_frame_, tf_timeout_s_, "atlas_planner", &mutex_, &support_plane_);
}

void AtlasPlannerServer::onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg) {
  // roscpp does not catch exceptions thrown by subscription callbacks: one would end the
  // nodelet manager.
  try {
    if (msg->points.empty()) {  // the GP node was reset
      std::lock_guard<std::mutex> lock(mutex_);
      model_.reset();
      view_.reset();
      model_error_.clear();
      publishNoPlan(msg->header);
      return;
    }
    std::shared_ptr<const gpatlas_core::SurfaceModel> model;
    std::string error;
    const ModelSource source = modelForTrainingSet(training_sub_.getTopic(), *msg, model_config_, &model, &error);
    if (source == ModelSource::kSuperseded) {
      ROS_DEBUG_STREAM("atlas_planner: training set " << msg->sequence << " skipped: a newer one follows");
      return;
    }
    const bool ok = source != ModelSource::kFailed;
    // A malformed view costs atlas_frontier its shadow pokes, not the model.
    std::optional<gpatlas_core::CameraView> view;
    std::string view_error;
    if (ok && !viewFromMsg(*msg, &view, &view_error)) ROS_WARN_STREAM("atlas_planner: view ignored: " << view_error);
    std::lock_guard<std::mutex> lock(mutex_);
    if (!ok) {
      // Planning on the previous model would plan on data the GP no longer has.
      model_.reset();
      view_.reset();
      model_error_ = error;
      ROS_ERROR_STREAM("atlas_planner: " << error);
      return;
    }
    model_ = std::move(model);
    view_ = std::move(view);
    model_stamp_ = msg->header.stamp;
    model_sequence_ = msg->sequence;
    model_error_.clear();
    ROS_DEBUG_STREAM("atlas_planner: " << model_->name() << " model with " << model_->observations().size()
                                       << " observations"
                                       << (source == ModelSource::kShared ? " (the GP nodelet's)" : " (refitted)"));
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("atlas_planner: message ignored: " << e.what());
  }
}

bool AtlasPlannerServer::onNextTouch(gpatlas_msgs::GetNextTouch::Request& req,
                                     gpatlas_msgs::GetNextTouch::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::WallTime start = ros::WallTime::now();
  std_msgs::Header header;
  header.frame_id = world_frame_;
  header.stamp = ros::Time::now();
  res.touch.header = header;
  if (answeredWithoutAPlan(req, res)) return true;
  const std::string name = req.strategy.empty() ? default_strategy_ : req.strategy;
  std::string error;
  const gpatlas_core::ExplorationStrategy* chosen = strategy(name, &error);
  // The exploration loop numbers its plans (use_seed); a call by hand gets the planner's own
  // count of the plans it made, this one included.
  const gpatlas_core::PlanRequest asked = fromMsg(req, {default_v_max_, default_max_position_sd_m_, plan_count_ + 1});
  gpatlas_core::PlanRequest request = asked;
  if (name == "atlas_frontier" && !view_)
    ROS_WARN_THROTTLE(60.0, "atlas_planner: atlas_frontier plans as atlas_poke: the training set carries no camera "
                            "view (the GP nodelet's sensor_frame is empty or had no transform)");
  // What the loop asks, merged as the bench's planner merges it, with the table and the view
  // this nodelet knows.
  gpatlas_core::EvidenceState own;
  own.support_plane = support_plane_;
  if (view_) own.views = {*view_};
  if (!chosen || !gpatlas_core::mergeEvidenceState(own, asked.evidence_state, &request.evidence_state, &error)) {
    res.status = gpatlas_msgs::GetNextTouch::Response::ERROR;
    res.message = error;
    return true;
  }
  std::unique_ptr<gpatlas_motion::TouchMotionPlanner> approach_check;
  std::string reachability_note;
  if (req.reachable_only && !addReachability(&request, &approach_check, &reachability_note, res)) return true;
  ++plan_count_;
  request.touch_observations = touch_config_;
  const gpatlas_core::PlanResult plan = planWith(*chosen, name, request);
  res = toMsg(plan);
  res.touch.header = header;
  res.plan_time_s = (ros::WallTime::now() - start).toSec();
  res.message += reachability_note;
  // A model without its view's free space and shadow is a model the user did not ask for (a
  // cloud in another frame than sensor_frame): the answer says so, not only the GP's log.
  if (!view_)
    res.message += "; the model was fitted without the camera view's free space (the GP nodelet's sensor_frame is "
                   "empty or had no transform to world_frame)";
  if (plan.status == gpatlas_core::PlanStatus::kTouch) touch_pub_.publish(res.touch);
  if (plan.atlas) publishAtlas(*plan.atlas, request.v_max, header);
  ROS_INFO_STREAM("atlas_planner: " << name << " -> " << gpatlas_core::toString(plan.status) << " in "
                                    << res.plan_time_s * 1000.0 << " ms (" << plan.message << ")");
  return true;
}

bool AtlasPlannerServer::answeredWithoutAPlan(const gpatlas_msgs::GetNextTouch::Request& req,
                                              gpatlas_msgs::GetNextTouch::Response& res) const {
  if (!model_) {
    res.status = gpatlas_msgs::GetNextTouch::Response::NO_MODEL;
    res.message = model_error_.empty() ? "no model yet: the GP has not published a training set"
                                       : "no usable model: " + model_error_;
    return true;
  }
  if (!req.model_stamp.isZero() && model_stamp_ < req.model_stamp) {
    res.status = gpatlas_msgs::GetNextTouch::Response::STALE_MODEL;
    std::ostringstream message;
    message << "the planner's model (training set of " << model_stamp_ << ") is older than the one asked for ("
            << req.model_stamp << "): its training set has not been rebuilt yet";
    res.message = message.str();
    return true;
  }
  // Refused here in GetNextTouch.srv's terms: the planner's own check speaks of its StopRule.
  using Request = gpatlas_msgs::GetNextTouch::Request;
  const auto refuse = [&res](const std::string& why) {
    res.status = gpatlas_msgs::GetNextTouch::Response::ERROR;
    res.message = why;
    return true;
  };
  if (req.use_v_max && (!(req.v_max > 0.0) || !std::isfinite(req.v_max)))
    return refuse("v_max must be > 0 and finite with use_v_max (use_v_max false: the parameter exploration/v_max), "
                  "got " + std::to_string(req.v_max));
  if (req.stop_rule == Request::STOP_RULE_POSITION_SD &&
      (!(req.max_position_sd_m > 0.0) || !std::isfinite(req.max_position_sd_m)))
    return refuse("max_position_sd_m must be > 0 and finite metres with stop_rule STOP_RULE_POSITION_SD "
                  "(STOP_RULE_V_MAX_ONLY: the V_max rule alone; STOP_RULE_PARAMETER: the parameter "
                  "exploration/max_position_sd_m), got " + std::to_string(req.max_position_sd_m));
  if (req.stop_rule != Request::STOP_RULE_PARAMETER && req.stop_rule != Request::STOP_RULE_POSITION_SD &&
      req.stop_rule != Request::STOP_RULE_V_MAX_ONLY)
    return refuse("stop_rule must be STOP_RULE_PARAMETER (0), STOP_RULE_POSITION_SD (1) or STOP_RULE_V_MAX_ONLY (2), "
                  "got " + std::to_string(req.stop_rule));
  return false;
}

bool AtlasPlannerServer::addReachability(gpatlas_core::PlanRequest* request,
                                         std::unique_ptr<gpatlas_motion::TouchMotionPlanner>* approach_check,
                                         std::string* note, gpatlas_msgs::GetNextTouch::Response& res) {
  const std::string& topic = training_sub_.getTopic();
  bool offered = false;
  const std::shared_ptr<const octomap::OcTree> map =
      SharedCollisionMaps::find(topic, model_sequence_, model_stamp_, &offered);
  if (SharedCollisionMaps::attended(topic) && !offered) {
    res.status = gpatlas_msgs::GetNextTouch::Response::STALE_MODEL;
    res.message = "the collision map of training set " + std::to_string(model_sequence_) +
                  " is not built yet (reachable_only)";
    return false;
  }
  if (approach_config_.use_arm && !approach_arm_) {
    res.status = gpatlas_msgs::GetNextTouch::Response::ERROR;
    res.message = "reachable_only with approach/use_arm, but there is no arm: " + approach_arm_error_;
    return false;
  }
  if (!map) {
    *note = offered ? "; every candidate taken: the collision map of this model failed"
                    : "; every candidate taken: no collision map in this process";
    return true;
  }
  *approach_check =
      std::make_unique<gpatlas_motion::TouchMotionPlanner>(approach_config_, map, support_plane_, approach_arm_, arm_reach_);
  const gpatlas_motion::TouchMotionPlanner* check = approach_check->get();
  request->reachable = [check](const gpatlas_core::Vector3& point, const gpatlas_core::Vector3& normal) {
    return check->approachDirection(point, normal);
  };
  return true;
}

gpatlas_core::PlanResult AtlasPlannerServer::planWith(const gpatlas_core::ExplorationStrategy& chosen,
                                                      const std::string& name,
                                                      const gpatlas_core::PlanRequest& request) const {
  gpatlas_core::PlanResult plan;
  try {
    plan = chosen.plan(*model_, request);
  } catch (const std::exception& e) {
    // A strategy from a library of the user's own (strategy_libraries) may throw: an answer, not
    // an exception out of the service callback.
    plan.status = gpatlas_core::PlanStatus::kError;
    plan.message = "strategy '" + name + "' failed: " + e.what();
  } catch (...) {
    plan.status = gpatlas_core::PlanStatus::kError;
    plan.message = "strategy '" + name + "' failed with an exception that is not a std::exception";
  }
  if (plan.status == gpatlas_core::PlanStatus::kTouch &&
      (plan.touch.points.empty() || plan.touch.points.size() != plan.touch.normals.size())) {
    plan.status = gpatlas_core::PlanStatus::kError;
    plan.message = "strategy '" + name + "' returned a touch without matching points and normals";
  }
  return plan;
}

void AtlasPlannerServer::publishAtlas(const gpatlas_core::AtlasPlanResult& planned, double v_max,
                                      const std_msgs::Header& header) {
  atlas_marker_pub_.publish(atlasMarkers(planned.atlas, planned.path, v_max, world_frame_));
  gpatlas_msgs::Atlas atlas = toMsg(planned.atlas, planned.path);
  atlas.header = header;
  atlas_pub_.publish(atlas);
}

void AtlasPlannerServer::publishNoPlan(const std_msgs::Header& header) {
  std_msgs::Header stamped = header;
  stamped.frame_id = world_frame_;
  visualization_msgs::MarkerArray clear = deleteAllMarkers(world_frame_);
  clear.markers.front().header = stamped;
  atlas_marker_pub_.publish(clear);
  gpatlas_msgs::Atlas no_atlas;
  no_atlas.header = stamped;
  atlas_pub_.publish(no_atlas);
  gpatlas_msgs::Touch no_touch;
  no_touch.header = stamped;
  touch_pub_.publish(no_touch);
}

}  // namespace gpatlas_ros
