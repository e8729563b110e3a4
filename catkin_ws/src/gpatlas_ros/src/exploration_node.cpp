// Tactile exploration, paper Algorithm 2, over ROS services: capture a view, wait for the GP,
// then repeat next touch -> probe -> add observations until the planner reports convergence,
// max_actions, or max_consecutive_failures failed touches. The probe service is probe_sim's in
// simulation; a real robot driver implements the same gpatlas_msgs/Probe service.

#include <gpatlas_core/common/background_work.h>
#include <gpatlas_core/exploration/exploration_report.h>
#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_geometry/shape_metrics.h>
#include <gpatlas_geometry/model_measurement.h>
#include <gpatlas_geometry/surface_mesher.h>
#include <gpatlas_core/common/triangle_mesh.h>
#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/Capture.h>
#include <gpatlas_msgs/CollisionMapStatus.h>
#include <gpatlas_msgs/GetMesh.h>
#include <gpatlas_msgs/GetNextTouch.h>
#include <gpatlas_msgs/PlanApproach.h>
#include <gpatlas_msgs/Probe.h>
#include <gpatlas_msgs/SaveMap.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <gpatlas_conversions/conversions.h>
#include <gpatlas_ros/ros_params.h>

#include <ros/package.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

namespace gpatlas_ros {

using namespace gpatlas_conversions;
namespace {

namespace fs = std::filesystem;

class ExplorationNode {
 public:
  ExplorationNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
    RosParamReader r(pnh_);
    gpatlas_core::PipelineFrames frames;
    readFrames(r, &frames);
    world_frame_ = frames.world_frame;
    readExplorer(r, &loop_);
    gpatlas_core::StrategyChoice choice;
    readStrategyChoice(r, &choice);
    strategy_ = choice.name;
    readExplorationNode(r, &node_config_);
    results_dir_ = node_config_.results_dir;
    readSurfaceModel(r, &model_config_);
    loadPluginLibraries(choice.libraries, r, "exploration");
    readMesher(r, &mesher_config_);
    readApproach(r, &approach_config_);
    if (!r.ok()) throw std::runtime_error("invalid parameters: " + r.errors());
    r.report("exploration");
    if (results_dir_.empty()) {
      std::time_t now = std::time(nullptr);
      char stamp[32];
      std::strftime(stamp, sizeof(stamp), "%Y%m%d_%H%M%S", std::localtime(&now));
      results_dir_ = (fs::current_path() / "results" / (std::string("exploration_") + stamp)).string();
    }
    cloud_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("camera_points", 1, true);
    training_sub_ = nh_.subscribe("training_set", 1, &ExplorationNode::onTrainingSet, this);
    if (approach_config_.enabled)
      map_status_sub_ = nh_.subscribe("collision_map_status", 1, &ExplorationNode::onMapStatus, this);
  }

  ~ExplorationNode() { stopMeasurements(); }

  int run() {
    ROS_INFO_STREAM("exploration: strategy " << strategy_ << ", V_max " << loop_.v_max << ", at most "
                                             << loop_.max_actions << " actions; results in " << results_dir_);
    std::error_code ec;
    fs::create_directories(results_dir_, ec);
    if (ec) {
      ROS_ERROR_STREAM("exploration: cannot create " << results_dir_ << ": " << ec.message());
      return 2;
    }
    loadGroundTruth();
    if (node_config_.capture && !captureView()) return 1;
    if (!waitForModel()) return 1;
    initial_.n_train = latestTraining()->points.size();
    if (const auto model = measure(*latestTraining(), initial_)) {
      // Said once here, and in every plan's answer.
      if (const std::string note = gpatlas_core::vMaxNoiseNote(*model, loop_.v_max); !note.empty())
        ROS_WARN_STREAM("exploration: " << note);
    }
    ROS_INFO_STREAM("exploration: initial model: max surface variance " << initial_.sampled_max_variance << ", RMSE "
                                                                         << 1000 * initial_.rmse_pred_to_gt_m << "/"
                                                                         << 1000 * initial_.rmse_gt_to_pred_m << " mm");
    // The core's Algorithm 2 over the pipeline's services: the bench runs the same loop.
    ServicePlanner planner(*this);
    ServiceProber prober(*this);
    ServiceUpdater updater(*this);
    ServiceApproacher approacher(*this);
    const gpatlas_core::Explorer explorer(loop_);
    measurer_ = std::thread(&ExplorationNode::measureLoop, this);
    gpatlas_core::ExplorationResult result =
        explorer.run(planner, prober, updater, [this](gpatlas_core::ExplorationRecord& record) {
          ROS_INFO_STREAM("exploration: " << gpatlas_core::describeAction(record));
          if (node_config_.metrics_every > 0 && (record.index + 1) % node_config_.metrics_every == 0)
            requestMeasurement(record.index, latestTraining());
        }, approach_config_.enabled ? &approacher : nullptr);
    mergeMeasurements(&result);
    return finish(result);
  }

