// Tactile exploration, paper Algorithm 2, over ROS services: capture a view, wait for the GP,
// then repeat next touch -> probe -> add observations until the planner reports convergence,
// max_actions, or max_consecutive_failures failed touches. The probe service is probe_sim's in
// simulation; a real robot driver implements the same gpatlas_msgs/Probe service.

#include <gpatlas_core/shape_metrics.h>
#include <gpatlas_core/surface_mesher.h>
#include <gpatlas_core/triangle_mesh.h>
#include <gpatlas_msgs/AddObservations.h>
#include <gpatlas_msgs/Capture.h>
#include <gpatlas_msgs/GetMesh.h>
#include <gpatlas_msgs/GetNextTouch.h>
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
#include <memory>
#include <mutex>
#include <sstream>
#include <system_error>
#include <thread>
#include <vector>

namespace gpatlas_ros {
namespace {

namespace fs = std::filesystem;

struct ActionRecord {
  int index{0};
  std::string plan_status;
  bool probe_success{false};
  std::string probe_reason;
  int contacts{0};
  int free_points{0};
  int contacts_total{0};
  double max_surface_variance{std::nan("")};
  double plan_ms{0.0};
  double probe_ms{0.0};
  double update_ms{0.0};
  std::size_t n_train{0};
  double rmse_pred_to_gt_m{std::nan("")};
  double rmse_gt_to_pred_m{std::nan("")};
  // Largest variance over the predicted mesh's vertices after the action (independent of the
  // planner's own estimate, which depends on the tree it grew).
  double mesh_max_variance{std::nan("")};
};

std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s << std::setprecision(8) << v;
  return s.str();
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

class ExplorationNode {
 public:
  ExplorationNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
    ParamReader r(pnh_);
    world_frame_ = r.text("world_frame", "world");
    v_max_ = r.number("v_max", 0.1, 1e-12, 1e12);
    strategy_ = r.text("strategy", "atlas_poke");
    max_actions_ = r.integer("max_actions", 60, 0, 100000);
    max_failures_ = r.integer("max_consecutive_failures", 5, 1, 100000);
    service_timeout_s_ = r.number("service_timeout_s", 60.0, 0.1, 3600.0);
    call_timeout_s_ = r.number("call_timeout_s", 600.0, 0.1, 86400.0);
    capture_ = r.flag("capture", true);
    metrics_every_ = r.integer("metrics_every", 1, 0, 100000);
    results_dir_ = r.text("results_dir", "");
    readGpis(r, &gpis_config_);
    readMesher(r, &mesher_config_);
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
  }

