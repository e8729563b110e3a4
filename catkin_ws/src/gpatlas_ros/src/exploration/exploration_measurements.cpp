#include "gpatlas_ros/exploration_measurements.h"
#include "gpatlas_ros/wait_report.h"

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_core/common/background_work.h>
#include <gpatlas_core/planning/surface_sampler.h>
#include <gpatlas_geometry/model_measurement.h>
#include <gpatlas_geometry/shape_metrics.h>

#include <ros/ros.h>

#include <cmath>
#include <iomanip>
#include <string>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

std::unique_ptr<gpatlas_core::SurfaceModel> TrainingSetMeasurer::measure(const gpatlas_msgs::TrainingSet& training,
                                                                      gpatlas_core::ExplorationRecord& record) const {
  std::unique_ptr<gpatlas_core::SurfaceModel> model_ptr;
  std::string error;
  if (!modelFromMsg(training, model_config_, &model_ptr, &error)) return nullptr;
  measureModel(*model_ptr, record);
  return model_ptr;
}

void TrainingSetMeasurer::measureModel(const gpatlas_core::SurfaceModel& model,
                                    gpatlas_core::ExplorationRecord& record) const {
  const gpatlas_geometry::ModelMeasurement measured =
      gpatlas_geometry::measureModel(model, ground_truth_, mesher_config_);
  record.sampled_max_variance = measured.sampled_max_variance;
  if (!measured.shape.ok) return;
  record.rmse_pred_to_gt_m = measured.shape.rmse_predicted_to_truth;
  record.rmse_gt_to_pred_m = measured.shape.rmse_truth_to_predicted;
  record.fscore_5mm = measured.shape.f_score;
}

void BackgroundMeasurements::start() { measurer_ = std::thread(&BackgroundMeasurements::measureLoop, this); }

void BackgroundMeasurements::request(int action_index, gpatlas_msgs::TrainingSet::ConstPtr training) {
  if (!training) return;
  {
    std::lock_guard<std::mutex> lock(measure_mutex_);
    if (measure_pending_) ++measurements_skipped_;
    measure_pending_ = std::make_pair(action_index, std::move(training));
  }
  measure_wake_.notify_all();
}

void BackgroundMeasurements::measureLoop() {
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
    measureJob(job);
    measure_wake_.notify_all();
  }
}

void BackgroundMeasurements::measureJob(const std::pair<int, gpatlas_msgs::TrainingSet::ConstPtr>& job) {
  gpatlas_core::ExplorationRecord measured;
  const ros::WallTime started = ros::WallTime::now();
  try {
    gpatlas_core::runOnThisThreadOnly([&] { measurement_.measure(*job.second, measured); });
  } catch (const std::exception& e) {
    ROS_WARN_STREAM("exploration: the model after action " << job.first + 1 << " not measured: " << e.what());
  }
  if (std::isfinite(measured.rmse_pred_to_gt_m))
    ROS_INFO_STREAM(std::setprecision(3) << "exploration: model after action " << job.first + 1 << ": RMSE "
                                         << 1000 * measured.rmse_pred_to_gt_m << "/"
                                         << 1000 * measured.rmse_gt_to_pred_m << " mm, F@5mm " << measured.fscore_5mm
                                         << ", sampled max variance "

                                         << measured.sampled_max_variance << " (measured in "
                                         << (ros::WallTime::now() - started).toSec() << " s)");
  std::lock_guard<std::mutex> lock(measure_mutex_);
  measurements_[job.first] = measured;
  measure_busy_ = false;
}

void BackgroundMeasurements::mergeInto(gpatlas_core::ExplorationResult* result, std::optional<int> metrics_every) {
  std::map<int, gpatlas_core::ExplorationRecord> measured;
  int skipped = 0;
  {
    std::unique_lock<std::mutex> lock(measure_mutex_);
    if (measure_busy_ || measure_pending_) ROS_INFO("exploration: waiting for the last model measurement");
    WaitReport report("exploration", [] { return "the last model measurement (meshing the model, for the report)"; });
    while (!measure_wake_.wait_for(lock, std::chrono::seconds(1), [this] { return !measure_busy_ && !measure_pending_; }))
      report.poll();
    measured = measurements_;
    skipped = measurements_skipped_;
  }
  for (auto& record : result->records) {
    const auto it = measured.find(record.index);
    if (it == measured.end()) continue;
    record.sampled_max_variance = it->second.sampled_max_variance;
    record.rmse_pred_to_gt_m = it->second.rmse_pred_to_gt_m;
    record.rmse_gt_to_pred_m = it->second.rmse_gt_to_pred_m;
    record.fscore_5mm = it->second.fscore_5mm;
  }
  if (skipped > 0 && metrics_every)
    ROS_INFO_STREAM("exploration: " << measured.size() << " models measured after actions, " << skipped
                                    << " skipped (metrics_every " << *metrics_every
                                    << ": a measurement took longer than the actions in between)");
}

void BackgroundMeasurements::stop() {
  {
    std::lock_guard<std::mutex> lock(measure_mutex_);
    measure_stopping_ = true;
    measure_pending_.reset();
  }
  measure_wake_.notify_all();
  if (measurer_.joinable()) measurer_.join();
}

}  // namespace gpatlas_ros