  // Joins the call workers; call after ros::shutdown(), which makes any blocked call return.
  void joinWorkers() {
    for (auto& worker : workers_)
      if (worker.joinable()) worker.join();
    workers_.clear();
    stopMeasurements();
  }

 private:
  // The loop's services over persistent connections: a call per step, several steps a second,
  // and a new connection for each would ask the master for the service every time (and a busy
  // master refuses now and then). A connection that failed or timed out is opened again at the
  // next call.
  template <typename Srv>
  bool callService(const std::string& name, Srv& srv) {
    const std::string resolved = nh_.resolveName(name);
    ros::ServiceClient& client = clients_[resolved];
    if (!client || !client.isValid()) {
      if (!ros::service::waitForService(resolved, ros::Duration(node_config_.service_timeout_s))) {
        ROS_ERROR_STREAM("exploration: service " << resolved << " not available after " << node_config_.service_timeout_s
                                                 << " s");
        return false;
      }
      client = nh_.serviceClient<Srv>(resolved, true);
    }
    if (timedCall(resolved, srv, -1.0, &client)) return true;
    clients_.erase(resolved);
    return false;
  }

  // Calls the service on `client` (persistent), or on a connection of its own without one.
  template <typename Srv>
  bool timedCall(const std::string& resolved, Srv& srv, double timeout_s = -1.0, const ros::ServiceClient* client = nullptr) {
    if (timeout_s < 0.0) timeout_s = node_config_.call_timeout_s;
    // ros::service::call has no timeout: a server that never answers (an arm stuck mid-motion,
    // a hung driver) would freeze the exploration for good. The call runs on a worker thread
    // with its own copy of the request; past the timeout we give up on it and report. Workers
    // are joined at exit, after ros::shutdown() has released any call still blocked.
    struct Pending {
      std::mutex mutex;
      std::condition_variable answered;
      bool done{false};
      bool ok{false};
      Srv srv;
    };
    auto pending = std::make_shared<Pending>();
    pending->srv = srv;
    // A copy of the handle: a call given up on keeps its connection, the next gets a new one.
    ros::ServiceClient connection = client ? *client : ros::ServiceClient();
    try {
      workers_.emplace_back([pending, resolved, connection]() mutable {
        const bool ok = connection ? connection.call(pending->srv) : ros::service::call(resolved, pending->srv);
        std::lock_guard<std::mutex> lock(pending->mutex);
        pending->ok = ok;
        pending->done = true;
        pending->answered.notify_all();
      });
    } catch (const std::system_error& e) {
      ROS_ERROR_STREAM("exploration: cannot call " << resolved << ": " << e.what());
      return false;
    }
    std::unique_lock<std::mutex> lock(pending->mutex);
    if (!pending->answered.wait_for(lock, std::chrono::duration<double>(timeout_s),
                                    [&pending]() { return pending->done; })) {
      ROS_ERROR_STREAM("exploration: " << resolved << " did not answer within " << timeout_s << " s");
      return false;
    }
    lock.unlock();
    workers_.back().join();  // finished: reap it now (the last started is this call's)
    workers_.pop_back();
    if (!pending->ok) {
      ROS_ERROR_STREAM("exploration: call to " << resolved << " failed");
      return false;
    }
    srv = pending->srv;
    return true;
  }

  // A touch for the services: in the world frame, stamped now, with the arm's trajectories
  // (named as plan_approach named them) when it has them.
  gpatlas_msgs::Touch touchMsg(const gpatlas_core::Touch& touch) const {
    gpatlas_msgs::Touch msg = toMsg(touch, arm_joint_names_, approach_config_.arm_joint_speed_rad_s);
    msg.header.frame_id = world_frame_;
    msg.header.stamp = ros::Time::now();
    return msg;
  }