  int run() {
    ROS_INFO_STREAM("exploration: strategy " << strategy_ << ", V_max " << v_max_ << ", at most " << max_actions_
                                             << " actions; results in " << results_dir_);
    std::error_code ec;
    fs::create_directories(results_dir_, ec);
    if (ec) {
      ROS_ERROR_STREAM("exploration: cannot create " << results_dir_ << ": " << ec.message());
      return 2;
    }
    loadGroundTruth();
    if (capture_ && !captureView()) return 1;
    if (!waitForModel()) return 1;
    measure(initial_, 0);
    ROS_INFO_STREAM("exploration: initial model: max surface variance " << initial_.mesh_max_variance
                                                                         << ", RMSE " << 1000 * initial_.rmse_pred_to_gt_m
                                                                         << "/" << 1000 * initial_.rmse_gt_to_pred_m << " mm");

    int failures_in_row = 0;
    int contacts_total = 0;
    // As the Explorer does: where touches aimed counts as evidence (GetNextTouch).
    std::vector<geometry_msgs::Point> attempted_targets;
    for (int action = 1; ros::ok(); ++action) {
      ActionRecord record;
      record.index = action;
      gpatlas_msgs::GetNextTouch plan;
      plan.request.v_max = v_max_;
      plan.request.strategy = strategy_;
      plan.request.attempted_targets = attempted_targets;
      if (!callService("next_touch", plan)) return finish("error: next_touch unavailable", 1);
      record.plan_ms = plan.response.plan_time_s * 1000.0;
      record.max_surface_variance = plan.response.max_surface_variance;
      const auto status = plan.response.status;
      if (status == gpatlas_msgs::GetNextTouch::Response::CONVERGED) {
        final_max_variance_ = plan.response.max_surface_variance;
        return finish("converged", 0);
      }
      if (status != gpatlas_msgs::GetNextTouch::Response::TOUCH)
        return finish("planner: " + plan.response.message, 1);
      if (action > max_actions_) return finish("max_actions", 0);

      gpatlas_msgs::Probe probe;
      probe.request.touch = plan.response.touch;
      const ros::WallTime probe_start = ros::WallTime::now();
      if (!callService("probe", probe)) return finish("error: probe unavailable", 1);
      gpatlas_core::Touch aimed;
      std::string malformed;  // the planner's touches are well formed; a malformed one aimed nowhere
      if (fromMsg(plan.response.touch, &aimed, &malformed))
        for (const auto& p : gpatlas_core::aimedPoints(aimed)) attempted_targets.push_back(toPointMsg(p));
      record.probe_ms = (ros::WallTime::now() - probe_start).toSec() * 1000.0;
      record.probe_success = probe.response.success;
      record.probe_reason = probe.response.reason;
      record.contacts = static_cast<int>(probe.response.observations.contacts.size());
      record.free_points = static_cast<int>(probe.response.observations.free_space.size());

      bool model_updated = false;
      if (record.contacts + record.free_points > 0) {
        gpatlas_msgs::AddObservations add;
        add.request.observations = probe.response.observations;
        const ros::WallTime update_start = ros::WallTime::now();
        if (!callService("add_observations", add)) return finish("error: add_observations unavailable", 1);
        record.update_ms = (ros::WallTime::now() - update_start).toSec() * 1000.0;
        model_updated = add.response.success;
        if (!add.response.success) ROS_WARN_STREAM("exploration: the model refused the touch: " << add.response.message);
        if (model_updated) waitForTrainingSetNewerThan(update_start);
      }
      contacts_total += record.contacts;
      record.contacts_total = contacts_total;
      failures_in_row = (probe.response.success && model_updated) ? 0 : failures_in_row + 1;
      measure(record, action);
      records_.push_back(record);
      std::ostringstream line;
      line << "action " << std::setw(3) << action << ": " << (record.probe_success ? "contact   " : "no contact")
           << " +" << record.contacts << " contacts (" << contacts_total << "), max surface variance "
           << std::setprecision(3) << record.max_surface_variance << ", plan " << std::fixed << std::setprecision(0)
           << record.plan_ms << " ms, update " << record.update_ms << " ms";
      if (std::isfinite(record.rmse_pred_to_gt_m))
        line << std::setprecision(1) << ", RMSE " << 1000 * record.rmse_pred_to_gt_m << "/"
             << 1000 * record.rmse_gt_to_pred_m << " mm";
      if (!record.probe_success) line << " (" << record.probe_reason << ")";
      ROS_INFO_STREAM("exploration: " << line.str());
      if (failures_in_row >= max_failures_) return finish("consecutive_failures", 0);
    }
    return finish("interrupted", 1);
  }

  // Joins the call workers; call after ros::shutdown(), which makes any blocked call return.
  void joinWorkers() {
    for (auto& worker : workers_)
      if (worker.joinable()) worker.join();
    workers_.clear();
  }

 private:
  template <typename Srv>
  bool callService(const std::string& name, Srv& srv) {
    const std::string resolved = nh_.resolveName(name);
    if (!ros::service::waitForService(resolved, ros::Duration(service_timeout_s_))) {
      ROS_ERROR_STREAM("exploration: service " << resolved << " not available after " << service_timeout_s_ << " s");
      return false;
    }
    return timedCall(resolved, srv);
  }

