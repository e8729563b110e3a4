// Tactile exploration, paper Algorithm 2, over ROS services: capture a view, wait for the GP,
// then repeat next touch -> probe -> add observations until the planner reports convergence,
// max_actions, or max_consecutive_failures failed touches. The probe service is probe_sim's in
// simulation; a real robot driver implements the same gpatlas_msgs/Probe service.
// gpatlas_core::Explorer runs the loop (the bench runs the same one) over the adapters of
// ros_exploration_adapters.h; exploration_report_writer.h writes the results.

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_msgs/Capture.h>
#include <gpatlas_msgs/GetMesh.h>
#include <gpatlas_ros/exploration_measurements.h>
#include <gpatlas_ros/exploration_report_writer.h>
#include <gpatlas_ros/pipeline_watch.h>
#include <gpatlas_ros/ros_exploration_adapters.h>
#include <gpatlas_ros/ros_params.h>
#include <gpatlas_ros/timed_service_client.h>
#include <gpatlas_ros/wait_report.h>

#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <optional>
#include <stdexcept>
#include <string>

namespace gpatlas_ros {

namespace {

using namespace gpatlas_conversions;

// Everything the node reads from its private parameters.
struct ExplorationNodeSettings {
  std::string world_frame;
  gpatlas_core::Explorer::Config loop;
  std::string strategy;
  ExplorationNodeConfig node;
  gpatlas_core::SurfaceModelConfig model;
  gpatlas_geometry::SurfaceMesher::Config mesher;
  gpatlas_motion::ApproachConfig approach;
};

ExplorationNodeSettings readSettings(const ros::NodeHandle& pnh) {
  RosParamReader r(pnh);
  ExplorationNodeSettings settings;
  gpatlas_core::PipelineFrames frames;
  readFrames(r, &frames);
  settings.world_frame = frames.world_frame;
  readExplorer(r, &settings.loop);
  gpatlas_core::StrategyChoice choice;
  readStrategyChoice(r, &choice);
  settings.strategy = choice.name;
  readExplorationNode(r, &settings.node);
  loadPluginLibraries(choice.libraries, r, "exploration");  // before the models read their settings
  readSurfaceModel(r, &settings.model);
  readMesher(r, &settings.mesher);
  readApproach(r, &settings.approach);
  if (!r.ok()) throw std::runtime_error("invalid parameters: " + r.errors());
  r.report("exploration");
  return settings;
}

class ExplorationNode {
 public:
  ExplorationNode(ros::NodeHandle nh, const ros::NodeHandle& pnh)
      : nh_(nh),
        settings_(readSettings(pnh)),
        client_(nh_, settings_.node.service_timeout_s, settings_.node.call_timeout_s),
        watch_(nh_, settings_.approach.enabled),
        measurement_(settings_.model, settings_.mesher),
        writer_(settings_.node.results_dir, client_) {
    cloud_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("camera_points", 1, true);
  }

  int run() {
    const gpatlas_core::StopRule stop_rule{settings_.loop.v_max, settings_.loop.max_position_sd_m};
    ROS_INFO_STREAM("exploration: strategy " << settings_.strategy << ", stop rule: " << stop_rule.describe()
                                             << ", at most " << settings_.loop.max_actions << " actions; results in "
                                             << writer_.resultsDir());
    if (!writer_.createFolder()) return 2;
    loadGroundTruth();
    if (settings_.node.capture && !captureView()) return 1;
    if (!waitForModel()) return 1;
    const gpatlas_core::ExplorationRecord initial = measureInitialModel();
    gpatlas_core::ExplorationResult result = explore();
    gpatlas_core::ExplorationReport report;
    report.strategy = settings_.strategy;
    report.model = settings_.model.type;
    report.loop = settings_.loop;
    report.initial = initial;
    report.result = result;
    return writer_.write(report, watch_.latestTraining(), measurement_);
  }

  // Joins the call workers; call after ros::shutdown(), which makes any blocked call return.
  void joinWorkers() {
    client_.joinWorkers();
    measurements_.stop();
  }