  void onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    training_ = msg;
    training_received_ = ros::WallTime::now();
  }

  void onMapStatus(const gpatlas_msgs::CollisionMapStatus::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    map_status_ = msg;
  }

  gpatlas_msgs::TrainingSet::ConstPtr latestTraining() {
    std::lock_guard<std::mutex> lock(mutex_);
    return training_;
  }

  void loadGroundTruth() {
    const std::string name = nh_.resolveName("ground_truth");
    if (!ros::service::waitForService(name, ros::Duration(2.0))) {
      ROS_INFO_STREAM("exploration: no " << name << " service: no shape metrics (real robot)");
      return;
    }
    gpatlas_msgs::GetMesh srv;
    if (!timedCall(name, srv, std::min(node_config_.call_timeout_s, kAuxiliaryCallTimeoutS)) || !srv.response.success) {
      ROS_WARN_STREAM("exploration: ground truth unavailable: " << srv.response.message);
      return;
    }
    gpatlas_core::TriangleMesh mesh;
    for (const auto& v : srv.response.mesh.vertices) mesh.vertices.push_back(fromMsg(v));
    for (const auto& t : srv.response.mesh.triangles)
      mesh.triangles.emplace_back(static_cast<int>(t.vertex_indices[0]), static_cast<int>(t.vertex_indices[1]),
                                  static_cast<int>(t.vertex_indices[2]));
    ground_truth_ = std::move(mesh);
    ROS_INFO_STREAM("exploration: ground truth with " << ground_truth_.triangles.size() << " triangles");
  }

  bool captureView() {
    gpatlas_msgs::Capture capture;
    if (!callService("capture", capture)) return false;
    if (!capture.response.success) {
      ROS_ERROR_STREAM("exploration: capture failed: " << capture.response.message);
      return false;
    }
    captured_cloud_ = capture.response.cloud;
    cloud_pub_.publish(*captured_cloud_);
    ROS_INFO_STREAM("exploration: captured " << capture.response.cloud.width * capture.response.cloud.height
                                             << " points in " << capture.response.cloud.header.frame_id);
    return true;
  }

  bool waitForModel() {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(node_config_.service_timeout_s);
    ros::WallTime last_published = ros::WallTime::now();
    while (ros::ok() && ros::WallTime::now() < deadline) {
      if (latestTraining()) {
        ROS_INFO_STREAM("exploration: model ready with " << latestTraining()->points.size() << " observations");
        return true;
      }
      const double silent_s = (ros::WallTime::now() - last_published).toSec();
      if (captured_cloud_ && node_config_.republish_view_after_s > 0.0 && silent_s > node_config_.republish_view_after_s) {
        ROS_WARN_STREAM("exploration: no model " << silent_s << " s after the view was published; publishing it again");
        cloud_pub_.publish(*captured_cloud_);
        last_published = ros::WallTime::now();
      }
      ros::WallDuration(0.1).sleep();
    }
    ROS_ERROR_STREAM("exploration: no model on " << training_sub_.getTopic() << " after " << node_config_.service_timeout_s
                                                 << " s (is the segmentation finding the object?)");
    return false;
  }