  template <typename Srv>
  bool timedCall(const std::string& resolved, Srv& srv, double timeout_s = -1.0) {
    if (timeout_s < 0.0) timeout_s = call_timeout_s_;
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
    try {
      workers_.emplace_back([pending, resolved]() {
        const bool ok = ros::service::call(resolved, pending->srv);
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

  void onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    training_ = msg;
    training_received_ = ros::WallTime::now();
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
    if (!timedCall(name, srv, std::min(call_timeout_s_, kAuxiliaryCallTimeoutS)) || !srv.response.success) {
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
    cloud_pub_.publish(capture.response.cloud);
    ROS_INFO_STREAM("exploration: captured " << capture.response.cloud.width * capture.response.cloud.height
                                             << " points in " << capture.response.cloud.header.frame_id);
    return true;
  }

  bool waitForModel() {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(service_timeout_s_);
    while (ros::ok() && ros::WallTime::now() < deadline) {
      if (latestTraining()) {
        ROS_INFO_STREAM("exploration: model ready with " << latestTraining()->points.size() << " observations");
        return true;
      }
      ros::WallDuration(0.1).sleep();
    }
    ROS_ERROR_STREAM("exploration: no model on " << training_sub_.getTopic() << " after " << service_timeout_s_
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

  // Rebuilds the GP from the latest training set, meshes it and, with a ground truth, measures it.
  void measure(ActionRecord& record, int action) {
    const auto training = latestTraining();
    if (!training) return;
    record.n_train = training->points.size();
    if (metrics_every_ <= 0 || action % metrics_every_ != 0) return;
    gpatlas_core::GpisModel model;
    std::string error;
    if (!modelFromMsg(*training, gpis_config_, &model, &error)) return;
    const auto surface = gpatlas_core::SurfaceMesher(mesher_config_).mesh(model);
    if (!surface.ok) return;
    for (double v : surface.mesh.vertex_variances)
      if (!(record.mesh_max_variance >= v)) record.mesh_max_variance = v;
    if (ground_truth_.empty()) return;
    const auto metrics = gpatlas_core::ShapeMetrics().compare(surface.mesh, ground_truth_);
    if (!metrics.ok) return;
    record.rmse_pred_to_gt_m = metrics.rmse_predicted_to_truth;
    record.rmse_gt_to_pred_m = metrics.rmse_truth_to_predicted;
  }

  int finish(const std::string& stop_reason, int code) {
    const fs::path dir(results_dir_);
    gpatlas_core::ShapeMetricsResult final_metrics;
    std::string mesh_path;
    if (const auto training = latestTraining()) {
      gpatlas_core::GpisModel model;
      std::string error;
      if (modelFromMsg(*training, gpis_config_, &model, &error)) {
        const auto surface = gpatlas_core::SurfaceMesher(mesher_config_).mesh(model);
        if (surface.ok) {
          mesh_path = (dir / "surface.ply").string();
          const std::string write_error = gpatlas_core::writePly(surface.mesh, mesh_path);
          if (!write_error.empty()) ROS_WARN_STREAM("exploration: " << write_error);
          if (!ground_truth_.empty()) final_metrics = gpatlas_core::ShapeMetrics().compare(surface.mesh, ground_truth_);
        }
      }
    }
    gpatlas_msgs::SaveMap save;
    save.request.path = (dir / "collision_map.bt").string();
    const std::string save_name = nh_.resolveName("save_map");
    if (ros::service::waitForService(save_name, ros::Duration(2.0)) &&
        timedCall(save_name, save, std::min(call_timeout_s_, kAuxiliaryCallTimeoutS)) &&
        !save.response.success)
      ROS_WARN_STREAM("exploration: " << save.response.message);

    int contacts = 0;
    for (const auto& r : records_) contacts += r.contacts;
    std::ofstream json(dir / "report.json");
    json << "{\n  \"settings\": {\"strategy\": " << jsonString(strategy_) << ", \"v_max\": " << jsonNumber(v_max_)
         << ", \"max_actions\": " << max_actions_ << ", \"max_consecutive_failures\": " << max_failures_
         << ", \"kernel\": " << jsonString(gpis_config_.kernel) << "},\n";
    json << "  \"stop_reason\": " << jsonString(stop_reason) << ",\n  \"converged\": "
         << (stop_reason == "converged" ? "true" : "false") << ",\n  \"actions\": " << records_.size()
         << ",\n  \"contacts\": " << contacts << ",\n  \"final_max_surface_variance\": "
         << jsonNumber(final_max_variance_) << ",\n";
    json << "  \"final_metrics\": ";
    if (final_metrics.ok)
      json << "{\"rmse_pred_to_gt_m\": " << jsonNumber(final_metrics.rmse_predicted_to_truth)
           << ", \"rmse_gt_to_pred_m\": " << jsonNumber(final_metrics.rmse_truth_to_predicted)
           << ", \"chamfer_l1_m\": " << jsonNumber(final_metrics.chamfer_l1)
           << ", \"fscore_5mm\": " << jsonNumber(final_metrics.f_score) << "}";
    else
      json << "null";
    json << ",\n  \"initial\": {\"n_train\": " << initial_.n_train
         << ", \"mesh_max_variance\": " << jsonNumber(initial_.mesh_max_variance)
         << ", \"rmse_pred_to_gt_m\": " << jsonNumber(initial_.rmse_pred_to_gt_m)
         << ", \"rmse_gt_to_pred_m\": " << jsonNumber(initial_.rmse_gt_to_pred_m) << "}";
    json << ",\n  \"history\": [\n";
    for (std::size_t i = 0; i < records_.size(); ++i) {
      const auto& r = records_[i];
      json << "    {\"action\": " << r.index << ", \"probe_success\": " << (r.probe_success ? "true" : "false")
           << ", \"probe_reason\": " << jsonString(r.probe_reason) << ", \"contacts\": " << r.contacts
           << ", \"free_points\": " << r.free_points << ", \"contacts_total\": " << r.contacts_total
           << ", \"max_surface_variance\": " << jsonNumber(r.max_surface_variance)
           << ", \"plan_ms\": " << jsonNumber(r.plan_ms) << ", \"probe_ms\": " << jsonNumber(r.probe_ms)
           << ", \"update_ms\": " << jsonNumber(r.update_ms) << ", \"n_train\": " << r.n_train
           << ", \"rmse_pred_to_gt_m\": " << jsonNumber(r.rmse_pred_to_gt_m)
           << ", \"rmse_gt_to_pred_m\": " << jsonNumber(r.rmse_gt_to_pred_m)
           << ", \"mesh_max_variance\": " << jsonNumber(r.mesh_max_variance) << "}"
           << (i + 1 < records_.size() ? ",\n" : "\n");
    }
    json << "  ]\n}\n";
    json.close();

    const std::string script = ros::package::getPath("gpatlas_ros") + "/scripts/plot_exploration.py";
    const std::string command = "/usr/bin/python3 \"" + script + "\" \"" + results_dir_ + "\" >/dev/null";
    if (std::system(command.c_str()) != 0) ROS_WARN_STREAM("exploration: plotting failed: " << command);

    std::ostringstream summary;
    summary << "exploration finished: " << stop_reason << " after " << records_.size() << " actions (" << contacts
            << " contacts)";
    if (final_metrics.ok)
      summary << std::setprecision(3) << "; shape RMSE " << 1000 * final_metrics.rmse_predicted_to_truth
              << " mm (predicted->truth), " << 1000 * final_metrics.rmse_truth_to_predicted
              << " mm (truth->predicted), F-score@5mm " << final_metrics.f_score;
    summary << "; results in " << results_dir_;
    ROS_INFO_STREAM(summary.str());
    return code;
  }

  ros::NodeHandle nh_, pnh_;
  std::string world_frame_, strategy_, results_dir_;
  double v_max_{0.1};
  int max_actions_{60};
  int max_failures_{5};
  double service_timeout_s_{60.0};  // for a service to appear
  double call_timeout_s_{600.0};    // for a call to answer (a touch on a slow arm takes minutes)
  // The ground truth and the map's saving: optional, at the start and the end; not worth a wait.
  static constexpr double kAuxiliaryCallTimeoutS = 30.0;
  std::vector<std::thread> workers_;  // service calls in flight or abandoned (see timedCall)
  bool capture_{true};
  int metrics_every_{1};
  gpatlas_core::GpisModel::Config gpis_config_;
  gpatlas_core::SurfaceMesher::Config mesher_config_;
  gpatlas_core::TriangleMesh ground_truth_;
  ActionRecord initial_;
  std::vector<ActionRecord> records_;
  double final_max_variance_{std::nan("")};

  std::mutex mutex_;
  gpatlas_msgs::TrainingSet::ConstPtr training_;
  ros::WallTime training_received_;
  ros::Publisher cloud_pub_;
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