 private:
  // The core's Algorithm 2 over the pipeline's services: the bench runs the same loop.
  gpatlas_core::ExplorationResult explore() {
    ExplorationServices services{client_, watch_, settings_.world_frame, settings_.strategy, settings_.approach,
                                 settings_.node.call_timeout_s, {}, {}};
    ServicePlanner planner(services);
    ServiceProber prober(services);
    ServiceUpdater updater(services);
    ServiceApproacher approacher(services);
    const gpatlas_core::Explorer explorer(settings_.loop);
    const std::optional<int> metrics_every = settings_.node.metrics_every;
    measurements_.start();
    gpatlas_core::ExplorationResult result =
        explorer.run(planner, prober, updater, [this, metrics_every](gpatlas_core::ExplorationRecord& record) {
          ROS_INFO_STREAM("exploration: " << gpatlas_core::describeAction(record));
          if (metrics_every && (record.index + 1) % *metrics_every == 0)
            measurements_.request(record.index, watch_.latestTraining());
        }, settings_.approach.enabled ? &approacher : nullptr);
    measurements_.mergeInto(&result, metrics_every);
    return result;
  }

  gpatlas_core::ExplorationRecord measureInitialModel() {
    gpatlas_core::ExplorationRecord initial;
    initial.n_train = watch_.latestTraining()->points.size();
    if (const auto model = measurement_.measure(*watch_.latestTraining(), initial)) {
      // Said once here, and in every plan's answer.
      if (const std::string note = gpatlas_core::vMaxNoiseNote(*model, settings_.loop.v_max); !note.empty())
        ROS_WARN_STREAM("exploration: " << note);
    }
    ROS_INFO_STREAM("exploration: initial model: max surface variance " << initial.sampled_max_variance << ", RMSE "
                                                                         << 1000 * initial.rmse_pred_to_gt_m << "/"
                                                                         << 1000 * initial.rmse_gt_to_pred_m << " mm");
    return initial;
  }

  void loadGroundTruth() {
    if (!client_.isOffered("ground_truth")) {
      ROS_INFO_STREAM("exploration: no " << client_.resolveName("ground_truth")
                                         << " service: no shape metrics (real robot)");
      return;
    }
    gpatlas_msgs::GetMesh srv;
    if (!client_.callOptional("ground_truth", srv) || !srv.response.success) {
      ROS_WARN_STREAM("exploration: ground truth unavailable: " << srv.response.message);
      return;
    }
    gpatlas_core::TriangleMesh mesh;
    std::string malformed;
    if (!fromMsg(srv.response.mesh, &mesh, &malformed)) {
      ROS_WARN_STREAM("exploration: ground truth unusable: " << malformed);
      return;
    }
    ROS_INFO_STREAM("exploration: ground truth with " << mesh.triangles.size() << " triangles");
    measurement_.setGroundTruth(std::move(mesh));
  }

  bool captureView() {
    gpatlas_msgs::Capture capture;
    if (!client_.call("capture", capture)) return false;
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
    const ExplorationNodeConfig& config = settings_.node;
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(config.service_timeout_s);
    ros::WallTime last_published = ros::WallTime::now();
    WaitReport report("exploration", [this, &config] {
      return watch_.describeTrainingSource() + "; gives up after service_timeout_s (" +
             seconds(config.service_timeout_s) + ")";
    });
    while (ros::ok() && ros::WallTime::now() < deadline) {
      report.poll();
      if (const auto training = watch_.latestTraining()) {
        ROS_INFO_STREAM("exploration: model ready with " << training->points.size() << " observations");
        return true;
      }
      const double silent_s = (ros::WallTime::now() - last_published).toSec();
      if (captured_cloud_ && config.republish_view_after_s && silent_s > *config.republish_view_after_s) {
        ROS_WARN_STREAM("exploration: no model " << silent_s << " s after the view was published; publishing it again");
        cloud_pub_.publish(*captured_cloud_);
        last_published = ros::WallTime::now();
      }
      ros::WallDuration(0.1).sleep();
    }
    ROS_ERROR_STREAM("exploration: no model on " << watch_.trainingTopic() << " after " << config.service_timeout_s
                                                 << " s (is the segmentation finding the object?)");
    return false;
  }

  ros::NodeHandle nh_;
  const ExplorationNodeSettings settings_;
  TimedServiceClient client_;
  PipelineWatch watch_;
  TrainingSetMeasurer measurement_;
  BackgroundMeasurements measurements_{measurement_};
  ExplorationReportWriter writer_;
  ros::Publisher cloud_pub_;
  std::optional<sensor_msgs::PointCloud2> captured_cloud_;  // the view captured, published again if no model comes
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