  void waitForTrainingSetNewerThan(const ros::WallTime& time) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(5.0);
    while (ros::ok() && ros::WallTime::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (training_received_ >= time) return;
      }
      ros::WallDuration(0.01).sleep();
    }
  }

  // Rebuilds the GP from a training set and measures it as the bench does: the largest variance
  // of a fixed surface sample and, with a ground truth, the shape error.
  // Returns the rebuilt model (null when the message gives none).
  std::unique_ptr<gpatlas_core::SurfaceModel> measure(const gpatlas_msgs::TrainingSet& training,
                                                      gpatlas_core::ExplorationRecord& record) {
    std::unique_ptr<gpatlas_core::SurfaceModel> model_ptr;
    std::string error;
    if (!modelFromMsg(training, model_config_, &model_ptr, &error)) return nullptr;
    measureModel(*model_ptr, record);
    return model_ptr;
  }

  void measureModel(const gpatlas_core::SurfaceModel& model, gpatlas_core::ExplorationRecord& record) {
    const gpatlas_geometry::ModelMeasurement measured =
        gpatlas_geometry::measureModel(model, ground_truth_, mesher_config_);
    record.sampled_max_variance = measured.sampled_max_variance;
    if (!measured.shape.ok) return;
    record.rmse_pred_to_gt_m = measured.shape.rmse_predicted_to_truth;
    record.rmse_gt_to_pred_m = measured.shape.rmse_truth_to_predicted;
  }

  // The models after the actions are measured off the loop's thread: a measurement refits the
  // model and meshes it, which takes longer than an action, and the robot should not wait for
  // a number only the report needs. The newest request wins; one still waiting when a newer
  // one comes is skipped and counted.
  void requestMeasurement(int action_index, gpatlas_msgs::TrainingSet::ConstPtr training) {
    if (!training) return;
    {
      std::lock_guard<std::mutex> lock(measure_mutex_);
      if (measure_pending_) ++measurements_skipped_;
      measure_pending_ = std::make_pair(action_index, std::move(training));
    }
    measure_wake_.notify_all();
  }

  void measureLoop() {
    // Measurements are for the report: the pipeline's nodelets get the cores first.
    if (!gpatlas_core::lowerCurrentThreadPriority())
      ROS_WARN("exploration: cannot lower the measurements' priority; they compete with the pipeline");
    for (;;) {
      std::pair<int, gpatlas_msgs::TrainingSet::ConstPtr> job;
      {
        std::unique_lock<std::mutex> lock(measure_mutex_);
        measure_wake_.wait(lock, [this] { return measure_stopping_ || measure_pending_; });
        if (!measure_pending_) return;  // stopping, nothing left
        job = std::move(*measure_pending_);
        measure_pending_.reset();
        measure_busy_ = true;
      }
      gpatlas_core::ExplorationRecord measured;
      const ros::WallTime started = ros::WallTime::now();
      try {
        gpatlas_core::runOnThisThreadOnly([&] { measure(*job.second, measured); });
      } catch (const std::exception& e) {
        ROS_WARN_STREAM("exploration: the model after action " << job.first + 1 << " not measured: " << e.what());
      }
      if (std::isfinite(measured.rmse_pred_to_gt_m))
        ROS_INFO_STREAM(std::setprecision(3) << "exploration: model after action " << job.first + 1 << ": RMSE "
                                             << 1000 * measured.rmse_pred_to_gt_m << "/"
                                             << 1000 * measured.rmse_gt_to_pred_m << " mm, sampled max variance "
                                             << measured.sampled_max_variance << " (measured in "
                                             << (ros::WallTime::now() - started).toSec() << " s)");
      {
        std::lock_guard<std::mutex> lock(measure_mutex_);
        measurements_[job.first] = measured;
        measure_busy_ = false;
      }
      measure_wake_.notify_all();
    }
  }

  // Waits for the measurement in progress and the one waiting, then copies every measurement
  // into the action's record.
  void mergeMeasurements(gpatlas_core::ExplorationResult* result) {
    std::map<int, gpatlas_core::ExplorationRecord> measured;
    int skipped = 0;
    {
      std::unique_lock<std::mutex> lock(measure_mutex_);
      if (measure_busy_ || measure_pending_) ROS_INFO("exploration: waiting for the last model measurement");
      measure_wake_.wait(lock, [this] { return !measure_busy_ && !measure_pending_; });
      measured = measurements_;
      skipped = measurements_skipped_;
    }
    for (auto& record : result->records) {
      const auto it = measured.find(record.index);
      if (it == measured.end()) continue;
      record.sampled_max_variance = it->second.sampled_max_variance;
      record.rmse_pred_to_gt_m = it->second.rmse_pred_to_gt_m;
      record.rmse_gt_to_pred_m = it->second.rmse_gt_to_pred_m;
    }
    if (skipped > 0)
      ROS_INFO_STREAM("exploration: " << measured.size() << " models measured after actions, " << skipped
                                      << " skipped (metrics_every " << node_config_.metrics_every
                                      << ": a measurement took longer than the actions in between)");
  }

  void stopMeasurements() {
    {
      std::lock_guard<std::mutex> lock(measure_mutex_);
      measure_stopping_ = true;
      measure_pending_.reset();
    }
    measure_wake_.notify_all();
    if (measurer_.joinable()) measurer_.join();
  }

  int finish(const gpatlas_core::ExplorationResult& result) {
    const fs::path dir(results_dir_);
    gpatlas_core::ExplorationReport report;
    report.strategy = strategy_;
    report.model = model_config_.type;
    report.loop = loop_;
    report.initial = initial_;
    report.result = result;
    bool has_surface = false;
    std::string surface_message = "no model";
    if (const auto training = latestTraining()) {
      std::unique_ptr<gpatlas_core::SurfaceModel> model;
      if (modelFromMsg(*training, model_config_, &model, &surface_message)) {
        const auto surface = gpatlas_geometry::SurfaceMesher(mesher_config_).mesh(*model);
        surface_message = surface.message;
        has_surface = surface.ok;
        if (surface.ok) {
          const std::string write_error = gpatlas_core::writePly(surface.mesh, (dir / "surface.ply").string());
          if (!write_error.empty()) ROS_WARN_STREAM("exploration: " << write_error);
          if (!ground_truth_.empty()) {
            const auto metrics = gpatlas_geometry::ShapeMetrics().compare(surface.mesh, ground_truth_);
            if (metrics.ok)
              report.final_shape = {true, metrics.rmse_predicted_to_truth, metrics.rmse_truth_to_predicted,
                                    metrics.chamfer_l1, metrics.f_score};
          }
        }
      }
    }
    report.status = gpatlas_core::runStatus(result, has_surface, surface_message);
    gpatlas_msgs::SaveMap save;
    save.request.path = (dir / "collision_map.bt").string();
    const std::string save_name = nh_.resolveName("save_map");
    if (ros::service::waitForService(save_name, ros::Duration(2.0)) &&
        timedCall(save_name, save, std::min(node_config_.call_timeout_s, kAuxiliaryCallTimeoutS)) &&
        !save.response.success)
      ROS_WARN_STREAM("exploration: " << save.response.message);

    std::ofstream json(dir / "report.json");
    json << gpatlas_core::toJson(report);
    json.close();

    const std::string script = ros::package::getPath("gpatlas_ros") + "/scripts/plot_exploration.py";
    const std::string command = "/usr/bin/python3 \"" + script + "\" \"" + results_dir_ + "\" >/dev/null";
    if (std::system(command.c_str()) != 0) ROS_WARN_STREAM("exploration: plotting failed: " << command);

    std::ostringstream summary;
    summary << "exploration finished: " << report.status << " after " << result.actions << " actions ("
            << result.contacts << " contacts)";
    if (report.final_shape.measured)
      summary << std::setprecision(3) << "; shape RMSE " << 1000 * report.final_shape.rmse_pred_to_gt_m
              << " mm (predicted->truth), " << 1000 * report.final_shape.rmse_gt_to_pred_m
              << " mm (truth->predicted), F-score@5mm " << report.final_shape.fscore_5mm;
    summary << "; results in " << results_dir_;
    if (report.status.rfind("error", 0) == 0) {
      ROS_ERROR_STREAM(summary.str());
      return 1;
    }
    ROS_INFO_STREAM(summary.str());
    return 0;
  }

  // Algorithm 2's three steps as the pipeline's services (gpatlas_core::Explorer runs the loop).
  // A service that is missing or does not answer ends the run ("error: ...").
  class ServicePlanner : public gpatlas_core::TouchPlanner {
   public:
    explicit ServicePlanner(ExplorationNode& node) : node_(node) {}
    gpatlas_core::PlanResult plan(const gpatlas_core::PlanRequest& request) override {
      gpatlas_msgs::GetNextTouch srv;
      srv.request.v_max = request.v_max;
      srv.request.strategy = node_.strategy_;
      srv.request.seed = request.seed;
      // The planner's side of the loop's reachability test (PlanRequest::reachable).
      srv.request.reachable_only = node_.approach_config_.enabled;
      for (const auto& p : request.evidence.attempted_targets) srv.request.attempted_targets.push_back(toPointMsg(p));
      srv.request.attempted_target_errors_m = request.evidence.attempted_target_errors_m;
      srv.request.footprint_radius_m = request.footprint_radius_m;
      // Plan on the model that holds the last update: the planner rebuilds its replica from the
      // training set this node has seen, which can take it longer than this node took to see it.
      if (const auto training = node_.latestTraining()) srv.request.model_stamp = training->header.stamp;
      const ros::WallTime asked = ros::WallTime::now();
      while (true) {
        if (!node_.callService("next_touch", srv)) throw std::runtime_error("next_touch did not answer");
        if (srv.response.status != gpatlas_msgs::GetNextTouch::Response::STALE_MODEL) break;
        if ((ros::WallTime::now() - asked).toSec() > node_.node_config_.call_timeout_s)
          throw std::runtime_error("next_touch: " + srv.response.message);
        ros::WallDuration(0.02).sleep();
      }
      gpatlas_core::PlanResult plan;
      plan.message = srv.response.message;
      plan.max_evaluated_variance = srv.response.max_evaluated_variance;
      plan.elapsed_s = srv.response.plan_time_s;
      plan.unreachable_candidates = static_cast<int>(srv.response.unreachable_candidates);
      switch (srv.response.status) {
        case gpatlas_msgs::GetNextTouch::Response::TOUCH: {
          plan.status = gpatlas_core::PlanStatus::kTouch;
          std::string malformed;
          if (!fromMsg(srv.response.touch, &plan.touch, &malformed)) {
            plan.status = gpatlas_core::PlanStatus::kError;
            plan.message = "malformed touch: " + malformed;
          }
          break;
        }
        case gpatlas_msgs::GetNextTouch::Response::CONVERGED:
          plan.status = gpatlas_core::PlanStatus::kConverged;
          break;
        default:
          plan.status = gpatlas_core::PlanStatus::kError;
      }
      return plan;
    }
    std::size_t modelSize() const override {
      const auto training = node_.latestTraining();
      return training ? training->points.size() : 0;
    }

   private:
    ExplorationNode& node_;
  };

  class ServiceProber : public gpatlas_core::Prober {
   public:
    explicit ServiceProber(ExplorationNode& node) : node_(node) {}
    gpatlas_core::ProbeResult probe(const gpatlas_core::Touch& touch) override {
      gpatlas_msgs::Probe srv;
      srv.request.touch = node_.touchMsg(touch);
      if (!node_.callService("probe", srv)) throw std::runtime_error("probe did not answer");
      gpatlas_core::ProbeResult result;
      std::string error;
      if (!fromMsg(srv.response.observations, &result, &error)) {
        result = gpatlas_core::ProbeResult();
        result.reason = "malformed observations: " + error;
        return result;
      }
      result.success = srv.response.success;
      result.reason = srv.response.reason;
      result.approach_collisions = srv.response.approach_collisions;
      result.retreat_collisions = srv.response.retreat_collisions;
      node_.observations_header_ = srv.response.observations.header;
      return result;
    }

   private:
    ExplorationNode& node_;
  };

  class ServiceUpdater : public gpatlas_core::ModelUpdater {
   public:
    explicit ServiceUpdater(ExplorationNode& node) : node_(node) {}
    gpatlas_core::TouchUpdate update(const gpatlas_core::ProbeResult& probed) override {
      gpatlas_msgs::AddObservations srv;
      srv.request.observations = toMsg(probed);
      srv.request.observations.header = node_.observations_header_;
      const ros::WallTime started = ros::WallTime::now();
      if (!node_.callService("add_observations", srv)) throw std::runtime_error("add_observations did not answer");
      gpatlas_core::TouchUpdate update;
      update.ok = srv.response.success;
      update.message = srv.response.message;
      update.contacts_added = static_cast<int>(srv.response.num_contacts_added);
      update.free_points_added = static_cast<int>(srv.response.num_added) - update.contacts_added;
      update.budget_full = srv.response.observation_budget_full;
      if (update.ok) node_.waitForTrainingSetNewerThan(started);
      return update;
    }

   private:
    ExplorationNode& node_;
  };

  // Approach planning on the collision map nodelet (plan_approach), on the map of the newest
  // training set this node has seen: after a touch the map is rebuilt from the updated model,
  // and the approach waits for it.
  class ServiceApproacher : public gpatlas_core::TouchApproacher {
   public:
    explicit ServiceApproacher(ExplorationNode& node) : node_(node) {}
    // Waits for the collision map of the newest training set (or the news that it failed), so
    // that neither the planner's reachability test nor plan_approach waits for it.
    void prepare() override {
      const auto training = node_.latestTraining();
      if (!training) return;
      const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(node_.node_config_.call_timeout_s);
      while (ros::ok() && ros::WallTime::now() < deadline) {
        {
          std::lock_guard<std::mutex> lock(node_.mutex_);
          const auto& status = node_.map_status_;
          // Built, or its build failed: STALE (an older map is left) or NONE (none is).
          const bool failed = status && status->latest_training_sequence >= training->sequence &&
                              (status->state == gpatlas_msgs::CollisionMapStatus::STALE ||
                               status->state == gpatlas_msgs::CollisionMapStatus::NONE);
          if (status && (status->map_training_sequence >= training->sequence || failed)) return;
        }
        ros::WallDuration(0.01).sleep();
      }
      throw std::runtime_error("no collision map of training set " + std::to_string(training->sequence) + " within " +
                               std::to_string(node_.node_config_.call_timeout_s) + " s (collision_map_status)");
    }
    gpatlas_core::ApproachResult plan(const gpatlas_core::Touch& touch) override {
      gpatlas_msgs::PlanApproach srv;
      srv.request.touch = node_.touchMsg(touch);
      srv.request.start = toPointMsg(node_.approach_config_.rest_tip_position_m);
      // prepare() waited for the map of the newest training set, or for the news that it failed:
      // then the answer comes from the older map and says so (map_stale).
      if (!node_.callService("plan_approach", srv)) throw std::runtime_error("plan_approach did not answer");
      gpatlas_core::ApproachResult result;
      result.ok = srv.response.success;
      result.message = srv.response.message;
      if (srv.response.map_stale) result.message += " (on the map of an older model: its rebuild failed)";
      result.planning_ms = 1000.0 * srv.response.planning_time_s;
      for (const auto& p : srv.response.approach) result.approach_path.push_back(fromMsg(p));
      for (const auto& p : srv.response.retreat) result.retreat_path.push_back(fromMsg(p));
      const auto& approach = srv.response.approach_trajectory;
      if (result.ok && !approach.points.empty()) {
        node_.arm_joint_names_ = approach.joint_names;
        std::string why;
        if (!fromJointTrajectoryMsg(approach, approach.joint_names, &result.approach_joints, &why) ||
            !fromJointTrajectoryMsg(srv.response.retreat_trajectory, approach.joint_names, &result.retreat_joints, &why))
          throw std::runtime_error("plan_approach answered a malformed joint trajectory: " + why);
      }
      return result;
    }

   private:
    ExplorationNode& node_;
  };

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_, strategy_, results_dir_;
  gpatlas_motion::ApproachConfig approach_config_;
  std::vector<std::string> arm_joint_names_;  // of plan_approach's trajectories, when planned for the arm
  gpatlas_core::Explorer::Config loop_;
  std_msgs::Header observations_header_;  // the frame of the last probe's observations
  // The ground truth and the map's saving: optional, at the start and the end; not worth a wait.
  static constexpr double kAuxiliaryCallTimeoutS = 30.0;
  std::vector<std::thread> workers_;  // service calls in flight or abandoned (see timedCall)
  std::map<std::string, ros::ServiceClient> clients_;  // callService's connections, by resolved name
  ExplorationNodeConfig node_config_;
  gpatlas_core::SurfaceModelConfig model_config_;
  gpatlas_geometry::SurfaceMesher::Config mesher_config_;
  gpatlas_core::TriangleMesh ground_truth_;
  gpatlas_core::ExplorationRecord initial_;

  std::thread measurer_;  // measureLoop
  std::mutex measure_mutex_;
  std::condition_variable measure_wake_;
  std::optional<std::pair<int, gpatlas_msgs::TrainingSet::ConstPtr>> measure_pending_;
  bool measure_busy_{false};
  bool measure_stopping_{false};
  std::map<int, gpatlas_core::ExplorationRecord> measurements_;  // by action index
  int measurements_skipped_{0};

  std::mutex mutex_;
  gpatlas_msgs::TrainingSet::ConstPtr training_;
  ros::WallTime training_received_;
  gpatlas_msgs::CollisionMapStatus::ConstPtr map_status_;
  ros::Subscriber map_status_sub_;
  ros::Publisher cloud_pub_;
  std::optional<sensor_msgs::PointCloud2> captured_cloud_;  // the view captured, published again if no model comes
  ros::Subscriber training_sub_;
};

}  // namespace
}  // namespace gpatlas_ros

int main(int argc, char** argv) {
  ros::init(argc, argv, "exploration");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  try {
    gpatlas_ros::ExplorationNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    const int code = node.run();
    ros::shutdown();
    node.joinWorkers();
    return code;
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("exploration: " << e.what());
    return 2;
  }
}
